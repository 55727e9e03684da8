#include "visnav/ipt_obstacles/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <nlopt.h>

#include "visnav/ipt_obstacles/classifier.hpp"

namespace visnav::ipt {

namespace {

struct Problem {
  IptCamera camera;
  std::span<const CalibrationPair> pairs;
  CalibrationOptions options;
  int evaluations = 0;
};

/// Transfer error of one track, pixels: the IPT ground point of the pixel in one frame,
/// projected into the other frame (DPT), against the tracked pixel; nullopt-like −1 when the
/// pixel does not meet the ground.
double transfer_px(const IptCamera& camera, const LensPose& from, const LensPose& to, const cv::Point2d& p_from,
                   const cv::Point2d& p_to) {
  const GroundHit hit = back_project(camera, from, p_from);
  if (!hit.valid()) return -1.0;
  const auto q = project_point(camera, to, {hit.ground_m.x, hit.ground_m.y, 0.0});
  if (!q) return -1.0;
  return std::hypot(q->x - p_to.x, q->y - p_to.y);
}

/// Mean of capped symmetric transfer errors² (px²); `rms_d` gets the RMS discrepancy D (m)
/// over the tracks meeting the ground.
double cost(const IptCamera& camera, const Problem& p, double* rms_d) {
  double sum = 0.0, d_sum = 0.0;
  long n = 0, valid = 0;
  const double cap = p.options.max_transfer_px;
  for (const auto& pair : p.pairs) {
    const LensPose a = lens_pose(camera, pair.pose_a), b = lens_pose(camera, pair.pose_b);
    for (std::size_t i = 0; i < pair.pixels_a.size(); ++i) {
      for (const double e : {transfer_px(camera, a, b, pair.pixels_a[i], pair.pixels_b[i]),
                             transfer_px(camera, b, a, pair.pixels_b[i], pair.pixels_a[i])}) {
        const double c = e < 0.0 ? cap : std::min(e, cap);
        sum += c * c;
        ++n;
      }
      const double d = discrepancy_m(camera, a, b, pair.pixels_a[i], pair.pixels_b[i]);
      if (d >= 0.0) {
        d_sum += d * d;
        ++valid;
      }
    }
  }
  if (rms_d != nullptr) *rms_d = valid > 0 ? std::sqrt(d_sum / static_cast<double>(valid)) : 0.0;
  return n > 0 ? sum / static_cast<double>(n) : 0.0;
}

double objective(unsigned /*n*/, const double* x, double* /*grad*/, void* data) {
  auto* p = static_cast<Problem*>(data);
  ++p->evaluations;
  IptCamera c = p->camera;
  c.height_m = x[0];
  c.pitch_rad = x[1];
  return cost(c, *p, nullptr);
}

}  // namespace

Result<CalibrationResult> calibrate_height_pitch(const IptCamera& initial, std::span<const CalibrationPair> pairs,
                                                 const CalibrationOptions& options) {
  int tracks = 0;
  for (const auto& pair : pairs) {
    if (pair.pixels_a.size() != pair.pixels_b.size())
      return Error{"calibrate-ipt: a pair has " + std::to_string(pair.pixels_a.size()) + " and " +
                       std::to_string(pair.pixels_b.size()) + " pixels",
                   ErrorCode::invalid_value};
    if (std::hypot(pair.pose_b.x_m - pair.pose_a.x_m, pair.pose_b.y_m - pair.pose_a.y_m) < 1e-3)
      return Error{"calibrate-ipt: a pair has no baseline (the robot must move between its frames)",
                   ErrorCode::invalid_value};
    tracks += static_cast<int>(pair.pixels_a.size());
  }
  if (tracks < options.min_tracks)
    return Error{"calibrate-ipt: " + std::to_string(tracks) + " tracks, at least " + std::to_string(options.min_tracks) +
                     " needed (is there textured ground in view?)",
                 ErrorCode::invalid_value};
  Problem problem{initial, pairs, options};
  CalibrationResult result;
  result.tracks = tracks;
  (void)cost(initial, problem, &result.initial_rms_discrepancy_m);
  nlopt_opt opt = nlopt_create(NLOPT_LN_BOBYQA, 2);
  const double lower[2] = {0.05, -1.4}, upper[2] = {5.0, 0.5};
  nlopt_set_lower_bounds(opt, lower);
  nlopt_set_upper_bounds(opt, upper);
  nlopt_set_min_objective(opt, &objective, &problem);
  nlopt_set_xtol_rel(opt, options.tolerance);
  nlopt_set_maxeval(opt, options.max_evaluations);
  const double step[2] = {0.05, 0.02};
  nlopt_set_initial_step(opt, step);
  double x[2] = {std::clamp(initial.height_m, 0.05, 5.0), std::clamp(initial.pitch_rad, -1.4, 0.5)};
  double minimum = 0.0;
  const nlopt_result status = nlopt_optimize(opt, x, &minimum);
  nlopt_destroy(opt);
  if (status < 0) return Error{"calibrate-ipt: NLopt failed (code " + std::to_string(static_cast<int>(status)) + ")"};
  IptCamera best = initial;
  best.height_m = x[0];
  best.pitch_rad = x[1];
  if (auto st = best.validate(); !st) return st.error().with_context("calibrate-ipt: the estimate is unusable");
  result.height_m = x[0];
  result.pitch_rad = x[1];
  result.evaluations = problem.evaluations;
  (void)cost(best, problem, &result.rms_discrepancy_m);
  return result;
}

}  // namespace visnav::ipt
