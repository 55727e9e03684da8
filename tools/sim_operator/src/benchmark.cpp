#include "benchmark.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "sim_session_util.hpp"
#include "visnav/command_line.hpp"
#include "visnav/file_io.hpp"
#include "visnav/runner.hpp"
#include "visnav_sim/generate.hpp"

namespace visnav::simop {
namespace {

namespace fs = std::filesystem;

const char* kUsage =
    "usage: visnav benchmark [--worlds N] [--first-world W] [--seeds S] [--seed K] [--loops L]\n"
    "                        [--maps hybrid,feature] [--jobs J] [--out DIR] [--fresh]\n"
    "                        [--obstacles auto|yes|no] [--kind any|indoor|outdoor|mixed]\n"
    "                        [--displace M[,DEG]] [--radius M] [--config FILE] [--set k=v]... [--port N.p=v]...\n"
    "the experiment of `visnav experiment` over generated worlds (`visnav sim generate`): per world\n"
    "seed W..W+N-1, map kind and run seed K..K+S-1, teach the world's closed route with every error\n"
    "model of the config on, displace the robot at the start, replay the loop L times; obstacles\n"
    "stand on the route in the replays of the worlds that have an obstacle file (--obstacles auto:\n"
    "every third world seed), where the avoiding tree drives. Failures count as failures.\n"
    "  --worlds N        number of generated worlds (default 20)\n"
    "  --first-world W   first world seed (default 2001: held out; 1-20 and 1001-1020 are the\n"
    "                    development worlds the defaults were chosen on, docs/benchmark.md)\n"
    "  --seeds S         runs per world and map kind (default 3), from --seed K (default 1)\n"
    "  --loops L         replayed loops per run (default 2)\n"
    "  --maps LIST       map kinds: hybrid (the route's feature/path legs), feature (every leg\n"
    "                    feature-based), path (default hybrid,feature)\n"
    "  --jobs J          parallel runs (default: the number of cores)\n"
    "  --out DIR         output folder (default out/benchmark): worlds/, runs/, runs.csv,\n"
    "                    report.md (the tables), benchmark.png (loop errors per world)\n"
    "  --fresh           run every run again (default: resume, skipping runs with a result file)\n"
    "  --obstacles MODE  obstacle files of the generator: auto, yes (every world with room), no\n"
    "  --kind K          only worlds of this kind (default any: drawn per seed)\n"
    "  --displace M[,D]  start displacement: metres to the left, degrees (default 1,10)\n"
    "  --radius M        success radius of a loop end (default 1)\n"
    "  --config FILE     run config (default config/sim_experiment.yaml: error models on)\n"
    "  --set k=v         config override for teach and replay (repeatable)\n"
    "  --port N.p=v      port override in the replay trees (repeatable)\n"
    "exit status 0 when every loop completed, 1 otherwise or on a setup error, 2 on bad options.\n";

Result<BenchmarkOptions> parse(int argc, char** argv) {
  BenchmarkOptions o;
  for (OptionReader in(argc, argv); in.next();) {
    const std::string& arg = in.arg();
    if (arg == "--worlds") { VISNAV_ASSIGN(double n, in.number(1, 1000)); o.worlds = static_cast<int>(n); }
    else if (arg == "--first-world") { VISNAV_ASSIGN(double n, in.number(0, 1e8)); o.first_world = static_cast<int>(n); }
    else if (arg == "--seeds") { VISNAV_ASSIGN(double n, in.number(1, 100)); o.seeds = static_cast<int>(n); }
    else if (arg == "--seed") { VISNAV_ASSIGN(double n, in.number(0, 1000000)); o.first_seed = static_cast<int>(n); }
    else if (arg == "--loops") { VISNAV_ASSIGN(double n, in.number(1, 100)); o.loops = static_cast<int>(n); }
    else if (arg == "--jobs") { VISNAV_ASSIGN(double n, in.number(1, 64)); o.jobs = static_cast<int>(n); }
    else if (arg == "--radius") { VISNAV_ASSIGN(o.success_radius_m, in.number(0.01, 100)); }
    else if (arg == "--out") { VISNAV_ASSIGN(o.out, in.value()); }
    else if (arg == "--config") { VISNAV_ASSIGN(o.config, in.value()); }
    else if (arg == "--fresh") { o.fresh = true; }
    else if (arg == "--set") { VISNAV_ASSIGN(std::string v, in.value()); o.overrides.push_back(v); }
    else if (arg == "--port") {
      VISNAV_ASSIGN(std::string v, in.value());
      VISNAV_TRY(bt::parse_port_override(v));
      o.replay_ports.push_back(v);
    }
    else if (arg == "--obstacles") {
      VISNAV_ASSIGN(o.obstacles, in.value());
      if (o.obstacles != "auto" && o.obstacles != "yes" && o.obstacles != "no")
        return fail("--obstacles: '" + o.obstacles + "' is not auto, yes or no");
    }
    else if (arg == "--kind") {
      VISNAV_ASSIGN(o.kind, in.value());
      if (o.kind != "any" && o.kind != "indoor" && o.kind != "outdoor" && o.kind != "mixed")
        return fail("--kind: '" + o.kind + "' is not any, indoor, outdoor or mixed");
    }
    else if (arg == "--displace") {
      VISNAV_ASSIGN(std::string v, in.value());
      VISNAV_TRY(parse_displacement(v, o.displace_m, o.displace_heading_deg));
    }
    else if (arg == "--maps") {
      VISNAV_ASSIGN(std::string v, in.value());
      VISNAV_ASSIGN(o.maps, parse_map_kinds(v));
    } else {
      return fail("unknown option '" + arg + "'");
    }
  }
  return o;
}

/// Tabs and newlines in free text would break the result file's lines.
std::string one_line(std::string text) {
  for (char& c : text)
    if (c == '\t' || c == '\n' || c == '\r') c = ' ';
  return text;
}

// result.tsv: "key<TAB>value" lines, then one "loop<TAB>n<TAB>finished<TAB>completed<TAB>error_m<TAB>failure"
// line per loop. Written last and renamed into place, so its presence means the run finished.
Status write_result(const BenchmarkRun& r, const fs::path& file) {
  const fs::path tmp = file.string() + ".tmp";
  {
    std::ofstream out(tmp);
    out << std::setprecision(10) << "format\tvisnav-benchmark-run 1\nworld\t" << r.world << "\nworld_kind\t" << r.world_kind
        << "\nworld_seed\t" << r.world_seed << "\nmap\t" << r.map << "\nseed\t" << r.seed << "\nobstacles\t" << r.obstacles
        << "\nroute_length_m\t" << r.route_length_m << "\nsetup_error\t" << one_line(r.setup_error) << "\ncollisions\t"
        << r.collisions << "\nlost_stops\t" << r.lost_stops << "\nstop_reason\t" << one_line(r.stop_reason) << "\naccuracy_m\t"
        << r.metrics.accuracy_m << "\nrepeatability_m\t" << r.metrics.repeatability_m << "\nwall_s\t" << r.wall_s << "\n";
    for (const auto& l : r.loops)
      out << "loop\t" << l.loop << "\t" << l.finished << "\t" << l.completed << "\t" << l.error_m << "\t" << one_line(l.failure) << "\n";
    if (!out) return fail("cannot write '" + tmp.string() + "'");
  }
  std::error_code ec;
  fs::rename(tmp, file, ec);
  if (ec) return fail("cannot rename '" + tmp.string() + "': " + ec.message());
  return ok();
}

/// Reads a result file of an earlier invocation; an unreadable or foreign file is an error (the
/// run is then run again, and the reason is printed).
Result<BenchmarkRun> read_result(const fs::path& file) {
  VISNAV_ASSIGN(const std::string text, read_text_file(file.string(), 1 << 20, "benchmark result"));
  BenchmarkRun r;
  std::istringstream in(text);
  int line_no = 0;
  bool format_ok = false;
  for (std::string line; std::getline(in, line);) {
    ++line_no;
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string part; std::getline(ss, part, '\t');) f.push_back(part);
    if (line.back() == '\t') f.emplace_back();
    if (f.size() < 2) return fail(file.string() + ":" + std::to_string(line_no) + ": expected key<TAB>value");
    auto number = [&](const std::string& s) -> Result<double> {
      return parse_number(s, -1e12, 1e12, file.string() + ":" + std::to_string(line_no) + " '" + f[0] + "'");
    };
    const std::string& k = f[0];
    if (k == "format") format_ok = f[1] == "visnav-benchmark-run 1";
    else if (k == "world") r.world = f[1];
    else if (k == "world_kind") r.world_kind = f[1];
    else if (k == "world_seed") { VISNAV_ASSIGN(double v, number(f[1])); r.world_seed = static_cast<int>(v); }
    else if (k == "map") r.map = f[1];
    else if (k == "seed") { VISNAV_ASSIGN(double v, number(f[1])); r.seed = static_cast<int>(v); }
    else if (k == "obstacles") { VISNAV_ASSIGN(double v, number(f[1])); r.obstacles = static_cast<int>(v); }
    else if (k == "route_length_m") { VISNAV_ASSIGN(r.route_length_m, number(f[1])); }
    else if (k == "setup_error") r.setup_error = f[1];
    else if (k == "collisions") { VISNAV_ASSIGN(double v, number(f[1])); r.collisions = static_cast<int>(v); }
    else if (k == "lost_stops") { VISNAV_ASSIGN(double v, number(f[1])); r.lost_stops = static_cast<int>(v); }
    else if (k == "stop_reason") r.stop_reason = f[1];
    else if (k == "accuracy_m") { VISNAV_ASSIGN(r.metrics.accuracy_m, number(f[1])); }
    else if (k == "repeatability_m") { VISNAV_ASSIGN(r.metrics.repeatability_m, number(f[1])); }
    else if (k == "wall_s") { VISNAV_ASSIGN(r.wall_s, number(f[1])); }
    else if (k == "loop") {
      if (f.size() < 6) return fail(file.string() + ":" + std::to_string(line_no) + ": a loop line has 6 fields");
      LoopOutcome l;
      VISNAV_ASSIGN(double n, number(f[1]));
      l.loop = static_cast<int>(n);
      l.finished = f[2] == "1";
      l.completed = f[3] == "1";
      VISNAV_ASSIGN(l.error_m, number(f[4]));
      l.failure = f[5];
      r.loops.push_back(std::move(l));
    } else {
      return fail(file.string() + ":" + std::to_string(line_no) + ": unknown key '" + k + "'");
    }
  }
  if (!format_ok) return fail(file.string() + ": not a visnav benchmark result (format line missing)");
  r.resumed = true;
  return r;
}

struct WorldFiles {
  sim::GeneratedWorld generated;
  std::string world_path, route_path, obstacles_path;
};

/// Writes a generated world unless the same text is already there (keeps the top view).
Result<WorldFiles> prepare_world(const BenchmarkOptions& o, int seed) {
  sim::GenerateParams gp;
  gp.seed = seed;
  gp.kind = o.kind;
  gp.obstacles = o.obstacles;
  VISNAV_ASSIGN(sim::GeneratedWorld g, sim::generate_world(gp));
  const fs::path dir = fs::path(o.out) / "worlds";
  WorldFiles f;
  f.world_path = (dir / (g.name + ".yaml")).string();
  f.route_path = (dir / (g.name + "_route.yaml")).string();
  if (!g.obstacles_yaml.empty()) f.obstacles_path = (dir / (g.name + "_obstacles.yaml")).string();
  auto same = [](const std::string& path, const std::string& text) {
    auto existing = read_text_file(path, 1 << 24, "world");
    return existing && *existing == text;
  };
  const bool up_to_date = same(f.world_path, g.world_yaml) && same(f.route_path, g.route_yaml) &&
                          (g.obstacles_yaml.empty() || same(f.obstacles_path, g.obstacles_yaml)) &&
                          fs::exists(dir / (g.name + "_top.png"));
  if (!up_to_date) VISNAV_TRY(sim::write_generated_world(g, dir.string()));
  f.generated = std::move(g);
  return f;
}

ExperimentOptions experiment_options(const BenchmarkOptions& o, const WorldFiles& w) {
  ExperimentOptions e;
  e.world = w.world_path;
  e.route = w.route_path;
  e.loops = o.loops;
  e.displace_m = o.displace_m;
  e.displace_heading_deg = o.displace_heading_deg;
  e.success_radius_m = o.success_radius_m;
  e.config = o.config;
  e.overrides = o.overrides;
  e.replay_ports = o.replay_ports;
  e.progress = false;
  if (!w.obstacles_path.empty()) {
    e.replay_overrides.push_back("robot.params.obstacles=" + w.obstacles_path);
    e.obstacles = true;
  }
  return e;
}

/// Progress of all runs on one line: metres driven (teach + loops) of the planned total.
class BenchProgress {
 public:
  BenchProgress(std::vector<double> work_m, bool enabled) : done_m_(work_m.size(), 0.0), work_m_(std::move(work_m)), enabled_(enabled) {}
  void update(std::size_t job, double done_m) {
    std::lock_guard lock(mutex_);
    done_m_[job] = std::min(done_m, work_m_[job]);
    draw_locked();
  }
  void finished(std::size_t job) {
    std::lock_guard lock(mutex_);
    done_m_[job] = work_m_[job];
    ++finished_;
    draw_locked();
  }
  void end() {
    std::lock_guard lock(mutex_);
    if (enabled_) line_.end();
  }

