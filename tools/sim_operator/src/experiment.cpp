#include "experiment.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <numbers>
#include <optional>
#include <sstream>
#include <thread>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "sim_session_util.hpp"
#include "visnav/bt/tree.hpp"
#include "visnav/feature_replay/experience.hpp"
#include "visnav/map.hpp"
#include "visnav/runner.hpp"
#include "visnav_sim/commands.hpp"
#include "visnav_sim/route.hpp"
#include "visnav_sim/world.hpp"

namespace fs = std::filesystem;

namespace visnav::simop {

AccuracyRepeatability accuracy_repeatability(const std::vector<cv::Point2d>& ends, const cv::Point2d& taught_end) {
  AccuracyRepeatability r;
  if (ends.empty()) return r;
  cv::Point2d mean(0, 0);
  for (const auto& e : ends) mean += e;
  mean *= 1.0 / static_cast<double>(ends.size());
  double acc = 0.0;
  double rep = 0.0;
  for (const auto& e : ends) {
    const cv::Point2d d = e - taught_end;
    const cv::Point2d m = e - mean;
    acc += d.dot(d);
    rep += m.dot(m);
  }
  r.accuracy_m = std::sqrt(acc / static_cast<double>(ends.size()));
  r.repeatability_m = std::sqrt(rep / static_cast<double>(ends.size()));
  return r;
}

Spread spread(const std::vector<double>& values) {
  Spread s;
  s.count = static_cast<int>(values.size());
  if (values.empty()) return s;
  for (double v : values) s.mean += v;
  s.mean /= static_cast<double>(values.size());
  double ss = 0.0;
  for (double v : values) ss += (v - s.mean) * (v - s.mean);
  s.sd = values.size() > 1 ? std::sqrt(ss / static_cast<double>(values.size() - 1)) : 0.0;
  s.worst = *std::max_element(values.begin(), values.end());
  return s;
}

Result<std::vector<std::string>> appearance_overrides(const std::string& name) {
  // Camera-side appearance changes between teach and replay. The season swaps the world's
  // seasonal textures (snow on grass and paths, bare or coloured trees); the light presets
  // change the global brightness/colour and throw world-fixed shadow bands as a low sun does.
  if (name == "same" || name.empty()) return std::vector<std::string>{};
  if (name == "winter" || name == "autumn") return std::vector<std::string>{"camera.params.season=" + name};
  if (name == "dusk")
    return std::vector<std::string>{"camera.params.gain=0.55", "camera.params.color_gain_bgr=0.8;0.95;1.15",
                                    "camera.params.noise_std=5"};
  if (name == "low_sun")
    return std::vector<std::string>{"camera.params.gain=1.15", "camera.params.shadow_strength=0.55",
                                    "camera.params.shadow_period_m=5", "camera.params.shadow_width_m=2",
                                    "camera.params.shadow_direction_deg=120"};
  if (name == "overcast")
    return std::vector<std::string>{"camera.params.gain=0.8", "camera.params.color_gain_bgr=1.05;1;0.95"};
  return Error{"unknown appearance '" + name + "' (known: same, winter, autumn, dusk, low_sun, overcast)",
               ErrorCode::out_of_range, {{}, 0, name}};
}

std::vector<std::string> ideal_overrides() {
  return {"robot.params.odom_scale_error_pct=3",  // seed 000's condition, identical in both runs
          "robot.params.odom_scale_error_sd_pct=0", "robot.params.odom_wheel_asymmetry_pct=0",
          "robot.params.odom_wheel_asymmetry_sd_pct=0", "robot.params.odom_heading_drift_degpm=0",
          "robot.params.odom_heading_drift_sd_degpm=0", "robot.params.odom_distance_noise_m_per_sqrt_m=0",
          "robot.params.odom_heading_noise_deg_per_sqrt_m=0", "robot.params.slip_path_pct=0",
          "robot.params.slip_grass_pct=0", "robot.params.slip_other_pct=0", "camera.params.noise_std=0",
          "camera.params.exposure_jitter=0", "camera.params.motion_blur_exposure_s=0", "camera.params.latency_s=0",
          "camera.params.drop_probability=0", "camera.params.freeze_probability=0"};
}

namespace {

constexpr const char* kUsage =
    "usage: visnav experiment [--world W] [--route R] [--displace M[,DEG]] [--loops N] [--seeds N]\n"
    "                         [--seed S] [--jobs J] [--radius M] [--maps hybrid,feature,path] [--ideal]\n"
    "                         [--teach-appearance A] [--replay-appearance A] [--config C] [--out DIR]\n"
    "                         [--set k=v]... [--teach-set k=v]... [--replay-set k=v]... [--port N.p=v]...\n"
    "                         [--learn-loops N] [--experience-teach A] [--obstacles FILE]\n"
    "                         [--replay-tree FILE] [--log-level L]\n"
    "\n"
    "The seed 000 Sec. 6 experiment, repeated over independent random runs. For each map style and\n"
    "each seed: teach the route R (a waypoint script, config/routes/) in the simulated world W with\n"
    "one draw of the simulator's error models (odometry scale, wheel asymmetry, drift, noise and\n"
    "slip; camera noise, exposure flicker, blur, latency, dropped frames), carry the robot M metres\n"
    "to the left of the first edge and turn it DEG degrees, then replay the closed route N times\n"
    "with a second, independent draw. Each loop's end is measured against the taught end with the\n"
    "simulator's ground truth. A loop is completed only when the robot finished it within the\n"
    "radius of the taught end and without a collision; a replay that stops (lost, camera frozen,\n"
    "collision) fails that loop and every loop after it. 'hybrid' teaches every leg with the\n"
    "primitive the route names, 'feature' every leg with the feature-based primitive, 'path'\n"
    "every leg with path following (legs without a visible path, e.g. indoors, fail).\n"
    "\n"
    "  --world W             world name or file (default campus)\n"
    "  --route R             route name or file (default: the world's name)\n"
    "  --displace M[,DEG]    lateral displacement (left +) before the first replay, m, and heading\n"
    "                        error, deg (default 1.0,10)\n"
    "  --loops N             replays of the closed route per run (default 5)\n"
    "  --seeds N             independent runs per map style (default 5)\n"
    "  --seed S              first seed (default 1): runs use S, S+1, ...; same seed, same result\n"
    "  --jobs J              runs in parallel (default: the number of cores); results do not depend on it\n"
    "  --radius M            a loop ending farther than M from the taught end failed (default 1.0)\n"
    "  --maps LIST           map styles, comma-separated: hybrid, feature, path (default hybrid,feature)\n"
    "  --ideal               every error model off: a noise-free regression run, not a result\n"
    "  --teach-appearance A  appearance while teaching: same, winter, autumn, dusk, low_sun, overcast\n"
    "  --replay-appearance A appearance while replaying (default same)\n"
    "  --learn-loops N       multi-experience maps: before the measured replay, drive N loops in the\n"
    "                        replay conditions learning each feature edge's view as a new appearance\n"
    "                        experience (trees/patrol_loop_learning.xml); not measured (default 0)\n"
    "  --learn-blind-m M     learning loops: learn frames without a confident match for up to M m\n"
    "                        (as seen on odometry) and allow M m blind (default: 1 m / 5 m, the replay's)\n"
    "  --experience-teach A  multi-experience maps by a supervised drive: after the teach, the scripted\n"
    "                        operator drives the route again under appearance A (e.g. winter; its own\n"
    "                        draw of the error models) with the teach tree into <run>/experience_drive/map,\n"
    "                        and each feature edge it taught is added to the taught edge as an appearance\n"
    "                        experience (visnav map experiences MAP --add-from DRIVE_MAP); not measured\n"
    "  --config C            run configuration (default config/sim_experiment.yaml)\n"
    "  --out DIR             output folder (default out/experiment)\n"
    "  --set k=v             config override for both runs, e.g. --set robot.params.odom_scale_error_sd_pct=5\n"
    "  --teach-set k=v       config override for the teach run only\n"
    "  --replay-set k=v      config override for the replay run only\n"
    "  --obstacles FILE      obstacle file added to the world for the replays (not the teach): YAML\n"
    "                        'obstacles:' list, docs/sim.md; same as --replay-set robot.params.obstacles=FILE,\n"
    "                        and the replays use trees/patrol_loop_avoiding.xml (docs/obstacles.md)\n"
    "  --replay-tree FILE    the measured replay's tree (default trees/patrol_loop.xml, with --obstacles\n"
    "                        trees/patrol_loop_avoiding.xml); it gets the blackboard entries start and\n"
    "                        loops; nodes that need the camera mount read the replay camera's params\n"
    "                        (hfov_deg, mount_height_m, mount_pitch_down_deg; docs/cameras.md)\n"
    "  --log-level L         lowest level written to each run's run.log: debug, info, warn, error\n"
    "                        (default warn; info shows e.g. the avoiding nodes' decisions)\n"
    "  --port Node.port=v    set a port on every such node of the replay trees (learning loops\n"
    "                        too, not the teach), e.g. --port ReplayFeatureEdge.gain=0.5; how\n"
    "                        `visnav tune` reaches primitive gains (docs/bt.md, port overrides)\n"
    "A car-like sim robot (robot.params.kinematics=car_like) cannot turn on the spot: the experiment\n"
    "then sets ScriptedOperator/FollowRoute min_turning_radius_m to the robot's (corners driven as\n"
    "arcs), ReplayFeatureEdge.scan_deg=0, and measures loops at the last taught edge's end\n"
    "(docs/navigation.md, \"Robots that cannot turn on the spot\"; --port still overrides).\n"
    "\n"
    "Output: DIR/report.md (the table and every run's per-loop errors), DIR/summary.json (the table's\n"
    "figures, machine-readable), DIR/errors.png (error per loop, every run; failed loops marked),\n"
    "and per run DIR/<style>/seed<S>/: trajectories.png, trajectory.csv (ground truth and odometry\n"
    "of every tick), loops.csv (end position, error, along-/cross-track parts, completed, failure),\n"
    "edges.csv (each replayed edge's end against where it ended when taught), run.log (warnings\n"
    "and errors of the run, or from --log-level up), map/.\n"
    "\n"
    "Exit status: 0 every loop of every run completed, 1 some loop failed or a run could not be\n"
    "set up, 2 usage error.\n";

}  // namespace

Result<std::vector<std::string>> parse_map_kinds(const std::string& text) {
  std::vector<std::string> maps;
  std::stringstream ss(text);
  for (std::string m; std::getline(ss, m, ',');) {
    if (m != "hybrid" && m != "feature" && m != "path") return fail("--maps: '" + m + "' is not hybrid, feature or path");
    maps.push_back(m);
  }
  if (maps.empty()) return fail("--maps needs at least one map kind");
  return maps;
}

Status parse_displacement(const std::string& text, double& lateral_m, double& heading_deg) {
  const auto comma = text.find(',');
  VISNAV_ASSIGN(lateral_m, parse_number(text.substr(0, comma), -5.0, 5.0, "--displace (metres)"));
  if (comma != std::string::npos) {
    VISNAV_ASSIGN(heading_deg, parse_number(text.substr(comma + 1), -90.0, 90.0, "--displace (degrees)"));
  }
  return ok();
}

namespace {

Result<ExperimentOptions> parse(int argc, char** argv) {
  ExperimentOptions o;
  for (OptionReader in(argc, argv); in.next();) {
    const std::string& arg = in.arg();
    if (arg == "--world") { VISNAV_ASSIGN(o.world, in.value()); }
    else if (arg == "--route") { VISNAV_ASSIGN(o.route, in.value()); }
    else if (arg == "--displace") {
      VISNAV_ASSIGN(std::string v, in.value());
      VISNAV_TRY(parse_displacement(v, o.displace_m, o.displace_heading_deg));
    }
    else if (arg == "--loops") { VISNAV_ASSIGN(double n, in.number(1, 100)); o.loops = static_cast<int>(n); }
    else if (arg == "--seeds") { VISNAV_ASSIGN(double n, in.number(1, 1000)); o.seeds = static_cast<int>(n); }
    else if (arg == "--seed") { VISNAV_ASSIGN(double n, in.number(0, 1000000)); o.first_seed = static_cast<int>(n); }
    else if (arg == "--jobs") { VISNAV_ASSIGN(double n, in.number(1, 64)); o.jobs = static_cast<int>(n); }
    else if (arg == "--radius") { VISNAV_ASSIGN(o.success_radius_m, in.number(0.01, 100)); }
    else if (arg == "--ideal") { o.ideal = true; }
    else if (arg == "--learn-loops") { VISNAV_ASSIGN(double n, in.number(0, 100)); o.learn_loops = static_cast<int>(n); }
    else if (arg == "--learn-blind-m") { VISNAV_ASSIGN(o.learn_blind_m, in.number(0, 100)); }
    else if (arg == "--experience-teach") {
      VISNAV_ASSIGN(o.experience_teach, in.value());
      VISNAV_TRY(appearance_overrides(o.experience_teach));
    }
    else if (arg == "--teach-appearance") {
      VISNAV_ASSIGN(o.teach_appearance, in.value());
      VISNAV_TRY(appearance_overrides(o.teach_appearance));
    }
    else if (arg == "--replay-appearance") {
      VISNAV_ASSIGN(o.replay_appearance, in.value());
      VISNAV_TRY(appearance_overrides(o.replay_appearance));
    }
    else if (arg == "--config") { VISNAV_ASSIGN(o.config, in.value()); }
    else if (arg == "--out") { VISNAV_ASSIGN(o.out, in.value()); }
    else if (arg == "--set") { VISNAV_ASSIGN(std::string v, in.value()); o.overrides.push_back(v); }
    else if (arg == "--teach-set") { VISNAV_ASSIGN(std::string v, in.value()); o.teach_overrides.push_back(v); }
    else if (arg == "--replay-set") { VISNAV_ASSIGN(std::string v, in.value()); o.replay_overrides.push_back(v); }
    else if (arg == "--obstacles") {  // issue 16: obstacles placed for the replays only
      VISNAV_ASSIGN(std::string v, in.value());
      o.replay_overrides.push_back("robot.params.obstacles=" + v);
      o.obstacles = true;
    }
    else if (arg == "--replay-tree") { VISNAV_ASSIGN(o.replay_tree, in.value()); }
    else if (arg == "--log-level") {
      VISNAV_ASSIGN(o.log_level, in.value());
      if (o.log_level != "debug" && o.log_level != "info" && o.log_level != "warn" && o.log_level != "error")
        return fail("--log-level: '" + o.log_level + "' is not debug, info, warn or error");
    }
    else if (arg == "--port") {
      VISNAV_ASSIGN(std::string v, in.value());
      VISNAV_TRY(bt::parse_port_override(v));
      o.replay_ports.push_back(v);
    }
    else if (arg == "--maps") {
      VISNAV_ASSIGN(std::string v, in.value());
      VISNAV_ASSIGN(o.maps, parse_map_kinds(v));
    } else {
      return fail("unknown option '" + arg + "'");
    }
  }
  if (o.route.empty()) o.route = o.world;
  return o;
}

cv::Point2d xy(const Pose2D& p) { return {p.x_m, p.y_m}; }

/// A point's components in the frame of `heading_rad`: x along (forward +), y across (left +).
cv::Point2d components(const cv::Point2d& d, double heading_rad) {
  return {d.x * std::cos(heading_rad) + d.y * std::sin(heading_rad), -d.x * std::sin(heading_rad) + d.y * std::cos(heading_rad)};
}

/// Combined progress of all runs on one line (thread-safe).
class RunProgress {
 public:
  RunProgress(int runs, double work_per_run_m, bool enabled, std::function<void(double, double)> hook = {})
      : done_m_(static_cast<std::size_t>(runs), 0.0), work_per_run_m_(work_per_run_m), enabled_(enabled), line_(24),
        hook_(std::move(hook)) {}
  void update(int run, double done_m) {
    if (hook_) hook_(std::min(done_m, work_per_run_m_), work_per_run_m_);
    if (!enabled_) return;
    std::lock_guard lock(mutex_);
    done_m_[static_cast<std::size_t>(run)] = std::min(done_m, work_per_run_m_);
    draw_locked();
  }
  void finished(int run) {
    std::lock_guard lock(mutex_);
    done_m_[static_cast<std::size_t>(run)] = work_per_run_m_;
    ++finished_;
    if (enabled_) draw_locked();
  }
  void end() {
    std::lock_guard lock(mutex_);
    if (enabled_) line_.end();
  }

