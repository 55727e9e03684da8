// visnav runtime — a run session (plugins built from a config) and the tick loop.
//
// Programmatic use (e.g. an experiment command):
//
//   VISNAV_ASSIGN(visnav::RunConfig config, visnav::load_run_config("config/sim.yaml", {"run.rate_hz=20"}));
//   VISNAV_ASSIGN(auto session, visnav::Session::create(std::move(config), {}));
//   visnav::Robot& robot = session->robot();              // guarded: records the last command
//   if (auto* sim = robot.simulation()) sim->set_ground_truth_pose({0, 0, 0});
//   VISNAV_ASSIGN(visnav::bt::Tree tree, session->load_tree("trees/mission.xml"));
//   visnav::RunOptions run;
//   run.after_tick = [&](const visnav::TickInfo& t) { record(sim->ground_truth_pose()); return true; };
//   visnav::RunReport report = visnav::run_tree(*session, tree, run);
//   // tree must be destroyed before session (its nodes use the session's host).
//
// Session::create builds, in order: logger, plugin loader (default search path + config
// `plugin_path` + SessionOptions::extra_plugin_dirs; scanned once), host services, robot
// (host.robot() is set before the camera is created, so a simulated camera can follow the
// simulated robot), the run clock (simulated time in lock-step, else wall time), camera,
// detector (optional), map (`map_path`), telemetry sinks (the `run.telemetry_file` JSON lines
// and, with an enabled `dds:` block, DDS telemetry — both fed by one FanOutTelemetry that is the
// host's telemetry), the DDS control subscriber (`dds.control`), node registry (built-in nodes,
// then each selected `nodes` plugin's registrar).
//
// Tick loop (run_tree), per tick:
//   lock-step (simulated robot, run.lockstep auto/on): step(1/rate_hz) → grab → odometry →
//     publish both on the frame bus → tick; as fast as possible, clock = simulated time;
//   tick: frame — wait for a new camera frame (short waits, so signals are seen), publish
//     it with the newest odometry, tick;
//   tick: rate  — every 1/rate_hz s (wall): take a frame if one is ready, odometry, tick.
// Between ticks: live config reload (see Session::poll_config_reload), stop requests, and the
// mission-control requests of the `dds:` control topic (Session::control()), in arrival order:
//   pause   — the robot is commanded to zero at once and again on every loop iteration while
//             paused (a keep-alive for robots with a cmd_vel timeout); the tree is not ticked
//             and not halted (RUNNING nodes resume where they were); telemetry publishes
//             status "paused"; after_tick is not called. Lock-step simulation keeps stepping,
//             paced at real time (1/rate_hz of wall time per step), so the robot brakes and
//             simulated time passes. Sensor failures and max_duration_s still end the run;
//             stale or missing data does not (the robot is already stopped): it is logged once.
//   resume  — ticking continues. Data must be fresh again within startup_timeout_s of the
//             resume (the tree is not ticked before); else safety stop as usual.
//   abort   — tree halted, robot stopped, outcome interrupted (exit 130), reason "aborted by
//             control topic".
//   swap_detector TYPE — Session::swap_detector(TYPE) between ticks; an unknown type or a
//             failing factory is rejected with a warning and the old detector kept.
// A pause while paused or a resume while running is ignored (logged). Rejected requests
// (malformed ones dropped by the subscriber and refused swaps) are counted in
// RunReport::control_rejected.
// Safety (in the runtime, not the nodes): newest frame older than max_frame_age_s, newest
// odometry older than max_odometry_age_s, no data within startup_timeout_s, or a camera/robot
// error → tree halted, robot stopped, reason logged, outcome safety_stop. A tick taking longer
// than 1/rate_hz (wall time) is an overrun: counted, and logged in real-time mode.
// Stop request (SIGINT/SIGTERM via install_signal_handlers, or RunOptions::stop_requested):
// tree halted (RUNNING nodes get their halt callbacks), zero velocity commanded, outcome
// interrupted. A node that throws (a bug; Tree::tick_once catches it and halts the tree) ends
// the run with outcome error. The robot is always commanded to stop when run_tree returns.
//
// Thread-safety: a Session and its tree are used from one thread; the stop flag may be set
// from any thread or a signal handler.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "visnav/bt/tree.hpp"
#include "visnav/config.hpp"
#include "visnav/dds.hpp"
#include "visnav/devices.hpp"
#include "visnav/host.hpp"
#include "visnav/loader.hpp"
#include "visnav/map.hpp"
#include "visnav/runtime_host.hpp"

