// `visnav sim ...`: snapshot, topview, drive, teleop.
#include "visnav_sim/commands.hpp"

#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <thread>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "visnav_sim/camera.hpp"
#include "visnav_sim/generate.hpp"
#include "visnav_sim/render.hpp"
#include "visnav_sim/world.hpp"

namespace visnav::sim {
namespace {

constexpr double kDeg = CV_PI / 180.0;

const char* kUsage =
    "usage: visnav sim <command> [options]\n"
    "  snapshot  render one camera view of a world to a PNG\n"
    "  topview   draw a world from above (with a route) to a PNG\n"
    "  drive     drive a route script, write ground-truth + odometry CSV\n"
    "  teleop    drive a robot in a world with the keyboard\n"
    "  generate  write generated worlds with closed teach routes (and obstacle files)\n"
    "Run 'visnav sim <command> --help' for the options.\n";

const char* kSnapshotUsage =
    "usage: visnav sim snapshot --world W --pose x,y,theta_deg -o view.png [options]\n"
    "  --world W         world file or name (config/worlds/<W>.yaml)\n"
    "  --pose x,y,th     robot pose in the world: metres, metres, degrees CCW from +x\n"
    "  -o FILE           output PNG\n"
    "  --width N --height N   image size (default 640x480)\n"
    "  --hfov DEG        horizontal field of view (default 60)\n"
    "  --cam-height M    camera height (default 0.5)   --pitch DEG  downward tilt (default 5)\n"
    "  --season S        seasonal texture set          --shadows S  shadow band strength 0..1\n"
    "  --labels FILE     also write the colourised label image\n"
    "  --label-ids FILE  also write the raw label image (8-bit LabelClass: 0 sky, 1 path, 2 grass,\n"
    "                    3 floor, 4 pavement, 5 ground, 6 wall, 7 fence, 8 tree, 9 obstacle)\n";

const char* kTopviewUsage =
    "usage: visnav sim topview --world W [--route R] -o top.png [--px-per-m N]\n"
    "  draws the ground regions, walls (red), fences (brown), trees (green) and the route\n"
    "  (feature legs red, path legs blue, start arrow) north-up; --px-per-m 0 fits 1200 px.\n";

const char* kDriveUsage =
    "usage: visnav sim drive --route R [--world W] -o traj.csv [options]\n"
    "  --route R             route script (config/routes/<R>.yaml)\n"
    "  --world W             world (default: the route's `world:`)\n"
    "  -o FILE               CSV: time_s, ground truth, odometry, command, leg, kind\n"
    "  --rate HZ             control rate (default 20)\n"
    "  --max-time S          give up after this much simulated time (default 3600)\n"
    "  --robot-param k=v     set a `sim` robot parameter (repeatable), e.g. odom_scale_error_pct=2\n";

const char* kGenerateUsage =
    "usage: visnav sim generate --seed N [--count M] [--kind any|indoor|outdoor|mixed]\n"
    "                           [--obstacles auto|yes|no] -o DIR\n"
    "  writes, per seed N .. N+M-1, DIR/gen_NNNN.yaml (world), DIR/gen_NNNN_route.yaml (closed\n"
    "  waypoint route, feature and path legs), DIR/gen_NNNN_obstacles.yaml (obstacles on the route\n"
    "  for the replays: with --obstacles auto every third seed) and DIR/gen_NNNN_top.png.\n"
    "  The seed alone decides the world (docs/benchmark.md). --kind any (default) draws the kind.\n";

const char* kTeleopUsage =
    "usage: visnav sim teleop --world W [-o traj.csv] [--record route.yaml] [--view view.png]\n"
    "  keys: up/w faster, down/s slower, left/a turn left, right/d turn right, space stop, q quit\n"
    "  --rate HZ          simulation/control rate in real time (default 20)\n"
    "  -o FILE            write ground truth + odometry CSV on exit\n"
    "  --record FILE      write the driven commands as a route script (duration_s legs)\n"
    "  --view FILE        rewrite this PNG with the camera view once per second\n"
    "  --robot-param k=v  set a `sim` robot parameter (repeatable)\n";

struct Args {
  std::vector<std::string> positional;
  std::vector<std::pair<std::string, std::string>> options;
  bool help = false;