 private:
  void draw_locked() {
    double done = 0.0;
    for (double d : done_m_) done += d;
    const std::string phase = "runs " + std::to_string(finished_) + "/" + std::to_string(done_m_.size()) + " done";
    line_.show(phase, done / 1000.0, work_per_run_m_ * static_cast<double>(done_m_.size()) / 1000.0, "km");
  }
  std::mutex mutex_;
  std::vector<double> done_m_;
  double work_per_run_m_;
  bool enabled_;
  int finished_ = 0;
  ProgressLine line_{30};
  std::function<void(double, double)> hook_;
};

/// The run's log: warnings and errors (or from --log-level up) go to run.log; the first
/// lost/frozen stop is remembered.
class RunLogger final : public Logger {
 public:
  RunLogger(const fs::path& file, LogLevel min_level) : out_(file), min_level_(min_level) {}
  void log(LogLevel level, std::string_view component, std::string_view message) override {
    if (level < min_level_) return;
    std::lock_guard lock(mutex_);
    out_ << (level == LogLevel::error  ? "error "
             : level == LogLevel::warn ? "warn  "
             : level == LogLevel::info ? "info  "
                                       : "debug ")
         << component << ": " << message << "\n";
    if (level == LogLevel::error && stop_reason_.empty() &&
        (message.find("lost:") != std::string_view::npos || message.find("camera frozen") != std::string_view::npos))
      stop_reason_ = std::string(message);
  }
  [[nodiscard]] std::string stop_reason() {
    std::lock_guard lock(mutex_);
    return stop_reason_;
  }
  void clear_stop_reason() {
    std::lock_guard lock(mutex_);
    stop_reason_.clear();
  }

