// `visnav experiment`: the seed 000 Sec. 6.3/6.4 experiment in the simulator — teach a closed
// route from its script, displace the robot, replay the loop N times, and report each loop's
// end-position error against ground truth, ε_acc and ε_rep (seed 000 eq. 18) and the fitted
// convergence rate, for a hybrid map and a feature-only map of the same route.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core/types.hpp>

#include "visnav/host.hpp"
#include "visnav/types.hpp"

namespace visnav::simop {

/// ε_acc = sqrt(mean ||x_i − x_f||²), ε_rep = sqrt(mean ||x_i − μ||²), μ = mean x_i
/// (seed 000 eq. 18). `ends` are the loop end positions, `taught_end` x_f.
struct AccuracyRepeatability {
  double accuracy_m = 0.0;
  double repeatability_m = 0.0;
};
[[nodiscard]] AccuracyRepeatability accuracy_repeatability(const std::vector<cv::Point2d>& ends,
                                                           const cv::Point2d& taught_end);

/// Entry point of the plugin command (argv[0] = "experiment").
int experiment_command(int argc, char** argv, HostServices& host);

}  // namespace visnav::simop