  [[nodiscard]] std::optional<std::string> get(const std::string& key) const {
    for (auto it = options.rbegin(); it != options.rend(); ++it)
      if (it->first == key) return it->second;
    return std::nullopt;
  }
  [[nodiscard]] std::vector<std::string> all(const std::string& key) const {
    std::vector<std::string> out;
    for (const auto& [k, v] : options) if (k == key) out.push_back(v);
    return out;
  }
};

Result<Args> parse_args(const std::vector<std::string>& args, size_t first, const std::vector<std::string>& known) {
  Args a;
  for (size_t i = first; i < args.size(); ++i) {
    const std::string& s = args[i];
    if (s == "-h" || s == "--help") { a.help = true; continue; }
    if (s.rfind("-", 0) == 0 && s.size() > 1) {
      std::string key = s, value;
      if (auto eq = s.find('='); eq != std::string::npos && s.rfind("--", 0) == 0) {
        key = s.substr(0, eq);
        value = s.substr(eq + 1);
      } else {
        if (i + 1 >= args.size()) return fail("option " + s + " needs a value");
        value = args[++i];
      }
      if (std::find(known.begin(), known.end(), key) == known.end()) return fail("unknown option " + key);
      a.options.emplace_back(key, value);
    } else {
      a.positional.push_back(s);
    }
  }
  return a;
}

Result<double> number(const Args& a, const std::string& key, double fallback) {
  auto v = a.get(key);
  if (!v) return fallback;
  auto d = visnav::detail::parse_double(*v);
  if (!d) return fail("option " + key + ": '" + *v + "' is not a number");
  return *d;
}

Result<std::shared_ptr<const World>> world_from(const std::string& name, const std::string& relative_to = {}) {
  VISNAV_ASSIGN(const std::string path, resolve_world_path(name, relative_to));
  return load_world_cached(path);
}

Result<Pose2D> parse_pose(const std::string& text) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    auto d = visnav::detail::parse_double(item);
    if (!d) return fail("--pose: '" + item + "' is not a number (expected x,y,theta_deg)");
    v.push_back(*d);
  }
  if (v.size() != 3) return fail("--pose: expected x,y,theta_deg, got '" + text + "'");
  return Pose2D{v[0], v[1], v[2] * kDeg};
}

Status write_png(const std::string& path, const cv::Mat& image) {
  try {
    if (!cv::imwrite(path, image)) return fail(path + ": cannot write image");
  } catch (const cv::Exception& e) {
    return fail(path + ": cannot write image: " + e.what());
  }
  return ok();
}

Result<RobotParams> robot_params_from(const Args& a) {
  ConfigNode node = ConfigNode::make_map(SourceLocation{"--robot-param", 0});
  for (const auto& kv : a.all("--robot-param")) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) return fail("--robot-param: expected key=value, got '" + kv + "'");
    node.set(kv.substr(0, eq), ConfigNode::make_scalar(kv.substr(eq + 1), SourceLocation{"--robot-param " + kv, 0}));
  }
  return RobotParams::schema().parse(node);
}

int report(const Status& st, std::ostream& err) {
  if (st) return 0;
  err << "visnav sim: " << st.error().message << "\n";
  return 1;
}