 private:
  std::mutex mutex_;
  std::ofstream out_;
  LogLevel min_level_;
  std::string stop_reason_;
};

/// Ground-truth pose of the robot when a primitive finished an edge (teach or replay).
struct EdgeEnd {
  int lap = 0;  ///< 0 = teach
  int index = 0;
  std::string edge;
  std::string kind;
  Pose2D pose;
  double odom_distance_m = 0.0;
};

/// Everything a run records for its files and pictures (the outcome is the summary).
struct RunTrace {
  std::vector<EdgeEnd> taught_edge_ends;
  std::vector<EdgeEnd> replay_edge_ends;
  std::vector<cv::Point2d> teach_path;
  std::vector<std::vector<cv::Point2d>> lap_paths;
  cv::Point2d taught_end;
  double taught_end_heading_rad = 0.0;
  /// Where a replayed loop must end: the taught end, or for a robot that turns on arcs the end
  /// of the last taught edge (the closing arc after it moved the robot on to the first edge's start).
  cv::Point2d loop_end;
  cv::Point2d replay_start;
};

/// The sim robot's drawn run errors: the same draw as the robot's (draw_run_errors on its params).
std::string run_errors_text(const RunConfig& config) {
  auto params = sim::RobotParams::schema().parse(config.robot.params);
  if (!params) return "?";
  const sim::RunErrors e = sim::draw_run_errors(*params);
  return "scale " + fixed(e.scale_error_pct, 2) + " %, asymmetry " + fixed(e.wheel_asymmetry_pct, 2) + " %, drift " +
         fixed(e.heading_drift_degpm, 2) + " deg/m";
}

cv::Mat draw_trajectories(const sim::World& world, const sim::Route& route, const ExperimentRun& run, const RunTrace& t) {
  cv::Rect2d b = world.bounds();
  const double margin = 3.0;  // as render_topview
  b = cv::Rect2d(b.x - margin, b.y - margin, b.width + 2 * margin, b.height + 2 * margin);
  const double px_per_m = 1200.0 / std::max(b.width, b.height);
  cv::Mat img = sim::render_topview(world, &route, px_per_m);
  cv::Mat dim;
  img.convertTo(dim, -1, 0.6, 0);
  img = dim;
  auto px = [&](const cv::Point2d& p) {
    return cv::Point(static_cast<int>(std::lround((p.x - b.x) * px_per_m)),
                     static_cast<int>(std::lround((b.y + b.height - p.y) * px_per_m)));
  };
  auto polyline = [&](const std::vector<cv::Point2d>& pts, const cv::Scalar& colour, int width) {
    for (std::size_t i = 1; i < pts.size(); ++i) cv::line(img, px(pts[i - 1]), px(pts[i]), colour, width, cv::LINE_AA);
  };
  polyline(t.teach_path, cv::Scalar(255, 255, 255), 3);
  for (std::size_t k = 0; k < t.lap_paths.size(); ++k) {
    const double s = t.lap_paths.size() > 1 ? static_cast<double>(k) / static_cast<double>(t.lap_paths.size() - 1) : 1.0;
    polyline(t.lap_paths[k], cv::Scalar(0, 255 * (1.0 - s), 255), 2);
  }
  cv::circle(img, px(t.loop_end), 6, cv::Scalar(255, 255, 255), 2, cv::LINE_AA);
  cv::circle(img, px(t.replay_start), 6, cv::Scalar(255, 0, 255), 2, cv::LINE_AA);
  for (const auto& l : run.loops) {
    if (l.finished) cv::drawMarker(img, px(l.end), l.completed ? cv::Scalar(0, 0, 255) : cv::Scalar(255, 0, 0),
                                   cv::MARKER_CROSS, 12, 2);
  }
  for (const auto& c : run.collisions) {
    cv::circle(img, px(xy(c.pose_world)), 10, cv::Scalar(0, 0, 255), 3, cv::LINE_AA);
    cv::putText(img, "collision: " + c.obstacle, px(xy(c.pose_world)) + cv::Point(12, -12), cv::FONT_HERSHEY_SIMPLEX,
                0.5, cv::Scalar(0, 0, 255), 1, cv::LINE_AA);
  }
  std::string title = run.style + " map, seed " + std::to_string(run.seed) +
                      ": teach (white), replay laps (yellow->red), start after displacement (magenta)";
  if (!run.stop_reason.empty()) title += "; STOPPED: " + run.stop_reason.substr(0, 80);
  cv::putText(img, title, {10, img.rows - 12}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  return img;
}

/// The phases of one run (run_one's steps); a phase that fails sets r.setup_error and returns
/// false. Members are declared in the order run_one made them, so they go away in the same order.
class RunPhases {
 public:
  RunPhases(const ExperimentOptions& options, const std::string& map_style, int run_seed, const sim::Route& taught_route,
            const std::string& route_path, const fs::path& run_dir, RunProgress& run_progress, int index,
            ExperimentRun& run, RunTrace& trace, RunLogger& run_logger)
      : o(options), style(map_style), seed(run_seed), route(taught_route), route_file(route_path), dir(run_dir),
        progress(run_progress), run_index(index), r(run), t(trace), logger(run_logger) {}

  bool load_configs();
  bool open_session();
  bool teach_route();
  void finish_teach();
  bool experience_drive();
  bool reconfigure_for_replay();
  bool learning_loops();
  bool displace();
  bool replay();
  void score_loops();
  void write_files(const sim::World& world);

 private:
  std::vector<std::string> phase_overrides(int phase, const std::string& appearance,
                                           const std::vector<std::string>& extra) const;
  std::vector<std::string> teach_values() const;
  void log_tick(const TickInfo& tick, const char* phase, int lap);
  double odom_distance();
  void finish_replay(const RunReport& report, double d0, std::size_t collisions_before);

  const ExperimentOptions& o;
  const std::string& style;
  int seed;
  const sim::Route& route;
  const std::string& route_file;
  const fs::path& dir;
  RunProgress& progress;
  int run_index;
  ExperimentRun& r;
  RunTrace& t;
  RunLogger& logger;
  std::error_code ec;

  std::vector<std::string> base;
  std::vector<bt::PortOverride> replay_ports;
  std::string config_file;
  std::optional<RunConfig> teach_config;
  std::optional<RunConfig> replay_config;
  double turning_radius_m = 0.0;
  std::vector<bt::PortOverride> teach_ports;
  fs::path map_dir;
  std::unique_ptr<Session> session;
  SimulationControl* sim = nullptr;
  std::ofstream trajectory;
  Pose2D teach_start;
  std::vector<cv::Point2d> lap_ends;
  std::string stop_reason;
};

std::vector<std::string> RunPhases::phase_overrides(int phase, const std::string& appearance,
                                                    const std::vector<std::string>& extra) const {
  std::vector<std::string> v = base;
  v.push_back("robot.params.seed=" + std::to_string(seed * 100 + phase));
  v.push_back("camera.params.seed=" + std::to_string(seed * 100 + 10 + phase));
  if (auto a = appearance_overrides(appearance)) v.insert(v.end(), a->begin(), a->end());
  v.insert(v.end(), extra.begin(), extra.end());
  return v;
}

/// The teach tree's blackboard (the taught run and the experience drive alike).
std::vector<std::string> RunPhases::teach_values() const {
  return {"route_file=" + route_file,
          std::string("force_kind=") + (style == "feature" ? "feature_segment"
                                        : style == "path"  ? "path_following"
                                                           : ""),
          std::string("close_loop=") + (route.closed ? "true" : "false")};
}

void RunPhases::log_tick(const TickInfo& tick, const char* phase, int lap) {
  const Pose2D gt = sim->ground_truth_pose();
  const auto odom = session->robot().latest_odometry();
  const Odometry od = odom ? *odom : Odometry{};
  trajectory << tick.t_s << ',' << phase << ',' << lap << ',' << gt.x_m << ',' << gt.y_m << ',' << gt.heading_rad << ','
             << od.pose.x_m << ',' << od.pose.y_m << ',' << od.pose.heading_rad << ',' << od.distance_m << '\n';
}

double RunPhases::odom_distance() {
  const auto od = session->robot().latest_odometry();
  return od ? od->distance_m : 0.0;
}

/// Overrides: placement, then the ideal switch, then the user's; per phase the seeds (one draw
/// of every error model per run) and the appearance. Parallel jobs need no robot names: each
/// session's camera rides on that session's robot.
bool RunPhases::load_configs() {
  base = {"robot.params.world=" + o.world};
  if (route.start) {
    std::ostringstream start;
    start << std::setprecision(17) << route.start->x_m << ";" << route.start->y_m << ";"
          << route.start->heading_rad * 180.0 / std::numbers::pi;
    base.push_back("robot.params.start_pose=" + start.str());
  }
  if (o.ideal)
    for (auto& v : ideal_overrides()) base.push_back(v);
  for (const auto& v : o.overrides) base.push_back(v);
  for (const auto& text : o.replay_ports) {
    auto port = bt::parse_port_override(text);
    if (!port) {  // parse() checked it already
      r.setup_error = port.error().message;
      return false;
    }
    replay_ports.push_back(std::move(*port));
  }
  config_file = project_file(o.config);
  auto teach_loaded = load_run_config(config_file, phase_overrides(1, o.teach_appearance, o.teach_overrides));
  auto replay_loaded = load_run_config(config_file, phase_overrides(2, o.replay_appearance, o.replay_overrides));
  if (!teach_loaded || !replay_loaded) {
    r.setup_error = (!teach_loaded ? teach_loaded.error() : replay_loaded.error()).message;
    return false;
  }
  teach_config = std::move(*teach_loaded);
  replay_config = std::move(*replay_loaded);
  r.teach_errors = run_errors_text(*teach_config);
  r.replay_errors = run_errors_text(*replay_config);
  // A robot that cannot turn on the spot (car_like): the operator drives corners as arcs of its
  // minimum turning radius and the replay's FollowRoute turns on arcs of it (docs/platforms.md).
  // Set before the user's --port, which may still override it; nothing is added otherwise.
  if (auto rp = sim::RobotParams::schema().parse(teach_config->robot.params); rp && rp->kinematics == "car_like")
    turning_radius_m = rp->min_turning_radius_m;
  if (turning_radius_m > 0.0) {
    std::ostringstream radius;
    radius << std::setprecision(17) << turning_radius_m;
    teach_ports.push_back({"ScriptedOperator", "min_turning_radius_m", radius.str()});
    replay_ports.insert(replay_ports.begin(), bt::PortOverride{"FollowRoute", "min_turning_radius_m", radius.str()});
    // ReplayFeatureEdge's start-view search turns on the spot to scan; a car would stand still.
    replay_ports.insert(replay_ports.begin(), bt::PortOverride{"ReplayFeatureEdge", "scan_deg", "0"});
  }
  return true;
}

/// The teach session on a fresh map, and the trajectory file every phase writes to.
bool RunPhases::open_session() {
  map_dir = dir / "map";
  fs::remove_all(map_dir, ec);
  SessionOptions so;
  so.map_path = map_dir.string();
  so.logger = &logger;
  auto made = Session::create(*teach_config, so);
  if (!made) {
    r.setup_error = made.error().message;
    return false;
  }
  session = std::move(*made);
  sim = session->robot().simulation();
  if (sim == nullptr) {
    r.setup_error = "the experiment needs the simulated robot (robot type sim)";
    return false;
  }
  trajectory.open(dir / "trajectory.csv");
  trajectory << "t_s,phase,lap,gt_x_m,gt_y_m,gt_heading_rad,odom_x_m,odom_y_m,odom_heading_rad,odom_distance_m\n";
  teach_start = sim->ground_truth_pose();
  return true;
}

/// --- teach
bool RunPhases::teach_route() {
  auto teach = session->load_tree(project_file("trees/teach_hybrid_route.xml"), teach_ports);
  if (!teach) {
    r.setup_error = teach.error().message;
    return false;
  }
  if (auto st = set_blackboard_values(*teach, teach_values()); !st) {
    r.setup_error = st.error().message;
    return false;
  }
  const double d0 = odom_distance();
  teach->add_observer([&](double, const bt::TreeNode& node, bt::NodeStatus, bt::NodeStatus to) {
    if (to != bt::NodeStatus::success) return;
    if (node.registration_id() != "TeachFeatureEdge" && node.registration_id() != "TeachPathEdge") return;
    EdgeEnd e;
    e.index = static_cast<int>(t.taught_edge_ends.size());
    if (auto id = node.blackboard().get<std::string>("taught_edge")) e.edge = *id;
    e.pose = sim->ground_truth_pose();
    e.odom_distance_m = odom_distance();
    t.taught_edge_ends.push_back(std::move(e));
  });
  const std::size_t collisions_before = sim->collisions().size();
  RunOptions ro;
  ro.after_tick = [&](const TickInfo& tick) {
    log_tick(tick, "teach", 0);
    if (tick.tick % 3 == 0) t.teach_path.push_back(xy(sim->ground_truth_pose()));
    progress.update(run_index, odom_distance() - d0);
    return sim->collisions().size() == collisions_before;  // the scripted operator hit something
  };
  RunReport report = run_tree(*session, *teach, ro);
  if (sim->collisions().size() != collisions_before) {
    const SimCollision& c = sim->collisions().back();
    r.setup_error = "teaching collided with '" + c.obstacle + "' at (" + fixed(c.pose_world.x_m, 2) + ", " +
                    fixed(c.pose_world.y_m, 2) + ")";
    return false;
  }
  if (report.outcome != RunOutcome::success) {
    r.setup_error = "teaching failed: " + report.reason;
    return false;
  }
  return true;
}

/// Where teaching ended, the taught edges' kinds and the map's size.
void RunPhases::finish_teach() {
  t.taught_end = xy(sim->ground_truth_pose());
  // Along/cross-track are split along the last edge's direction: the heading when that edge was
  // stored, not after the operator's closing turn to face the first edge.
  t.taught_end_heading_rad = t.taught_edge_ends.empty() ? sim->ground_truth_pose().heading_rad
                                                        : t.taught_edge_ends.back().pose.heading_rad;
  t.loop_end = turning_radius_m > 0.0 && !t.taught_edge_ends.empty() ? xy(t.taught_edge_ends.back().pose) : t.taught_end;
  t.teach_path.push_back(t.taught_end);
  for (auto& e : t.taught_edge_ends)
    if (const EdgeRecord* rec = session->map()->find_edge(e.edge)) e.kind = rec->kind;
  const MapStats map_stats = session->map()->stats();
  for (const auto& [kind, ks] : map_stats.per_kind) {
    r.map_bytes += ks.payload_bytes;
    r.map_length_m += ks.length_m;
  }
}

/// --- supervised experience drive (multi-experience maps): the scripted operator drives the
/// route again in its own session (phase 3: another draw of every error model, the drive's
/// appearance) with the same teach tree into a scratch map, whose feature edges become
/// experiences of the taught ones. The taught robot stays where teaching ended.
bool RunPhases::experience_drive() {
  auto drive_config = load_run_config(config_file, phase_overrides(3, o.experience_teach, o.teach_overrides));
  if (!drive_config) {
    r.setup_error = "experience drive: " + drive_config.error().message;
    return false;
  }
  const fs::path drive_map = dir / "experience_drive" / "map";
  fs::remove_all(drive_map, ec);
  fs::create_directories(drive_map.parent_path(), ec);
  SessionOptions dso;
  dso.map_path = drive_map.string();
  dso.logger = &logger;
  auto drive_made = Session::create(*drive_config, dso);
  if (!drive_made) {
    r.setup_error = "experience drive: " + drive_made.error().message;
    return false;
  }
  auto drive = std::move(*drive_made);
  SimulationControl* drive_sim = drive->robot().simulation();
  auto tree = drive->load_tree(project_file("trees/teach_hybrid_route.xml"), teach_ports);
  if (!tree || drive_sim == nullptr) {
    r.setup_error = "experience drive: " + (tree ? std::string("no simulated robot") : tree.error().message);
    return false;
  }
  if (auto st = set_blackboard_values(*tree, teach_values()); !st) {
    r.setup_error = "experience drive: " + st.error().message;
    return false;
  }
  RunOptions ro;
  ro.after_tick = [&](const TickInfo&) { return drive_sim->collisions().empty(); };
  RunReport report = run_tree(*drive, *tree, ro);
  if (!drive_sim->collisions().empty() || report.outcome != RunOutcome::success) {
    r.setup_error = "experience drive failed: " +
                    (drive_sim->collisions().empty() ? report.reason : "collided with " + drive_sim->collisions().back().obstacle);
    return false;
  }
  drive.reset();
  auto added = feature_replay::add_drive_experiences(map_dir.string(), drive_map.string(),
                                                     "supervised drive in " + o.experience_teach, 4);
  if (!added) {
    r.setup_error = "experience drive: " + added.error().message;
    return false;
  }
  for (const auto& a : *added) {
    ++r.experience_edges;
    if (a.added) ++r.experiences_added;
    else logger.log(LogLevel::warn, "experiment", "experience drive: edge " + a.edge_id + ": " + a.note);
  }
  logger.log(LogLevel::info, "experiment",
             "experience drive in " + o.experience_teach + ": " + std::to_string(r.experiences_added) + " of " +
                 std::to_string(r.experience_edges) + " feature edges got an experience");
  return true;
}

/// --- the replay run: its own draw of every error model (and its appearance)
bool RunPhases::reconfigure_for_replay() {
  if (auto st = session->robot().reconfigure(replay_config->robot.params); !st) {
    r.setup_error = "replay robot params: " + st.error().message;
    return false;
  }
  if (auto st = session->camera().reconfigure(replay_config->camera.params); !st) {
    r.setup_error = "replay camera params: " + st.error().message;
    return false;
  }
  return true;
}

/// --- learning loops (multi-experience maps): the replay conditions, learn_experiences on; the
/// robot starts where teaching ended, as the measured replay does before its displacement.
/// Returns false on a setup error (r.setup_error).
bool RunPhases::learning_loops() {
  auto learn = session->load_tree(project_file("trees/patrol_loop_learning.xml"), replay_ports);
  if (!learn) {
    r.setup_error = learn.error().message;
    return false;
  }
  const std::string hold_m = o.learn_blind_m > 0.0 ? fixed(o.learn_blind_m, 2) : "1";
  const std::string blind_m = o.learn_blind_m > 0.0 ? fixed(o.learn_blind_m, 2) : "5";
  if (auto st = set_blackboard_values(*learn, {"start=start", "loops=" + std::to_string(o.learn_loops),
                                               "learn_hold_m=" + hold_m, "learn_max_blind_m=" + blind_m});
      !st) {
    r.setup_error = st.error().message;
    return false;
  }
  learn->add_observer([&](double, const bt::TreeNode& node, bt::NodeStatus, bt::NodeStatus to) {
    if (to == bt::NodeStatus::success && node.registration_id() == "FollowRoute") ++r.learn_loops_driven;
  });
  const std::size_t collisions_before = sim->collisions().size();
  RunOptions ro;
  ro.after_tick = [&](const TickInfo& tick) {
    log_tick(tick, "learn", r.learn_loops_driven + 1);
    return sim->collisions().size() == collisions_before;
  };
  RunReport report = run_tree(*session, *learn, ro);
  if (report.outcome != RunOutcome::success)
    logger.log(LogLevel::warn, "experiment", "learning loops ended early: " + report.reason);
  logger.clear_stop_reason();  // a lost stop while learning is not the measured replay's
  return true;
}

/// --- displace: carried to the left of the first edge (which starts where teaching started)
/// and turned; odometry does not see it.
bool RunPhases::displace() {
  const double h0 = teach_start.heading_rad;
  Pose2D displaced;
  displaced.x_m = t.taught_end.x - std::sin(h0) * o.displace_m;
  displaced.y_m = t.taught_end.y + std::cos(h0) * o.displace_m;
  displaced.heading_rad = h0 + o.displace_heading_deg * std::numbers::pi / 180.0;
  if (auto st = sim->set_ground_truth_pose(displaced); !st) {
    r.setup_error = st.error().message;
    return false;
  }
  t.replay_start = xy(displaced);
  return true;
}

/// --- replay the loop N times
bool RunPhases::replay() {
  const std::string tree_file = !o.replay_tree.empty() ? o.replay_tree
                                : o.obstacles         ? project_file("trees/patrol_loop_avoiding.xml")
                                                      : project_file("trees/patrol_loop.xml");
  auto patrol = session->load_tree(tree_file, replay_ports);
  if (!patrol) {
    r.setup_error = tree_file + ": " + patrol.error().message;
    return false;
  }
  // Nodes that need the camera mount (the IPT obstacle nodes) read it from the replay camera
  // through the session's host (HostServices::camera_mount()), not from the blackboard.
  if (auto st = set_blackboard_values(*patrol, {"start=start", "loops=" + std::to_string(o.loops)}); !st) {
    r.setup_error = st.error().message;
    return false;
  }
  t.lap_paths.emplace_back();
  int lap_edge = 0;
  patrol->add_observer([&](double, const bt::TreeNode& node, bt::NodeStatus, bt::NodeStatus to) {
    if (to == bt::NodeStatus::success &&
        (node.registration_id() == "ReplayFeatureEdge" || node.registration_id() == "FollowPathEdge")) {
      EdgeEnd e;
      e.lap = static_cast<int>(lap_ends.size()) + 1;
      e.index = lap_edge++;
      if (auto id = node.get_input<std::string>("edge")) e.edge = *id;
      if (const EdgeRecord* rec = session->map()->find_edge(e.edge)) e.kind = rec->kind;
      e.pose = sim->ground_truth_pose();
      e.odom_distance_m = odom_distance();
      t.replay_edge_ends.push_back(std::move(e));
    }
    if (to == bt::NodeStatus::success && node.registration_id() == "FollowRoute") {
      lap_edge = 0;
      const cv::Point2d end = xy(sim->ground_truth_pose());
      lap_ends.push_back(end);
      t.lap_paths.back().push_back(end);
      t.lap_paths.emplace_back();
    }
  });
  const double d0 = odom_distance();
  const std::size_t collisions_before = sim->collisions().size();
  RunOptions ro;
  ro.after_tick = [&](const TickInfo& tick) {
    log_tick(tick, "replay", static_cast<int>(lap_ends.size()) + 1);
    if (tick.tick % 3 == 0) t.lap_paths.back().push_back(xy(sim->ground_truth_pose()));
    progress.update(run_index, r.route_length_m + odom_distance() - d0);
    if (o.replay_hook) o.replay_hook(*sim, session->robot(), odom_distance() - d0);
    return sim->collisions().size() == collisions_before;  // a collision ends the replay
  };
  RunReport report = run_tree(*session, *patrol, ro);
  finish_replay(report, d0, collisions_before);
  return true;
}

/// After the replay tree (still loaded): odometry, coasting, collisions and why it stopped.
void RunPhases::finish_replay(const RunReport& report, double d0, std::size_t collisions_before) {
  r.replay_odometry_m = odom_distance() - d0;
  {  // the robot was stopped: how far does it still roll (braking) in the next 2 s?
    const Pose2D at_end = sim->ground_truth_pose();
    for (int k = 0; k < 40; ++k) (void)sim->step(0.05);
    r.coast_after_stop_m = cv::norm(xy(sim->ground_truth_pose()) - xy(at_end));
  }
  const auto collisions = sim->collisions();
  r.collisions.assign(collisions.begin() + static_cast<std::ptrdiff_t>(collisions_before), collisions.end());
  if (!r.collisions.empty()) {
    const SimCollision& c = r.collisions.front();
    stop_reason = "collision with '" + c.obstacle + "' at (" + fixed(c.pose_world.x_m, 2) + ", " +
                  fixed(c.pose_world.y_m, 2) + ")";
  } else if (report.outcome != RunOutcome::success) {
    const std::string lost = logger.stop_reason();
    if (!lost.empty()) {
      ++r.lost_stops;
      stop_reason = lost;
    } else {
      stop_reason = report.reason;
    }
  }
  if (t.lap_paths.back().empty()) t.lap_paths.pop_back();
}

/// --- loops
void RunPhases::score_loops() {
  r.stop_reason = stop_reason;
  r.replay_start = t.replay_start;
  r.taught_end = t.loop_end;
  std::vector<cv::Point2d> finished_ends;
  for (int i = 0; i < o.loops; ++i) {
    LoopOutcome l;
    l.loop = i + 1;
    if (i < static_cast<int>(lap_ends.size())) {
      l.finished = true;
      l.end = lap_ends[static_cast<std::size_t>(i)];
      finished_ends.push_back(l.end);
    } else if (i == static_cast<int>(lap_ends.size())) {
      l.end = xy(sim->ground_truth_pose());  // where the replay stopped
      l.failure = stop_reason.empty() ? "replay ended early" : stop_reason;
    } else {
      l.end = xy(sim->ground_truth_pose());
      l.failure = "not driven: the replay stopped in loop " + std::to_string(lap_ends.size() + 1);
    }
    l.error_m = cv::norm(l.end - t.loop_end);
    const cv::Point2d c = components(l.end - t.loop_end, t.taught_end_heading_rad);
    l.along_m = c.x;
    l.cross_m = c.y;
    if (l.finished) {
      l.completed = l.error_m <= o.success_radius_m;
      if (!l.completed) l.failure = "ended " + fixed(l.error_m, 2) + " m from the taught end (radius " +
                                    fixed(o.success_radius_m, 2) + " m)";
    }
    r.loops.push_back(std::move(l));
  }
  r.metrics = accuracy_repeatability(finished_ends, t.loop_end);
}

/// --- files
void RunPhases::write_files(const sim::World& world) {
  std::ofstream csv(dir / "loops.csv");
  csv << "loop,finished,completed,end_x_m,end_y_m,error_m,along_m,cross_m,failure\n";
  for (const auto& l : r.loops)
    csv << l.loop << "," << l.finished << "," << l.completed << "," << l.end.x << "," << l.end.y << "," << l.error_m << ","
        << l.along_m << "," << l.cross_m << ",\"" << l.failure << "\"\n";
  std::ofstream edges(dir / "edges.csv");
  edges << "lap,index,edge,kind,gt_x_m,gt_y_m,gt_heading_rad,odom_distance_m,error_m,along_m,cross_m,heading_error_rad\n";
  for (const auto& e : t.replay_edge_ends) {
    const auto taught = std::find_if(t.taught_edge_ends.begin(), t.taught_edge_ends.end(),
                                     [&](const EdgeEnd& x) { return x.edge == e.edge; });
    edges << e.lap << "," << e.index << "," << e.edge << "," << e.kind << "," << e.pose.x_m << "," << e.pose.y_m << ","
          << e.pose.heading_rad << "," << e.odom_distance_m;
    if (taught == t.taught_edge_ends.end()) {
      edges << ",,,,\n";
      continue;
    }
    const cv::Point2d d = xy(e.pose) - xy(taught->pose);
    const cv::Point2d c = components(d, taught->pose.heading_rad);
    edges << "," << cv::norm(d) << "," << c.x << "," << c.y << ","
          << std::remainder(e.pose.heading_rad - taught->pose.heading_rad, 2.0 * std::numbers::pi) << "\n";
  }
  for (const auto& e : t.taught_edge_ends)
    edges << 0 << "," << e.index << "," << e.edge << "," << e.kind << "," << e.pose.x_m << "," << e.pose.y_m << ","
          << e.pose.heading_rad << "," << e.odom_distance_m << ",0,0,0,0\n";
  cv::imwrite((dir / "trajectories.png").string(), draw_trajectories(world, route, r, t));
}

/// Teaches and replays one (style, seed); never throws; errors end up in setup_error.
ExperimentRun run_one(const ExperimentOptions& o, const std::string& style, int seed, const sim::World& world,
                   const sim::Route& route, const std::string& route_file, const fs::path& dir, RunProgress& progress,
                   int run_index) {
  ExperimentRun r;
  r.style = style;
  r.seed = seed;
  r.route_length_m = route.waypoint_length_m();
  RunTrace t;
  const auto wall_start = std::chrono::steady_clock::now();
  auto done = [&]() -> ExperimentRun {
    r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    return std::move(r);
  };
  std::error_code ec;
  fs::create_directories(dir, ec);
  const LogLevel min_level = o.log_level == "debug" ? LogLevel::debug
                             : o.log_level == "info" ? LogLevel::info
                             : o.log_level == "error" ? LogLevel::error
                                                      : LogLevel::warn;
  RunLogger logger(dir / "run.log", min_level);
  RunPhases run(o, style, seed, route, route_file, dir, progress, run_index, r, t, logger);
  if (!run.load_configs() || !run.open_session() || !run.teach_route()) return done();
  run.finish_teach();
  if (!o.experience_teach.empty() && !run.experience_drive()) return done();
  if (!run.reconfigure_for_replay()) return done();
  if (o.learn_loops > 0 && !run.learning_loops()) return done();
  if (!run.displace() || !run.replay()) return done();
  run.score_loops();
  run.write_files(world);
  return done();
}

/// Error per loop for every run (as seed 002 Figs. 5-10); failed loops as crosses on the top line.
cv::Mat draw_errors(const std::vector<ExperimentRun>& runs, const std::vector<std::string>& styles, int loops,
                    double radius_m) {
  const int w = 720, h = 440, left = 60, bottom = 50, top = 60, right = 20;
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  double max_err = 0.1;
  for (const auto& r : runs)
    for (const auto& l : r.loops)
      if (l.finished) max_err = std::max(max_err, std::min(l.error_m, radius_m * 1.5));
  max_err *= 1.15;
  auto px = [&](double loop, double err) {
    const double x = left + (loop - 1) / std::max(1, loops - 1) * (w - left - right - 40) + 20;
    const double y = h - bottom - std::min(err, max_err) / max_err * (h - bottom - top);
    return cv::Point(static_cast<int>(x), static_cast<int>(y));
  };
  cv::line(img, {left, h - bottom}, {w - right, h - bottom}, cv::Scalar(0, 0, 0), 1);
  cv::line(img, {left, top}, {left, h - bottom}, cv::Scalar(0, 0, 0), 1);
  for (int i = 1; i <= loops; ++i)
    cv::putText(img, std::to_string(i), px(i, 0) + cv::Point(-4, 20), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1);
  for (int k = 0; k <= 4; ++k) {
    const double e = max_err * k / 4;
    std::ostringstream s;
    s << std::fixed << std::setprecision(2) << e;
    cv::putText(img, s.str(), {5, px(1, e).y + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1);
    cv::line(img, {left, px(1, e).y}, {w - right, px(1, e).y}, cv::Scalar(220, 220, 220), 1);
  }
  cv::putText(img, "end-of-loop position error [m] vs loop, every run (x: failed loop)", {left, 22},
              cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  const cv::Scalar colours[] = {cv::Scalar(200, 80, 0), cv::Scalar(0, 140, 0), cv::Scalar(0, 0, 200)};
  int legend_x = left + 10;
  for (std::size_t si = 0; si < styles.size(); ++si) {
    const cv::Scalar c = colours[si % 3];
    const int dx = static_cast<int>(si) * 6 - 3;
    std::vector<double> acc;
    for (const auto& r : runs) {
      if (r.style != styles[si]) continue;
      if (std::any_of(r.loops.begin(), r.loops.end(), [](const LoopOutcome& l) { return l.finished; }))
        acc.push_back(r.metrics.accuracy_m);
      for (std::size_t i = 0; i < r.loops.size(); ++i) {
        const LoopOutcome& l = r.loops[i];
        const cv::Point p = px(static_cast<double>(i + 1), l.finished ? l.error_m : max_err) + cv::Point(dx, 0);
        if (l.completed) {
          cv::circle(img, p, 3, c, cv::FILLED, cv::LINE_AA);
          if (i > 0 && r.loops[i - 1].completed)
            cv::line(img, px(static_cast<double>(i), r.loops[i - 1].error_m) + cv::Point(dx, 0), p, c, 1, cv::LINE_AA);
        } else {
          cv::drawMarker(img, p, c, cv::MARKER_TILTED_CROSS, 10, 2);
        }
      }
    }
    const Spread s = spread(acc);
    std::ostringstream label;
    label << styles[si] << ": eps_acc " << std::fixed << std::setprecision(3) << s.mean << " +- " << s.sd << " m";
    // one label after the other, each as wide as its text
    int baseline = 0;
    const int width_px = cv::getTextSize(label.str(), cv::FONT_HERSHEY_SIMPLEX, 0.45, 1, &baseline).width;
    cv::putText(img, label.str(), {legend_x, 44}, cv::FONT_HERSHEY_SIMPLEX, 0.45, c, 1, cv::LINE_AA);
    legend_x += width_px + 24;
  }
  return img;
}

struct StyleSummary {
  std::string style;
  int attempted = 0;
  int completed = 0;
  int collisions = 0;
  int lost = 0;
  int setup_failures = 0;
  Spread acc;
  Spread rep;
  double along_rms_m = 0.0;
  double cross_rms_m = 0.0;
  double bytes_per_m = 0.0;
  double wall_s = 0.0;
};

StyleSummary summarise(const std::string& style, const std::vector<ExperimentRun>& runs) {
  StyleSummary s;
  s.style = style;
  std::vector<double> acc, rep;
  double along2 = 0.0, cross2 = 0.0;
  int finished = 0;
  double bytes = 0.0, length = 0.0;
  for (const auto& r : runs) {
    if (r.style != style) continue;
    s.wall_s += r.wall_s;
    s.collisions += static_cast<int>(r.collisions.size());
    s.lost += r.lost_stops;
    if (!r.setup_error.empty()) ++s.setup_failures;
    bytes += static_cast<double>(r.map_bytes);
    length += r.map_length_m;
    bool any = false;
    for (const auto& l : r.loops) {
      ++s.attempted;
      if (l.completed) ++s.completed;
      if (!l.finished) continue;
      any = true;
      ++finished;
      along2 += l.along_m * l.along_m;
      cross2 += l.cross_m * l.cross_m;
    }
    if (any) {
      acc.push_back(r.metrics.accuracy_m);
      rep.push_back(r.metrics.repeatability_m);
    }
  }
  s.acc = spread(acc);
  s.rep = spread(rep);
  if (finished > 0) {
    s.along_rms_m = std::sqrt(along2 / finished);
    s.cross_rms_m = std::sqrt(cross2 / finished);
  }
  s.bytes_per_m = length > 0.0 ? bytes / length : 0.0;
  return s;
}

std::string json_spread(const Spread& s) {
  std::ostringstream o;
  o << std::setprecision(6) << "{\"mean\":" << s.mean << ",\"sd\":" << s.sd << ",\"worst\":" << s.worst
    << ",\"seeds\":" << s.count << "}";
  return o.str();
}

std::string json_escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '"' || c == '\\') { out += '\\'; out += c; }
    else if (static_cast<unsigned char>(c) < 0x20) out += ' ';
    else out += c;
  }
  return out;
}

std::string summary_json(const ExperimentOptions& o, const std::vector<ExperimentRun>& runs) {
  std::ostringstream j;
  j << std::setprecision(6);
  j << "{\"world\":\"" << json_escape(o.world) << "\",\"route\":\"" << json_escape(o.route) << "\",\"loops\":" << o.loops
    << ",\"seeds\":" << o.seeds << ",\"first_seed\":" << o.first_seed << ",\"displace_m\":" << o.displace_m
    << ",\"displace_heading_deg\":" << o.displace_heading_deg << ",\"radius_m\":" << o.success_radius_m
    << ",\"ideal\":" << (o.ideal ? "true" : "false") << ",\"teach_appearance\":\"" << json_escape(o.teach_appearance)
    << "\",\"replay_appearance\":\"" << json_escape(o.replay_appearance) << "\",\"experience_teach\":\""
    << json_escape(o.experience_teach) << "\",\"styles\":[";
  for (std::size_t i = 0; i < o.maps.size(); ++i) {
    const StyleSummary s = summarise(o.maps[i], runs);
    j << (i ? "," : "") << "{\"style\":\"" << s.style << "\",\"attempted\":" << s.attempted
      << ",\"completed\":" << s.completed << ",\"eps_acc_m\":" << json_spread(s.acc)
      << ",\"eps_rep_m\":" << json_spread(s.rep) << ",\"along_rms_m\":" << s.along_rms_m
      << ",\"cross_rms_m\":" << s.cross_rms_m << ",\"collisions\":" << s.collisions << ",\"lost\":" << s.lost
      << ",\"setup_failures\":" << s.setup_failures << ",\"bytes_per_m\":" << s.bytes_per_m << ",\"wall_s\":" << s.wall_s
      << "}";
  }
  j << "],\"runs\":[";
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const ExperimentRun& r = runs[i];
    j << (i ? "," : "") << "{\"style\":\"" << r.style << "\",\"seed\":" << r.seed << ",\"experiences_added\":"
      << r.experiences_added << ",\"experience_edges\":" << r.experience_edges << ",\"eps_acc_m\":"
      << r.metrics.accuracy_m << ",\"eps_rep_m\":" << r.metrics.repeatability_m << ",\"stop_reason\":\""
      << json_escape(r.stop_reason.empty() ? r.setup_error : r.stop_reason) << "\",\"loops\":[";
    for (std::size_t k = 0; k < r.loops.size(); ++k) {
      const LoopOutcome& l = r.loops[k];
      j << (k ? "," : "") << "{\"loop\":" << l.loop << ",\"completed\":" << (l.completed ? "true" : "false")
        << ",\"finished\":" << (l.finished ? "true" : "false") << ",\"error_m\":" << l.error_m << ",\"along_m\":"
        << l.along_m << ",\"cross_m\":" << l.cross_m << "}";
    }
    j << "]}";
  }
  j << "]}\n";
  return j.str();
}

}  // namespace