 private:
  void draw_locked() {
    if (!enabled_) return;
    double done = 0.0, total = 0.0;
    for (std::size_t i = 0; i < work_m_.size(); ++i) { done += done_m_[i]; total += work_m_[i]; }
    line_.show("runs " + std::to_string(finished_) + "/" + std::to_string(work_m_.size()), done / 1000.0, total / 1000.0, "km");
  }
  std::mutex mutex_;
  std::vector<double> done_m_, work_m_;
  bool enabled_;
  int finished_ = 0;
  ProgressLine line_{14};
};

struct Group {
  int runs = 0, attempted = 0, completed = 0, collisions = 0, encounters = 0, lost = 0, setup = 0;
  std::vector<double> accuracy, repeatability;
  std::map<std::string, int> failures;
};

void add(Group& g, const BenchmarkRun& r) {
  ++g.runs;
  g.collisions += r.collisions;
  g.encounters += r.encounters();
  g.lost += r.lost_stops;
  if (!r.setup_error.empty()) ++g.setup;
  bool any_finished = false;
  for (const auto& l : r.loops) {
    ++g.attempted;
    if (l.completed) ++g.completed;
    else ++g.failures[failure_class(r, l)];
    any_finished = any_finished || l.finished;
  }
  if (r.setup_error.empty() && r.loops.empty()) ++g.failures["setup"];
  if (any_finished) {
    g.accuracy.push_back(r.metrics.accuracy_m);
    g.repeatability.push_back(r.metrics.repeatability_m);
  }
}

std::string percent(int part, int whole) { return whole > 0 ? fixed(100.0 * part / whole, 1) + " %" : "–"; }

std::string failures_text(const Group& g) {
  std::string s;
  for (const auto& [k, n] : g.failures) {
    if (!s.empty()) s += ", ";
    s += k;
    s += ' ';
    s += std::to_string(n);
  }
  return s.empty() ? "none" : s;
}

cv::Mat draw_benchmark(const BenchmarkOptions& o, const std::vector<BenchmarkRun>& runs) {
  const int per_world = static_cast<int>(o.maps.size());
  const int w = std::max(720, 90 + o.worlds * per_world * 14 + 40), h = 460, left = 60, bottom = 70, top = 60, right = 20;
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  double max_err = 0.2;
  for (const auto& r : runs)
    for (const auto& l : r.loops)
      if (l.finished) max_err = std::max(max_err, std::min(l.error_m, o.success_radius_m * 1.5));
  const double plot_w = w - left - right, plot_h = h - top - bottom;
  auto px = [&](double world_index, double err) {
    return cv::Point(static_cast<int>(left + (world_index + 0.5) / o.worlds * plot_w),
                     static_cast<int>(top + plot_h - std::min(err, max_err) / max_err * plot_h));
  };
  cv::rectangle(img, cv::Point(left, top), cv::Point(w - right, h - bottom), cv::Scalar(0, 0, 0), 1);
  for (int k = 0; k <= 4; ++k) {
    const double e = max_err * k / 4.0;
    const cv::Point p = px(-0.5, e);
    cv::line(img, cv::Point(left, p.y), cv::Point(w - right, p.y), cv::Scalar(225, 225, 225), 1);
    cv::putText(img, fixed(e, 2), cv::Point(8, p.y + 4), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1);
  }
  const cv::Scalar colours[] = {{200, 90, 0}, {0, 140, 255}, {60, 160, 60}};
  for (const auto& r : runs) {
    const int wi = r.world_seed - o.first_world;
    const auto mi = static_cast<int>(std::find(o.maps.begin(), o.maps.end(), r.map) - o.maps.begin());
    const double x = wi + (mi - (per_world - 1) / 2.0) * 0.25;
    const cv::Scalar c = colours[mi % 3];
    for (const auto& l : r.loops) {
      if (l.completed) cv::circle(img, px(x, l.error_m), 3, c, -1, cv::LINE_AA);
      else {
        const cv::Point p = px(x, l.finished ? l.error_m : max_err);
        cv::drawMarker(img, p, cv::Scalar(0, 0, 220), cv::MARKER_TILTED_CROSS, 9, 2);
      }
    }
  }
  for (int wi = 0; wi < o.worlds; ++wi) {
    const cv::Point p = px(wi, 0);
    const bool obstacles = std::any_of(runs.begin(), runs.end(), [&](const BenchmarkRun& r) { return r.world_seed - o.first_world == wi && r.obstacles > 0; });
    cv::putText(img, std::to_string(o.first_world + wi) + (obstacles ? "*" : ""), cv::Point(p.x - 12, h - bottom + 16 + (wi % 2) * 14),
                cv::FONT_HERSHEY_SIMPLEX, 0.35, cv::Scalar(0, 0, 0), 1);
  }
  cv::putText(img, "loop-end error [m] per generated world (* obstacles); x = failed loop", cv::Point(left, 22),
              cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1);
  for (std::size_t i = 0; i < o.maps.size(); ++i) {
    const cv::Point at(left + static_cast<int>(i) * 110, 44);
    cv::circle(img, at, 4, colours[i % 3], -1, cv::LINE_AA);
    cv::putText(img, o.maps[i], at + cv::Point(8, 4), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1);
  }
  cv::putText(img, "world seed", cv::Point(w / 2 - 30, h - 12), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1);
  return img;
}

}  // namespace