namespace visnav {

struct SessionOptions {
  /// Searched after the default path and the config's plugin_path (e.g. `--plugin-path`).
  std::vector<std::string> extra_plugin_dirs;
  /// false: only config plugin_path + extra_plugin_dirs are searched (tests).
  bool use_default_plugin_path = true;
  /// `--map`: opened with MapStore::open; a missing folder is created as an empty map only with
  /// `create_map` (the CLI's `--create`), else it is an error. The loaded plugins' payload
  /// readers are registered with the map (MapStore::set_payload_check).
  std::string map_path;
  bool create_map = true;
  /// Overrides applied to the file on every live reload (the `--set` list used to load it).
  std::vector<std::string> overrides;
  /// Borrowed logger; nullptr: a StderrLogger at run.log_level owned by the session.
  Logger* logger = nullptr;
};

/// A robot wrapper owned by the session: forwards to the plugin robot, remembers the last
/// command, and once latched (safety stop) only passes zero commands.
class GuardedRobot final : public Robot {
 public:
  explicit GuardedRobot(Robot& inner) : inner_(&inner) {}
  Status send_command(const Twist& command) override;
  std::optional<Odometry> latest_odometry() override { return inner_->latest_odometry(); }
  Status stop() override;
  SimulationControl* simulation() override { return inner_->simulation(); }
  Status reconfigure(const ConfigNode& params) override { return inner_->reconfigure(params); }

  [[nodiscard]] const Twist& last_command() const { return last_command_; }
  [[nodiscard]] std::uint64_t commands_sent() const { return commands_; }
  /// After latch() non-zero commands are refused (error) and replaced by a stop.
  void latch(std::string reason) { latched_reason_ = std::move(reason); }
  /// Allows motion again (e.g. before running another tree on the same session).
  void unlatch() { latched_reason_.reset(); }
  [[nodiscard]] bool latched() const { return latched_reason_.has_value(); }

 private:
  Robot* inner_;
  Twist last_command_;
  std::uint64_t commands_ = 0;
  std::optional<std::string> latched_reason_;
};

class Session {
 public:
  /// Builds everything (see the file comment). Errors name the section, type and library.
  [[nodiscard]] static Result<std::unique_ptr<Session>> create(RunConfig config, const SessionOptions& options = {});
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  [[nodiscard]] const RunConfig& config() const { return config_; }
  [[nodiscard]] Logger& logger() { return *logger_; }
  [[nodiscard]] PluginLoader& loader() { return loader_; }
  [[nodiscard]] RuntimeHost& host() { return *host_; }
  [[nodiscard]] FrameBus& frame_bus() { return frame_bus_; }
  /// The run clock: simulated time in lock-step, else wall time since the session started.
  [[nodiscard]] const Clock& clock() { return host_->clock(); }
  /// The robot as nodes see it (guarded wrapper around the plugin robot).
  [[nodiscard]] GuardedRobot& robot() { return *guard_; }
  [[nodiscard]] Camera& camera() { return *camera_; }
  /// Active detector (nullptr when the config has no `detector:` section).
  [[nodiscard]] Detector* detector() { return detector_.get(); }
  [[nodiscard]] MapStore* map() { return map_ ? &*map_ : nullptr; }
  [[nodiscard]] bt::NodeRegistry& registry() { return *registry_; }
  [[nodiscard]] bool lockstep() const { return lockstep_; }
  /// Number of NavStatus published through host().telemetry() (0 without a telemetry sink:
  /// no `run.telemetry_file`, no DDS telemetry and no added sink).
  [[nodiscard]] std::uint64_t telemetry_published() const;
  /// Adds a consumer of every NavStatus (the live view, a recording) beside the config's sinks;
  /// borrowed until remove_telemetry_sink(). The host has a telemetry exactly while some sink
  /// exists, so primitives build no status nobody reads.
  void add_telemetry_sink(Telemetry* sink);
  void remove_telemetry_sink(Telemetry* sink);
  /// DDS telemetry publisher (nullptr unless the `dds:` block enables telemetry).
  [[nodiscard]] dds::DdsTelemetry* dds_telemetry();
  /// DDS mission-control subscriber (nullptr unless the `dds:` block enables control); the run
  /// loop drains it between ticks.
  [[nodiscard]] dds::ControlSubscriber* control();

