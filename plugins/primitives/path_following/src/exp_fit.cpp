#include "visnav/path_following/exp_fit.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <nlopt.h>

namespace visnav::path_following {

namespace {

struct FitData {
  std::span<const double> x;
  std::span<const double> y;
};

// Sum of squared residuals of y = a·e^(−k·x) and its gradient in (a, k).
double objective(unsigned n, const double* p, double* grad, void* data) {
  (void)n;
  const auto* d = static_cast<const FitData*>(data);
  const double a = p[0];
  const double k = p[1];
  double f = 0.0, ga = 0.0, gk = 0.0;
  for (std::size_t i = 0; i < d->x.size(); ++i) {
    const double e = std::exp(-k * d->x[i]);
    const double r = a * e - d->y[i];
    f += r * r;
    ga += 2.0 * r * e;
    gk += -2.0 * r * a * d->x[i] * e;
  }
  if (grad != nullptr) {
    grad[0] = ga;
    grad[1] = gk;
  }
  return f;
}

}  // namespace

Result<ExpDecayFit> fit_exponential_decay(std::span<const double> x, std::span<const double> y) {
  if (x.size() != y.size())
    return fail("fit_exponential_decay: " + std::to_string(x.size()) + " x values but " + std::to_string(y.size()) +
                " y values");
  if (x.size() < 3) return fail("fit_exponential_decay: needs at least 3 points, got " + std::to_string(x.size()));
  for (std::size_t i = 0; i < x.size(); ++i)
    if (!std::isfinite(x[i]) || !std::isfinite(y[i]))
      return fail(ErrorCode::invalid_value, "fit_exponential_decay: point " + std::to_string(i) + " is not finite");
  const auto [xmin_it, xmax_it] = std::minmax_element(x.begin(), x.end());
  const double x_span = *xmax_it - *xmin_it;
  if (!(x_span > 0.0)) return fail("fit_exponential_decay: all x values are equal");
  const double x_abs_max = std::max(std::abs(*xmin_it), std::abs(*xmax_it));

  // Start: log-linear least squares on the points sharing the sign of the value at the
  // smallest x (ln|y| = ln|a| − k·x); fall back to a = y(x_min), k = 0.
  const std::size_t first = static_cast<std::size_t>(xmin_it - x.begin());
  const double sign = y[first] < 0.0 ? -1.0 : 1.0;
  double sx = 0, sy = 0, sxx = 0, sxy = 0, m = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double v = sign * y[i];
    if (v <= 1e-12) continue;
    const double ly = std::log(v);
    sx += x[i]; sy += ly; sxx += x[i] * x[i]; sxy += x[i] * ly; m += 1.0;
  }
  double start[2] = {y[first], 0.0};
  const double denom = m * sxx - sx * sx;
  if (m >= 2.0 && std::abs(denom) > 1e-12 * std::max(1.0, m * sxx)) {
    const double slope = (m * sxy - sx * sy) / denom;
    const double intercept = (sy - slope * sx) / m;
    start[0] = sign * std::exp(intercept);
    start[1] = -slope;
  }
  // Keep the exponent bounded (|k·x| ≤ 50) so e^(−k·x) stays finite.
  const double k_limit = 50.0 / std::max(x_abs_max, 1e-9);
  start[1] = std::clamp(start[1], -k_limit, k_limit);
  if (!std::isfinite(start[0])) start[0] = y[first];

  nlopt_opt opt = nlopt_create(NLOPT_LD_LBFGS, 2);
  if (opt == nullptr) return fail("fit_exponential_decay: could not create the NLopt optimiser");
  FitData data{x, y};
  const double lower[2] = {-HUGE_VAL, -k_limit};
  const double upper[2] = {HUGE_VAL, k_limit};
  nlopt_set_lower_bounds(opt, lower);
  nlopt_set_upper_bounds(opt, upper);
  nlopt_set_min_objective(opt, &objective, &data);
  nlopt_set_xtol_rel(opt, 1e-12);
  nlopt_set_ftol_abs(opt, 1e-20);
  nlopt_set_maxeval(opt, 5000);
  double p[2] = {start[0], start[1]};
  double f = 0.0;
  const nlopt_result rc = nlopt_optimize(opt, p, &f);
  nlopt_destroy(opt);
  // Round-off limited means the optimum was reached to machine precision: accept it.
  if (rc < 0 && rc != NLOPT_ROUNDOFF_LIMITED)
    return fail("fit_exponential_decay: NLopt failed (code " + std::to_string(static_cast<int>(rc)) + ")");
  f = objective(2, p, nullptr, &data);
  if (!std::isfinite(f) || !std::isfinite(p[0]) || !std::isfinite(p[1]))
    return fail("fit_exponential_decay: the fit diverged");
  return ExpDecayFit{p[0], p[1], std::sqrt(f / static_cast<double>(x.size()))};
}

}  // namespace visnav::path_following