int BenchmarkRun::encounters() const {
  if (obstacles == 0) return 0;
  int driven = 0;
  for (const auto& l : loops) driven += l.finished ? 1 : 0;
  if (driven < static_cast<int>(loops.size()) && setup_error.empty()) ++driven;  // stopped inside this loop
  return obstacles * driven;
}

std::string failure_class(const BenchmarkRun& r, const LoopOutcome& l) {
  if (l.completed) return "";
  if (!r.setup_error.empty()) return "setup";
  if (l.finished) return "outside radius";
  if (l.failure.rfind("not driven", 0) == 0) return "not driven";
  if (l.failure.find("collision") != std::string::npos) return "collision";
  if (r.lost_stops > 0 || l.failure.find("lost") != std::string::npos) return "lost";
  return "other";
}

std::string benchmark_table(const BenchmarkOptions& o, const std::vector<BenchmarkRun>& runs) {
  std::ostringstream t;
  t << "| map | obstacles | runs | loops completed | ε_acc mean ± sd [m] | ε_acc worst | ε_rep mean ± sd | collisions / "
       "encounters | lost stops | failed loops by reason |\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& map : o.maps)
    for (int with : {0, 1}) {
      Group g;
      for (const auto& r : runs)
        if (r.map == map && (r.obstacles > 0) == (with == 1)) add(g, r);
      if (g.runs == 0) continue;
      const Spread a = spread(g.accuracy), p = spread(g.repeatability);
      t << "| " << map << " | " << (with ? "yes" : "no") << " | " << g.runs << " | " << g.completed << "/" << g.attempted << " ("
        << percent(g.completed, g.attempted) << ") | " << (a.count ? fixed(a.mean) + " ± " + fixed(a.sd) : "–") << " | "
        << (a.count ? fixed(a.worst) : "–") << " | " << (p.count ? fixed(p.mean) + " ± " + fixed(p.sd) : "–") << " | "
        << g.collisions << " / " << g.encounters << " | " << g.lost << " | " << failures_text(g) << " |\n";
    }
  // completion per world kind
  t << "\n| map | indoor | outdoor | mixed |\n|---|---|---|---|\n";
  for (const auto& map : o.maps) {
    t << "| " << map;
    for (const char* kind : {"indoor", "outdoor", "mixed"}) {
      Group g;
      for (const auto& r : runs)
        if (r.map == map && r.world_kind == kind) add(g, r);
      t << " | " << (g.attempted ? std::to_string(g.completed) + "/" + std::to_string(g.attempted) : "–");
    }
    t << " |\n";
  }
  return t.str();
}

