// `visnav play`: run a mission on a recorded run (robot and camera type `recorded`), and compare
// its decisions tick by tick with the ones recorded live (docs/recorded_runs.md).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

#include "args.hpp"
#include "command.hpp"
#include "mcap_input.hpp"
#include "session_args.hpp"
#include "visnav/file_io.hpp"
#include "visnav/runner.hpp"

namespace {

namespace fs = std::filesystem;

constexpr const char* kUsage =
    "usage: visnav play RUN --tree T [--bb key=value]... [--config C] [--map M [--create]] [--set k=v]... [--commands-out F]\n"
    "                   [--trace F] [--plugin-path DIR]... [--log-level L] [--image-topic T] [--odom-topic T]\n"
    "\n"
    "Runs the mission tree T on the recorded run RUN (written by `visnav record`) with no robot:\n"
    "the robot is type `recorded` (replays RUN/odometry.csv; commands are accepted and logged, it\n"
    "does not move) and the camera is type `recorded` (RUN's frames). Lock-step: each tick is one\n"
    "tick of the recorded run (RUN/commands.csv; or one frame when recorded without a mission), at\n"
    "its recorded time, with the frame and odometry the live run had at that time.\n"
    "The rest of the configuration (detector, nodes, run settings) comes from --config, default\n"
    "RUN/config.yaml (the copy `visnav record` made) with the recorded --set overrides.\n"
    "\n"
    "  RUN               recorded-run folder (also --run RUN), or an MCAP file: one written by\n"
    "                    `visnav record --format mcap`, or a ROS 2 bag (give --config C)\n"
    "  --image-topic T   MCAP: topic of the images (sensor_msgs Image or CompressedImage; default\n"
    "                    run.bag_image_topic of --config, else /camera/image_raw/compressed)\n"
    "  --odom-topic T    MCAP: topic of nav_msgs/Odometry (default run.bag_odom_topic, else /odom)\n"
    "  --tree T          mission tree\n"
    "  --bb key=value    blackboard entry before the first tick (after the recorded ones in run.yaml)\n"
    "  --config C        configuration to take detector/nodes/run settings from\n"
    "  --map M           map folder (as `visnav run --map`: a bare name is maps/M; must exist unless --create)\n"
    "  --create          with --map: create M as an empty map if missing\n"
    "  --set k=v         config override (repeatable), applied after the recorded ones\n"
    "  --commands-out F  write this run's decisions as F (same columns as RUN/commands.csv)\n"
    "  --trace F         BT status transitions as JSON lines\n"
    "  --no-compare      do not compare the decisions with the recorded ones (e.g. teaching from a\n"
    "                    recording, where the robot is not commanded)\n"
    "\n"
    "When RUN/commands.csv has recorded decisions, prints how many ticks agree with them:\n"
    "'decisions: N of M ticks identical (first difference at tick K)'.\n"
    "Exit status: as `visnav run`; 4 when the decisions differ from the recorded ones.\n";

std::string yaml_quote(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out.push_back('\\');
    out.push_back(c);
  }
  return out + "\"";
}

/// A recorded list of run.yaml (`overrides:` --set values, `blackboard:` --bb values), empty if none.
std::vector<std::string> recorded_list(const std::string& run_dir, const char* key) {
  std::vector<std::string> out;
  auto root = visnav::parse_yaml_file((fs::path(run_dir) / "run.yaml").string());
  if (!root || !root->is_map()) return out;
  const visnav::ConfigNode* list = root->find(key);
  if (list == nullptr || !list->is_sequence()) return out;
  for (const auto& item : list->items())
    if (item.is_scalar()) out.push_back(item.scalar());
  return out;
}

/// Complete lines of a file; an unterminated last line (a killed recording) is dropped.
std::vector<std::string> read_lines(const std::string& path) {
  std::vector<std::string> lines;
  auto read = visnav::read_text_file(path, visnav::kMaxTableFileBytes, "log");
  if (!read) return lines;  // a missing or refused log reads as empty (the caller reports that)
  const std::string& text = *read;
  std::size_t start = 0;
  for (std::size_t nl = text.find('\n'); nl != std::string::npos; nl = text.find('\n', start)) {
    lines.push_back(text.substr(start, nl - start));
    start = nl + 1;
  }
  return lines;
}

