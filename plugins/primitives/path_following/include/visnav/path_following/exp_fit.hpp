// visnav path following — least-squares fit of an exponential decay y = a·e^(−k·x).
//
// Used for the convergence comparison of seed 000 Fig. 3 (lateral offset y in metres against
// travelled distance x in metres; k in 1/m). Minimises Σ (a·e^(−k·x_i) − y_i)² with NLopt
// (L-BFGS on the analytic gradient, started from a log-linear fit). Pure and thread-safe.
#pragma once

#include <span>

#include "visnav/result.hpp"

namespace visnav::path_following {

struct ExpDecayFit {
  double a = 0.0;    ///< value at x = 0 (units of y)
  double k = 0.0;    ///< decay rate (1 / units of x); negative means growth
  double rms = 0.0;  ///< root-mean-square residual (units of y)
};

/// Errors: sizes differ, fewer than 3 points, a non-finite value, all x equal, or the
/// optimiser failing outright.
[[nodiscard]] Result<ExpDecayFit> fit_exponential_decay(std::span<const double> x, std::span<const double> y);

}  // namespace visnav::path_following