namespace {

/// The generated worlds of the benchmark, in seed order.
Result<std::vector<WorldFiles>> prepare_worlds(const BenchmarkOptions& o) {
  std::vector<WorldFiles> worlds;
  ProgressLine line(14);
  for (int k = 0; k < o.worlds; ++k) {
    VISNAV_ASSIGN(WorldFiles w, prepare_world(o, o.first_world + k));
    worlds.push_back(std::move(w));
    if (o.progress) line.show("worlds", k + 1, o.worlds, "worlds");
  }
  if (o.progress) line.end();
  return worlds;
}

/// One (world, map kind, run seed) of the benchmark and its folder.
struct BenchmarkJob {
  std::size_t world;
  std::string map;
  int seed;
  fs::path dir;
};

/// Every job, its result row (named, not yet run) and its work in metres, in one order.
void plan_jobs(const BenchmarkOptions& o, const std::vector<WorldFiles>& worlds, std::vector<BenchmarkJob>& jobs,
               std::vector<BenchmarkRun>& runs, std::vector<double>& work) {
  for (std::size_t w = 0; w < worlds.size(); ++w)
    for (const auto& map : o.maps)
      for (int s = 0; s < o.seeds; ++s) {
        const int seed = o.first_seed + s;
        jobs.push_back({w, map, seed, fs::path(o.out) / "runs" / worlds[w].generated.name / map / ("seed" + std::to_string(seed))});
        BenchmarkRun r;
        r.world = worlds[w].generated.name;
        r.world_kind = worlds[w].generated.kind;
        r.world_seed = o.first_world + static_cast<int>(w);
        r.map = map;
        r.seed = seed;
        r.obstacles = worlds[w].generated.obstacles;
        r.route_length_m = worlds[w].generated.route_length_m;
        runs.push_back(std::move(r));
        work.push_back(worlds[w].generated.route_length_m * (o.loops + 1));
      }
}

/// Takes the result files of earlier runs made with the same options (unless --fresh); returns
/// the indices of the jobs still to run.
std::vector<std::size_t> resume_runs(const BenchmarkOptions& o, const std::vector<BenchmarkJob>& jobs,
                                     std::vector<BenchmarkRun>& runs) {
  std::vector<std::size_t> todo;
  int resumed = 0;
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    const fs::path file = jobs[i].dir / "result.tsv";
    if (!o.fresh && fs::exists(file)) {
      auto earlier = read_result(file);
      if (earlier && earlier->world == runs[i].world && earlier->map == runs[i].map && earlier->seed == runs[i].seed &&
          static_cast<int>(earlier->loops.size()) == o.loops) {
        runs[i] = std::move(*earlier);
        ++resumed;
        continue;
      }
      std::cerr << "visnav benchmark: running " << file.string() << " again: "
                << (earlier ? "it was made with other options" : earlier.error().message) << "\n";
    }
    todo.push_back(i);
  }
  if (o.progress && resumed > 0)
    std::cerr << "visnav benchmark: " << resumed << " of " << jobs.size() << " runs already done (" << o.out
              << "/runs; --fresh runs them again)\n";
  return todo;
}