Result<ExperimentRun> run_experiment_job(const ExperimentOptions& o, const std::string& style, int seed, const std::string& dir,
                                         const std::function<void(double, double)>& progress) {
  VISNAV_ASSIGN(const std::string world_path, sim::resolve_world_path(o.world));
  VISNAV_ASSIGN(const std::string route_path, sim::resolve_route_path(o.route));
  VISNAV_ASSIGN(auto world, sim::load_world_cached(world_path));
  VISNAV_ASSIGN(auto route, sim::load_route(route_path));
  if (route.waypoints.empty() || !route.closed) return fail(route_path + ": the experiment needs a closed waypoint route");
  RunProgress silent(1, route.waypoint_length_m() * (o.loops + 1), false, progress);
  return run_one(o, style, seed, *world, route, route_path, dir, silent, 0);
}

std::string experiment_table(const ExperimentOptions& o, const std::vector<ExperimentRun>& runs) {
  std::ostringstream t;
  t << "| map | loops completed | ε_acc [m] mean ± sd (worst) | ε_rep [m] mean ± sd (worst) | along / cross RMS [m] | "
       "collisions | lost stops | bytes/m | wall [s] |\n"
       "|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& style : o.maps) {
    const StyleSummary s = summarise(style, runs);
    auto cell = [](const Spread& x) {
      return x.count == 0 ? std::string("-") : fixed(x.mean) + " ± " + fixed(x.sd) + " (" + fixed(x.worst) + ")";
    };
    t << "| " << style << " | " << s.completed << "/" << s.attempted << " | " << cell(s.acc) << " | " << cell(s.rep)
      << " | " << fixed(s.along_rms_m) << " / " << fixed(s.cross_rms_m) << " | " << s.collisions << " | " << s.lost
      << " | " << fixed(s.bytes_per_m, 0) << " | " << fixed(s.wall_s, 0) << " |\n";
  }
  return t.str();
}

