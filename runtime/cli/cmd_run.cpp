// `visnav run`: build the plugins named in a config and run a mission tree.
#include <chrono>
#include <cstdlib>
#include <iostream>
#include <thread>

#include "args.hpp"
#include "command.hpp"
#include "view/live_view.hpp"
#include "visnav/runner.hpp"

namespace {

constexpr const char* kUsage =
    "usage: visnav run --config C --tree T [--map M [--create]] [--set key.path=value]... [--bb key=value]...\n"
    "                  [--port Node.port=value]... [--resume] [--trace F] [--view PORT]\n"
    "                  [--plugin-path DIR]... [--log-level debug|info|warn|error]\n"
    "\n"
    "Builds the robot, camera and detector named in the YAML config C, registers the built-in\n"
    "and plugin behaviour-tree nodes, validates the tree T and ticks it until it finishes. First it\n"
    "makes every check of `visnav validate` (nothing runs when one fails; all problems are listed).\n"
    "Simulated robots run in lock-step, as fast as possible.\n"
    "\n"
    "  --config C         run configuration (docs/config.md)\n"
    "  --tree T           mission tree, BehaviorTree.CPP v4 XML\n"
    "  --map M            map folder (opened; a missing folder is an error unless --create). A bare\n"
    "                     name (no '/') is maps/M ($VISNAV_MAPS_DIR/M when set); a path is used as given\n"
    "  --create           with --map: create M as an empty map if it does not exist (teaching)\n"
    "  --set k=v          override a config value, e.g. --set detector.params.target_keypoints=300\n"
    "  --bb key=value     set a blackboard entry before the first tick, e.g. --bb start=dock\n"
    "  --port N.p=value   set port p on every node N of the tree (included files too), as if written\n"
    "                     in the XML, e.g. --port ReplayFeatureEdge.speed_mps=0.4 (what `visnav tune`\n"
    "                     prints); an unknown node or port is an error (docs/bt.md, port overrides)\n"
    "  --resume           with --map: continue a stopped or crashed mission from the progress checkpoint\n"
    "                     M/progress.yaml its run kept (FollowRoute checkpoint=\"true\"): its entries and\n"
    "                     resume=true become blackboard entries (--bb wins), e.g. with\n"
    "                     trees/resume_route.xml, which relocalises before moving (docs/relocalisation.md)\n"
    "  --trace F          write every node status transition to F as JSON lines\n"
    "  --view PORT        live view: serve the Foxglove WebSocket protocol on 127.0.0.1:PORT (camera\n"
    "                     with the primitive's overlays, pose, map, telemetry, tree statuses; open\n"
    "                     ws://localhost:PORT in Foxglove;\n"
    "                     docs/live_view.md); overrides run.view_port. VISNAV_VIEW_ALL_INTERFACES=1 listens\n"
    "                     on every interface\n"
    "  --view-speed X     with the live view in lock-step simulation: run X times real time so it can be\n"
    "                     watched (default 1; 0 = as fast as possible)\n"
    "  --plugin-path DIR  extra plugin directory (after VISNAV_PLUGIN_PATH and plugin_path)\n"
    "  --log-level L      overrides run.log_level\n"
    "\n"
    "Editing the config file while running applies parameter changes live (see docs/config.md).\n"
    "With a `dds:` block in C, every tick's status is published on DDS and pause / resume /\n"
    "abort / swap_detector requests are obeyed (`visnav monitor`, docs/dds.md).\n"
    "Exit status: 0 tree SUCCESS, 1 tree FAILURE or setup/validation error, 2 usage error,\n"
    "3 safety stop (stale data, sensor failure), 130 interrupted (SIGINT or an abort request:\n"
    "tree halted, robot stopped).\n";

/// run_mission, with the live view attached when --view or run.view_port asks for it (same
/// steps: prepare_mission, then run).
visnav::RunReport run_with_view(const visnav::MissionOptions& m, const std::string& port_text,
                                const std::string& speed_text) {
  visnav::RunReport r;
  r.outcome = visnav::RunOutcome::error;
  r.exit_code = 1;
  int port = -1;
  if (!port_text.empty()) {
    try {
      port = std::stoi(port_text);
    } catch (...) {
    }
    if (port < 0 || port > 65535) {
      r.reason = "--view: '" + port_text + "' is not a port number 0..65535";
      return r;
    }
  }
  double speed = -1.0;
  try {
    speed = std::stod(speed_text);
  } catch (...) {
  }
  if (!(speed >= 0.0 && speed <= 1000.0)) {
    r.reason = "--view-speed: '" + speed_text + "' is not a number in [0, 1000]";
    return r;
  }
  auto prepared = visnav::prepare_mission(m);  // the checks of `visnav validate`, then session and tree
  if (!prepared) {
    r.reason = prepared.error().message;
    return r;
  }
  visnav::Session& session = *prepared->session;
  visnav::bt::Tree& tree = *prepared->tree;
  if (port < 0) port = session.config().run.view_port > 0 ? session.config().run.view_port : -1;
  if (port < 0) {  // no live view
    visnav::RunOptions ro;
    ro.trace_file = m.trace_file;
    return visnav::run_tree(session, tree, ro);
  }
  const char* all = std::getenv("VISNAV_VIEW_ALL_INTERFACES");
  auto view = visnav::view::LiveView::create(port, session, all != nullptr && std::string(all) == "1");
  if (!view) {
    r.reason = view.error().message;
    return r;
  }
  std::cerr << "visnav run: live view on ws://localhost:" << (*view)->port() << " (Foxglove: Open connection)\n";
  visnav::RunOptions ro;
  ro.trace_file = m.trace_file;
  // Lock-step runs as fast as it can; to be watched it is paced to `speed` x real time.
  const bool pace = session.lockstep() && speed > 0.0;
  const auto wall0 = std::chrono::steady_clock::now();
  double sim0 = -1.0;
  ro.after_tick = [&](const visnav::TickInfo& t) {
    (*view)->after_tick(t, tree);
    if (pace) {
      if (sim0 < 0.0) sim0 = t.t_s;
      std::this_thread::sleep_until(wall0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                std::chrono::duration<double>((t.t_s - sim0) / speed)));
    }
    return true;
  };
  return visnav::run_tree(session, tree, ro);  // view, then tree, then session are destroyed
}