/// This run's decisions, one line per tick in the columns of RUN/commands.csv.
class DecisionLog {
 public:
  explicit DecisionLog(visnav::Session& session) : session_(session) {
    lines_.emplace_back("tick,t_s,frame_index,linear_mps,angular_radps,commands_sent");
  }
  void after_tick(const visnav::TickInfo& t) {
    if (auto f = session_.frame_bus().latest_frame()) {
      if (!last_frame_ || last_frame_->first != f->sequence || last_frame_->second != f->timestamp_s) ++frame_index_;
      last_frame_ = std::make_pair(f->sequence, f->timestamp_s);
    }
    const visnav::Twist c = session_.robot().last_command();
    char buf[256];
    std::snprintf(buf, sizeof buf, "%llu,%.17g,%ld,%.17g,%.17g,%llu", static_cast<unsigned long long>(t.tick), t.t_s,
                  frame_index_, c.linear_mps, c.angular_radps, static_cast<unsigned long long>(session_.robot().commands_sent()));
    lines_.emplace_back(buf);
  }
  [[nodiscard]] const std::vector<std::string>& lines() const { return lines_; }

 private:
  visnav::Session& session_;
  std::vector<std::string> lines_;
  std::optional<std::pair<std::uint64_t, double>> last_frame_;
  long frame_index_ = -1;
};

/// Prints how many ticks decided as the recording did; true when every one did.
bool compare_decisions(const std::vector<std::string>& recorded, const std::vector<std::string>& decisions) {
  const std::size_t n = std::min(recorded.size(), decisions.size());
  std::size_t same = 0;
  std::size_t first_diff = 0;
  for (std::size_t i = 1; i < n; ++i) {
    if (recorded[i] == decisions[i]) ++same;
    else if (first_diff == 0) first_diff = i;
  }
  const std::size_t total = std::max(recorded.size(), decisions.size()) - 1;
  if (first_diff == 0 && recorded.size() != decisions.size()) first_diff = n;
  std::cout << "decisions: " << same << " of " << total << " ticks identical to the recording";
  if (first_diff != 0) std::cout << " (first difference at tick " << first_diff << ")";
  std::cout << "\n";
  return first_diff == 0;
}

/// The configuration a playback runs: the recording's (with its overrides) unless --config, then
/// --set, then the recorded robot and camera in place of the live ones, in lock-step.
visnav::Result<std::pair<std::string, std::vector<std::string>>> playback_config(const visnav::cli::Args& a,
                                                                                 const std::string& run_dir) {
  const std::string abs_run = fs::absolute(run_dir).lexically_normal().string();
  std::string config_file = a.get("--config");
  std::vector<std::string> overrides;
  if (config_file.empty()) {
    config_file = (fs::path(run_dir) / "config.yaml").string();
    std::error_code ec;
    if (!fs::exists(config_file, ec))
      return visnav::fail(visnav::ErrorCode::not_found, {config_file}, "is missing; give the configuration with --config C");
    overrides = recorded_list(run_dir, "overrides");
  }
  for (const auto& s : a.all("--set")) overrides.push_back(s);
  // Replace the robot and camera sections by the recorded ones (plugin pins and params included).
  overrides.push_back("robot={type: recorded, params: {run_dir: " + yaml_quote(abs_run) + "}}");
  overrides.push_back("camera={type: recorded, params: {run_dir: " + yaml_quote(abs_run) + "}}");
  overrides.push_back("run.lockstep=on");
  return std::make_pair(config_file, overrides);
}

