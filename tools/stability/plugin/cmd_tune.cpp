// `visnav tune`: NLopt over primitive parameters; each evaluation runs `visnav experiment` as a
// child process and scores its summary.json (docs/convergence.md, "Tuning").

#include <algorithm>
#include <cstring>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <thread>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "cli_util.hpp"
#include "commands.hpp"
#include "visnav_stability/tune.hpp"

namespace visnav::stability {
namespace {

namespace fs = std::filesystem;

constexpr const char* kUsage =
    "usage: visnav tune --world W --route R --params KEY=LO:HI[:START],... [--maps feature] [--seeds 5]\n"
    "                   [--loops 3] [--out DIR] [--lambda 1] [--penalty 5] [--style S] [--max-evals 30]\n"
    "                   [--algorithm sbplx] [--set KEY=VALUE]... [--child \"CMD ARGS\"] [--timeout-s T]\n"
    "\n"
    "Minimises eps_acc + lambda*eps_rep (m) + penalty x (share of failed loops) over the box given by\n"
    "--params with NLopt's derivative-free Sbplx. Each evaluation runs\n"
    "  CHILD --world W --route R --maps M --seeds N --loops L --out DIR/runs/NNNN --set KEY=VALUE ...\n"
    "and reads DIR/runs/NNNN/summary.json. Every evaluation is appended to DIR/evals.csv; running the\n"
    "same command again resumes (known points are not re-run). Writes DIR/tuned.yaml (the best\n"
    "parameters as a config block), DIR/convergence.csv and DIR/convergence.png.\n"
    "\n"
    "  --params LIST   parameters (config override keys) with bounds, e.g.\n"
    "                  port.ReplayFeatureEdge.correction_gain_radps_per_px=0.001:0.01,\n"
    "                  robot.params.max_linear_mps=0.3:1:0.5 (a key port.NODE.PORT is a tree port,\n"
    "                  passed to the experiment as --port NODE.PORT=V; others are --set keys)\n"
    "  --maps M        map style passed to the experiment (default feature)\n"
    "  --seeds N       seeds per evaluation (default 5)     --loops L  loops per seed (default 3)\n"
    "  --out DIR       output folder (default out/tune)\n"
    "  --lambda X      weight of eps_rep (default 1)     --penalty P  m per failed-loop share (default 5)\n"
    "  --style S       score only this style of the summary (default: mean over all)\n"
    "  --max-evals N   objective evaluations (default 30)\n"
    "  --algorithm A   sbplx (default), bobyqa, cobyla, neldermead\n"
    "  --set K=V       extra override passed to every experiment (repeatable)\n"
    "  --child CMD     the experiment command (default: this visnav binary + ' experiment');\n"
    "                  split at spaces\n"
    "  --timeout-s T   kill an experiment after T s and count it as failed (default 3600)\n"
    "Exit status: 0 done, 1 error, 2 usage error.\n";

struct TuneCommandOptions {
  std::string world, route, maps = "feature", out = "out/tune", child;
  int seeds = 5, loops = 3;
  double timeout_s = 3600.0;
  std::vector<TuneParam> params;
  std::vector<std::string> extra_sets;
  TuneOptions tune;
  ObjectiveWeights weights;
};

std::string g17(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// evals.csv: header "key1,...,keyN,objective,eps_acc_m,eps_rep_m,failed_share,run"; one row per
// evaluation actually run. Returns the cache; an error when the header names other parameters.
Result<std::map<std::string, double>> load_cache(const std::string& path, const std::vector<TuneParam>& params) {
  std::map<std::string, double> cache;
  std::ifstream in(path);
  if (!in) return cache;
  std::string header;
  std::getline(in, header);
  std::string want;
  for (const auto& p : params) want += p.key + ",";
  want += "objective,eps_acc_m,eps_rep_m,failed_share,run";
  if (header != want)
    return fail(path + ":1: made for other parameters ('" + header + "'); use another --out or the same --params");
  int line_no = 1;
  for (std::string line; std::getline(in, line);) {
    ++line_no;
    if (line.empty()) continue;
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    if (cells.size() != params.size() + 5) return fail(path + ":" + std::to_string(line_no) + ": wrong number of columns");
    std::vector<double> x;
    try {
      for (std::size_t i = 0; i < params.size(); ++i) x.push_back(std::stod(cells[i]));
      cache[cache_key(x)] = std::stod(cells[params.size()]);
    } catch (const std::exception&) {
      return fail(path + ":" + std::to_string(line_no) + ": not a number");
    }
  }
  return cache;
}

void write_plot(const std::string& path, const std::vector<Evaluation>& history) {
  const int w = 720, h = 420, left = 70, right = 20, top = 30, bottom = 50;
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  double lo = history.front().objective, hi = lo;
  for (const auto& e : history) {
    lo = std::min(lo, e.objective);
    hi = std::max(hi, e.objective);
  }
  if (hi - lo < 1e-9) hi = lo + 1e-3;
  const auto n = static_cast<double>(std::max<std::size_t>(history.size(), 2) - 1);
  auto px = [&](double i, double v) {
    return cv::Point(left + static_cast<int>((w - left - right) * i / n),
                     top + static_cast<int>((h - top - bottom) * (hi - v) / (hi - lo)));
  };
  cv::rectangle(img, {left, top}, {w - right, h - bottom}, cv::Scalar(0, 0, 0), 1);
  double best = history.front().objective;
  cv::Point prev = px(0, best);
  for (std::size_t i = 0; i < history.size(); ++i) {
    best = std::min(best, history[i].objective);
    const cv::Point b = px(static_cast<double>(i), best);
    if (i > 0) cv::line(img, prev, b, cv::Scalar(200, 60, 0), 2, cv::LINE_AA);
    prev = b;
    cv::circle(img, px(static_cast<double>(i), history[i].objective), 3, cv::Scalar(40, 40, 220), cv::FILLED, cv::LINE_AA);
  }
  auto text = [&](const std::string& s, cv::Point at) {
    cv::putText(img, s, at, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  };
  text(cli::fixed(hi, 3), {5, top + 5});
  text(cli::fixed(lo, 3), {5, h - bottom});
  text("evaluation 1.." + std::to_string(history.size()), {left, h - 20});
  text("objective [m] (red: each evaluation, blue: best so far)", {left, 20});
  cv::imwrite(path, img);
}

// A --params key "port.Node.port" is a behaviour-tree port, passed to the experiment as
// `--port Node.port=value` (docs/bt.md, port overrides); every other key is a config `--set`.
constexpr std::string_view kPortPrefix = "port.";
bool is_port_key(const std::string& key) { return key.rfind(kPortPrefix, 0) == 0; }

// Nested YAML from dotted keys: a.b.c=v → a: {b: {c: v}}; tree ports as the --port options
// that set them (a config file has no place for them).
std::string config_block(const std::vector<TuneParam>& params, const std::vector<double>& x) {
  std::vector<std::vector<std::string>> paths;
  std::string ports;
  for (std::size_t i = 0; i < params.size(); ++i) {
    if (is_port_key(params[i].key))
      ports += "#   --port " + params[i].key.substr(kPortPrefix.size()) + "=" + g17(x[i]) + "\n";
  }
  for (const auto& p : params) {
    if (is_port_key(p.key)) {
      paths.emplace_back();
      continue;
    }
    std::vector<std::string> parts;
    std::stringstream ss(p.key);
    for (std::string s; std::getline(ss, s, '.');) parts.push_back(s);
    paths.push_back(parts);
  }
  std::vector<std::size_t> order(params.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return paths[a] < paths[b]; });
  std::string out;
  std::vector<std::string> open;
  for (std::size_t i : order) {
    const auto& parts = paths[i];
    if (parts.empty()) continue;  // a tree port
    std::size_t common = 0;
    while (common < open.size() && common + 1 < parts.size() && open[common] == parts[common]) ++common;
    open.resize(common);
    for (std::size_t d = common; d + 1 < parts.size(); ++d) {
      out += std::string(2 * d, ' ') + parts[d] + ":\n";
      open.push_back(parts[d]);
    }
    out += std::string(2 * (parts.size() - 1), ' ') + parts.back() + ": " + g17(x[i]) + "\n";
  }
  if (!ports.empty()) out += "# tree ports (visnav run / experiment options):\n" + ports;
  return out;
}

Status parse(int argc, char** argv, TuneCommandOptions& o) {
  bool have_params = false;
  for (cli::OptionReader in(argc, argv); in.next();) {
    const std::string& a = in.arg();
    if (a == "--world") { VISNAV_ASSIGN(o.world, in.value()); }
    else if (a == "--route") { VISNAV_ASSIGN(o.route, in.value()); }
    else if (a == "--maps") { VISNAV_ASSIGN(o.maps, in.value()); }
    else if (a == "--out") { VISNAV_ASSIGN(o.out, in.value()); }
    else if (a == "--child") { VISNAV_ASSIGN(o.child, in.value()); }
    else if (a == "--seeds") { VISNAV_ASSIGN(double v, in.number(1, 1000)); o.seeds = static_cast<int>(v); }
    else if (a == "--loops") { VISNAV_ASSIGN(double v, in.number(1, 100)); o.loops = static_cast<int>(v); }
    else if (a == "--timeout-s") { VISNAV_ASSIGN(o.timeout_s, in.number(1, 1e6)); }
    else if (a == "--lambda") { VISNAV_ASSIGN(o.weights.lambda, in.number(0, 1e6)); }
    else if (a == "--penalty") { VISNAV_ASSIGN(o.weights.failed_loop_penalty_m, in.number(0, 1e6)); }
    else if (a == "--style") { VISNAV_ASSIGN(o.weights.style, in.value()); }
    else if (a == "--max-evals") { VISNAV_ASSIGN(double v, in.number(1, 100000)); o.tune.max_evals = static_cast<int>(v); }
    else if (a == "--algorithm") {
      VISNAV_ASSIGN(std::string v, in.value());
      VISNAV_ASSIGN(o.tune.algorithm, parse_tune_algorithm(v));
    } else if (a == "--params") {
      VISNAV_ASSIGN(std::string v, in.value());
      VISNAV_ASSIGN(o.params, parse_tune_params(v));
      have_params = true;
    } else if (a == "--set") {
      VISNAV_ASSIGN(std::string v, in.value());
      if (v.find('=') == std::string::npos) return fail("--set: '" + v + "' must be KEY=VALUE");
      o.extra_sets.push_back(v);
    } else {
      return fail("unknown option '" + a + "'");
    }
  }
  if (o.world.empty()) return fail("--world is required");
  if (o.route.empty()) return fail("--route is required");
  if (!have_params) return fail("--params is required");
  if (o.child.empty()) o.child = cli::self_exe() + " experiment";
  if (cli::split_spaces(o.child).empty()) return fail("--child is empty");
  VISNAV_TRY(o.weights.validate());
  return o.tune.validate();
}

int run(int argc, char** argv) {
  if (cli::print_help_if_asked(argc, argv, kUsage)) return 0;
  TuneCommandOptions o;
  if (auto st = parse(argc, argv, o); !st) return cli::usage_error("tune", st.error().message, kUsage);
  std::error_code ec;
  fs::create_directories(fs::path(o.out) / "runs", ec);
  if (ec) {
    std::cerr << "tune: cannot create " << o.out << "/runs: " << ec.message() << "\n";
    return 1;
  }
  const std::string evals_path = (fs::path(o.out) / "evals.csv").string();
  auto cache = load_cache(evals_path, o.params);
  if (!cache) {
    std::cerr << "tune: " << cache.error().message << "\n";
    return 1;
  }
  const std::size_t resumed = cache->size();
  if (!fs::exists(evals_path)) {
    std::ofstream h(evals_path);
    for (const auto& p : o.params) h << p.key << ",";
    h << "objective,eps_acc_m,eps_rep_m,failed_share,run\n";
  }
  int run_counter = static_cast<int>(resumed);
  std::cout << "tune: " << o.params.size() << " parameters, " << to_string(o.tune.algorithm) << ", at most "
            << o.tune.max_evals << " evaluations" << (resumed ? ", " + std::to_string(resumed) + " known from evals.csv" : "")
            << "\n";

  const TuneObjective objective = [&](const std::vector<double>& x, int /*index*/) -> Result<double> {
    char name[32];
    std::snprintf(name, sizeof name, "run-%04d", ++run_counter);
    const fs::path dir = fs::path(o.out) / "runs" / name;
    fs::create_directories(dir);
    std::vector<std::string> args = cli::split_spaces(o.child);
    for (const std::string& a : {std::string("--world"), o.world, std::string("--route"), o.route, std::string("--maps"),
                                 o.maps, std::string("--seeds"), std::to_string(o.seeds), std::string("--loops"),
                                 std::to_string(o.loops), std::string("--out"), dir.string()})
      args.push_back(a);
    for (const auto& s : o.extra_sets) {
      args.push_back("--set");
      args.push_back(s);
    }
    for (std::size_t i = 0; i < x.size(); ++i) {
      const bool port = is_port_key(o.params[i].key);
      args.push_back(port ? "--port" : "--set");
      args.push_back(o.params[i].key.substr(port ? kPortPrefix.size() : 0) + "=" + g17(x[i]));
    }
    VISNAV_ASSIGN(int status, cli::run_child(args, (dir / "child.log").string(), o.timeout_s));
    ObjectiveBreakdown b;
    std::string note;
    std::ifstream in(dir / "summary.json");
    std::stringstream text;
    text << in.rdbuf();
    // Exit 1 with a summary: some loops failed, which the summary's failed share already scores.
    auto scored = ((status == 0 || status == 1) && in) ? objective_from_summary(text.str(), o.weights)
                                      : Result<ObjectiveBreakdown>(fail("experiment exited with status " +
                                                                        std::to_string(status)));
    if (scored) {
      b = *scored;
    } else {
      // A failed experiment is scored as if every loop failed, never skipped.
      b.failed_share = 1.0;
      b.objective = o.weights.failed_loop_penalty_m;
      std::cerr << "\ntune: " << name << ": " << scored.error().message << " (see " << (dir / "child.log").string()
                << "); scored as all loops failed\n";
    }
    std::ofstream log(evals_path, std::ios::app);
    for (double v : x) log << g17(v) << ",";
    log << g17(b.objective) << "," << g17(b.eps_acc_m) << "," << g17(b.eps_rep_m) << "," << g17(b.failed_share) << ","
        << name << "\n";
    return b.objective;
  };

  cli::ProgressLine bar;
  auto result = tune(o.params, o.tune, objective, &*cache, [&](const Evaluation& e) {
    bar.show("evaluations", e.index, o.tune.max_evals, "evaluations");
  });
  bar.end();
  if (!result) {
    std::cerr << "tune: " << result.error().message << "\n";
    return 1;
  }
  {
    std::ofstream csv(fs::path(o.out) / "convergence.csv");
    csv << "evaluation,cached";
    for (const auto& p : o.params) csv << "," << p.key;
    csv << ",objective,best_so_far\n";
    double best = result->history.front().objective;
    for (const auto& e : result->history) {
      best = std::min(best, e.objective);
      csv << e.index << "," << (e.cached ? 1 : 0);
      for (double v : e.x) csv << "," << g17(v);
      csv << "," << g17(e.objective) << "," << g17(best) << "\n";
    }
  }
  write_plot((fs::path(o.out) / "convergence.png").string(), result->history);
  {
    std::ofstream y(fs::path(o.out) / "tuned.yaml");
    y << "# visnav tune: world " << o.world << ", route " << o.route << ", objective " << g17(result->best_objective)
      << " m (start " << g17(result->history.front().objective) << " m), " << result->history.size()
      << " evaluations, " << to_string(o.tune.algorithm) << "\n"
      << config_block(o.params, result->best_x);
  }
  std::cout << "\n| parameter | start | tuned | bounds |\n| --- | --- | --- | --- |\n";
  for (std::size_t i = 0; i < o.params.size(); ++i)
    std::cout << "| " << o.params[i].key << " | " << g17(o.params[i].start_value) << " | " << g17(result->best_x[i])
              << " | [" << g17(o.params[i].lo_value) << ", " << g17(o.params[i].hi_value) << "] |\n";
  std::cout << "\nobjective: start " << cli::fixed(result->history.front().objective, 4) << " m, tuned "
            << cli::fixed(result->best_objective, 4) << " m after " << result->history.size() << " evaluations ("
            << result->stop_reason << ")\nwrote " << o.out << "/tuned.yaml, convergence.csv, convergence.png, evals.csv\n";
  return 0;
}

}  // namespace

int tune_command(int argc, char** argv, HostServices& /*host*/) { return run(argc, argv); }

}  // namespace visnav::stability