int run(const std::vector<std::string>& args) {
  using visnav::cli::Opt;
  visnav::cli::Args a;
  if (auto st = a.parse(args, {{"--config", Opt::value}, {"--tree", Opt::value}, {"--map", Opt::value},
                               {"--create", Opt::flag}, {"--resume", Opt::flag}, {"--set", Opt::repeated}, {"--bb", Opt::repeated}, {"--port", Opt::repeated}, {"--trace", Opt::value}, {"--plugin-path", Opt::repeated},
                               {"--log-level", Opt::value}, {"--view", Opt::value}, {"--view-speed", Opt::value}});
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
  m.port_overrides = a.all("--port");
  if (a.has("--resume")) {
    if (m.map_path.empty()) return visnav::cli::usage_error("run", "--resume needs --map");
    auto resumed = visnav::progress_checkpoint_values(visnav::resolve_map_path(m.map_path));
    if (!resumed) {
      std::cerr << "visnav run: " << resumed.error().message << "\n";
      return 1;
    }
    resumed->insert(resumed->end(), m.blackboard_values.begin(), m.blackboard_values.end());
    m.blackboard_values = std::move(*resumed);
  }
  m.trace_file = a.get("--trace");
  m.extra_plugin_dirs = a.all("--plugin-path");
  if (a.has("--log-level")) {
    auto level = visnav::parse_log_level(a.get("--log-level"));
    if (!level) return visnav::cli::usage_error("run", level.error().message);
    m.log_level = *level;
  }
  visnav::install_signal_handlers();
  const visnav::RunReport r = run_with_view(m, a.has("--view") ? a.get("--view") : std::string(), a.get("--view-speed", "1"));
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
