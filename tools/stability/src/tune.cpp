// NLopt driver with a replay cache, and the summary.json scoring of `visnav tune`.
#include "visnav_stability/tune.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <optional>

#include <nlopt.h>
#include <yaml-cpp/yaml.h>

namespace visnav::stability {
namespace {

Result<double> parse_double(const std::string& text, const std::string& what) {
  if (text.empty()) return fail(what + ": empty number");
  try {
    std::size_t used = 0;
    const double v = std::stod(text, &used);
    if (used != text.size() || !std::isfinite(v)) return fail(what + ": '" + text + "' is not a finite number");
    return v;
  } catch (const std::exception&) {
    return fail(what + ": '" + text + "' is not a number");
  }
}

std::vector<std::string> split(std::string_view s, char sep) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : s) {
    if (c == sep) {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  out.push_back(cur);
  return out;
}

struct Driver {
  nlopt_opt opt = nullptr;
  const TuneObjective* objective = nullptr;
  std::map<std::string, double>* cache = nullptr;
  const std::function<void(const Evaluation&)>* on_eval = nullptr;
  TuneResult* result = nullptr;
  std::optional<Error> error;
  int calls = 0;
};

// NLopt calls this through a C function pointer: nothing may throw out of it.
double nlopt_objective(unsigned n, const double* x, double* /*grad: derivative-free only*/, void* data) noexcept {
  auto& d = *static_cast<Driver*>(data);
  try {
    Evaluation ev;
    ev.index = ++d.calls;
    ev.x.assign(x, x + n);
    const std::string key = cache_key(ev.x);
    if (d.cache != nullptr) {
      if (auto it = d.cache->find(key); it != d.cache->end()) {
        ev.objective = it->second;
        ev.cached = true;
      }
    }
    if (!ev.cached) {
      Result<double> v = (*d.objective)(ev.x, ev.index);
      if (!v) {
        d.error = v.error();
        nlopt_force_stop(d.opt);
        return HUGE_VAL;
      }
      ev.objective = *v;
      if (d.cache != nullptr) (*d.cache)[key] = ev.objective;
    }
    if (d.result->history.empty() || ev.objective < d.result->best_objective) {
      d.result->best_objective = ev.objective;
      d.result->best_x = ev.x;
    }
    d.result->history.push_back(ev);
    if (*d.on_eval) (*d.on_eval)(ev);
    return ev.objective;
  } catch (const std::exception& e) {
    d.error = fail(std::string("objective threw: ") + e.what());
  } catch (...) {
    d.error = fail("objective threw a non-standard exception");
  }
  nlopt_force_stop(d.opt);
  return HUGE_VAL;
}

const char* describe(nlopt_result rc) {
  switch (rc) {
    case NLOPT_SUCCESS: return "success";
    case NLOPT_STOPVAL_REACHED: return "objective target reached";
    case NLOPT_FTOL_REACHED: return "objective change below ftol";
    case NLOPT_XTOL_REACHED: return "step below xtol";
    case NLOPT_MAXEVAL_REACHED: return "evaluation budget used";
    case NLOPT_MAXTIME_REACHED: return "time budget used";
    case NLOPT_FORCED_STOP: return "stopped";
    case NLOPT_ROUNDOFF_LIMITED: return "roundoff limited";
    case NLOPT_OUT_OF_MEMORY: return "out of memory";
    case NLOPT_INVALID_ARGS: return "invalid arguments";
    default: return "failure";
  }
}

}  // namespace

Result<std::vector<TuneParam>> parse_tune_params(std::string_view list) {
  std::vector<TuneParam> out;
  for (const std::string& item : split(list, ',')) {
    if (item.empty()) return fail("--params: empty item in '" + std::string(list) + "'");
    const auto eq = item.find('=');
    if (eq == std::string::npos || eq == 0)
      return fail("--params: '" + item + "' needs bounds: key=lo:hi[:start] (the search is bounded)");
    TuneParam p;
    p.key = item.substr(0, eq);
    for (char c : p.key) {
      if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-'))
        return fail("--params: key '" + p.key + "' may hold only letters, digits, '.', '_' and '-'");
    }
    const auto parts = split(std::string_view(item).substr(eq + 1), ':');
    if (parts.size() < 2 || parts.size() > 3) return fail("--params: '" + item + "' must be key=lo:hi or key=lo:hi:start");
    VISNAV_ASSIGN(p.lo_value, parse_double(parts[0], "--params " + p.key + " lower bound"));
    VISNAV_ASSIGN(p.hi_value, parse_double(parts[1], "--params " + p.key + " upper bound"));
    if (!(p.lo_value < p.hi_value))
      return fail("--params: '" + item + "': lower bound " + parts[0] + " is not below upper bound " + parts[1]);
    p.start_value = 0.5 * (p.lo_value + p.hi_value);
    if (parts.size() == 3) {
      VISNAV_ASSIGN(p.start_value, parse_double(parts[2], "--params " + p.key + " start"));
      if (p.start_value < p.lo_value || p.start_value > p.hi_value)
        return fail("--params: '" + item + "': start " + parts[2] + " is outside [" + parts[0] + ", " + parts[1] + "]");
    }
    for (const auto& q : out)
      if (q.key == p.key) return fail("--params: key '" + p.key + "' given twice");
    out.push_back(std::move(p));
  }
  return out;
}

Result<TuneAlgorithm> parse_tune_algorithm(std::string_view name) {
  if (name == "sbplx") return TuneAlgorithm::sbplx;
  if (name == "bobyqa") return TuneAlgorithm::bobyqa;
  if (name == "cobyla") return TuneAlgorithm::cobyla;
  if (name == "neldermead") return TuneAlgorithm::neldermead;
  return fail("--algorithm: '" + std::string(name) + "' is not sbplx, bobyqa, cobyla or neldermead");
}

const char* to_string(TuneAlgorithm a) {
  switch (a) {
    case TuneAlgorithm::sbplx: return "sbplx";
    case TuneAlgorithm::bobyqa: return "bobyqa";
    case TuneAlgorithm::cobyla: return "cobyla";
    case TuneAlgorithm::neldermead: return "neldermead";
  }
  return "?";
}

Status TuneOptions::validate() const {
  if (max_evals < 1 || max_evals > 100000) return fail("max_evals must be in [1, 100000], got " + std::to_string(max_evals));
  if (!(xtol_rel >= 0.0 && xtol_rel < 1.0)) return fail("xtol_rel must be in [0, 1), got " + std::to_string(xtol_rel));
  if (!(ftol_abs >= 0.0 && std::isfinite(ftol_abs))) return fail("ftol_abs must be >= 0, got " + std::to_string(ftol_abs));
  if (!(initial_step_share > 0.0 && initial_step_share <= 1.0))
    return fail("initial_step_share must be in (0, 1], got " + std::to_string(initial_step_share));
  return ok();
}

std::string cache_key(const std::vector<double>& x) {
  std::string key;
  char buf[40];
  for (double v : x) {
    std::snprintf(buf, sizeof buf, "%.17g", v);
    if (!key.empty()) key += ';';
    key += buf;
  }
  return key;
}

Result<TuneResult> tune(const std::vector<TuneParam>& params, const TuneOptions& options, const TuneObjective& objective,
                        std::map<std::string, double>* cache, const std::function<void(const Evaluation&)>& on_eval) {
  VISNAV_TRY(options.validate());
  if (params.empty()) return fail("tune: no parameter to tune");
  const auto n = static_cast<unsigned>(params.size());
  nlopt_algorithm algo = NLOPT_LN_SBPLX;
  switch (options.algorithm) {
    case TuneAlgorithm::sbplx: algo = NLOPT_LN_SBPLX; break;
    case TuneAlgorithm::bobyqa: algo = NLOPT_LN_BOBYQA; break;
    case TuneAlgorithm::cobyla: algo = NLOPT_LN_COBYLA; break;
    case TuneAlgorithm::neldermead: algo = NLOPT_LN_NELDERMEAD; break;
  }
  std::vector<double> lo, hi, step, x;
  for (const auto& p : params) {
    lo.push_back(p.lo_value);
    hi.push_back(p.hi_value);
    step.push_back(options.initial_step_share * (p.hi_value - p.lo_value));
    x.push_back(p.start_value);
  }
  if (options.algorithm == TuneAlgorithm::bobyqa && n == 1)
    return fail("--algorithm bobyqa needs at least two parameters (NLopt); use sbplx");
  nlopt_opt opt = nlopt_create(algo, n);
  if (opt == nullptr) return fail("NLopt could not create the optimiser");
  TuneResult result;
  Driver d;
  d.opt = opt;
  d.objective = &objective;
  d.cache = cache;
  d.on_eval = &on_eval;
  d.result = &result;
  nlopt_set_lower_bounds(opt, lo.data());
  nlopt_set_upper_bounds(opt, hi.data());
  nlopt_set_initial_step(opt, step.data());
  nlopt_set_min_objective(opt, &nlopt_objective, &d);
  nlopt_set_maxeval(opt, options.max_evals);
  nlopt_set_xtol_rel(opt, options.xtol_rel);
  nlopt_set_ftol_abs(opt, options.ftol_abs);
  double f = 0.0;
  const nlopt_result rc = nlopt_optimize(opt, x.data(), &f);
  nlopt_destroy(opt);
  if (d.error) return *d.error;
  if (result.history.empty()) return fail(std::string("NLopt stopped before the first evaluation: ") + describe(rc));
  result.stop_reason = describe(rc);
  return result;
}

Status ObjectiveWeights::validate() const {
  if (!(lambda >= 0.0 && std::isfinite(lambda))) return fail("lambda must be >= 0, got " + std::to_string(lambda));
  if (!(failed_loop_penalty_m >= 0.0 && std::isfinite(failed_loop_penalty_m)))
    return fail("failed-loop penalty must be >= 0 m, got " + std::to_string(failed_loop_penalty_m));
  return ok();
}

Result<std::vector<StyleSummary>> parse_summary(const std::string& json_text) {
  YAML::Node root;
  try {
    root = YAML::Load(json_text);
  } catch (const YAML::Exception& e) {
    return fail("summary.json: not valid JSON: " + std::string(e.what()));
  }
  if (!root.IsMap() || !root["styles"] || !root["styles"].IsSequence()) return fail("summary.json: no \"styles\" list");
  std::vector<StyleSummary> out;
  try {
    for (const auto& s : root["styles"]) {
      StyleSummary st;
      st.style = s["style"] ? s["style"].as<std::string>() : std::string();
      for (const char* key : {"attempted", "completed"})
        if (!s[key]) return fail("summary.json: style '" + st.style + "' has no \"" + key + "\"");
      st.attempted = s["attempted"].as<double>();
      st.completed = s["completed"].as<double>();
      st.collisions = s["collisions"] ? s["collisions"].as<double>() : 0.0;
      st.lost = s["lost"] ? s["lost"].as<double>() : 0.0;
      auto stat = [&](const char* key, const char* field) {
        const YAML::Node n = s[key];
        if (!n || !n.IsMap() || !n[field] || n[field].IsNull()) return std::nan("");
        return n[field].as<double>();
      };
      st.eps_acc_mean_m = stat("eps_acc_m", "mean");
      st.eps_acc_sd_m = stat("eps_acc_m", "sd");
      st.eps_acc_worst_m = stat("eps_acc_m", "worst");
      st.eps_rep_mean_m = stat("eps_rep_m", "mean");
      st.eps_rep_sd_m = stat("eps_rep_m", "sd");
      st.eps_rep_worst_m = stat("eps_rep_m", "worst");
      out.push_back(std::move(st));
    }
  } catch (const YAML::Exception& e) {
    return fail("summary.json: bad value: " + std::string(e.what()));
  }
  return out;
}

Result<ObjectiveBreakdown> objective_from_summary(const std::string& json_text, const ObjectiveWeights& w) {
  VISNAV_TRY(w.validate());
  VISNAV_ASSIGN(std::vector<StyleSummary> styles, parse_summary(json_text));
  ObjectiveBreakdown total;
  int scored = 0;
  for (const StyleSummary& s : styles) {
    if (!w.style.empty() && s.style != w.style) continue;
    ObjectiveBreakdown b;
    b.failed_share = s.attempted <= 0.0 ? 1.0 : std::clamp((s.attempted - s.completed + s.collisions) / s.attempted, 0.0, 1.0);
    auto mean_of = [&](double v, const char* key) -> Result<double> {
      if (std::isnan(v)) {
        if (s.completed <= 0.0) return 0.0;  // nothing completed: only the penalty counts
        return fail("summary.json: style '" + s.style + "' has no \"" + key + "\".mean");
      }
      if (!std::isfinite(v)) return fail("summary.json: style '" + s.style + "': " + key + ".mean is not finite");
      return v;
    };
    VISNAV_ASSIGN(b.eps_acc_m, mean_of(s.eps_acc_mean_m, "eps_acc_m"));
    VISNAV_ASSIGN(b.eps_rep_m, mean_of(s.eps_rep_mean_m, "eps_rep_m"));
    total.eps_acc_m += b.eps_acc_m;
    total.eps_rep_m += b.eps_rep_m;
    total.failed_share += b.failed_share;
    ++scored;
  }
  if (scored == 0)
    return Error{w.style.empty() ? std::string("summary.json: \"styles\" is empty") : "summary.json: no style '" + w.style + "'",
                 ErrorCode::not_found, {"summary.json", 0, w.style.empty() ? std::string("styles") : w.style}};
  total.eps_acc_m /= scored;
  total.eps_rep_m /= scored;
  total.failed_share /= scored;
  total.objective = total.eps_acc_m + w.lambda * total.eps_rep_m + w.failed_loop_penalty_m * total.failed_share;
  return total;
}

}  // namespace visnav::stability
