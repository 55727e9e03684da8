#include "experiment.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <numbers>
#include <optional>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "sim_session_util.hpp"
#include "visnav/bt/tree.hpp"
#include "visnav/map.hpp"
#include "visnav/path_following/exp_fit.hpp"
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

namespace {

constexpr const char* kUsage =
    "usage: visnav experiment [--world W] [--route R] [--displace M] [--loops N]\n"
    "                         [--maps hybrid,feature] [--config C] [--out DIR] [--set key=value]...\n"
    "\n"
    "Teaches the route R (a waypoint script, config/routes/) in the simulated world W, displaces\n"
    "the robot M metres to its left, replays the closed route N times and measures, against the\n"
    "simulator's ground truth, each loop's end-position error, the accuracy and repeatability\n"
    "of seed 000 eq. 18 and the convergence rate k of err_i = a·e^(−k·i). Each map style in --maps\n"
    "is a separate run: 'hybrid' teaches every leg with the primitive the route names (feature\n"
    "edges in the hall and across the square, path following on the gravel paths), 'feature'\n"
    "teaches every leg with the feature-based primitive.\n"
    "\n"
    "  --world W       world name or file (default campus)\n"
    "  --route R       route name or file (default: the world's name)\n"
    "  --displace M    lateral displacement before the first replay, m (default 1.0)\n"
    "  --loops N       replays of the closed route (default 5)\n"
    "  --maps LIST     map styles, comma-separated (default hybrid,feature)\n"
    "  --config C      run configuration (default config/sim_experiment.yaml)\n"
    "  --out DIR       output folder (default out/experiment): maps, CSVs, PNGs, report.md\n"
    "  --set k=v       config override, e.g. --set robot.params.odom_scale_error_pct=5\n"
    "\n"
    "Per style, DIR/<style>/ holds the map, trajectory.csv (ground truth and odometry of every\n"
    "tick), loops.csv (each loop's end position and error, split into along-track (forward +)\n"
    "and cross-track (left +) components in the frame of the heading where teaching ended) and\n"
    "edges.csv (where each replayed edge ended against where the same edge ended when taught,\n"
    "in the taught end heading's frame; lap 0 rows are the taught ends), for finding the edges\n"
    "that introduce an error.\n"
    "\n"
    "Exit status: 0 done, 1 a run failed, 2 usage error.\n";

struct Options {
  std::string world = "campus";
  std::string route;
  double displace_m = 1.0;
  int loops = 5;
  std::vector<std::string> maps = {"hybrid", "feature"};
  std::string config = "config/sim_experiment.yaml";
  std::string out = "out/experiment";
  std::vector<std::string> overrides;
};

/// Ground-truth pose of the robot when a primitive finished an edge (teach or replay).
struct EdgeEnd {
  int lap = 0;  ///< 0 = teach
  int index = 0;  ///< position in the lap's route
  std::string edge;
  std::string kind;
  Pose2D pose;
  double odom_distance_m = 0.0;
};

struct StyleResult {
  std::string style;
  std::vector<EdgeEnd> taught_edge_ends;
  std::vector<EdgeEnd> replay_edge_ends;
  double taught_end_heading_rad = 0.0;
  bool ok = false;
  std::string failure;
  cv::Point2d taught_end;
  cv::Point2d replay_start;
  std::vector<cv::Point2d> teach_path;
  std::vector<std::vector<cv::Point2d>> lap_paths;
  std::vector<cv::Point2d> lap_ends;
  std::vector<double> errors_m;
  AccuracyRepeatability metrics;
  std::optional<path_following::ExpDecayFit> fit;
  MapStats stats;
  double route_length_m = 0.0;
  double wall_s = 0.0;
};

Result<Options> parse(int argc, char** argv) {
  Options o;
  for (OptionReader in(argc, argv); in.next();) {
    const std::string& arg = in.arg();
    if (arg == "--world") { VISNAV_ASSIGN(o.world, in.value()); }
    else if (arg == "--route") { VISNAV_ASSIGN(o.route, in.value()); }
    else if (arg == "--displace") { VISNAV_ASSIGN(o.displace_m, in.number(-5.0, 5.0)); }
    else if (arg == "--loops") { VISNAV_ASSIGN(double n, in.number(1, 100)); o.loops = static_cast<int>(n); }
    else if (arg == "--config") { VISNAV_ASSIGN(o.config, in.value()); }
    else if (arg == "--out") { VISNAV_ASSIGN(o.out, in.value()); }
    else if (arg == "--set") { VISNAV_ASSIGN(std::string v, in.value()); o.overrides.push_back(v); }
    else if (arg == "--maps") {
      VISNAV_ASSIGN(std::string v, in.value());
      o.maps.clear();
      std::stringstream ss(v);
      for (std::string m; std::getline(ss, m, ',');) {
        if (m != "hybrid" && m != "feature") return fail("--maps: '" + m + "' is not hybrid or feature");
        o.maps.push_back(m);
      }
      if (o.maps.empty()) return fail("--maps needs at least one style");
    } else {
      return fail("unknown option '" + arg + "'");
    }
  }
  if (o.route.empty()) o.route = o.world;
  return o;
}

cv::Point2d xy(const Pose2D& p) { return {p.x_m, p.y_m}; }

Result<StyleResult> run_style(const Options& o, const std::string& style, const sim::Route& route,
                              const std::string& route_file, const fs::path& out_dir) {
  StyleResult r;
  r.style = style;
  r.route_length_m = route.waypoint_length_m();
  const auto wall_start = std::chrono::steady_clock::now();
  std::vector<std::string> overrides = o.overrides;
  overrides.insert(overrides.begin(), "robot.params.world=" + o.world);
  if (route.start) {
    std::ostringstream start;
    start << route.start->x_m << ";" << route.start->y_m << ";" << route.start->heading_rad * 180.0 / std::numbers::pi;
    overrides.insert(overrides.begin(), "robot.params.start_pose=" + start.str());
  }
  VISNAV_ASSIGN(RunConfig config, load_run_config(project_file(o.config), overrides));
  if (config.run.log_level == "info") config.run.log_level = "warn";  // the progress bar is the output
  const fs::path map_dir = out_dir / "map";
  fs::remove_all(map_dir);
  SessionOptions so;
  so.map_path = map_dir.string();
  VISNAV_ASSIGN(auto session, Session::create(std::move(config), so));
  SimulationControl* sim = session->robot().simulation();
  if (sim == nullptr) return fail("the experiment needs the simulated robot (robot type sim)");
  ProgressLine progress(22);
  // Ground truth and odometry of every tick (evaluation only: the navigation never sees it).
  std::ofstream trajectory(out_dir / "trajectory.csv");
  trajectory << "t_s,phase,lap,gt_x_m,gt_y_m,gt_heading_rad,odom_x_m,odom_y_m,odom_heading_rad,odom_distance_m\n";
  auto log_tick = [&](const TickInfo& t, const char* phase, int lap) {
    const Pose2D gt = sim->ground_truth_pose();
    const auto odom = session->robot().latest_odometry();
    const Odometry od = odom ? *odom : Odometry{};
    trajectory << t.t_s << ',' << phase << ',' << lap << ',' << gt.x_m << ',' << gt.y_m << ',' << gt.heading_rad << ','
               << od.pose.x_m << ',' << od.pose.y_m << ',' << od.pose.heading_rad << ',' << od.distance_m << '\n';
  };

  {  // --- teach
    VISNAV_ASSIGN(bt::Tree teach, session->load_tree(project_file("trees/teach_hybrid_route.xml")));
    VISNAV_TRY(set_blackboard_values(teach, {"route_file=" + route_file,
                                             std::string("force_kind=") + (style == "feature" ? "feature_segment" : ""),
                                             std::string("close_loop=") + (route.closed ? "true" : "false")}));
    const double d0 = session->robot().latest_odometry() ? session->robot().latest_odometry()->distance_m : 0.0;
    teach.add_observer([&](double, const bt::TreeNode& node, bt::NodeStatus, bt::NodeStatus to) {
      if (to != bt::NodeStatus::success) return;
      if (node.registration_id() != "TeachFeatureEdge" && node.registration_id() != "TeachPathEdge") return;
      EdgeEnd e;
      e.index = static_cast<int>(r.taught_edge_ends.size());
      if (auto id = node.blackboard().get<std::string>("taught_edge")) e.edge = *id;
      e.pose = sim->ground_truth_pose();
      if (auto od = session->robot().latest_odometry()) e.odom_distance_m = od->distance_m;
      r.taught_edge_ends.push_back(std::move(e));
    });
    RunOptions ro;
    ro.after_tick = [&](const TickInfo& t) {
      log_tick(t, "teach", 0);
      if (t.tick % 3 == 0) r.teach_path.push_back(xy(sim->ground_truth_pose()));
      const auto odom = session->robot().latest_odometry();
      progress.show(style + ": teach", odom ? odom->distance_m - d0 : 0.0, r.route_length_m, "m");
      return true;
    };
    RunReport report = run_tree(*session, teach, ro);
    progress.end();
    if (report.outcome != RunOutcome::success) return fail("teaching failed: " + report.reason);
  }
  r.taught_end = xy(sim->ground_truth_pose());
  r.taught_end_heading_rad = sim->ground_truth_pose().heading_rad;
  r.teach_path.push_back(r.taught_end);
  for (auto& e : r.taught_edge_ends)
    if (const EdgeRecord* rec = session->map()->find_edge(e.edge)) e.kind = rec->kind;

  // --- displace (the robot is carried sideways; odometry does not see it)
  Pose2D displaced = sim->ground_truth_pose();
  displaced.x_m += -std::sin(displaced.heading_rad) * o.displace_m;
  displaced.y_m += std::cos(displaced.heading_rad) * o.displace_m;
  VISNAV_TRY(sim->set_ground_truth_pose(displaced));
  r.replay_start = xy(displaced);

  {  // --- replay the loop N times
    VISNAV_ASSIGN(bt::Tree patrol, session->load_tree(project_file("trees/patrol_loop.xml")));
    VISNAV_TRY(set_blackboard_values(patrol, {"start=start", std::string("loops=").append(std::to_string(o.loops))}));
    r.lap_paths.emplace_back();
    // A lap ends when FollowRoute succeeds.
    int lap_edge = 0;
    patrol.add_observer([&](double, const bt::TreeNode& node, bt::NodeStatus, bt::NodeStatus to) {
      if (to == bt::NodeStatus::success &&
          (node.registration_id() == "ReplayFeatureEdge" || node.registration_id() == "FollowPathEdge")) {
        EdgeEnd e;
        e.lap = static_cast<int>(r.lap_ends.size()) + 1;
        e.index = lap_edge++;
        if (auto id = node.get_input<std::string>("edge")) e.edge = *id;
        if (const EdgeRecord* rec = session->map()->find_edge(e.edge)) e.kind = rec->kind;
        e.pose = sim->ground_truth_pose();
        if (auto od = session->robot().latest_odometry()) e.odom_distance_m = od->distance_m;
        r.replay_edge_ends.push_back(std::move(e));
      }
      if (to == bt::NodeStatus::success && node.registration_id() == "FollowRoute") {
        lap_edge = 0;
        const cv::Point2d end = xy(sim->ground_truth_pose());
        r.lap_ends.push_back(end);
        r.lap_paths.back().push_back(end);
        r.lap_paths.emplace_back();
      }
    });
    const double d0 = session->robot().latest_odometry() ? session->robot().latest_odometry()->distance_m : 0.0;
    RunOptions ro;
    ro.after_tick = [&](const TickInfo& t) {
      log_tick(t, "replay", static_cast<int>(r.lap_ends.size()) + 1);
      if (t.tick % 3 == 0) r.lap_paths.back().push_back(xy(sim->ground_truth_pose()));
      const auto odom = session->robot().latest_odometry();
      std::string phase = style;
      phase.append(": replay lap ").append(std::to_string(std::min<int>(o.loops, static_cast<int>(r.lap_ends.size()) + 1)));
      phase.append("/").append(std::to_string(o.loops));
      progress.show(phase,
                    odom ? odom->distance_m - d0 : 0.0, r.route_length_m * o.loops, "m");
      return true;
    };
    RunReport report = run_tree(*session, patrol, ro);
    progress.end();
    if (r.lap_paths.back().empty()) r.lap_paths.pop_back();
    if (report.outcome != RunOutcome::success) {
      r.failure = "replay ended after " + std::to_string(r.lap_ends.size()) + " loops: " + report.reason;
    }
  }
  for (const auto& e : r.lap_ends) r.errors_m.push_back(cv::norm(e - r.taught_end));
  r.metrics = accuracy_repeatability(r.lap_ends, r.taught_end);
  if (r.errors_m.size() >= 3) {
    std::vector<double> x;
    for (std::size_t i = 0; i < r.errors_m.size(); ++i) x.push_back(static_cast<double>(i + 1));
    if (auto fit = path_following::fit_exponential_decay(x, r.errors_m)) r.fit = *fit;
  }
  r.stats = session->map()->stats();
  r.ok = r.failure.empty() && static_cast<int>(r.lap_ends.size()) == o.loops;
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();

  // Error components in the frame of the taught heading: along-track (forward +), cross-track (left +).
  auto components = [](const cv::Point2d& d, double heading_rad) {
    return cv::Point2d(d.x * std::cos(heading_rad) + d.y * std::sin(heading_rad),
                       -d.x * std::sin(heading_rad) + d.y * std::cos(heading_rad));
  };
  std::ofstream csv(out_dir / "loops.csv");
  csv << "loop,end_x_m,end_y_m,error_m,along_m,cross_m\n";
  for (std::size_t i = 0; i < r.lap_ends.size(); ++i) {
    const cv::Point2d c = components(r.lap_ends[i] - r.taught_end, r.taught_end_heading_rad);
    csv << i + 1 << "," << r.lap_ends[i].x << "," << r.lap_ends[i].y << "," << r.errors_m[i] << "," << c.x << ","
        << c.y << "\n";
  }
  // Each replayed edge's end against the same edge's end when taught (ground truth).
  std::ofstream edges(out_dir / "edges.csv");
  edges << "lap,index,edge,kind,gt_x_m,gt_y_m,gt_heading_rad,odom_distance_m,error_m,along_m,cross_m,heading_error_rad\n";
  for (const auto& e : r.replay_edge_ends) {
    const auto taught = std::find_if(r.taught_edge_ends.begin(), r.taught_edge_ends.end(),
                                     [&](const EdgeEnd& t) { return t.edge == e.edge; });
    edges << e.lap << "," << e.index << "," << e.edge << "," << e.kind << "," << e.pose.x_m << "," << e.pose.y_m << ","
          << e.pose.heading_rad << "," << e.odom_distance_m;
    if (taught == r.taught_edge_ends.end()) {
      edges << ",,,,\n";
      continue;
    }
    const cv::Point2d d = xy(e.pose) - xy(taught->pose);
    const cv::Point2d c = components(d, taught->pose.heading_rad);
    edges << "," << cv::norm(d) << "," << c.x << "," << c.y << ","
          << std::remainder(e.pose.heading_rad - taught->pose.heading_rad, 2.0 * std::numbers::pi) << "\n";
  }
  for (const auto& t : r.taught_edge_ends)
    edges << 0 << "," << t.index << "," << t.edge << "," << t.kind << "," << t.pose.x_m << "," << t.pose.y_m << ","
          << t.pose.heading_rad << "," << t.odom_distance_m << ",0,0,0,0\n";
  return r;
}

/// Trajectories over the world's top view: teach (white), each lap (yellow → red), ends.
cv::Mat draw_trajectories(const sim::World& world, const sim::Route& route, const StyleResult& r) {
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
  polyline(r.teach_path, cv::Scalar(255, 255, 255), 3);
  for (std::size_t k = 0; k < r.lap_paths.size(); ++k) {
    const double s = r.lap_paths.size() > 1 ? static_cast<double>(k) / static_cast<double>(r.lap_paths.size() - 1) : 1.0;
    polyline(r.lap_paths[k], cv::Scalar(0, 255 * (1.0 - s), 255), 2);
  }
  cv::circle(img, px(r.taught_end), 6, cv::Scalar(255, 255, 255), 2, cv::LINE_AA);
  cv::circle(img, px(r.replay_start), 6, cv::Scalar(255, 0, 255), 2, cv::LINE_AA);
  for (const auto& e : r.lap_ends) cv::drawMarker(img, px(e), cv::Scalar(0, 0, 255), cv::MARKER_CROSS, 12, 2);
  const std::string title = r.style + " map: teach (white), replay laps (yellow->red), start after displacement (magenta)";
  cv::putText(img, title, {10, img.rows - 12}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  return img;
}

/// Error per loop for every style (as seed 002 Figs. 5-10).
cv::Mat draw_errors(const std::vector<StyleResult>& results, int loops) {
  const int w = 640, h = 400, left = 60, bottom = 50, top = 40, right = 20;
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  double max_err = 0.1;
  for (const auto& r : results)
    for (double e : r.errors_m) max_err = std::max(max_err, e);
  max_err *= 1.1;
  auto px = [&](double loop, double err) {
    const double x = left + (loop - 1) / std::max(1, loops - 1) * (w - left - right);
    const double y = h - bottom - err / max_err * (h - bottom - top);
    return cv::Point(static_cast<int>(x), static_cast<int>(y));
  };
  cv::line(img, {left, h - bottom}, {w - right, h - bottom}, cv::Scalar(0, 0, 0), 1);
  cv::line(img, {left, top}, {left, h - bottom}, cv::Scalar(0, 0, 0), 1);
  for (int i = 1; i <= loops; ++i) {
    cv::putText(img, std::to_string(i), px(i, 0) + cv::Point(-4, 20), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1);
  }
  for (int k = 0; k <= 4; ++k) {
    const double e = max_err * k / 4;
    std::ostringstream s;
    s << std::fixed << std::setprecision(2) << e;
    cv::putText(img, s.str(), {5, px(1, e).y + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1);
    cv::line(img, {left, px(1, e).y}, {w - right, px(1, e).y}, cv::Scalar(220, 220, 220), 1);
  }
  cv::putText(img, "end-of-loop position error [m] vs loop", {left, 25}, cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 1,
              cv::LINE_AA);
  const cv::Scalar colours[] = {cv::Scalar(200, 80, 0), cv::Scalar(0, 0, 200), cv::Scalar(0, 150, 0)};
  for (std::size_t s = 0; s < results.size(); ++s) {
    const auto& r = results[s];
    const cv::Scalar c = colours[s % 3];
    for (std::size_t i = 0; i < r.errors_m.size(); ++i) {
      cv::circle(img, px(static_cast<double>(i + 1), r.errors_m[i]), 4, c, cv::FILLED, cv::LINE_AA);
      if (i > 0)
        cv::line(img, px(static_cast<double>(i), r.errors_m[i - 1]), px(static_cast<double>(i + 1), r.errors_m[i]), c, 2,
                 cv::LINE_AA);
    }
    std::ostringstream label;
    label << r.style << ": acc " << std::fixed << std::setprecision(3) << r.metrics.accuracy_m << " m, rep "
          << r.metrics.repeatability_m << " m";
    cv::putText(img, label.str(), {w - 300, top + 20 + 20 * static_cast<int>(s)}, cv::FONT_HERSHEY_SIMPLEX, 0.45, c, 1,
                cv::LINE_AA);
  }
  return img;
}

std::string report_table(const Options& o, const std::vector<StyleResult>& results) {
  std::ostringstream t;
  t << "| map | loops | errors per loop [m] | ε_acc [m] | ε_rep [m] | k [1/loop] | map bytes | bytes/m | wall [s] |\n"
       "|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : results) {
    std::string errors;
    for (double e : r.errors_m) {
      if (!errors.empty()) errors += ' ';
      errors += fixed(e);
    }
    std::uint64_t bytes = 0;
    double length = 0;
    for (const auto& [kind, ks] : r.stats.per_kind) {
      bytes += ks.payload_bytes;
      length += ks.length_m;
    }
    t << "| " << r.style << " | " << r.lap_ends.size() << "/" << o.loops << " | " << errors << " | "
      << fixed(r.metrics.accuracy_m) << " | " << fixed(r.metrics.repeatability_m) << " | "
      << (r.fit ? fixed(r.fit->k) : std::string("-")) << " | " << bytes << " | "
      << (length > 0 ? fixed(static_cast<double>(bytes) / length, 0) : std::string("-")) << " | " << fixed(r.wall_s, 0)
      << " |\n";
  }
  return t.str();
}

}  // namespace

int experiment_command(int argc, char** argv, HostServices& /*host*/) {
  if (print_help_if_asked(argc, argv, kUsage)) return 0;
  auto options = parse(argc, argv);
  if (!options) return usage_error("visnav experiment", options.error(), kUsage);
  const Options& o = *options;
  auto world_path = sim::resolve_world_path(o.world);
  auto route_path = sim::resolve_route_path(o.route);
  if (!world_path || !route_path) {
    std::cerr << "visnav experiment: " << (!world_path ? world_path.error() : route_path.error()).message << "\n";
    return 2;
  }
  auto world = sim::load_world_cached(*world_path);
  auto route = sim::load_route(*route_path);
  if (!world || !route) {
    std::cerr << "visnav experiment: " << (!world ? world.error() : route.error()).message << "\n";
    return 1;
  }
  if (route->waypoints.empty() || !route->closed) {
    std::cerr << "visnav experiment: " << *route_path << ": the experiment needs a closed waypoint route\n";
    return 2;
  }
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (ec) {
    std::cerr << "visnav experiment: cannot create " << o.out << ": " << ec.message() << "\n";
    return 1;
  }
  std::cout << "visnav experiment: world " << o.world << ", route " << *route_path << " (" << fixed(route->waypoint_length_m(), 1)
            << " m), displacement " << o.displace_m << " m, " << o.loops << " loops\n";
  std::vector<StyleResult> results;
  int status = 0;
  for (const auto& style : o.maps) {
    const fs::path dir = fs::path(o.out) / style;
    fs::create_directories(dir, ec);
    auto r = run_style(o, style, *route, *route_path, dir);
    if (!r) {
      std::cerr << "visnav experiment: " << style << ": " << r.error().message << "\n";
      status = 1;
      continue;
    }
    if (!r->ok) {
      std::cerr << "visnav experiment: " << style << ": " << r->failure << "\n";
      status = 1;
    }
    cv::imwrite((dir / "trajectories.png").string(), draw_trajectories(**world, *route, *r));
    results.push_back(std::move(*r));
  }
  if (results.empty()) return 1;
  const std::string table = report_table(o, results);
  cv::imwrite((fs::path(o.out) / "errors.png").string(), draw_errors(results, o.loops));
  std::ofstream md(fs::path(o.out) / "report.md");
  md << "# visnav experiment\n\nworld `" << o.world << "`, route `" << *route_path << "` ("
     << fixed(route->waypoint_length_m(), 1) << " m), lateral displacement " << o.displace_m << " m, " << o.loops
     << " loops, config `" << o.config << "`\n\n"
     << table << "\nε_acc, ε_rep: seed 000 eq. (18) over the loop end positions against the position where teaching "
                 "ended. k: least-squares fit err_i = a·e^(−k·i).\n";
  std::cout << "\n" << table << "\n";
  std::cout << "pictures: " << (fs::path(o.out) / "errors.png").string();
  for (const auto& r : results) std::cout << ", " << (fs::path(o.out) / r.style / "trajectories.png").string();
  std::cout << "\nreport:   " << (fs::path(o.out) / "report.md").string() << "\n";
  return status;
}

}  // namespace visnav::simop