Result<std::vector<ExperimentRun>> run_experiment(const ExperimentOptions& o) {
  VISNAV_ASSIGN(const std::string world_path, sim::resolve_world_path(o.world));
  VISNAV_ASSIGN(const std::string route_path, sim::resolve_route_path(o.route));
  VISNAV_ASSIGN(auto world, sim::load_world_cached(world_path));
  VISNAV_ASSIGN(auto route, sim::load_route(route_path));
  if (route.waypoints.empty() || !route.closed) return fail(route_path + ": the experiment needs a closed waypoint route");
  VISNAV_TRY(load_run_config(project_file(o.config), o.overrides));  // a bad config fails before any run
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (ec) return fail("cannot create " + o.out + ": " + ec.message());

  struct Job {
    std::string style;
    int seed;
  };
  std::vector<Job> jobs;
  for (const auto& style : o.maps)
    for (int k = 0; k < o.seeds; ++k) jobs.push_back({style, o.first_seed + k});
  std::vector<ExperimentRun> runs(jobs.size());
  RunProgress progress(static_cast<int>(jobs.size()), route.waypoint_length_m() * (o.loops + 1), o.progress);
  std::atomic<std::size_t> next{0};
  auto worker = [&]() {
    for (std::size_t i = next++; i < jobs.size(); i = next++) {
      const Job& job = jobs[i];
      const fs::path dir = fs::path(o.out) / job.style / ("seed" + std::to_string(job.seed));
      runs[i] = run_one(o, job.style, job.seed, *world, route, route_path, dir, progress, static_cast<int>(i));
      progress.finished(static_cast<int>(i));
    }
  };
  const int threads =
      std::clamp(o.jobs > 0 ? o.jobs : static_cast<int>(std::thread::hardware_concurrency()), 1, static_cast<int>(jobs.size()));
  std::vector<std::thread> pool;
  for (int k = 1; k < threads; ++k) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
  progress.end();

  // --- report
  cv::imwrite((fs::path(o.out) / "errors.png").string(), draw_errors(runs, o.maps, o.loops, o.success_radius_m));
  std::ofstream(fs::path(o.out) / "summary.json") << summary_json(o, runs);
  std::ofstream md(fs::path(o.out) / "report.md");
  md << "# visnav experiment\n\nworld `" << o.world << "`, route `" << route_path << "` ("
     << fixed(route.waypoint_length_m(), 1) << " m), " << o.seeds << " seeds from " << o.first_seed << ", " << o.loops
     << " loops each, initial error " << o.displace_m << " m lateral + " << o.displace_heading_deg
     << " deg, success radius " << o.success_radius_m << " m, config `" << o.config << "`"
     << (o.ideal ? ", **--ideal (error models off: a regression run, not a result)**" : "")
     << ", appearance teach `" << o.teach_appearance << "` / replay `" << o.replay_appearance << "`";
  if (!o.experience_teach.empty()) {
    md << ", supervised experience drive `" << o.experience_teach << "` (feature edges given an experience per run:";
    for (const auto& r : runs) md << " " << r.experiences_added << "/" << r.experience_edges;
    md << ")";
  }
  md << "\n\n"
     << experiment_table(o, runs)
     << "\nε_acc, ε_rep: seed 000 eq. (18) over the finished loops' end positions against the position where "
        "teaching ended, per run; mean ± sd and worst over the runs. Along/cross: RMS of the loop-end error's "
        "components in the taught end heading's frame. A loop is completed when finished within the radius and "
        "without collision.\n\n## Runs\n\n| map | seed | odometry errors (teach / replay) | loop errors [m] | ε_acc | ε_rep | "
        "stop |\n|---|---|---|---|---|---|---|\n";
  for (const auto& r : runs) {
    std::string errors;
    for (const auto& l : r.loops) {
      if (!errors.empty()) errors += ' ';
      errors += l.finished ? fixed(l.error_m) + (l.completed ? "" : "!") : "×";
    }
    md << "| " << r.style << " | " << r.seed << " | " << r.teach_errors << " / " << r.replay_errors << " | " << errors
       << " | " << fixed(r.metrics.accuracy_m) << " | " << fixed(r.metrics.repeatability_m) << " | "
       << (r.setup_error.empty() ? r.stop_reason : "setup: " + r.setup_error) << " |\n";
  }
  md << "\n`!` finished outside the radius, `×` not finished.\n";
  return runs;
}

