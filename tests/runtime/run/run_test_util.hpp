// Helpers for the session/run-loop tests: temp folders, fixture configs, a capturing logger.
#pragma once

#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <vector>

#include "visnav/runner.hpp"

namespace visnav::test {

inline bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

/// Collects log lines ("W component: message").
class CaptureLogger final : public Logger {
 public:
  void log(LogLevel level, std::string_view component, std::string_view message) override {
    static constexpr const char* kTag[] = {"D", "I", "W", "E"};
    std::lock_guard lock(mutex_);
    lines_.push_back(std::string(kTag[static_cast<int>(level)]) + " " + std::string(component) + ": " + std::string(message));
  }
  [[nodiscard]] bool saw(const std::string& part) const {
    std::lock_guard lock(mutex_);
    for (const auto& l : lines_)
      if (contains(l, part)) return true;
    return false;
  }
  /// Index of the first line containing `part`, or -1.
  [[nodiscard]] int index_of(const std::string& part) const {
    std::lock_guard lock(mutex_);
    for (std::size_t i = 0; i < lines_.size(); ++i)
      if (contains(lines_[i], part)) return static_cast<int>(i);
    return -1;
  }
  [[nodiscard]] std::string all() const {
    std::lock_guard lock(mutex_);
    std::string out;
    for (const auto& l : lines_) out += l + "\n";
    return out;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<std::string> lines_;
};

/// A temporary folder removed at the end of the test.
class TempDir {
 public:
  TempDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "visnav_run_XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) ADD_FAILURE() << "mkdtemp failed";
    path_ = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  [[nodiscard]] std::string file(const std::string& name) const { return (path_ / name).string(); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path_ / name) << text;
    return file(name);
  }

 private:
  std::filesystem::path path_;
};

inline std::string read_file(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Fixture robot (simulated unless told otherwise) + fixture camera + a grid detector.
inline std::string fixture_config(const std::string& robot_params = "{}", const std::string& camera_params = "{}",
                                  const std::string& run = "{}", const std::string& detector = "grid_hamming",
                                  const std::string& detector_params = "{}") {
  return "robot: {type: fixture, params: " + robot_params + "}\n" +
         "camera: {type: fixture, params: " + camera_params + "}\n" +
         "detector: {type: " + detector + ", params: " + detector_params + "}\n" +
         "run: " + run + "\n";
}

inline std::string drive_tree(double distance_m, double speed_mps = 0.5) {
  return R"(<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main">
    <Sequence>
      <FixtureHasFrame/>
      <FixtureDrive distance_m=")" +
         std::to_string(distance_m) + R"(" speed_mps=")" + std::to_string(speed_mps) + R"("/>
    </Sequence>
  </BehaviorTree>
</root>
)";
}

inline SessionOptions fixture_options(Logger* logger) {
  SessionOptions o;
  o.use_default_plugin_path = false;
  o.extra_plugin_dirs = {VISNAV_TEST_FIXTURE_PLUGIN_DIR};
  o.logger = logger;
  return o;
}

/// Loads `config_file` and creates a session on the fixture plugins.
inline Result<std::unique_ptr<Session>> fixture_session(const std::string& config_file, Logger* logger) {
  VISNAV_ASSIGN(RunConfig config, load_run_config(config_file));
  return Session::create(std::move(config), fixture_options(logger));
}

/// Writes `tree_xml` as tree.xml and `config` as c.yaml into `dir` and creates a session on the
/// fixture plugins; fails the test (nullptr) on error.
inline std::unique_ptr<Session> start_fixture_session(const TempDir& dir, const std::string& config,
                                                      const std::string& tree_xml, Logger* logger) {
  dir.write("tree.xml", tree_xml);
  auto s = fixture_session(dir.write("c.yaml", config), logger);
  if (!s) {
    ADD_FAILURE() << s.error().message;
    return nullptr;
  }
  return std::move(s).value();
}

/// Loads `tree_file` into `session` and runs it; fails the test (empty report) when it does not load.
inline RunReport run_tree_file(Session& session, const std::string& tree_file, const RunOptions& options) {
  auto tree = session.load_tree(tree_file);
  if (!tree) {
    ADD_FAILURE() << tree.error().message;
    return {};
  }
  return run_tree(session, *tree, options);
}

}  // namespace visnav::test