/// Runs the jobs of `todo` on --jobs threads, each writing its result file; returns the last
/// write error (empty when every file was written).
std::string run_jobs(const BenchmarkOptions& o, const std::vector<WorldFiles>& worlds, const std::vector<BenchmarkJob>& jobs,
                     const std::vector<std::size_t>& todo, std::vector<BenchmarkRun>& runs, BenchProgress& progress) {
  std::atomic<std::size_t> next{0};
  std::mutex error_mutex;
  std::string write_error;
  auto worker = [&]() {
    for (std::size_t k = next++; k < todo.size(); k = next++) {
      const std::size_t i = todo[k];
      const BenchmarkJob& job = jobs[i];
      const WorldFiles& w = worlds[job.world];
      const auto start = std::chrono::steady_clock::now();
      BenchmarkRun& r = runs[i];
      auto run = run_experiment_job(experiment_options(o, w), job.map, job.seed, job.dir.string(),
                                    [&progress, i](double done, double) { progress.update(i, done); });
      if (!run) {
        r.setup_error = run.error().message;
      } else {
        r.setup_error = run->setup_error;
        r.loops = run->loops;
        r.collisions = run->collisions.empty() ? 0 : 1;  // a contact ends the replay: one collision, however many contacts
        r.lost_stops = run->lost_stops;
        r.stop_reason = run->stop_reason;
        r.metrics = run->metrics;
      }
      r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      if (auto st = write_result(r, job.dir / "result.tsv"); !st) {
        std::lock_guard lock(error_mutex);
        write_error = st.error().message;
      }
      progress.finished(i);
    }
  };
  const int threads = std::clamp(o.jobs > 0 ? o.jobs : static_cast<int>(std::thread::hardware_concurrency()), 1,
                                 std::max(1, static_cast<int>(todo.size())));
  std::vector<std::thread> pool;
  for (int k = 1; k < threads; ++k) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
  return write_error;
}