int cmd_snapshot(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  auto a = parse_args(args, 1, {"--world", "--pose", "-o", "--width", "--height", "--hfov", "--cam-height", "--pitch",
                                "--season", "--shadows", "--labels", "--label-ids"});
  if (!a) { err << "visnav sim snapshot: " << a.error().message << "\n" << kSnapshotUsage; return 2; }
  if (a->help) { out << kSnapshotUsage; return 0; }
  if (!a->get("--world") || !a->get("--pose") || !a->get("-o")) { err << kSnapshotUsage; return 2; }
  auto run = [&]() -> Status {
    VISNAV_ASSIGN(auto world, world_from(*a->get("--world")));
    VISNAV_ASSIGN(const Pose2D pose, parse_pose(*a->get("--pose")));
    CameraModel m;
    VISNAV_ASSIGN(const double w, number(*a, "--width", 640));
    VISNAV_ASSIGN(const double h, number(*a, "--height", 480));
    m.width_px = static_cast<int>(w);
    m.height_px = static_cast<int>(h);
    VISNAV_ASSIGN(m.hfov_deg, number(*a, "--hfov", 60));
    VISNAV_ASSIGN(m.height_m, number(*a, "--cam-height", 0.5));
    VISNAV_ASSIGN(m.pitch_down_deg, number(*a, "--pitch", 5));
    VISNAV_TRY(m.validate());
    RenderOptions o;
    o.season = a->get("--season").value_or("");
    VISNAV_ASSIGN(o.shadows.strength, number(*a, "--shadows", 0.0));
    Renderer r(world, m, o);
    cv::Mat bgr, labels;
    r.render(pose, bgr, &labels);
    VISNAV_TRY(write_png(*a->get("-o"), bgr));
    if (auto lp = a->get("--labels")) {
      cv::Mat vis;
      colorize_labels(labels, vis);
      VISNAV_TRY(write_png(*lp, vis));
    }
    if (auto ip = a->get("--label-ids")) VISNAV_TRY(write_png(*ip, labels));
    out << "wrote " << *a->get("-o") << " (" << m.width_px << "x" << m.height_px << ")\n";
    return ok();
  };
  return report(run(), err);
}

int cmd_topview(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  auto a = parse_args(args, 1, {"--world", "--route", "-o", "--px-per-m"});
  if (!a) { err << "visnav sim topview: " << a.error().message << "\n" << kTopviewUsage; return 2; }
  if (a->help) { out << kTopviewUsage; return 0; }
  if (!a->get("-o") || (!a->get("--world") && !a->get("--route"))) { err << kTopviewUsage; return 2; }
  auto run = [&]() -> Status {
    std::optional<Route> route;
    std::string world_name = a->get("--world").value_or("");
    std::string relative;
    if (auto r = a->get("--route")) {
      VISNAV_ASSIGN(const std::string rp, resolve_route_path(*r));
      VISNAV_ASSIGN(route, load_route(rp));
      if (world_name.empty()) { world_name = route->world; relative = rp; }
      if (world_name.empty()) return fail("the route names no world; give --world");
    }
    VISNAV_ASSIGN(auto world, world_from(world_name, relative));
    VISNAV_ASSIGN(const double ppm, number(*a, "--px-per-m", 0.0));
    cv::Mat img = render_topview(*world, route ? &*route : nullptr, ppm);
    VISNAV_TRY(write_png(*a->get("-o"), img));
    out << "wrote " << *a->get("-o") << " (" << img.cols << "x" << img.rows << ")\n";
    return ok();
  };
  return report(run(), err);
}

int cmd_drive(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  auto a = parse_args(args, 1, {"--world", "--route", "-o", "--rate", "--max-time", "--robot-param"});
  if (!a) { err << "visnav sim drive: " << a.error().message << "\n" << kDriveUsage; return 2; }
  if (a->help) { out << kDriveUsage; return 0; }
  if (!a->get("--route") || !a->get("-o")) { err << kDriveUsage; return 2; }
  auto run = [&]() -> Status {
    VISNAV_ASSIGN(const std::string rp, resolve_route_path(*a->get("--route")));
    VISNAV_ASSIGN(Route route, load_route(rp));
    VISNAV_ASSIGN(RobotParams params, robot_params_from(*a));
    if (auto w = a->get("--world")) {
      VISNAV_ASSIGN(params.world, resolve_world_path(*w));
    } else if (!route.world.empty()) {
      VISNAV_ASSIGN(params.world, resolve_world_path(route.world, rp));
    }
    VISNAV_ASSIGN(const double rate, number(*a, "--rate", 20.0));
    VISNAV_ASSIGN(const double max_time, number(*a, "--max-time", 3600.0));
    if (!(rate > 0.0 && rate <= 1000.0)) return fail("--rate must be in (0, 1000]");
    VISNAV_ASSIGN(auto samples, drive_route(route, params, rate, max_time));
    VISNAV_TRY(write_drive_csv(samples, *a->get("-o")));
    const DriveSample& last = samples.back();
    out << "drove '" << route.name << "': " << samples.size() << " ticks, " << std::fixed << std::setprecision(2)
        << last.time_s << " s, odometric distance " << last.odometry.distance_m << " m; final pose (" << last.ground_truth.x_m
        << ", " << last.ground_truth.y_m << ", " << last.ground_truth.heading_rad / kDeg << " deg); wrote " << *a->get("-o")
        << "\n";
    return ok();
  };
  return report(run(), err);
}

