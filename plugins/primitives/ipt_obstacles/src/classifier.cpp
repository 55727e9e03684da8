#include "visnav/ipt_obstacles/classifier.hpp"

#include <cmath>

namespace visnav::ipt {

const char* to_string(FeatureClass label) {
  switch (label) {
    case FeatureClass::ground: return "ground";
    case FeatureClass::obstacle: return "obstacle";
    case FeatureClass::unclassified: return "unclassified";
  }
  return "?";
}

const char* to_string(ClassReason reason) {
  switch (reason) {
    case ClassReason::above_horizon: return "above_horizon";
    case ClassReason::guard_band: return "guard_band";
    case ClassReason::beyond_range: return "beyond_range";
    case ClassReason::no_baseline: return "no_baseline";
    case ClassReason::d_ground: return "d_ground";
    case ClassReason::d_band: return "d_band";
    case ClassReason::d_obstacle: return "d_obstacle";
    case ClassReason::d_below_ground: return "d_below_ground";
  }
  return "?";
}

Status ClassifierParams::validate() const {
  if (auto st = schema().check(*this); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  if (unclassified_bands_m.size() % 2 != 0)
    return Error{"unclassified_bands_m needs pairs lo,hi (got " + std::to_string(unclassified_bands_m.size()) + " values)",
                 ErrorCode::inconsistent};
  for (std::size_t i = 0; i < unclassified_bands_m.size(); i += 2)
    if (!(unclassified_bands_m[i] < unclassified_bands_m[i + 1]))
      return Error{"unclassified_bands_m: band " + std::to_string(i / 2) + " has lo >= hi", ErrorCode::inconsistent};
  return ok();
}

const ParamSchema<ClassifierParams>& ClassifierParams::schema() {
  using P = ClassifierParams;
  static const auto s =
      ParamSchema<P>{}
          .field("beta_m", &P::beta_m, "discrepancy D at or below which a feature is ground (thesis 21 mm)")
          .range(0.0, 1.0)
          .field("unclassified_bands_m", &P::unclassified_bands_m, "D intervals (lo,hi] left unclassified, pairs")
          .range(0.0, 10.0)
          .field("guard_band_px", &P::guard_band_px, "rows below the horizon left unclassified").range(0.0, 1000.0)
          .field("max_range_m", &P::max_range_m, "ground projections farther than this are unclassified")
          .range(0.1, 1000.0)
          .field("max_range_applies_to_obstacles", &P::max_range_applies_to_obstacles,
                 "the range cut also unclassifies OBSTACLE labels (spec 1.5 literally)")
          .field("min_baseline_m", &P::min_baseline_m, "lens translation below which nothing is classified")
          .range(0.0, 1.0)
          .field("signed_discrepancy", &P::signed_discrepancy,
                 "an OBSTACLE-by-D feature whose projection moved with the lens (a point below the ground) is "
                 "unclassified");
  return s;
}

double discrepancy_m(const IptCamera& camera, const LensPose& previous, const LensPose& current,
                     const cv::Point2d& pixel_previous, const cv::Point2d& pixel_current) {
  const GroundHit a = back_project(camera, previous, pixel_previous);
  const GroundHit b = back_project(camera, current, pixel_current);
  if (!a.valid() || !b.valid()) return -1.0;
  return std::hypot(b.ground_m.x - a.ground_m.x, b.ground_m.y - a.ground_m.y);  // (4.9)
}

FeatureClass label_for_discrepancy(double d_m, const ClassifierParams& params, ClassReason* reason) {
  auto out = [&](FeatureClass c, ClassReason r) {
    if (reason != nullptr) *reason = r;
    return c;
  };
  if (d_m < 0.0) return out(FeatureClass::obstacle, ClassReason::above_horizon);
  if (d_m <= params.beta_m) return out(FeatureClass::ground, ClassReason::d_ground);
  for (std::size_t i = 0; i + 1 < params.unclassified_bands_m.size(); i += 2)
    if (d_m > params.unclassified_bands_m[i] && d_m <= params.unclassified_bands_m[i + 1])
      return out(FeatureClass::unclassified, ClassReason::d_band);
  return out(FeatureClass::obstacle, ClassReason::d_obstacle);
}

Result<std::vector<ClassifiedFeature>> classify_features(const IptCamera& camera, const LensPose& previous,
                                                         const LensPose& current,
                                                         std::span<const cv::Point2f> pixel_previous,
                                                         std::span<const cv::Point2f> pixel_current,
                                                         const ClassifierParams& params) {
  if (pixel_previous.size() != pixel_current.size())
    return Error{"classify_features: " + std::to_string(pixel_previous.size()) + " previous and " +
                     std::to_string(pixel_current.size()) + " current pixels",
                 ErrorCode::invalid_value};
  const double v_h = horizon_row_px(camera);
  const double baseline_m = std::hypot(current.x_m - previous.x_m, current.y_m - previous.y_m);
  std::vector<ClassifiedFeature> out(pixel_current.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    ClassifiedFeature& f = out[i];
    f.pixel = pixel_current[i];
    f.pixel_previous = pixel_previous[i];
    const cv::Point2d p0 = pixel_previous[i];
    // (4.14)/(4.15): above the horizon in either frame, the point is above the lens plane.
    if (f.pixel.y < v_h || p0.y < v_h) {
      f.label = FeatureClass::obstacle;
      f.reason = ClassReason::above_horizon;
      continue;
    }
    f.label = FeatureClass::unclassified;
    if (f.pixel.y < v_h + params.guard_band_px || p0.y < v_h + params.guard_band_px) {
      f.reason = ClassReason::guard_band;
      continue;
    }
    const GroundHit hit = back_project(camera, current, f.pixel);
    f.ground_m = hit.ground_m;
    if (baseline_m < params.min_baseline_m) {
      f.reason = ClassReason::no_baseline;
      continue;
    }
    f.discrepancy_m = discrepancy_m(camera, previous, current, p0, f.pixel);
    f.label = label_for_discrepancy(f.discrepancy_m, params, &f.reason);
    if (params.signed_discrepancy && f.label == FeatureClass::obstacle) {
      // An elevated point's projection moves against the lens travel t, by t·h/(Z0 − h).
      const GroundHit before = back_project(camera, previous, p0);
      const cv::Point2d moved = hit.ground_m - before.ground_m;
      const double back_m = -(moved.x * (current.x_m - previous.x_m) + moved.y * (current.y_m - previous.y_m)) / baseline_m;
      if (back_m <= 0.0) {
        f.label = FeatureClass::unclassified;
        f.reason = ClassReason::d_below_ground;
        continue;
      }
    }
    // The range cut (spec §1.5 [I]) on the ground projection. An elevated point projects far
    // beyond where it stands (h = 0.35 m at 1.4 m projects to 7.5 m with Z0 = 0.43 m), so by
    // default the cut spares OBSTACLE labels; see docs/obstacles.md.
    const bool far = std::hypot(hit.ground_m.x - current.x_m, hit.ground_m.y - current.y_m) > params.max_range_m;
    if (far && (f.label != FeatureClass::obstacle || params.max_range_applies_to_obstacles)) {
      f.label = FeatureClass::unclassified;
      f.reason = ClassReason::beyond_range;
    }
  }
  return out;
}

}  // namespace visnav::ipt