/// runs.csv: one row per run.
void write_runs_csv(const BenchmarkOptions& o, const std::vector<BenchmarkRun>& runs) {
  std::ofstream csv(fs::path(o.out) / "runs.csv");
  csv << "world,world_seed,world_kind,map,seed,obstacles,route_length_m,loops_completed,loops,accuracy_m,repeatability_m,"
         "collisions,encounters,lost_stops,wall_s,stop\n";
  for (const auto& r : runs) {
    int done = 0;
    for (const auto& l : r.loops) done += l.completed ? 1 : 0;
    std::string stop = r.setup_error.empty() ? r.stop_reason : "setup: " + r.setup_error;
    std::replace(stop.begin(), stop.end(), '"', '\'');
    csv << r.world << "," << r.world_seed << "," << r.world_kind << "," << r.map << "," << r.seed << "," << r.obstacles << ","
        << fixed(r.route_length_m, 1) << "," << done << "," << r.loops.size() << "," << fixed(r.metrics.accuracy_m, 4) << ","
        << fixed(r.metrics.repeatability_m, 4) << "," << r.collisions << "," << r.encounters() << "," << r.lost_stops << ","
        << fixed(r.wall_s, 1) << ",\"" << stop << "\"\n";
  }
}

/// report.md: the options, the tables, the worlds and one row per run.
void write_report(const BenchmarkOptions& o, const std::vector<WorldFiles>& worlds, const std::vector<BenchmarkRun>& runs) {
  double wall = 0.0;
  for (const auto& r : runs) wall += r.wall_s;
  std::ofstream md(fs::path(o.out) / "report.md");
  md << "# visnav benchmark\n\n" << o.worlds << " generated worlds (seeds " << o.first_world << "–" << o.first_world + o.worlds - 1
     << ", `visnav sim generate`), " << o.seeds << " run seeds from " << o.first_seed << ", " << o.loops
     << " loops per run, start displaced " << o.displace_m << " m + " << o.displace_heading_deg << "°, success radius "
     << o.success_radius_m << " m, config `" << o.config << "`";
  for (const auto& s : o.overrides) md << ", `--set " << s << "`";
  for (const auto& s : o.replay_ports) md << ", `--port " << s << "`";
  md << ". Sum of run wall times " << fixed(wall / 60.0, 1) << " min.\n\n" << benchmark_table(o, runs)
     << "\nε_acc, ε_rep: seed 000 eq. (18) per run over its finished loops; mean ± sd and worst over runs. Encounters: "
        "obstacles × loops driven into. A loop is completed when finished within the radius without collision; a loop "
        "after a stop is failed (`not driven`).\n\n## Worlds\n\n";
  for (const auto& w : worlds) md << "* " << w.generated.summary << "\n";
  md << "\n## Runs\n\n| world | kind | map | seed | loop errors [m] | ε_acc | stop |\n|---|---|---|---|---|---|---|\n";
  for (const auto& r : runs) {
    std::string errors;
    for (const auto& l : r.loops) {
      if (!errors.empty()) errors += ' ';
      errors += l.finished ? fixed(l.error_m) + (l.completed ? "" : "!") : "×";
    }
    md << "| " << r.world << (r.obstacles ? "*" : "") << " | " << r.world_kind << " | " << r.map << " | " << r.seed << " | " << errors
       << " | " << fixed(r.metrics.accuracy_m) << " | " << (r.setup_error.empty() ? r.stop_reason : "setup: " + r.setup_error)
       << " |\n";
  }
  md << "\n`*` obstacles on the route, `!` finished outside the radius, `×` not finished.\n";
}

}  // namespace

