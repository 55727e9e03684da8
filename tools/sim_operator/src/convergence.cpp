#include "convergence.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numeric>
#include <optional>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "sim_session_util.hpp"
#include "visnav/bt/tree.hpp"
#include "visnav/runner.hpp"

namespace fs = std::filesystem;

namespace visnav::simop {

namespace {

constexpr const char* kUsage =
    "usage: visnav convergence [--world W] [--length M] [--displace M] [--replays N]\n"
    "                          [--primitives LIST] [--speed V] [--noise S] [--seed K]\n"
    "                          [--config C] [--out DIR] [--set key=value]...\n"
    "\n"
    "The straight-segment comparison of seed 000 Fig. 3 in the simulator, with the shipped\n"
    "behaviour-tree nodes: drives M metres (odometry) straight from the world's start pose while\n"
    "TeachPathEdge and TeachFeatureEdge (styles segment and localmaps) teach one edge each; then,\n"
    "for every replay and primitive, starts a fresh session displaced sideways (+D, -D, +D, ...,\n"
    "noise seed K + replay), replays that primitive's edge, records the ground-truth lateral\n"
    "offset against the distance travelled along the segment and fits y = a*exp(-k*x) (NLopt\n"
    "least squares). Prints k, a, rms and the final offset per replay and mean +- sd of k per\n"
    "primitive; writes samples.csv, fits.csv, convergence.png (offset vs distance, one panel per\n"
    "primitive) and report.md.\n"
    "\n"
    "  --world W        world name or file with a straight path from its start (default straight6m;\n"
    "                   straight15m for a longer segment)\n"
    "  --length M       odometric length of the taught segment, m (default 5.6, as seed 000)\n"
    "  --displace D     lateral displacement of every replay start, m (default 0.5)\n"
    "  --replays N      replays per primitive (default 5)\n"
    "  --primitives L   comma-separated edge kinds (default\n"
    "                   path_following,feature_segment,feature_localmaps)\n"
    "  --speed V        teach speed and replay speed limit, m/s (default 0.4)\n"
    "  --noise S        camera noise std, grey levels, seeded per replay (default 2)\n"
    "  --seed K         noise seed of the first replay (default 1)\n"
    "  --config C       run configuration (default config/sim_experiment.yaml)\n"
    "  --out DIR        output folder (default out/convergence): map/, trees/, CSVs, PNG, report.md\n"
    "  --set k=v        config override for every session, e.g. --set robot.params.odom_scale_error_pct=0\n"
    "\n"
    "Exit status: 0 done, 1 a run failed, 2 usage error.\n";

bool known_primitive(const std::string& p) { return p == kPathKind || p == kSegmentKind || p == kLocalMapsKind; }

/// Ground truth in the taught segment's frame: origin and heading of the teach start.
struct SegmentFrame {
  Pose2D origin;
  [[nodiscard]] double along_m(const Pose2D& p) const {
    return (p.x_m - origin.x_m) * std::cos(origin.heading_rad) + (p.y_m - origin.y_m) * std::sin(origin.heading_rad);
  }
  [[nodiscard]] double across_m(const Pose2D& p) const {
    return -(p.x_m - origin.x_m) * std::sin(origin.heading_rad) + (p.y_m - origin.y_m) * std::cos(origin.heading_rad);
  }
};

Result<std::unique_ptr<Session>> make_session(const ConvergenceOptions& o, const std::vector<std::string>& own,
                                              const fs::path& map_dir) {
  std::vector<std::string> overrides = {"robot.params.world=" + o.world,
                                        "camera.params.noise_std=" + fixed(o.camera_noise_std, 3)};
  overrides.insert(overrides.end(), own.begin(), own.end());
  overrides.insert(overrides.end(), o.overrides.begin(), o.overrides.end());  // the user's word last
  VISNAV_ASSIGN(RunConfig config, load_run_config(project_file(o.config), overrides));
  if (config.run.log_level == "info" || config.run.log_level == "debug") config.run.log_level = "warn";
  SessionOptions so;
  so.map_path = map_dir.string();
  so.extra_plugin_dirs = o.plugin_dirs;
  so.use_default_plugin_path = o.use_default_plugin_path;
  so.overrides = overrides;
  VISNAV_ASSIGN(auto session, Session::create(std::move(config), so));
  if (session->robot().simulation() == nullptr)
    return fail("visnav convergence needs the simulated robot (robot type sim) in " + o.config);
  if (session->map() == nullptr) return fail("the session has no map");
  session->map()->set_sync(false);  // an experiment's scratch map: no fsync per edge
  return session;
}

Status write_text(const fs::path& file, const std::string& text) {
  std::ofstream out(file);
  out << text;
  out.close();
  if (!out) return fail("cannot write " + file.string());
  return ok();
}

std::string tree_xml(const std::string& body) {
  return "<root BTCPP_format=\"4\">\n  <BehaviorTree ID=\"Main\">\n" + body + "  </BehaviorTree>\n</root>\n";
}

struct Taught {
  SegmentFrame frame;
  std::vector<std::pair<std::string, std::string>> edges;  // primitive, edge id
  double length_m = 0.0;
};

Result<Taught> teach(const ConvergenceOptions& o, const fs::path& map_dir, const fs::path& tree_dir,
                     ProgressLine& progress) {
  VISNAV_ASSIGN(auto session, make_session(o, {"camera.params.seed=" + std::to_string(o.first_seed + 1000),
                                               "robot.params.seed=" + std::to_string(o.first_seed + 1000)},
                                           map_dir));
  SimulationControl* sim = session->robot().simulation();
  MapStore& map = *session->map();
  NodeRecord start_node;
  start_node.name = "start";
  VISNAV_ASSIGN(std::string from, map.add_node(start_node));
  NodeRecord end_node;
  end_node.name = "end";
  VISNAV_ASSIGN(std::string to, map.add_node(end_node));

  std::string body = "    <Parallel success_count=\"" + std::to_string(o.primitives.size()) + "\" failure_count=\"1\">\n";
  for (const auto& p : o.primitives) {
    const std::string ends = " edge_from=\"" + from + "\" edge_to=\"" + to + "\" finish=\"{finish}\" edge=\"{edge_" + p + "}\"";
    if (p == kPathKind) body += "      <TeachPathEdge" + ends + " learn_every=\"2\"/>\n";
    else body += "      <TeachFeatureEdge style=\"" + std::string(p == kSegmentKind ? "segment" : "localmaps") + "\"" + ends + "/>\n";
  }
  body += "    </Parallel>\n";
  const fs::path file = tree_dir / "teach.xml";
  VISNAV_TRY(write_text(file, tree_xml(body)));
  VISNAV_ASSIGN(bt::Tree tree, session->load_tree(file.string()));
  tree.blackboard().set("finish", false);

  Taught taught;
  taught.frame.origin = sim->ground_truth_pose();
  std::optional<double> d0;
  const double timeout_s = 4.0 * o.length_m / o.speed_mps + 20.0;
  RunOptions ro;
  ro.after_tick = [&](const TickInfo& t) {
    const auto odom = session->robot().latest_odometry();
    if (!odom) return t.t_s < timeout_s;
    if (!d0) d0 = odom->distance_m;
    const double d = odom->distance_m - *d0;
    if (d >= o.length_m) {
      tree.blackboard().set("finish", true);
      (void)session->robot().stop();
    } else if (!session->robot().send_command({o.speed_mps, 0.0})) {
      return false;  // the robot refused the command: the teach run ends (and is reported as failed)
    }
    if (o.progress) progress.show("teach", std::min(d, o.length_m), o.length_m, "m");
    return t.t_s < timeout_s;
  };
  const RunReport report = run_tree(*session, tree, ro);
  if (o.progress) progress.end();
  if (report.outcome != RunOutcome::success)
    return fail(std::string("teaching failed (") + to_string(report.outcome) + "): " +
                (report.reason.empty() ? "timeout after " + fixed(timeout_s, 0) + " s" : report.reason));
  for (const auto& p : o.primitives) {
    const EdgeRecord* found = nullptr;
    for (const auto& e : map.edges())
      if (e.kind == p) found = &e;
    if (found == nullptr) return fail("teaching stored no " + p + " edge");
    taught.edges.emplace_back(p, found->id);
    taught.length_m = found->length_m;
  }
  return taught;
}

ReplayTrace replay(const ConvergenceOptions& o, const Taught& taught, const std::string& primitive,
                   const std::string& edge_id, int index, const fs::path& map_dir, const fs::path& tree_dir,
                   ProgressLine& progress) {
  ReplayTrace tr;
  tr.primitive = primitive;
  tr.replay = index;
  tr.seed = o.first_seed + index;
  const double sign = index % 2 == 0 ? 1.0 : -1.0;
  auto session = make_session(o,
                              {"robot.params.displacement_lateral_m=" + fixed(sign * o.displacement_m, 6),
                               "robot.params.seed=" + std::to_string(tr.seed), "camera.params.seed=" + std::to_string(tr.seed)},
                              map_dir);
  if (!session) {
    tr.failure = session.error().message;
    return tr;
  }
  std::string node;
  if (primitive == kPathKind) node = "<FollowPathEdge edge=\"" + edge_id + "\" max_speed_mps=\"" + fixed(o.speed_mps, 3) + "\"/>";
  else if (primitive == kSegmentKind) node = "<ReplayFeatureEdge edge=\"" + edge_id + "\" speed_mps=\"" + fixed(o.speed_mps, 3) + "\"/>";
  else node = "<ReplayFeatureEdge edge=\"" + edge_id + "\"/>";  // style B replays the recorded speed
  const fs::path file = tree_dir / ("replay_" + primitive + ".xml");
  if (auto st = write_text(file, tree_xml("    " + node + "\n")); !st) {
    tr.failure = st.error().message;
    return tr;
  }
  auto tree = (*session)->load_tree(file.string());
  if (!tree) {
    tr.failure = tree.error().message;
    return tr;
  }
  SimulationControl* sim = (*session)->robot().simulation();
  const Pose2D start = sim->ground_truth_pose();
  const double along0 = taught.frame.along_m(start);
  tr.start_offset_m = taught.frame.across_m(start);
  tr.distance_m.push_back(0.0);
  tr.offset_m.push_back(tr.start_offset_m);
  const double timeout_s = 4.0 * taught.length_m / o.speed_mps + 20.0;
  const std::string phase = primitive + " " + std::to_string(index + 1) + "/" + std::to_string(o.replays);
  RunOptions ro;
  ro.after_tick = [&](const TickInfo& t) {
    const Pose2D p = sim->ground_truth_pose();
    tr.distance_m.push_back(taught.frame.along_m(p) - along0);
    tr.offset_m.push_back(taught.frame.across_m(p));
    if (o.progress) progress.show(phase, std::max(0.0, tr.distance_m.back()), taught.length_m, "m");
    return t.t_s < timeout_s;
  };
  const RunReport report = run_tree(**session, *tree, ro);
  if (o.progress) progress.end();
  tr.completed = report.outcome == RunOutcome::success;
  if (!tr.completed)
    tr.failure = std::string(to_string(report.outcome)) + ": " +
                 (report.reason.empty() ? "timeout after " + fixed(timeout_s, 0) + " s" : report.reason);
  if (auto fit = path_following::fit_exponential_decay(tr.distance_m, tr.offset_m)) tr.fit = *fit;
  else tr.fit_error = fit.error().message;
  return tr;
}

Result<ConvergenceOptions> parse(int argc, char** argv) {
  ConvergenceOptions o;
  o.progress = true;
  for (OptionReader in(argc, argv); in.next();) {
    const std::string& arg = in.arg();
    if (arg == "--world") { VISNAV_ASSIGN(o.world, in.value()); }
    else if (arg == "--length") { VISNAV_ASSIGN(o.length_m, in.number(0.5, 1000.0)); }
    else if (arg == "--displace") { VISNAV_ASSIGN(o.displacement_m, in.number(0.01, 5.0)); }
    else if (arg == "--replays") { VISNAV_ASSIGN(double n, in.number(1, 100)); o.replays = static_cast<int>(n); }
    else if (arg == "--speed") { VISNAV_ASSIGN(o.speed_mps, in.number(0.05, 2.0)); }
    else if (arg == "--noise") { VISNAV_ASSIGN(o.camera_noise_std, in.number(0.0, 50.0)); }
    else if (arg == "--seed") { VISNAV_ASSIGN(double s, in.number(0, 1e6)); o.first_seed = static_cast<int>(s); }
    else if (arg == "--config") { VISNAV_ASSIGN(o.config, in.value()); }
    else if (arg == "--out") { VISNAV_ASSIGN(o.out_dir, in.value()); }
    else if (arg == "--set") { VISNAV_ASSIGN(std::string v, in.value()); o.overrides.push_back(v); }
    else if (arg == "--primitives") {
      VISNAV_ASSIGN(std::string v, in.value());
      o.primitives.clear();
      std::stringstream ss(v);
      for (std::string p; std::getline(ss, p, ',');) o.primitives.push_back(p);
    } else {
      return fail("unknown option '" + arg + "'");
    }
  }
  VISNAV_TRY(o.validate());
  return o;
}

}  // namespace

Status ConvergenceOptions::validate() const {
  if (!(length_m > 0.0)) return fail("length_m must be > 0 (got " + fixed(length_m) + ")");
  if (!(displacement_m > 0.0)) return fail("displacement_m must be > 0 (got " + fixed(displacement_m) + ")");
  if (!(speed_mps > 0.0)) return fail("speed_mps must be > 0 (got " + fixed(speed_mps) + ")");
  if (replays < 1 || replays > 100) return fail("replays must be in [1, 100] (got " + std::to_string(replays) + ")");
  if (!(camera_noise_std >= 0.0)) return fail("camera_noise_std must be >= 0");
  if (first_seed < 0) return fail("first_seed must be >= 0");
  if (primitives.empty()) return fail("no primitive to compare");
  for (std::size_t i = 0; i < primitives.size(); ++i) {
    if (!known_primitive(primitives[i]))
      return fail("primitive '" + primitives[i] + "' is not one of " + kPathKind + ", " + kSegmentKind + ", " +
                  kLocalMapsKind);
    if (std::find(primitives.begin(), primitives.begin() + static_cast<std::ptrdiff_t>(i), primitives[i]) !=
        primitives.begin() + static_cast<std::ptrdiff_t>(i))
      return fail("primitive '" + primitives[i] + "' is listed twice");
  }
  if (world.empty()) return fail("world is empty");
  if (out_dir.empty()) return fail("out_dir is empty");
  return ok();
}

const PrimitiveSummary* ConvergenceReport::find(const std::string& primitive) const {
  for (const auto& s : summary)
    if (s.primitive == primitive) return &s;
  return nullptr;
}

std::vector<PrimitiveSummary> summarise(const std::vector<ReplayTrace>& traces, const std::vector<std::string>& order) {
  std::vector<PrimitiveSummary> out;
  for (const auto& p : order) {
    PrimitiveSummary s;
    s.primitive = p;
    std::vector<double> ks;
    double final_sum = 0.0;
    for (const auto& t : traces) {
      if (t.primitive != p) continue;
      ++s.replays;
      final_sum += std::abs(t.final_offset_m());
      if (t.fit) ks.push_back(t.fit->k);
    }
    s.fitted = static_cast<int>(ks.size());
    if (!ks.empty()) s.mean_k_per_m = std::accumulate(ks.begin(), ks.end(), 0.0) / static_cast<double>(ks.size());
    if (ks.size() >= 2) {
      double ss = 0.0;
      for (double k : ks) ss += (k - s.mean_k_per_m) * (k - s.mean_k_per_m);
      s.sd_k_per_m = std::sqrt(ss / static_cast<double>(ks.size() - 1));
    }
    if (s.replays > 0) s.mean_abs_final_offset_m = final_sum / s.replays;
    out.push_back(s);
  }
  return out;
}

Result<ConvergenceReport> run_convergence(const ConvergenceOptions& o) {
  VISNAV_TRY(o.validate());
  const auto wall_start = std::chrono::steady_clock::now();
  const fs::path out(o.out_dir);
  const fs::path map_dir = out / "map";
  const fs::path tree_dir = out / "trees";
  std::error_code ec;
  fs::remove_all(map_dir, ec);
  fs::create_directories(tree_dir, ec);
  if (ec) return fail("cannot create " + tree_dir.string() + ": " + ec.message());
  ProgressLine progress{30};
  VISNAV_ASSIGN(Taught taught, teach(o, map_dir, tree_dir, progress));
  ConvergenceReport report;
  report.world = o.world;
  report.taught_length_m = taught.length_m;
  for (int i = 0; i < o.replays; ++i)
    for (const auto& [primitive, edge] : taught.edges)
      report.traces.push_back(replay(o, taught, primitive, edge, i, map_dir, tree_dir, progress));
  report.summary = summarise(report.traces, o.primitives);
  report.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return report;
}

cv::Mat draw_convergence(const ConvergenceReport& report) {
  const int pw = 520, ph = 380, left = 62, right = 16, top = 46, bottom = 48;
  const int panels = std::max<int>(1, static_cast<int>(report.summary.size()));
  cv::Mat img(ph, pw * panels, CV_8UC3, cv::Scalar(255, 255, 255));
  double x_max = std::max(0.5, report.taught_length_m);
  double y_max = 0.1;
  for (const auto& t : report.traces) {
    for (double d : t.distance_m) x_max = std::max(x_max, d);
    for (double y : t.offset_m) y_max = std::max(y_max, std::abs(y));
  }
  y_max = std::ceil(y_max * 1.1 * 10.0) / 10.0;
  const cv::Scalar black(0, 0, 0), grid(225, 225, 225);
  const cv::Scalar colours[] = {cv::Scalar(200, 80, 0), cv::Scalar(0, 0, 200), cv::Scalar(0, 150, 0),
                                cv::Scalar(160, 0, 160), cv::Scalar(0, 140, 220), cv::Scalar(120, 120, 0)};
  for (int k = 0; k < panels && k < static_cast<int>(report.summary.size()); ++k) {
    const PrimitiveSummary& s = report.summary[static_cast<std::size_t>(k)];
    const int x0 = k * pw;
    auto px = [&](double x_m, double y_m) {
      const double u = x0 + left + x_m / x_max * (pw - left - right);
      const double v = top + (y_max - y_m) / (2.0 * y_max) * (ph - top - bottom);
      return cv::Point(static_cast<int>(std::lround(u)), static_cast<int>(std::lround(v)));
    };
    // grid and axes
    const double x_step = x_max > 8 ? 2.0 : 1.0;
    for (double x = 0; x <= x_max + 1e-9; x += x_step) {
      cv::line(img, px(x, -y_max), px(x, y_max), grid, 1);
      cv::putText(img, fixed(x, 0), px(x, -y_max) + cv::Point(-5, 18), cv::FONT_HERSHEY_SIMPLEX, 0.4, black, 1, cv::LINE_AA);
    }
    for (int j = -4; j <= 4; ++j) {
      const double y = y_max * j / 4.0;
      cv::line(img, px(0, y), px(x_max, y), j == 0 ? cv::Scalar(150, 150, 150) : grid, 1);
      cv::putText(img, fixed(y, 2), cv::Point(x0 + 8, px(0, y).y + 4), cv::FONT_HERSHEY_SIMPLEX, 0.38, black, 1, cv::LINE_AA);
    }
    cv::rectangle(img, px(0, y_max), px(x_max, -y_max), black, 1);
    cv::putText(img, "distance along the segment [m]", cv::Point(x0 + left + 120, ph - 10), cv::FONT_HERSHEY_SIMPLEX, 0.42,
                black, 1, cv::LINE_AA);
    std::string title = s.primitive + ": k = " + fixed(s.mean_k_per_m, 3) + " +- " + fixed(s.sd_k_per_m, 3) + " 1/m (" +
                        std::to_string(s.fitted) + " fits)";
    cv::putText(img, title, cv::Point(x0 + left, 20), cv::FONT_HERSHEY_SIMPLEX, 0.5, black, 1, cv::LINE_AA);
    cv::putText(img, "lateral offset [m] vs distance; dashed: y = a exp(-kx)", cv::Point(x0 + left, 38),
                cv::FONT_HERSHEY_SIMPLEX, 0.38, cv::Scalar(90, 90, 90), 1, cv::LINE_AA);
    int n = 0;
    for (const auto& t : report.traces) {
      if (t.primitive != s.primitive) continue;
      const cv::Scalar c = colours[n++ % 6];
      for (std::size_t i = 1; i < t.distance_m.size(); ++i)
        cv::line(img, px(t.distance_m[i - 1], t.offset_m[i - 1]), px(t.distance_m[i], t.offset_m[i]), c, 2, cv::LINE_AA);
      if (t.fit) {
        const double end = t.distance_m.empty() ? x_max : *std::max_element(t.distance_m.begin(), t.distance_m.end());
        const int steps = 60;
        for (int i = 0; i < steps; i += 2) {
          const double xa = end * i / steps, xb = end * (i + 1) / steps;
          cv::line(img, px(xa, t.fit->a * std::exp(-t.fit->k * xa)), px(xb, t.fit->a * std::exp(-t.fit->k * xb)),
                   cv::Scalar(40, 40, 40), 1, cv::LINE_AA);
        }
      }
    }
  }
  return img;
}

std::string convergence_table(const ConvergenceReport& report) {
  std::ostringstream t;
  t << "| primitive | replay | seed | start offset [m] | a [m] | k [1/m] | rms [m] | final offset [m] | distance [m] | "
       "completed |\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : report.traces) {
    const double dist = r.distance_m.empty() ? 0.0 : r.distance_m.back();
    t << "| " << r.primitive << " | " << r.replay + 1 << " | " << r.seed << " | " << fixed(r.start_offset_m) << " | "
      << (r.fit ? fixed(r.fit->a) : "-") << " | " << (r.fit ? fixed(r.fit->k) : "-") << " | "
      << (r.fit ? fixed(r.fit->rms) : "-") << " | " << fixed(r.final_offset_m()) << " | " << fixed(dist, 2) << " | "
      << (r.completed ? "yes" : "no: " + r.failure) << " |\n";
  }
  t << "\n| primitive | fits | mean k [1/m] | sd k [1/m] | mean abs final offset [m] | e^(-k L) |\n|---|---|---|---|---|---|\n";
  for (const auto& s : report.summary)
    t << "| " << s.primitive << " | " << s.fitted << "/" << s.replays << " | " << fixed(s.mean_k_per_m) << " | "
      << fixed(s.sd_k_per_m) << " | " << fixed(s.mean_abs_final_offset_m) << " | "
      << fixed(std::exp(-s.mean_k_per_m * report.taught_length_m), 2) << " |\n";
  return t.str();
}

