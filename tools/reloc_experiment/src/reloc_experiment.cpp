// `visnav reloc-experiment` (see reloc_experiment.hpp).
#include "reloc_experiment.hpp"

#include <algorithm>
#include <array>
#include <map>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <mutex>
#include <numbers>
#include <optional>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "visnav/bt/node.hpp"
#include "visnav/bt/tree.hpp"
#include "visnav/command_line.hpp"
#include "visnav/map.hpp"
#include "visnav/runner.hpp"

namespace fs = std::filesystem;

namespace visnav::relocexp {
namespace {

const char* const kUsage =
    "usage: visnav reloc-experiment [--trials N] [--replays R] [--appearance A] [--route R] [--config C]\n"
    "                               [--lateral-m L] [--heading-deg H] [--look-around-deg D] [--creep-m C] [--seed S]\n"
    "                               [--reloc PORT=VALUE ...] [--kind K] [--out DIR]\n"
    "\n"
    "Relocalisation from random start poses (issue 21). Teaches ROUTE in the simulator with every leg\n"
    "as an edge of kind K (feature_segment by default), then for each trial starts a\n"
    "fresh session (its own draw of the odometry and camera error models) at a random point of the\n"
    "taught route, offset sideways by up to +-L m and turned by up to +-H deg, and runs Relocalise.\n"
    "An answer is correct when it names the edge the robot is on (or the neighbouring edge across\n"
    "a node) with an along-track error <= 1 m; wrong when it names another place; refused when it is\n"
    "ambiguous, not_on_map or camera_blocked. The first R correctly localised trials then replay\n"
    "from there (trees/replay_from_here.xml) to the end node of the following edge; a replay is\n"
    "complete when the run succeeds and ends within 1 m of where that node was taught.\n"
    "\n"
    "  --trials N       start poses (default 50)\n"
    "  --replays R      trials that replay after relocalising (default 5; 0 = none)\n"
    "  --appearance A   while relocalising: same (default), winter, autumn, dusk, low_sun, overcast\n"
    "  --route R        config/routes/R.yaml (default campus)\n"
    "  --config C       run config (default config/sim_reloc_campus.yaml)\n"
    "  --lateral-m L    lateral offset bound (default 0.5)\n"
    "  --heading-deg H  heading offset bound (default 30)\n"
    "  --look-around-deg D  Relocalise's look_around_deg (default 0: stand still)\n"
    "  --creep-m C      Relocalise's creep_m (default 0: no creeping forward); the truth is where the\n"
    "                   robot is when it answers\n"
    "  --reloc P=V      another Relocalise port, e.g. --reloc min_answer_confidence=0.3 (repeatable)\n"
    "  --kind K         edge kind of every taught leg: feature_segment (default, trees/teach_hybrid_route.xml)\n"
    "                   or visual_memory (trees/teach_hybrid_visual_memory.xml; the index describes the\n"
    "                   reference images with the config's detector), or hybrid\n"
    "                   (the route's own kinds: feature_segment and path_following legs, the path edges\n"
    "                   indexed by their thumbnails)\n"
    "  --seed S         random seed of the start poses and error models (default 1)\n"
    "  --out DIR        output folder: map/, trials.csv, run.log (default /tmp/visnav_reloc_experiment)\n"
    "\n"
    "Prints one line per trial and the rates. Exit status: 0 done, 1 setup failed, 2 usage error.\n";

struct Options {
  int trials = 50;
  int replays = 5;
  std::string appearance = "same";
  std::string route = "campus";
  std::string config = "config/sim_reloc_campus.yaml";
  double lateral_m = 0.5;
  double heading_deg = 30.0;
  int seed = 1;
  double look_around_deg = 0.0;
  double creep_m = 0.0;
  std::string kind = "feature_segment";
  std::string reloc_attrs;  // extra Relocalise attributes (--reloc K=V), ' K="V"' each
  std::string reloc_names = "look_around_deg|creep_m";  // the attributes the experiment sets
  std::string out = "/tmp/visnav_reloc_experiment";
};

std::string project_file(const std::string& path) {
  std::error_code ec;
  if (fs::path(path).is_absolute() || fs::exists(path, ec)) return path;
  const fs::path in_source = fs::path(VISNAV_SOURCE_DIR) / path;
  return fs::exists(in_source, ec) ? in_source.string() : path;
}

Result<std::vector<std::string>> appearance_overrides(const std::string& name) {
  // The appearance presets of `visnav experiment` (sim_operator), camera-side only.
  if (name == "same") return std::vector<std::string>{};
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
  return fail(ErrorCode::out_of_range,
              "--appearance: '" + name + "' is not one of: same, winter, autumn, dusk, low_sun, overcast");
}

/// Session logs go to run.log, not the terminal (one line per trial is printed instead).
class FileLogger final : public Logger {
 public:
  explicit FileLogger(const fs::path& file) : out_(file) {}
  void log(LogLevel level, std::string_view component, std::string_view message) override {
    static const char* names[] = {"D", "I", "W", "E"};
    std::lock_guard lock(mutex_);
    out_ << names[static_cast<int>(level)] << ' ' << component << ": " << message << '\n';
  }