// ---- keyboard teleop ------------------------------------------------------------------

class RawTerminal {
 public:
  RawTerminal() {
    if (tcgetattr(STDIN_FILENO, &saved_) != 0) return;
    termios raw = saved_;
    raw.c_lflag &= static_cast<tcflag_t>(~(ICANON | ECHO));
    raw.c_cc[VMIN] = 0;
    raw.c_cc[VTIME] = 0;
    active_ = tcsetattr(STDIN_FILENO, TCSANOW, &raw) == 0;
  }
  ~RawTerminal() {
    if (active_) tcsetattr(STDIN_FILENO, TCSANOW, &saved_);
  }
  RawTerminal(const RawTerminal&) = delete;
  RawTerminal& operator=(const RawTerminal&) = delete;
  [[nodiscard]] bool active() const { return active_; }

 private:
  termios saved_{};
  bool active_ = false;
};

int cmd_generate(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  auto a = parse_args(args, 1, {"--seed", "--count", "--kind", "--obstacles", "-o"});
  if (!a) { err << "visnav sim generate: " << a.error().message << "\n" << kGenerateUsage; return 2; }
  if (a->help) { out << kGenerateUsage; return 0; }
  if (!a->get("-o") || !a->get("--seed")) { err << kGenerateUsage; return 2; }
  auto run = [&]() -> Status {
    VISNAV_ASSIGN(const double seed, number(*a, "--seed", 1));
    VISNAV_ASSIGN(const double count, number(*a, "--count", 1));
    if (seed < 0 || seed != std::floor(seed) || seed > 1e8) return fail("option --seed: expected an integer in [0, 1e8]");
    if (count < 1 || count != std::floor(count) || count > 10000) return fail("option --count: expected an integer in [1, 10000]");
    for (int k = 0; k < static_cast<int>(count); ++k) {
      GenerateParams gp;
      gp.seed = static_cast<int>(seed) + k;
      gp.kind = a->get("--kind").value_or("any");
      gp.obstacles = a->get("--obstacles").value_or("auto");
      VISNAV_ASSIGN(const GeneratedWorld g, generate_world(gp));
      VISNAV_ASSIGN(const auto files, write_generated_world(g, *a->get("-o")));
      out << g.summary << "\n";
      for (const auto& f : files) out << "  wrote " << f << "\n";
    }
    return ok();
  };
  return report(run(), err);
}