Status write_convergence_outputs(const ConvergenceReport& report, const ConvergenceOptions& o) {
  const fs::path out(o.out_dir);
  std::ostringstream samples;
  samples << "primitive,replay,seed,start_offset_m,distance_m,offset_m\n";
  std::ostringstream fits;
  fits << "primitive,replay,seed,start_offset_m,a_m,k_per_m,rms_m,final_offset_m,distance_m,completed\n";
  for (const auto& r : report.traces) {
    for (std::size_t i = 0; i < r.distance_m.size(); ++i)
      samples << r.primitive << ',' << r.replay + 1 << ',' << r.seed << ',' << fixed(r.start_offset_m, 4) << ','
              << fixed(r.distance_m[i], 4) << ',' << fixed(r.offset_m[i], 4) << '\n';
    fits << r.primitive << ',' << r.replay + 1 << ',' << r.seed << ',' << fixed(r.start_offset_m, 4) << ','
         << (r.fit ? fixed(r.fit->a, 4) : "") << ',' << (r.fit ? fixed(r.fit->k, 4) : "") << ','
         << (r.fit ? fixed(r.fit->rms, 4) : "") << ',' << fixed(r.final_offset_m(), 4) << ','
         << fixed(r.distance_m.empty() ? 0.0 : r.distance_m.back(), 3) << ',' << (r.completed ? 1 : 0) << '\n';
  }
  VISNAV_TRY(write_text(out / "samples.csv", samples.str()));
  VISNAV_TRY(write_text(out / "fits.csv", fits.str()));
  const std::string png = (out / "convergence.png").string();
  if (!cv::imwrite(png, draw_convergence(report))) return fail("cannot write " + png);
  std::ostringstream md;
  md << "# visnav convergence\n\nworld `" << report.world << "`, taught segment " << fixed(report.taught_length_m, 2)
     << " m (odometry), replays from " << fixed(o.displacement_m, 2) << " m lateral displacement (sign alternating), "
     << "config `" << o.config << "`";
  for (const auto& s : o.overrides) md << ", `--set " << s << "`";
  md << "\n\n" << convergence_table(report)
     << "\nx: distance along the taught segment from the replay start (ground truth); y: lateral offset from the "
        "taught line, left positive. Fit: y = a·e^(−k·x), NLopt least squares over every tick. e^(−kL): share of "
        "the offset left after the segment (L = taught length) at the mean k.\n";
  return write_text(out / "report.md", md.str());
}