 private:
  std::mutex mutex_;
  std::ofstream out_;
};

struct TeachSample {
  double odom_m;
  Pose2D truth;
};

struct TaughtEdge {
  std::string id;
  double start_m = 0.0;  // teach-run odometric distance at the edge's start
  double length_m = 0.0;
  Pose2D end_truth;      // where its end node was taught
  std::string kind;
};

std::string fixed(double v, int digits) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

Result<Options> parse(int argc, char** argv) {
  Options o;
  cli::OptionReader in(argc, argv);
  while (in.next()) {
    const std::string& a = in.arg();
    if (a == "--trials") {
      VISNAV_ASSIGN(const double v, in.number(1, 10000));
      o.trials = static_cast<int>(v);
    } else if (a == "--replays") {
      VISNAV_ASSIGN(const double v, in.number(0, 10000));
      o.replays = static_cast<int>(v);
    } else if (a == "--appearance") {
      VISNAV_ASSIGN(o.appearance, in.value());
      VISNAV_TRY(appearance_overrides(o.appearance));
    } else if (a == "--route") {
      VISNAV_ASSIGN(o.route, in.value());
    } else if (a == "--config") {
      VISNAV_ASSIGN(o.config, in.value());
    } else if (a == "--lateral-m") {
      VISNAV_ASSIGN(o.lateral_m, in.number(0, 10));
    } else if (a == "--heading-deg") {
      VISNAV_ASSIGN(o.heading_deg, in.number(0, 180));
    } else if (a == "--look-around-deg") {
      VISNAV_ASSIGN(o.look_around_deg, in.number(0, 180));
    } else if (a == "--reloc") {
      VISNAV_ASSIGN(const std::string kv, in.value());
      const auto eq = kv.find('=');
      if (eq == std::string::npos || eq == 0 ||
          kv.find_first_not_of("abcdefghijklmnopqrstuvwxyz_0123456789") < eq ||
          kv.find_first_of("\"<>& ") != std::string::npos)
        return fail(ErrorCode::invalid_value, "--reloc: '" + kv + "' is not PORT=VALUE");
      o.reloc_attrs += " " + kv.substr(0, eq) + "=\"" + kv.substr(eq + 1) + "\"";
      o.reloc_names += "|" + kv.substr(0, eq);
    } else if (a == "--kind") {
      VISNAV_ASSIGN(o.kind, in.value());
      if (o.kind != "feature_segment" && o.kind != "visual_memory" && o.kind != "hybrid")
        return fail(ErrorCode::invalid_value, "--kind: '" + o.kind + "' is not feature_segment, visual_memory or hybrid");
    } else if (a == "--creep-m") {
      VISNAV_ASSIGN(o.creep_m, in.number(0, 5));
    } else if (a == "--seed") {
      VISNAV_ASSIGN(const double v, in.number(0, 1e9));
      o.seed = static_cast<int>(v);
    } else if (a == "--out") {
      VISNAV_ASSIGN(o.out, in.value());
    } else {
      return fail(ErrorCode::unknown_key, "unknown argument '" + a + "'");
    }
  }
  return o;
}

/// What every phase of the experiment shares: the options, the output folder and the log.
struct Context {
  const Options& o;
  fs::path dir;
  FileLogger& logger;
  std::string config_file;
  std::string route_file;
  fs::path map_dir;