int cmd_teleop(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  auto a = parse_args(args, 1, {"--world", "-o", "--record", "--view", "--rate", "--robot-param"});
  if (!a) { err << "visnav sim teleop: " << a.error().message << "\n" << kTeleopUsage; return 2; }
  if (a->help) { out << kTeleopUsage; return 0; }
  if (!a->get("--world")) { err << kTeleopUsage; return 2; }
  auto run = [&]() -> Status {
    if (isatty(STDIN_FILENO) == 0) return fail("teleop needs an interactive terminal on stdin");
    VISNAV_ASSIGN(RobotParams params, robot_params_from(*a));
    VISNAV_ASSIGN(params.world, resolve_world_path(*a->get("--world")));
    VISNAV_ASSIGN(const double rate, number(*a, "--rate", 20.0));
    if (!(rate > 0.0 && rate <= 200.0)) return fail("--rate must be in (0, 200]");
    VISNAV_ASSIGN(auto robot, SimRobot::create(params));
    std::unique_ptr<Renderer> view;
    if (a->get("--view")) {
      CameraModel m;
      view = std::make_unique<Renderer>(robot->core()->world(), m);
    }
    RawTerminal term;
    if (!term.active()) return fail("cannot switch the terminal to raw mode");
    out << "teleop: arrows/WASD drive, space stops, q quits\n" << std::flush;
    TeleopState state;
    std::vector<DriveSample> samples;
    std::vector<std::pair<Twist, double>> recorded;  // command, duration
    const double dt = 1.0 / rate;
    double next_view_s = 0.0;
    std::string escape;
    cv::Mat frame;
    while (!state.quit) {
      const auto tick_start = std::chrono::steady_clock::now();
      pollfd pfd{STDIN_FILENO, POLLIN, 0};
      while (poll(&pfd, 1, 0) > 0) {
        char c = 0;
        if (read(STDIN_FILENO, &c, 1) != 1) break;
        escape.push_back(c);
        if (escape == "\x1b" || escape == "\x1b[") continue;  // incomplete escape sequence
        apply_teleop_key(state, escape);
        escape.clear();
      }
      VISNAV_TRY(robot->send_command(state.command));
      VISNAV_TRY(robot->step(dt));
      if (!recorded.empty() && recorded.back().first.linear_mps == state.command.linear_mps &&
          recorded.back().first.angular_radps == state.command.angular_radps)
        recorded.back().second += dt;
      else
        recorded.emplace_back(state.command, dt);
      const Pose2D gt = robot->ground_truth_pose();
      const Odometry odo = *robot->latest_odometry();
      samples.push_back(DriveSample{robot->time_s(), gt, odo, state.command, 0, ""});
      if (view && robot->time_s() >= next_view_s) {
        view->render(gt, frame, nullptr, nullptr, robot->time_s());
        VISNAV_TRY(write_png(*a->get("--view"), frame));
        next_view_s += 1.0;
      }
      out << "\rt=" << std::fixed << std::setprecision(1) << robot->time_s() << " s  v=" << std::setprecision(2)
          << state.command.linear_mps << " w=" << state.command.angular_radps << "  pose (" << gt.x_m << ", " << gt.y_m
          << ", " << std::setprecision(0) << gt.heading_rad / kDeg << " deg)  odom " << std::setprecision(2) << odo.distance_m
          << " m   " << std::flush;
      std::this_thread::sleep_until(tick_start + std::chrono::duration<double>(dt));
    }
    out << "\n";
    if (auto o = a->get("-o")) VISNAV_TRY(write_drive_csv(samples, *o));
    if (auto r = a->get("--record")) {
      std::ofstream f(*r);
      if (!f) return fail(*r + ": cannot write route file");
      const Pose2D s = resolve_start(params, robot->core()->world().get());
      f << std::fixed << std::setprecision(3);
      f << "# recorded by visnav sim teleop\nroute:\n  world: " << *a->get("--world") << "\n  start: [" << s.x_m << ", "
        << s.y_m << ", " << s.heading_rad / kDeg << "]\n  commands:\n";
      for (const auto& [cmd, dur] : recorded)
        f << "    - {duration_s: " << dur << ", v: " << cmd.linear_mps << ", w: " << cmd.angular_radps << "}\n";
      if (!f) return fail(*r + ": write failed");
    }
    return ok();
  };
  return report(run(), err);
}

}  // namespace

void apply_teleop_key(TeleopState& state, const std::string& key) {
  constexpr double kDv = 0.1, kDw = 0.1;
  if (key == "\x1b[A" || key == "w" || key == "W") state.command.linear_mps += kDv;
  else if (key == "\x1b[B" || key == "s" || key == "S") state.command.linear_mps -= kDv;
  else if (key == "\x1b[D" || key == "a" || key == "A") state.command.angular_radps += kDw;
  else if (key == "\x1b[C" || key == "d" || key == "D") state.command.angular_radps -= kDw;
  else if (key == " ") state.command = Twist{};
  else if (key == "q" || key == "Q" || key == "\x03") { state.command = Twist{}; state.quit = true; }
  state.command.linear_mps = std::round(state.command.linear_mps * 100.0) / 100.0;
  state.command.angular_radps = std::round(state.command.angular_radps * 100.0) / 100.0;
}

