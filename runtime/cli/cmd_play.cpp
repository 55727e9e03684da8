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
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  std::size_t start = 0;
  for (std::size_t nl = text.find('\n'); nl != std::string::npos; nl = text.find('\n', start)) {
    lines.push_back(text.substr(start, nl - start));
    start = nl + 1;
  }
  return lines;
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
  auto topics = visnav::cli::bag_topics(a, a.get("--config"), a.all("--set"));
  if (!topics) {
    std::cerr << "visnav play: " << topics.error().message << "\n";
    return 1;
  }
  visnav::cli::TempRun temp_run;
  if (auto folder = visnav::cli::run_folder_of(run_dir, topics->run, temp_run); folder) {
    run_dir = *folder;
  } else {
    std::cerr << "visnav play: " << folder.error().message << "\n";
    return 1;
  }
  std::error_code ec;
  if (!fs::is_directory(run_dir, ec) || !fs::exists(fs::path(run_dir) / "frames.csv", ec)) {
    std::cerr << "visnav play: " << run_dir << ": not a recorded-run folder (no frames.csv; see docs/recorded_runs.md)\n";
    return 1;
  }
  const std::string abs_run = fs::absolute(run_dir).lexically_normal().string();
  std::string config_file = a.get("--config");
  std::vector<std::string> overrides;
  if (config_file.empty()) {
    config_file = (fs::path(run_dir) / "config.yaml").string();
    if (!fs::exists(config_file, ec)) {
      std::cerr << "visnav play: " << config_file << " is missing; give the configuration with --config C\n";
      return 1;
    }
    overrides = recorded_list(run_dir, "overrides");
  }
  for (const auto& s : a.all("--set")) overrides.push_back(s);
  // Replace the robot and camera sections by the recorded ones (plugin pins and params included).
  overrides.push_back("robot={type: recorded, params: {run_dir: " + yaml_quote(abs_run) + "}}");
  overrides.push_back("camera={type: recorded, params: {run_dir: " + yaml_quote(abs_run) + "}}");
  overrides.push_back("run.lockstep=on");

  if (a.has("--log-level"))
    if (auto level = visnav::parse_log_level(a.get("--log-level")); !level)
      return visnav::cli::usage_error("play", level.error().message);
  auto session_made = visnav::cli::open_session(a, config_file, overrides);
  if (!session_made) {
    std::cerr << "visnav play: " << session_made.error().message << "\n";
    return 1;
  }
  visnav::Session& session = **session_made;
  auto tree = session.load_tree(a.get("--tree"));
  if (!tree) {
    std::cerr << "visnav play: " << tree.error().message << "\n";
    return 1;
  }
  std::vector<std::string> bb = recorded_list(run_dir, "blackboard");
  for (const auto& v : a.all("--bb")) bb.push_back(v);
  if (auto st = visnav::set_blackboard_values(*tree, bb); !st) {
    std::cerr << "visnav play: " << st.error().message << "\n";
    return 1;
  }

  // This run's decisions, in the columns of RUN/commands.csv.
  std::vector<std::string> decisions;
  decisions.emplace_back("tick,t_s,frame_index,linear_mps,angular_radps,commands_sent");
  std::optional<std::pair<std::uint64_t, double>> last_frame;
  long frame_index = -1;
  visnav::RunOptions ro;
  ro.trace_file = a.get("--trace");
  ro.after_tick = [&](const visnav::TickInfo& t) {
    if (auto f = session.frame_bus().latest_frame()) {
      if (!last_frame || last_frame->first != f->sequence || last_frame->second != f->timestamp_s) ++frame_index;
      last_frame = std::make_pair(f->sequence, f->timestamp_s);
    }
    const visnav::Twist c = session.robot().last_command();
    char buf[256];
    std::snprintf(buf, sizeof buf, "%llu,%.17g,%ld,%.17g,%.17g,%llu", static_cast<unsigned long long>(t.tick), t.t_s,
                  frame_index, c.linear_mps, c.angular_radps, static_cast<unsigned long long>(session.robot().commands_sent()));
    decisions.emplace_back(buf);
    return true;
  };
  visnav::install_signal_handlers();
  const visnav::RunReport r = visnav::run_tree(session, *tree, ro);

  if (a.has("--commands-out")) {
    std::ofstream out(a.get("--commands-out"), std::ios::trunc);
    for (const auto& l : decisions) out << l << "\n";
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
  if (recorded.size() > 1 && !a.has("--no-compare")) {
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
    if (first_diff != 0 && exit_code == 0) exit_code = 4;
  }
  return exit_code;
}

}  // namespace

VISNAV_COMMAND(play, "play", "run a mission on a recorded run (no robot) and compare its decisions", kUsage, &play)