int experiment_command(int argc, char** argv, HostServices& /*host*/) {
  if (print_help_if_asked(argc, argv, kUsage)) return 0;
  auto options = parse(argc, argv);
  if (!options) return usage_error("visnav experiment", options.error().message, kUsage);
  const ExperimentOptions& o = *options;
  std::cout << "visnav experiment: world " << o.world << ", route " << o.route << ", " << o.seeds << " seeds x "
            << o.loops << " loops per map style, initial error " << o.displace_m << " m + " << o.displace_heading_deg
            << " deg" << (o.ideal ? ", IDEAL (error models off: regression only)" : ", realistic error models")
            << "\n";
  auto runs = run_experiment(o);
  if (!runs) {
    std::cerr << "visnav experiment: " << runs.error().message << "\n";
    return 1;
  }
  int status = 0;
  for (const auto& r : *runs) {
    if (!r.setup_error.empty()) {
      std::cerr << "visnav experiment: " << r.style << " seed " << r.seed << ": " << r.setup_error << "\n";
      status = 1;
    }
    for (const auto& l : r.loops)
      if (!l.completed) status = 1;
  }
  std::cout << "\n" << experiment_table(o, *runs) << "\n";
  for (const auto& r : *runs)
    if (!r.stop_reason.empty())
      std::cout << "  " << r.style << " seed " << r.seed << " stopped: " << r.stop_reason << "\n";
  std::cout << "pictures: " << (fs::path(o.out) / "errors.png").string() << ", " << o.out
            << "/<map>/seed<S>/trajectories.png\nreport:   " << (fs::path(o.out) / "report.md").string()
            << "\nsummary:  " << (fs::path(o.out) / "summary.json").string() << "\n";
  return status;
}

}  // namespace visnav::simop