  /// Replaces the active detector with a new one of `type` (default params, any library that
  /// provides it), between ticks (tick thread only). The new detector is created first: an
  /// unknown type or a failing factory returns the error and keeps the old detector. On
  /// success config().detector becomes {type, no params} (a later live reload compares against
  /// it, so editing the file's detector section swaps again). Requesting the active type is a
  /// no-op (ok).
  Status swap_detector(const std::string& type);

  /// Loads, validates and instantiates a tree with the run clock. Validation errors (all of
  /// them, file:line each) are the error message; nothing is instantiated then.
  [[nodiscard]] Result<bt::Tree> load_tree(const std::string& tree_file,
                                          const std::vector<bt::PortOverride>& port_overrides = {});

  /// Re-reads the config file (with the session's overrides) and applies it between ticks:
  /// changed params → PluginObject::reconfigure; a changed detector type/plugin → new detector
  /// created, then swapped in; run.{rate_hz, max_*_age_s, startup_timeout_s, max_duration_s,
  /// log_level, reload_poll_s} take effect. Rejected (old config kept, reason logged and
  /// returned): parse/validation errors, a failing detector factory, and changes that need a
  /// restart (robot/camera type or plugin, nodes, plugin_path, run.tick, run.lockstep,
  /// run.trace_file, run.telemetry_file, the `dds:` block). A robot/camera reconfigure error keeps that object's
  /// old params and is logged; the rest is applied. Returns true when something changed.
  Result<bool> reload_config();
  /// Cheap check (a stat at most every run.reload_poll_s of wall time, or always with
  /// `force`): reloads when the file's mtime or size changed. Returns true when a reload was
  /// applied.
  bool poll_config_reload(bool force = false);
  /// Number of reloads applied / rejected so far.
  [[nodiscard]] int reloads_applied() const;
  [[nodiscard]] int reloads_rejected() const;

 private:
  Session();  // out of line: Links and LiveReload are complete only in the .cpp files
  // Build steps, in this order (see the file comment); each is one job.
  Status build(const SessionOptions& options);
  Status build_logger(const SessionOptions& options);
  Status build_loader(const SessionOptions& options);
  Status build_devices();
  Status open_map(const SessionOptions& options);
  Status build_links();