int convergence_command(int argc, char** argv, HostServices& /*host*/) {
  if (print_help_if_asked(argc, argv, kUsage)) return 0;
  auto options = parse(argc, argv);
  if (!options) return usage_error("visnav convergence", options.error().message, kUsage);
  const ConvergenceOptions& o = *options;
  std::cout << "visnav convergence: world " << o.world << ", segment " << fixed(o.length_m, 2) << " m, "
            << o.replays << " replays from +-" << fixed(o.displacement_m, 2) << " m, primitives "
            << join(o.primitives, ", ") << "\n";
  auto report = run_convergence(o);
  if (!report) {
    std::cerr << "visnav convergence: " << report.error().message << "\n";
    return 1;
  }
  if (auto st = write_convergence_outputs(*report, o); !st) {
    std::cerr << "visnav convergence: " << st.error().message << "\n";
    return 1;
  }
  std::cout << "\n" << convergence_table(*report) << "\n";
  for (const auto& s : report->summary) {
    const double left = std::exp(-s.mean_k_per_m * report->taught_length_m);
    if (s.fitted > 0 && left > 0.5)
      std::cout << "note: " << s.primitive << " keeps " << fixed(100.0 * left, 0) << " % of its offset over the "
                << fixed(report->taught_length_m, 1) << " m segment: the fit covers only the start of the decay"
                << (report->taught_length_m < 10.0 ? "; a longer straight (--world straight15m --length 14) "
                                                     "conditions k better"
                                                   : "")
                << "\n";
  }
  int status = 0;
  for (const auto& t : report->traces)
    if (!t.completed) status = 1;
  std::cout << "plot:    " << (fs::path(o.out_dir) / "convergence.png").string() << "\n"
            << "data:    " << (fs::path(o.out_dir) / "samples.csv").string() << ", "
            << (fs::path(o.out_dir) / "fits.csv").string() << "\n"
            << "report:  " << (fs::path(o.out_dir) / "report.md").string() << " (" << fixed(report->wall_s, 0)
            << " s)\n";
  return status;
}

}  // namespace visnav::simop