Result<std::vector<BenchmarkRun>> run_benchmark(const BenchmarkOptions& o) {
  VISNAV_TRY(load_run_config(project_file(o.config), o.overrides));  // a bad config fails before any run
  std::error_code ec;
  fs::create_directories(fs::path(o.out) / "worlds", ec);
  if (ec) return fail("cannot create " + o.out + ": " + ec.message());

  VISNAV_ASSIGN(const std::vector<WorldFiles> worlds, prepare_worlds(o));
  std::vector<BenchmarkJob> jobs;
  std::vector<BenchmarkRun> runs;
  std::vector<double> work;
  plan_jobs(o, worlds, jobs, runs, work);
  const std::vector<std::size_t> todo = resume_runs(o, jobs, runs);

  BenchProgress progress(work, o.progress);
  for (std::size_t i = 0; i < jobs.size(); ++i)
    if (std::find(todo.begin(), todo.end(), i) == todo.end()) progress.finished(i);
  const std::string write_error = run_jobs(o, worlds, jobs, todo, runs, progress);
  progress.end();
  if (!write_error.empty()) return fail(write_error);

  // --- files
  write_runs_csv(o, runs);
  cv::imwrite((fs::path(o.out) / "benchmark.png").string(), draw_benchmark(o, runs));
  write_report(o, worlds, runs);
  return runs;
}

