// maps/example — the small map shipped with visnav, taught on the simulator by
// scripts/make-example-map.sh — passes every check `visnav run` makes before its first tick, is
// what a bare `--map example` names, and replays to success. A damaged copy is refused before
// the robot moves, with a code and a location.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "visnav/runner.hpp"

namespace fs = std::filesystem;
using visnav::ErrorCode;

namespace {

const fs::path kSource = VISNAV_TEST_SOURCE_DIR;
const fs::path kMap = kSource / "maps" / "example";
const fs::path kBuild = VISNAV_TEST_BINARY_DIR;

std::string read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// graph.yaml without the `created:` times (the one thing a re-teach changes).
std::string graph_without_times(const fs::path& map) {
  std::istringstream in(read_bytes(map / "graph.yaml"));
  std::string out, line;
  while (std::getline(in, line))
    if (line.find("created:") == std::string::npos) out.append(line).append("\n");
  return out;
}

std::string dump(const std::vector<visnav::Error>& errors) {
  std::string out;
  for (const auto& e : errors) out += std::string(visnav::to_string(e.code)) + ": " + e.message + "\n";
  return out;
}

class ExampleMap : public ::testing::Test {
 protected:
  void SetUp() override {
    tmp_ = fs::temp_directory_path() /
           ("visnav_example_map_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(tmp_);
    fs::create_directories(tmp_);
    ASSERT_TRUE(fs::exists(kMap / "graph.yaml")) << "no shipped map at " << kMap << " (scripts/make-example-map.sh)";
  }
  void TearDown() override {
    ::unsetenv("VISNAV_MAPS_DIR");
    fs::remove_all(tmp_);
  }
  /// A copy of the shipped map (replays may update it; the source tree stays as shipped).
  fs::path copy() {
    const fs::path to = tmp_ / "example";
    fs::copy(kMap, to, fs::copy_options::recursive);
    return to;
  }
  visnav::SetupCheck setup(const std::string& map) const {
    visnav::SetupCheck s;
    s.config_file = (kSource / "config" / "sim_feature.yaml").string();
    s.tree_file = (kSource / "trees" / "replay_feature_edge.xml").string();
    s.map_path = map;
    return s;
  }
  fs::path tmp_;
};

TEST_F(ExampleMap, PassesEveryCheckBeforeTheFirstTick) {
  const auto problems = visnav::check_setup(setup(kMap.string()));
  EXPECT_TRUE(problems.empty()) << dump(problems);
}

TEST_F(ExampleMap, ABareNameIsFoundInTheMapsFolder) {
  ::setenv("VISNAV_MAPS_DIR", (kSource / "maps").c_str(), 1);
  EXPECT_EQ(visnav::resolve_map_path("example"), kMap.string());
  const auto problems = visnav::check_setup(setup("example"));
  EXPECT_TRUE(problems.empty()) << dump(problems);
  ::setenv("VISNAV_MAPS_DIR", tmp_.c_str(), 1);  // no "example" there
  const auto missing = visnav::check_setup(setup("example"));
  ASSERT_EQ(missing.size(), 1u) << dump(missing);
  EXPECT_EQ(missing[0].code, ErrorCode::not_found);
  EXPECT_EQ(missing[0].where.file, (tmp_ / "example").string());
}

TEST_F(ExampleMap, ADamagedPayloadIsRefusedBeforeTheRobotMoves) {
  const fs::path map = copy();
  fs::path payload;
  for (const auto& e : fs::recursive_directory_iterator(map))
    if (e.path().extension() == ".bin") payload = e.path();
  ASSERT_FALSE(payload.empty());
  {
    std::fstream f(payload, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(fs::file_size(payload) / 2));
    f.put('\x5a');
    f.seekp(static_cast<std::streamoff>(fs::file_size(payload) / 2 + 1));
    f.put('\xa5');
  }
  const auto problems = visnav::check_setup(setup(map.string()));
  ASSERT_FALSE(problems.empty());
  EXPECT_EQ(problems[0].code, ErrorCode::parse_error) << dump(problems);
  EXPECT_EQ(problems[0].where.file, map.string());
  EXPECT_NE(problems[0].message.find(payload.filename().string()), std::string::npos) << dump(problems);

  visnav::MissionOptions m;
  m.config_file = (kSource / "config" / "sim_feature.yaml").string();
  m.tree_file = (kSource / "trees" / "replay_feature_edge.xml").string();
  m.map_path = map.string();
  m.create_map = false;
  m.blackboard_values = {"start=start", "goal=start", "loops=1", "laps=1", "speed_mps=0.3"};
  const visnav::RunReport r = visnav::run_mission(m);
  EXPECT_EQ(r.outcome, visnav::RunOutcome::error) << r.reason;
  EXPECT_EQ(r.ticks, 0u);
}

// The shipped files are what scripts/make-example-map.sh writes (the teach is deterministic: the
// simulator's default seeds), so nobody edits them by hand and a format change shows up here.
TEST_F(ExampleMap, IsWhatTheScriptProduces) {
  const fs::path out = tmp_ / "regenerated" / "example";
  // (append, not an operator+ chain: GCC 12 reports a false -Wrestrict on those)
  std::string cmd = "'";
  cmd.append((kSource / "scripts" / "make-example-map.sh").string()).append("' '").append(kBuild.string());
  cmd.append("' '").append(out.string()).append("' > '").append((tmp_ / "script.log").string()).append("' 2>&1");
  ASSERT_EQ(std::system(cmd.c_str()), 0) << read_bytes(tmp_ / "script.log");
  EXPECT_EQ(graph_without_times(out), graph_without_times(kMap));
  std::size_t payloads = 0;
  for (const auto& e : fs::directory_iterator(kMap / "edges")) {
    ++payloads;
    EXPECT_TRUE(read_bytes(e.path()) == read_bytes(out / "edges" / e.path().filename()))
        << e.path().filename() << " differs from what the script writes: run scripts/make-example-map.sh";
  }
  EXPECT_EQ(payloads, 4u);
}

TEST_F(ExampleMap, ReplaysToSuccess) {
  visnav::MissionOptions m;
  m.config_file = (kSource / "config" / "sim_feature.yaml").string();
  m.tree_file = (kSource / "trees" / "replay_feature_edge.xml").string();
  m.map_path = copy().string();
  m.create_map = false;
  m.overrides = {"run.log_level=warn"};
  m.blackboard_values = {"start=start", "goal=start", "loops=1", "laps=1", "speed_mps=0.3"};
  const visnav::RunReport r = visnav::run_mission(m);
  EXPECT_EQ(r.outcome, visnav::RunOutcome::success) << r.reason;
  EXPECT_GT(r.ticks, 50u);
}

}  // namespace
