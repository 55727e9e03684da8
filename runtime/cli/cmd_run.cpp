// `visnav run`: build the plugins named in a config and run a mission tree.
#include <iostream>

#include "args.hpp"
#include "command.hpp"
#include "visnav/runner.hpp"

namespace {

constexpr const char* kUsage =
    "usage: visnav run --config C --tree T [--map M [--create]] [--set key.path=value]... [--bb key=value]...\n"
    "                  [--trace F]\n"
    "                  [--plugin-path DIR]... [--log-level debug|info|warn|error]\n"
    "\n"
    "Builds the robot, camera and detector named in the YAML config C, registers the built-in\n"
    "and plugin behaviour-tree nodes, validates the tree T (nothing runs if it is invalid) and\n"
    "ticks it until it finishes. Simulated robots run in lock-step, as fast as possible.\n"
    "\n"
    "  --config C         run configuration (docs/config.md)\n"
    "  --tree T           mission tree, BehaviorTree.CPP v4 XML\n"
    "  --map M            map folder (opened; a missing folder is an error unless --create)\n"
    "  --create           with --map: create M as an empty map if it does not exist (teaching)\n"
    "  --set k=v          override a config value, e.g. --set detector.params.target_keypoints=300\n"
    "  --bb key=value     set a blackboard entry before the first tick, e.g. --bb start=dock\n"
    "  --trace F          write every node status transition to F as JSON lines\n"
    "  --plugin-path DIR  extra plugin directory (after VISNAV_PLUGIN_PATH and plugin_path)\n"
    "  --log-level L      overrides run.log_level\n"
    "\n"
    "Editing the config file while running applies parameter changes live (see docs/config.md).\n"
    "With a `dds:` block in C, every tick's status is published on DDS and pause / resume /\n"
    "abort / swap_detector requests are obeyed (`visnav monitor`, docs/dds.md).\n"
    "Exit status: 0 tree SUCCESS, 1 tree FAILURE or setup/validation error, 2 usage error,\n"
    "3 safety stop (stale data, sensor failure), 130 interrupted (SIGINT or an abort request:\n"
    "tree halted, robot stopped).\n";

int run(const std::vector<std::string>& args) {
  using visnav::cli::Opt;
  visnav::cli::Args a;
  if (auto st = a.parse(args, {{"--config", Opt::value}, {"--tree", Opt::value}, {"--map", Opt::value},
                               {"--create", Opt::flag}, {"--set", Opt::repeated}, {"--bb", Opt::repeated}, {"--trace", Opt::value}, {"--plugin-path", Opt::repeated},
                               {"--log-level", Opt::value}});
      !st)
    return visnav::cli::usage_error("run", st.error().message);
  if (auto st = a.require({"--config", "--tree"}); !st) return visnav::cli::usage_error("run", st.error().message);

  visnav::MissionOptions m;
  m.config_file = a.get("--config");
  m.tree_file = a.get("--tree");
  m.map_path = a.get("--map");
  m.create_map = a.has("--create");
  m.overrides = a.all("--set");
  m.blackboard_values = a.all("--bb");
  m.trace_file = a.get("--trace");
  m.extra_plugin_dirs = a.all("--plugin-path");
  if (a.has("--log-level")) {
    auto level = visnav::parse_log_level(a.get("--log-level"));
    if (!level) return visnav::cli::usage_error("run", level.error().message);
    m.log_level = *level;
  }
  visnav::install_signal_handlers();
  const visnav::RunReport r = visnav::run_mission(m);
  if (r.outcome == visnav::RunOutcome::error) {
    std::cerr << "visnav run: " << r.reason << "\n";
    return r.exit_code;
  }
  std::cout << "visnav run: " << visnav::to_string(r.outcome) << " after " << r.ticks << " ticks, "
            << r.run_time_s << " s run time (" << r.wall_time_s << " s wall)";
  if (r.overruns > 0) std::cout << ", " << r.overruns << " overruns";
  if (r.control_applied > 0 || r.control_rejected > 0)
    std::cout << ", " << r.control_applied << " control requests applied, " << r.control_rejected << " rejected";
  if (r.pauses > 0) std::cout << ", paused " << r.pauses << "x for " << r.paused_s << " s";
  std::cout << "\n";
  if (!r.reason.empty()) std::cerr << "visnav run: " << r.reason << "\n";
  return r.exit_code;
}

}  // namespace

VISNAV_COMMAND(run, "run", "run a mission tree with the plugins named in a config", kUsage, &run)