int play(const std::vector<std::string>& raw_args) {
  using visnav::cli::Opt;
  std::vector<std::string> args = raw_args;
  std::string run_dir;
  if (!args.empty() && args[0].rfind("-", 0) != 0) {
    run_dir = args[0];
    args.erase(args.begin());
  }
  visnav::cli::Args a;
  if (auto st = a.parse(args, {{"--run", Opt::value}, {"--tree", Opt::value}, {"--config", Opt::value}, {"--map", Opt::value},
                               {"--create", Opt::flag}, {"--set", Opt::repeated}, {"--bb", Opt::repeated}, {"--commands-out", Opt::value}, {"--trace", Opt::value},
                               {"--plugin-path", Opt::repeated}, {"--log-level", Opt::value},
                               {"--image-topic", Opt::value}, {"--odom-topic", Opt::value}, {"--no-compare", Opt::flag}});
      !st)
    return visnav::cli::usage_error("play", st.error().message);
  if (run_dir.empty()) run_dir = a.get("--run");
  if (run_dir.empty()) return visnav::cli::usage_error("play", "missing the recorded-run folder RUN");
  if (auto st = a.require({"--tree"}); !st) return visnav::cli::usage_error("play", st.error().message);
  if (a.has("--log-level"))
    if (auto level = visnav::parse_log_level(a.get("--log-level")); !level)
      return visnav::cli::usage_error("play", level.error().message);
  auto report_error = [](const visnav::Error& e) {
    std::cerr << "visnav play: " << e.message << "\n";
    return 1;
  };
  auto topics = visnav::cli::bag_topics(a, a.get("--config"), a.all("--set"));
  if (!topics) return report_error(topics.error());
  visnav::cli::TempRun temp_run;
  auto folder = visnav::cli::run_folder_of(run_dir, topics->run, temp_run);
  if (!folder) return report_error(folder.error());
  run_dir = *folder;
  std::error_code ec;
  if (!fs::is_directory(run_dir, ec) || !fs::exists(fs::path(run_dir) / "frames.csv", ec))
    return report_error(visnav::fail(visnav::ErrorCode::not_found, {run_dir},
                                     "not a recorded-run folder (no frames.csv; see docs/recorded_runs.md)"));
  auto config = playback_config(a, run_dir);
  if (!config) return report_error(config.error());
  auto session_made = visnav::cli::open_session(a, config->first, config->second);
  if (!session_made) return report_error(session_made.error());
  visnav::Session& session = **session_made;
  auto tree = session.load_tree(a.get("--tree"));
  if (!tree) return report_error(tree.error());
  std::vector<std::string> bb = recorded_list(run_dir, "blackboard");
  for (const auto& v : a.all("--bb")) bb.push_back(v);
  if (auto st = visnav::set_blackboard_values(*tree, bb); !st) return report_error(st.error());

  DecisionLog decisions(session);
  visnav::RunOptions ro;
  ro.trace_file = a.get("--trace");
  ro.after_tick = [&](const visnav::TickInfo& t) {
    decisions.after_tick(t);
    return true;
  };
  visnav::install_signal_handlers();
  const visnav::RunReport r = visnav::run_tree(session, *tree, ro);

  if (a.has("--commands-out")) {
    std::ofstream out(a.get("--commands-out"), std::ios::trunc);
    for (const auto& l : decisions.lines()) out << l << "\n";
    if (!out) std::cerr << "visnav play: cannot write " << a.get("--commands-out") << "\n";
  }
  std::cout << "visnav play: " << visnav::to_string(r.outcome) << " after " << r.ticks << " ticks, " << r.run_time_s
            << " s recorded time (" << r.wall_time_s << " s wall)\n";
  if (!r.reason.empty()) std::cerr << "visnav play: " << r.reason << "\n";

  int exit_code = r.exit_code;
  // A recording that ends before the tree does is a normal end of playback.
  if (r.outcome == visnav::RunOutcome::safety_stop && r.reason.find("end of the recorded run") != std::string::npos)
    exit_code = 0;
  const std::vector<std::string> recorded = read_lines((fs::path(run_dir) / "commands.csv").string());
  if (recorded.size() > 1 && !a.has("--no-compare") && !compare_decisions(recorded, decisions.lines()) && exit_code == 0)
    exit_code = 4;
  return exit_code;
}

}  // namespace

VISNAV_COMMAND(play, "play", "run a mission on a recorded run (no robot) and compare its decisions", kUsage, &play)