Result<std::vector<DriveSample>> drive_route(const Route& route, RobotParams robot_params, double rate_hz, double max_time_s) {
  if (robot_params.start_pose.empty()) {
    if (route.start) {
      robot_params.start_pose = {route.start->x_m, route.start->y_m, route.start->heading_rad / kDeg};
    } else if (route.waypoints.size() >= 2) {
      const cv::Point2d a = route.waypoints[0].position_m, b = route.waypoints[1].position_m;
      robot_params.start_pose = {a.x, a.y, std::atan2(b.y - a.y, b.x - a.x) / kDeg};
    }
  }
  VISNAV_ASSIGN(auto robot, SimRobot::create(robot_params));
  RouteFollower follower(route);
  std::vector<DriveSample> samples;
  const double dt = 1.0 / rate_hz;
  samples.push_back(DriveSample{0.0, robot->ground_truth_pose(), *robot->latest_odometry(), Twist{}, 0, follower.leg_kind()});
  while (robot->time_s() < max_time_s) {
    const Odometry odo = *robot->latest_odometry();
    auto cmd = follower.next(robot->ground_truth_pose(), odo.distance_m, robot->time_s());
    if (!cmd) break;
    VISNAV_TRY(robot->send_command(*cmd));
    VISNAV_TRY(robot->step(dt));
    samples.push_back(DriveSample{robot->time_s(), robot->ground_truth_pose(), *robot->latest_odometry(), *cmd,
                                  follower.leg(), follower.leg_kind()});
  }
  if (!follower.done()) return fail("route '" + route.name + "' not completed within " + std::to_string(max_time_s) + " s of simulated time");
  return samples;
}

Status write_drive_csv(const std::vector<DriveSample>& samples, const std::string& path) {
  std::ofstream f(path);
  if (!f) return fail(path + ": cannot write CSV");
  f << "time_s,gt_x_m,gt_y_m,gt_heading_rad,odom_x_m,odom_y_m,odom_heading_rad,odom_distance_m,cmd_linear_mps,"
       "cmd_angular_radps,leg,kind\n";
  f << std::fixed << std::setprecision(5);
  for (const auto& s : samples)
    f << s.time_s << ',' << s.ground_truth.x_m << ',' << s.ground_truth.y_m << ',' << s.ground_truth.heading_rad << ','
      << s.odometry.pose.x_m << ',' << s.odometry.pose.y_m << ',' << s.odometry.pose.heading_rad << ','
      << s.odometry.distance_m << ',' << s.command.linear_mps << ',' << s.command.angular_radps << ',' << s.leg << ','
      << s.kind << '\n';
  if (!f) return fail(path + ": write failed");
  return ok();
}

