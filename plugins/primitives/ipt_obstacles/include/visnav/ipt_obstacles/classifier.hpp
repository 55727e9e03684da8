// visnav IPT obstacles — the obstacle/ground feature classifier (thesis §4.2-4.3; spec §3).
//
// A feature tracked from frame k−1 to frame k is back-projected onto the ground with each
// frame's own lens pose. A point on the ground lands at the same place twice; a point above
// it does not. The discrepancy D (4.9) between the two ground positions decides the label:
//
//   v < v_h (λ* < 0, 4.14/4.15)                 OBSTACLE      (no D computed)
//   v_h ≤ v < v_h + guard_band_px               UNCLASSIFIED  [spec §1.5 I]
//   lens moved < min_baseline_m                 UNCLASSIFIED  [spec §2.1 I]
//   D ≤ beta_m                                  GROUND
//   D in a stored band (lo, hi]                 UNCLASSIFIED  (the D-interval filter, §3.4)
//   otherwise                                   OBSTACLE
//   then: ground projection farther than max_range_m → UNCLASSIFIED [spec §1.5 I], except
//   OBSTACLE labels unless max_range_applies_to_obstacles (an elevated point projects far).
//
// Defaults are the thesis's: β = 21 mm (§3.3), band (21, 50] mm (§3.4). With pure camera
// translation t a point at height h gives D = |t|·|h|/(Z0 − h) (spec §3.5), so β and the band
// are tied to the baseline: pair frames about 2 cm apart as the thesis did.
//
// Units: metres, pixels; poses in one ground frame (world or odom). Pure, thread-safe.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core/types.hpp>

#include "visnav/ipt_obstacles/ipt.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav::ipt {

enum class FeatureClass : std::uint8_t { ground = 0, obstacle = 1, unclassified = 2 };
[[nodiscard]] const char* to_string(FeatureClass label);

/// Why a feature got its label (one per row of the decision table above).
enum class ClassReason : std::uint8_t {
  above_horizon,   ///< v < v_h: OBSTACLE
  guard_band,      ///< just below the horizon, range unreliable: UNCLASSIFIED
  beyond_range,    ///< ground projection farther than max_range_m: UNCLASSIFIED
  no_baseline,     ///< lens moved less than min_baseline_m: UNCLASSIFIED (no parallax)
  d_ground,        ///< D ≤ β: GROUND
  d_band,          ///< D in a stored band: UNCLASSIFIED
  d_obstacle,      ///< D above β and outside every band: OBSTACLE
  d_below_ground,  ///< D says OBSTACLE but the projection moved with the lens, not against it: UNCLASSIFIED
};
[[nodiscard]] const char* to_string(ClassReason reason);

struct ClassifierParams {
  double beta_m = 0.021;                                ///< β, thesis §4.3 (f(β) = FP + 0.5 FN minimum)
  std::vector<double> unclassified_bands_m{0.021, 0.050};  ///< pairs (lo, hi], thesis §4.3 D-interval filter
  double guard_band_px = 3.0;                           ///< rows below v_h left unclassified [spec §1.5 I]
  double max_range_m = 3.0;                             ///< farther ground projections unclassified [spec §1.5 I]
  double min_baseline_m = 0.005;                        ///< below: no classification [spec §2.1 I]
  bool max_range_applies_to_obstacles = false;          ///< true: spec §1.5 literally
  /// [ours, measured] The direction of the discrepancy: the IPT projection of a point at height
  /// 0 < h < Z0 moves by exactly −t·h/(Z0 − h) (t the lens travel; spec §3.5), i.e. against the
  /// travel. A feature that D (4.9) labels OBSTACLE but whose projection moved with the lens
  /// (component along t ≥ 0: a point below the ground, i.e. tracking noise) is UNCLASSIFIED
  /// (reason d_below_ground). D itself, and so the ROC's scores, stay the thesis's length.
  /// Off by default: it drops OBSTACLE labels of points high on an obstacle too, and in test
  /// ReplayAvoiding.TheLaneDetourKeepsItsSideBeforeAVanAndStopsWithTheReason the IPT then no
  /// longer closed the lane beside the van and the detour hit its corner (docs/obstacles.md).
  bool signed_discrepancy = false;

  /// Schema ranges, bands as ordered (lo < hi) pairs.
  [[nodiscard]] Status validate() const;
  static const ParamSchema<ClassifierParams>& schema();
};

struct ClassifiedFeature {
  FeatureClass label = FeatureClass::unclassified;
  ClassReason reason = ClassReason::no_baseline;
  double discrepancy_m = -1.0;  ///< D; −1 when not computed (above horizon, guard band, no baseline)
  cv::Point2d ground_m;         ///< ground projection in frame k (valid when below the guard band)
  cv::Point2d pixel;            ///< the feature in frame k
  cv::Point2d pixel_previous;   ///< the same track in frame k−1 (the ground-feature EKF observes both)
};

/// The ground-projection discrepancy D (4.9) of one track; −1 when either pixel does not
/// meet the ground ahead (λ* ≤ 0 in one of the frames).
[[nodiscard]] double discrepancy_m(const IptCamera& camera, const LensPose& previous, const LensPose& current,
                                   const cv::Point2d& pixel_previous, const cv::Point2d& pixel_current);

/// Labels with the decision table alone, from D (for β sweeps and tests).
[[nodiscard]] FeatureClass label_for_discrepancy(double discrepancy_m, const ClassifierParams& params,
                                                 ClassReason* reason = nullptr);

/// Classifies tracks (pixel_previous[i] → pixel_current[i]) between two lens poses.
/// Error (invalid_value) when the spans differ in length; camera and params must validate().
[[nodiscard]] Result<std::vector<ClassifiedFeature>> classify_features(
    const IptCamera& camera, const LensPose& previous, const LensPose& current,
    std::span<const cv::Point2f> pixel_previous, std::span<const cv::Point2f> pixel_current,
    const ClassifierParams& params);

}  // namespace visnav::ipt