  [[nodiscard]] Result<std::unique_ptr<Session>> session_for(const std::vector<std::string>& overrides,
                                                             const std::string& map_path) const {
    VISNAV_ASSIGN(RunConfig config, load_run_config(config_file, overrides));
    SessionOptions so;
    so.map_path = map_path;
    so.logger = &logger;
    so.overrides = overrides;
    return Session::create(std::move(config), so);
  }
};

/// --- teach: every leg a feature edge; the ground truth of each tick and of each edge's end.
Status teach(const Context& c, std::vector<TeachSample>& samples, std::vector<TaughtEdge>& taught) {
  const Options& o = c.o;
  auto session = c.session_for({"robot.params.seed=" + std::to_string(o.seed * 100 + 1),
                                "camera.params.seed=" + std::to_string(o.seed * 100 + 11)},
                               c.map_dir.string());
  if (!session) return session.error();
  SimulationControl* sim = (*session)->robot().simulation();
  if (sim == nullptr) return fail("the experiment needs the simulated robot (robot type sim)");
  const bool memory = o.kind == "visual_memory";
  const std::string teacher = memory ? "TeachVisualMemoryEdge" : "TeachFeatureEdge";
  auto tree = (*session)->load_tree(
      project_file(memory ? "trees/teach_hybrid_visual_memory.xml" : "trees/teach_hybrid_route.xml"));
  if (!tree) return tree.error();
  // hybrid: the route's own kinds (feature_segment and path_following legs).
  if (auto st = set_blackboard_values(*tree, {"route_file=" + c.route_file,
                                              "force_kind=" + (o.kind == "hybrid" ? std::string() : o.kind),
                                              "close_loop=true"});
      !st)
    return st.error();
  auto odom_m = [&]() {
    const auto od = (*session)->robot().latest_odometry();
    return od ? od->distance_m : 0.0;
  };
  tree->add_observer([&](double, const bt::TreeNode& node, bt::NodeStatus, bt::NodeStatus to) {
    if (to != bt::NodeStatus::success ||
        (node.registration_id() != teacher && !(o.kind == "hybrid" && node.registration_id() == "TeachPathEdge")))
      return;
    TaughtEdge e;
    if (auto id = node.blackboard().get<std::string>("taught_edge")) e.id = *id;
    e.start_m = odom_m();  // the end for now; the start is end - length below
    e.end_truth = sim->ground_truth_pose();
    taught.push_back(std::move(e));
  });
  cli::ProgressLine progress;
  RunOptions ro;
  ro.after_tick = [&](const TickInfo& t) {
    samples.push_back({odom_m(), sim->ground_truth_pose()});
    progress.show("teach", std::min(t.t_s, 599.0), 600.0, "s simulated");
    return t.t_s < 3600.0;
  };
  const RunReport report = run_tree(**session, *tree, ro);
  progress.end();
  if (report.outcome != RunOutcome::success) return fail("teaching failed: " + report.reason);
  for (auto& e : taught) {
    const EdgeRecord* rec = (*session)->map()->find_edge(e.id);
    if (rec == nullptr) return fail("taught edge '" + e.id + "' is not in the map");
    e.length_m = rec->length_m;
    e.kind = rec->kind;
    e.start_m -= rec->length_m;
  }
  std::printf("taught %zu %s edges, %.1f m (odometric), %.0f s wall\n", taught.size(), o.kind.c_str(),
              (*session)->map()->stats().total.length_m, report.wall_time_s);
  return ok();
}

/// The tallies of all trials.
struct Tally {
  // Per kind of the edge the robot stood on: correct, refused, wrong.
  std::map<std::string, std::array<int, 3>> by_kind;
  int correct = 0, wrong = 0, ambiguous = 0, not_on_map = 0, blocked = 0, other = 0;
  int replays_run = 0, replays_completed = 0;
  double relocalise_wall_s = 0.0;
  std::vector<double> along_errors;
};

/// The random start poses and error-model seeds of the trials.
struct Draws {
  std::mt19937_64 rng;
  std::uniform_real_distribution<double> along, unit;
};

/// A trial's start: a taught point (not in a gap between edges), its edge k and distance along
/// the teach run, and the sideways and heading offsets from it.
struct TrialStart {
  double at_m = 0.0;
  std::size_t k = 0;
  double lateral_m = 0.0;
  double heading_rad = 0.0;
  Pose2D start;
};

TrialStart draw_start(const Options& o, const std::vector<TeachSample>& samples, const std::vector<TaughtEdge>& taught,
                      Draws& draws) {
  auto& rng = draws.rng;
  TrialStart s;
  // A taught point (not in a gap between edges), its edge and distance along it.
  double at_m = draws.along(rng);
  std::size_t k = 0;
  for (int tries = 0; tries < 100; ++tries) {
    auto it = std::find_if(taught.begin(), taught.end(), [&](const TaughtEdge& e) {
      return at_m >= e.start_m && at_m <= e.start_m + e.length_m;
    });
    if (it != taught.end()) {
      k = static_cast<std::size_t>(it - taught.begin());
      break;
    }
    at_m = draws.along(rng);
  }
  const auto sample = std::min_element(samples.begin(), samples.end(), [&](const TeachSample& a, const TeachSample& b) {
    return std::abs(a.odom_m - at_m) < std::abs(b.odom_m - at_m);
  });
  const double lateral_m = o.lateral_m * draws.unit(rng);
  const double heading_rad = o.heading_deg * std::numbers::pi / 180.0 * draws.unit(rng);
  Pose2D start = sample->truth;
  start.x_m += -std::sin(start.heading_rad) * lateral_m;
  start.y_m += std::cos(start.heading_rad) * lateral_m;
  start.heading_rad += heading_rad;
  s.at_m = at_m;
  s.k = k;
  s.lateral_m = lateral_m;
  s.heading_rad = heading_rad;
  s.start = start;
  return s;
}

/// Relocalise alone, or the whole replay_from_here tree (its Relocalise given the experiment's
/// look_around_deg and creep_m) for the trials that replay. Returns the file written.
fs::path write_trial_tree(const Options& o, const fs::path& dir, bool replay) {
  const fs::path reloc_xml = dir / (replay ? "replay_from_here.xml" : "relocalise.xml");
  if (!replay) {
    std::ofstream(reloc_xml) << "<root BTCPP_format=\"4\" main_tree_to_execute=\"R\"><BehaviorTree ID=\"R\">\n"
                                "  <Relocalise look_around_deg=\"" << o.look_around_deg << "\" creep_m=\"" << o.creep_m
                             << "\"" << o.reloc_attrs << " edge=\"{reloc_edge}\" distance_m=\"{reloc_distance_m}\" "
                                "status=\"{reloc_status}\" reason=\"{reloc_reason}\"/>\n</BehaviorTree></root>\n";
  } else {
    std::ifstream in(project_file("trees/replay_from_here.xml"));
    std::string xml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    // Drop the tree's own settings of the attributes the experiment sets, then set them.
    xml = std::regex_replace(xml, std::regex(" (" + o.reloc_names + ")=\"[^\"]*\""), "");
    std::ostringstream attrs;
    attrs << "<Relocalise look_around_deg=\"" << o.look_around_deg << "\" creep_m=\"" << o.creep_m << "\""
          << o.reloc_attrs << " ";
    xml = std::regex_replace(xml, std::regex(R"(<Relocalise\s)"), attrs.str());
    std::ofstream(reloc_xml) << xml;
  }
  return reloc_xml;
}

/// The truth at the answer: the taught sample nearest the robot then (within a few metres of
/// the start along the route), plus the remainder projected on its heading.
double truth_at_answer(const Options& o, const std::vector<TeachSample>& samples, double at_m, const Pose2D& at_answer) {
  double truth_at_m = at_m;
  const TeachSample* near = nullptr;
  double near_d = 1e9;
  for (const TeachSample& s : samples) {
    if (std::abs(s.odom_m - at_m) > o.creep_m + 3.0) continue;
    const double dd = std::hypot(s.truth.x_m - at_answer.x_m, s.truth.y_m - at_answer.y_m);
    if (dd < near_d) {
      near_d = dd;
      near = &s;
    }
  }
  if (near != nullptr)
    truth_at_m = near->odom_m + (at_answer.x_m - near->truth.x_m) * std::cos(near->truth.heading_rad) +
                 (at_answer.y_m - near->truth.y_m) * std::sin(near->truth.heading_rad);
  return truth_at_m;
}

/// correct, wrong, refused or error for Relocalise's answer (status, edge, d) when the robot
/// stood truth_d along taught[k_now]; counts it and sets the along-track error.
std::string judge(const std::string& status, const std::string& edge, double d, const std::vector<TaughtEdge>& taught,
                  std::size_t k_now, double truth_d, Tally& tally, double& along_error_m) {
  const TaughtEdge& truth_edge = taught[k_now];
  const std::size_t next_now = (k_now + 1) % taught.size();
  std::string verdict;
  if (status == "localised") {
    // The same spot may be named on either side of a node.
    std::optional<double> error;
    if (edge == truth_edge.id) error = d - truth_d;
    if (k_now > 0 && edge == taught[k_now - 1].id) error = -((taught[k_now - 1].length_m - d) + truth_d);
    if (k_now == 0 && edge == taught.back().id) error = -((taught.back().length_m - d) + truth_d);
    if (edge == taught[next_now].id) error = (truth_edge.length_m - truth_d) + d;
    if (error && std::abs(*error) <= 1.0) {
      verdict = "correct";
      ++tally.correct;
      along_error_m = *error;
      tally.along_errors.push_back(std::abs(*error));
    } else {
      verdict = "wrong";
      ++tally.wrong;
      along_error_m = error ? *error : std::nan("");
    }
  } else if (status == "ambiguous") {
    verdict = "refused";
    ++tally.ambiguous;
  } else if (status == "not_on_map") {
    verdict = "refused";
    ++tally.not_on_map;
  } else if (status == "camera_blocked") {
    verdict = "refused";
    ++tally.blocked;
  } else {
    verdict = "error";
    ++tally.other;
  }
  return verdict;
}

/// One trial: a fresh session at a drawn start, Relocalise (and for the first correctly
/// localised trials the replay from there), its row in trials.csv and its line on stdout.
Status run_trial(const Context& c, int trial, const std::vector<TeachSample>& samples,
                 const std::vector<TaughtEdge>& taught, const std::vector<std::string>& appearance, Draws& draws,
                 std::ofstream& csv, Tally& tally) {
  const Options& o = c.o;
  const TrialStart ts = draw_start(o, samples, taught, draws);
  const double at_m = ts.at_m;
  const std::size_t k = ts.k;
  const double lateral_m = ts.lateral_m;
  const double heading_rad = ts.heading_rad;
  const Pose2D start = ts.start;
  std::ostringstream pose;
  pose.precision(10);
  pose << start.x_m << ';' << start.y_m << ';' << start.heading_rad * 180.0 / std::numbers::pi;
  std::vector<std::string> overrides = {"robot.params.start_pose=" + pose.str(),
                                        "robot.params.seed=" + std::to_string(o.seed * 100000 + trial * 10 + 2),
                                        "camera.params.seed=" + std::to_string(o.seed * 100000 + trial * 10 + 3)};
  overrides.insert(overrides.end(), appearance.begin(), appearance.end());
  auto session = c.session_for(overrides, c.map_dir.string());
  if (!session) return session.error();
  const bool replay = tally.replays_run < o.replays;
  const fs::path reloc_xml = write_trial_tree(o, c.dir, replay);
  auto tree = (*session)->load_tree(reloc_xml.string());
  if (!tree) return tree.error();
  // The goal of a replay: the end node of the edge after the one the robot is on.
  const std::size_t next = (k + 1) % taught.size();
  std::string goal_node;
  if (const EdgeRecord* rec = (*session)->map()->find_edge(taught[next].id)) goal_node = rec->to;
  tree->blackboard().set("goal", goal_node);
  // Relocalise's own wall time: from the first tick to its answer.
  // Where the robot is when it answers (it may have crept forward): the ground truth then.
  std::optional<std::chrono::steady_clock::time_point> t_answer;
  SimulationControl* sim = (*session)->robot().simulation();
  Pose2D at_answer = start;
  const auto t0 = std::chrono::steady_clock::now();
  tree->add_observer([&](double, const bt::TreeNode& node, bt::NodeStatus, bt::NodeStatus to) {
    if (node.registration_id() == "Relocalise" && (to == bt::NodeStatus::success || to == bt::NodeStatus::failure)) {
      t_answer = std::chrono::steady_clock::now();
      if (sim != nullptr) at_answer = sim->ground_truth_pose();
    }
  });
  RunOptions ro;
  ro.after_tick = [&](const TickInfo& t) { return t.t_s < 400.0; };
  const RunReport report = run_tree(**session, *tree, ro);
  const double wall_s = std::chrono::duration<double>((t_answer ? *t_answer : std::chrono::steady_clock::now()) - t0).count();
  tally.relocalise_wall_s += wall_s;
  auto bb = [&](const char* key) {
    auto v = tree->blackboard().get<std::string>(key);
    return v ? *v : std::string();
  };
  const double truth_at_m = truth_at_answer(o, samples, at_m, at_answer);
  std::size_t k_now = k;
  for (std::size_t i = 0; i < taught.size(); ++i)
    if (truth_at_m >= taught[i].start_m && truth_at_m <= taught[i].start_m + taught[i].length_m) k_now = i;
  const TaughtEdge& truth_edge = taught[k_now];
  const double truth_d = truth_at_m - truth_edge.start_m;
  const std::string status = bb("reloc_status");
  const std::string edge = bb("reloc_edge");
  const double d = tree->blackboard().get<double>("reloc_distance_m").value_or(-1.0);
  double along_error_m = 0.0;
  const std::string verdict = judge(status, edge, d, taught, k_now, truth_d, tally, along_error_m);
  std::string replay_result = "-";
  if (replay && verdict == "correct") {
    ++tally.replays_run;
    const Pose2D end = sim->ground_truth_pose();
    const double miss_m = std::hypot(end.x_m - taught[next].end_truth.x_m, end.y_m - taught[next].end_truth.y_m);
    const bool done = report.outcome == RunOutcome::success && miss_m <= 1.0;
    tally.replays_completed += done ? 1 : 0;
    replay_result = std::string(done ? "completed" : "failed") + " (" + fixed(miss_m, 2) + " m from node " + goal_node +
                    (report.outcome == RunOutcome::success ? "" : ": " + report.reason) + ")";
  }
  csv << trial << ',' << truth_edge.id << ',' << fixed(truth_d, 3) << ',' << fixed(lateral_m, 3) << ','
      << fixed(heading_rad * 180.0 / std::numbers::pi, 1) << ',' << status << ',' << edge << ',' << fixed(d, 3) << ','
      << fixed(along_error_m, 3) << ',' << verdict << ','
      << fixed(tree->blackboard().get<double>("reloc_confidence").value_or(0.0), 3) << ',' << fixed(wall_s, 3) << ",\"" << replay_result << "\"," << truth_edge.kind << "\n";
  auto& kind_tally = tally.by_kind[truth_edge.kind];
  ++kind_tally[verdict == "correct" ? 0 : verdict == "wrong" ? 2 : 1];
  std::printf("trial %3d: truth %s at %5.2f m (lateral %+.2f m, heading %+5.1f deg): %-14s %s %s -> %s%s%s\n", trial + 1,
              truth_edge.id.c_str(), truth_d, lateral_m, heading_rad * 180.0 / std::numbers::pi, status.c_str(),
              edge.c_str(), status == "localised" ? fixed(d, 2).c_str() : "", verdict.c_str(),
              replay_result == "-" ? "" : ", replay ", replay_result == "-" ? "" : replay_result.c_str());
  std::fflush(stdout);
  return ok();
}

/// The rates over all trials.
void print_summary(const Options& o, const fs::path& dir, Tally& tally) {
  const double n = o.trials;
  std::sort(tally.along_errors.begin(), tally.along_errors.end());
  const double median_m = tally.along_errors.empty() ? 0.0 : tally.along_errors[tally.along_errors.size() / 2];
  const int correct = tally.correct, wrong = tally.wrong, ambiguous = tally.ambiguous, not_on_map = tally.not_on_map,
            blocked = tally.blocked, other = tally.other;
  std::printf("\nroute %s, appearance %s, %d trials (lateral +-%.2f m, heading +-%.0f deg):\n", o.route.c_str(),
              o.appearance.c_str(), o.trials, o.lateral_m, o.heading_deg);
  std::printf("  correct %d (%.1f %%), median |along-track error| %.2f m\n", correct, 100.0 * correct / n, median_m);
  std::printf("  refused %d (%.1f %%): ambiguous %d, not_on_map %d, camera_blocked %d\n", ambiguous + not_on_map + blocked,
              100.0 * (ambiguous + not_on_map + blocked) / n, ambiguous, not_on_map, blocked);
  std::printf("  wrong %d (%.1f %%)%s\n", wrong, 100.0 * wrong / n, other > 0 ? (", errors " + std::to_string(other)).c_str() : "");
  std::printf("  relocalise wall time %.2f s per trial (frames + on-demand index build in the first)\n",
              tally.relocalise_wall_s / n);
  if (o.replays > 0) std::printf("  replays from there completed %d of %d\n", tally.replays_completed, tally.replays_run);
  for (const auto& [kind, t] : tally.by_kind)
    std::printf("  starts on %s edges: %d: correct %d, refused %d, wrong %d\n", kind.c_str(), t[0] + t[1] + t[2], t[0],
                t[1], t[2]);
  std::printf("  per trial: %s\n", (dir / "trials.csv").string().c_str());
}

}  // namespace

int run_reloc_experiment(int argc, char** argv, HostServices& host) {
  (void)host;
  if (cli::print_help_if_asked(argc, argv, kUsage)) return 0;
  auto parsed = parse(argc, argv);
  if (!parsed) return cli::usage_error("reloc-experiment", parsed.error().message, kUsage);
  const Options o = *parsed;
  const fs::path dir(o.out);
  std::error_code ec;
  fs::create_directories(dir, ec);
  FileLogger logger(dir / "run.log");
  const Context c{o, dir, logger, project_file(o.config), project_file("config/routes/" + o.route + ".yaml"), dir / "map"};
  auto setup_error = [](const std::string& m) {
    std::fprintf(stderr, "reloc-experiment: %s\n", m.c_str());
    return 1;
  };

  fs::remove_all(c.map_dir, ec);
  std::vector<TeachSample> samples;
  std::vector<TaughtEdge> taught;
  if (auto st = teach(c, samples, taught); !st) return setup_error(st.error().message);
  if (taught.empty() || samples.empty()) return setup_error("nothing was taught");

  // --- trials
  std::mt19937_64 rng(static_cast<std::uint64_t>(o.seed) * 7919u + 17u);
  const double lo = taught.front().start_m;
  const double hi = taught.back().start_m + taught.back().length_m;
  Draws draws{rng, std::uniform_real_distribution<double>(lo, hi), std::uniform_real_distribution<double>(-1.0, 1.0)};
  auto appearance = appearance_overrides(o.appearance);
  std::ofstream csv(dir / "trials.csv");
  csv << "trial,truth_edge,truth_distance_m,lateral_m,heading_deg,status,edge,distance_m,along_error_m,verdict,"
         "confidence,relocalise_wall_s,replay,truth_kind\n";
  Tally tally;
  for (int trial = 0; trial < o.trials; ++trial)
    if (auto st = run_trial(c, trial, samples, taught, *appearance, draws, csv, tally); !st)
      return setup_error(st.error().message);
  print_summary(o, dir, tally);
  return 0;
}

}  // namespace visnav::relocexp