cv::Mat render_topview(const World& world, const Route* route, double px_per_m) {
  cv::Rect2d b = world.bounds();
  if (route != nullptr)
    for (const auto& w : route->waypoints) b |= cv::Rect2d(w.position_m.x, w.position_m.y, 0.01, 0.01);
  const double margin = 3.0;
  b = cv::Rect2d(b.x - margin, b.y - margin, b.width + 2 * margin, b.height + 2 * margin);
  if (px_per_m <= 0.0) px_per_m = 1200.0 / std::max(b.width, b.height);
  const int W = std::max(16, static_cast<int>(std::ceil(b.width * px_per_m)));
  const int H = std::max(16, static_cast<int>(std::ceil(b.height * px_per_m)));
  cv::Mat img(H, W, CV_8UC3);
  const double foot = 1.0 / px_per_m;
  for (int r = 0; r < H; ++r) {
    auto* out = img.ptr<cv::Vec3b>(r);
    const double y = b.y + b.height - (r + 0.5) * foot;
    for (int c = 0; c < W; ++c) {
      const double x = b.x + (c + 0.5) * foot;
      const int region = world.region_at(x, y);
      const Texture& t = world.textures[static_cast<size_t>(region < 0 ? world.default_texture : world.regions[static_cast<size_t>(region)].texture)];
      const int level = std::clamp(static_cast<int>(std::floor(std::log2(foot / t.texel_m))), 0, static_cast<int>(t.levels.size()) - 1);
      const cv::Mat& L = t.levels[static_cast<size_t>(level)];
      const double scale = 1.0 / (t.texel_m * (1 << level));
      const int mask = L.cols - 1;
      const int tx = static_cast<int>(std::floor(x * scale)) & mask, ty = static_cast<int>(std::floor(-y * scale)) & mask;
      const cv::Vec4b p = L.at<cv::Vec4b>(ty, tx);
      out[c] = cv::Vec3b(p[0], p[1], p[2]);
    }
  }
  auto px = [&](const cv::Point2d& p) {
    return cv::Point(static_cast<int>(std::lround((p.x - b.x) * px_per_m)), static_cast<int>(std::lround((b.y + b.height - p.y) * px_per_m)));
  };
  for (const auto& w : world.walls) {
    if (w.label == LabelClass::tree) {
      cv::circle(img, px((w.from + w.to) * 0.5), std::max(2, static_cast<int>(cv::norm(w.to - w.from) * 0.5 * px_per_m)),
                 cv::Scalar(30, 110, 30), 1, cv::LINE_AA);
      continue;
    }
    const cv::Vec3b c = label_color(w.label);
    cv::line(img, px(w.from), px(w.to), cv::Scalar(c[0], c[1], c[2]), std::max(2, static_cast<int>(px_per_m * 0.25)), cv::LINE_AA);
  }
  if (route != nullptr && route->waypoints.size() >= 2) {
    const size_t n = route->waypoints.size();
    const size_t legs = route->closed ? n : n - 1;
    for (size_t i = 0; i < legs; ++i) {
      const auto& a = route->waypoints[i];
      const auto& bb = route->waypoints[(i + 1) % n];
      const cv::Scalar color = a.kind == "path" ? cv::Scalar(255, 90, 0) : cv::Scalar(0, 0, 230);
      cv::line(img, px(a.position_m), px(bb.position_m), color, 3, cv::LINE_AA);
    }
    for (const auto& w : route->waypoints) cv::circle(img, px(w.position_m), 4, cv::Scalar(255, 255, 255), -1, cv::LINE_AA);
    cv::putText(img, "feature legs", cv::Point(10, 24), cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(0, 0, 230), 2);
    cv::putText(img, "path legs", cv::Point(10, 48), cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(255, 90, 0), 2);
  }
  std::optional<Pose2D> start = route != nullptr && route->start ? route->start : std::optional<Pose2D>(world.start);
  if (start) {
    const cv::Point2d s(start->x_m, start->y_m);
    const cv::Point2d e = s + cv::Point2d(std::cos(start->heading_rad), std::sin(start->heading_rad)) * 2.0;
    cv::arrowedLine(img, px(s), px(e), cv::Scalar(0, 255, 255), 3, cv::LINE_AA, 0, 0.35);
  }
  // 10 m scale bar
  const cv::Point sb(10, H - 15);
  cv::line(img, sb, sb + cv::Point(static_cast<int>(10 * px_per_m), 0), cv::Scalar(255, 255, 255), 3);
  cv::putText(img, "10 m", sb + cv::Point(0, -8), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1);
  return img;
}

int sim_main(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  if (args.empty() || args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
    (args.empty() ? err : out) << kUsage;
    return args.empty() ? 2 : 0;
  }
  const std::string& cmd = args[0];
  if (cmd == "snapshot") return cmd_snapshot(args, out, err);
  if (cmd == "topview") return cmd_topview(args, out, err);
  if (cmd == "drive") return cmd_drive(args, out, err);
  if (cmd == "teleop") return cmd_teleop(args, out, err);
  if (cmd == "generate") return cmd_generate(args, out, err);
  err << "visnav sim: unknown command '" << cmd << "'\n" << kUsage;
  return 2;
}

}  // namespace visnav::sim