int benchmark_command(int argc, char** argv, HostServices& /*host*/) {
  if (print_help_if_asked(argc, argv, kUsage)) return 0;
  auto options = parse(argc, argv);
  if (!options) return usage_error("visnav benchmark", options.error().message, kUsage);
  const BenchmarkOptions& o = *options;
  std::cout << "visnav benchmark: " << o.worlds << " generated worlds from seed " << o.first_world
            << (o.first_world >= 1000 ? " (held out)" : o.first_world + o.worlds <= 21 ? " (development)" : "") << ", " << o.seeds
            << " seeds x " << o.loops << " loops per map kind, realistic error models (" << o.config << ")\n";
  auto runs = run_benchmark(o);
  if (!runs) {
    std::cerr << "visnav benchmark: " << runs.error().message << "\n";
    return 1;
  }
  int status = 0;
  for (const auto& r : *runs) {
    if (!r.setup_error.empty()) {
      std::cerr << "visnav benchmark: " << r.world << " " << r.map << " seed " << r.seed << ": " << r.setup_error << "\n";
      status = 1;
    }
    for (const auto& l : r.loops)
      if (!l.completed) status = 1;
  }
  std::cout << "\n" << benchmark_table(o, *runs) << "\n";
  for (const auto& r : *runs)
    if (!r.stop_reason.empty()) std::cout << "  " << r.world << " " << r.map << " seed " << r.seed << " stopped: " << r.stop_reason << "\n";
  std::cout << "picture: " << (fs::path(o.out) / "benchmark.png").string() << "\nreport:  " << (fs::path(o.out) / "report.md").string()
            << "\nruns:    " << (fs::path(o.out) / "runs.csv").string() << ", " << o.out << "/runs/<world>/<map>/seed<S>/\n";
  return status;
}

}  // namespace visnav::simop