  RunConfig config_;
  std::unique_ptr<StderrLogger> own_logger_;
  Logger* logger_ = nullptr;
  PluginLoader loader_{std::vector<std::string>{}};
  WallClock wall_clock_;
  std::unique_ptr<SimulationClock> sim_clock_;
  FrameBus frame_bus_;
  std::unique_ptr<RuntimeHost> host_;
  /// Telemetry sinks (run.telemetry_file, DDS) behind one fan-out, and the DDS control subscriber.
  struct Links;
  std::unique_ptr<Links> links_;
  std::optional<MapStore> map_;
  PluginPtr<Robot> robot_;
  std::unique_ptr<GuardedRobot> guard_;
  PluginPtr<Camera> camera_;
  PluginPtr<Detector> detector_;  // changed only through install_detector (swap, reload)
  std::unique_ptr<bt::NodeRegistry> registry_;
  bool lockstep_ = false;
  /// Live reload (session_reload.cpp): re-reads the file and applies it to the parts above,
  /// which it borrows; made last, destroyed first.
  class LiveReload;
  std::unique_ptr<LiveReload> reload_;
};

enum class RunOutcome { success, failure, safety_stop, interrupted, stopped, error };
[[nodiscard]] const char* to_string(RunOutcome outcome);

struct TickInfo {
  std::uint64_t tick = 0;       ///< 1-based tick index
  double t_s = 0.0;             ///< run clock at the tick
  bt::NodeStatus status = bt::NodeStatus::idle;  ///< root status after the tick
  double tick_duration_s = 0.0; ///< wall time spent in tick_once()
};

struct RunOptions {
  /// Overrides run.trace_file when not empty.
  std::string trace_file;
  /// Polled between ticks; set from a signal handler or another thread to stop the run.
  /// nullptr: the process-wide flag of install_signal_handlers().
  const std::atomic<int>* stop_requested = nullptr;
  /// Called after every tick; return false to end the run (outcome stopped, exit 0).
  std::function<bool(const TickInfo&)> after_tick;
};

struct RunReport {
  RunOutcome outcome = RunOutcome::error;
  /// Process exit status: success 0, failure 1, safety_stop 3, interrupted 128+signal
  /// (130 for SIGINT and for an abort request on the control topic), stopped 0, error 1.
  int exit_code = 1;
  std::string reason;           ///< why the run ended (failure, safety, error), empty on success
  std::uint64_t ticks = 0;
  std::uint64_t overruns = 0;
  double run_time_s = 0.0;      ///< on the run clock
  double wall_time_s = 0.0;
  // Mission control (the `dds:` control topic).
  std::uint64_t control_applied = 0;   ///< requests carried out (pause, resume, abort, swaps)
  std::uint64_t control_rejected = 0;  ///< malformed requests dropped + swaps refused
  std::uint64_t pauses = 0;            ///< number of pauses
  double paused_s = 0.0;               ///< run-clock time spent paused
};

/// Runs `tree` on `session` until it finishes or is stopped (see the file comment).
RunReport run_tree(Session& session, bt::Tree& tree, const RunOptions& options = {});

/// Installs SIGINT/SIGTERM handlers that store the signal number in signal_flag()
/// (async-signal-safe). A second signal while the flag is set restores the default action.
void install_signal_handlers();
/// The process-wide stop flag: 0, or the number of the signal received.
[[nodiscard]] std::atomic<int>& signal_flag();

/// Everything `visnav run` does: check the setup (check_setup, the very checks of `visnav
/// validate`), load config (+overrides), create the session, load the tree, run, print nothing
/// (logs go to the logger). Errors before the first tick → outcome error, every problem listed.
struct MissionOptions {
  std::string config_file;
  std::vector<std::string> overrides;
  std::string tree_file;
  /// `--map`: a folder path, or a bare name resolved by resolve_map_path (maps/NAME).
  std::string map_path;
  bool create_map = true;  ///< SessionOptions::create_map (`visnav run` sets it from --create)
  std::string trace_file;
  std::vector<std::string> extra_plugin_dirs;
  bool use_default_plugin_path = true;
  std::optional<LogLevel> log_level;  ///< overrides run.log_level
  /// "key=value" entries written (as strings) to the tree's root blackboard before the first
  /// tick (`visnav run --bb`); ports convert them to their types when read.
  std::vector<std::string> blackboard_values;
  /// "Node.port=value" set on every such node of the tree (`visnav run --port`; bt::PortOverride).
  std::vector<std::string> port_overrides;
  const std::atomic<int>* stop_requested = nullptr;
};
[[nodiscard]] RunReport run_mission(const MissionOptions& options);

/// A mission ready for its first tick. Members are declared so that the tree is destroyed
/// before the session (its nodes use the session's host).
struct PreparedMission {
  std::unique_ptr<Session> session;
  std::optional<bt::Tree> tree;
};
/// The part of run_mission before the first tick, shared with `visnav run --view`:
/// check_setup (nothing is built when it finds a problem; the error's message lists every
/// problem, one per line, and its code and location are the first one's), then the session,
/// the tree and the blackboard values.
[[nodiscard]] Result<PreparedMission> prepare_mission(const MissionOptions& options);

/// Writes "key=value" assignments (values as strings) to the tree's root blackboard.
/// Error names a malformed entry.
[[nodiscard]] Status set_blackboard_values(bt::Tree& tree, const std::vector<std::string>& assignments);

/// `visnav run --resume`: the entries of MAP/progress.yaml (written by a run, e.g. FollowRoute
/// checkpoint="true") as "key=value" blackboard assignments, plus "resume=true". Errors: no
/// checkpoint (not_found), not a flat YAML map (parse_error / invalid_value, naming file:line).
[[nodiscard]] Result<std::vector<std::string>> progress_checkpoint_values(const std::string& map_dir);

/// The folder bare map names live in: $VISNAV_MAPS_DIR when set and not empty, else `maps`
/// (relative to the current directory, i.e. the repository's top-level maps/ when run there).
[[nodiscard]] std::string maps_dir();
/// `--map` rule: a bare name (no '/', not "." or "..") is the folder maps_dir()/NAME; anything
/// else is a path used as given. "demo" → "maps/demo"; "./demo", "/tmp/m", "a/b" unchanged.
[[nodiscard]] std::string resolve_map_path(const std::string& name_or_path);

/// What the checks before the first tick look at (`visnav validate` and `visnav run`).
struct SetupCheck {
  std::string config_file;
  std::vector<std::string> overrides;        ///< `--set` key.path=value
  std::string tree_file;                     ///< empty: no tree
  /// `--bb key=value`: each value is checked by every port of the tree that reads {key}, as a
  /// literal would be (type and check).
  std::vector<std::string> blackboard_values;
  /// `--port Node.port=value`: applied to the tree as it is validated (bt::PortOverride); a
  /// malformed entry, an unknown node or port, or a bad value is a problem like any other.
  std::vector<std::string> port_overrides;
  std::string map_path;                      ///< empty: no map; else as resolve_map_path
  bool create_map = false;                   ///< a missing map folder is fine (run --create)
  std::vector<std::string> extra_plugin_dirs;
  bool use_default_plugin_path = true;
};

/// Every check `visnav run` makes before its first tick, without building a robot, camera or
/// detector and without running plugin code beyond loading the declared plugins and calling
/// their parameter checks (TypeEntry::check_params) and node registrars:
///  * the YAML syntax and structure of the config (unknown keys, the run: and dds: blocks),
///  * that a plugin provides each robot/camera/detector type, and each `params:` block through
///    the type's schema and validate() (ranges, cross-field rules), including the files the
///    params name (a simulated `world:` is opened and parsed),
///  * the nodes plugins register, and the tree against the registered node types: structure,
///    ports, and every literal port value against its type and its check (range); built-in
///    nodes included (`<Sleep msec="-5"/>`); so are the `blackboard_values` the ports read,
///  * with a map: that it opens (graph file) and that every edge payload reads and passes its
///    primitive's payload check.
/// Returns every problem found (not just the first), each with a code and a location
/// (file:line, key); empty: valid. Warnings (plugin_path libraries being loaded) go to `log`
/// (nullptr: stderr at warn level).
[[nodiscard]] std::vector<Error> check_setup(const SetupCheck& setup, Logger* log = nullptr);

/// check_setup with each problem as its message text (the form `visnav validate` prints).
[[nodiscard]] std::vector<std::string> validate_setup(const std::string& config_file,
                                                      const std::vector<std::string>& overrides,
                                                      const std::string& tree_file,
                                                      const std::vector<std::string>& extra_plugin_dirs = {},
                                                      bool use_default_plugin_path = true);

/// Builds the node registry of a setup without devices (for `visnav nodes`): built-in nodes
/// plus every nodes plugin the loader has loaded (or only `only` when given). Errors name the
/// plugin whose registrar failed.
[[nodiscard]] Status register_all_nodes(bt::NodeRegistry& registry, PluginLoader& loader, HostServices& host,
                                        const std::optional<std::vector<std::string>>& only = std::nullopt);

}  // namespace visnav
