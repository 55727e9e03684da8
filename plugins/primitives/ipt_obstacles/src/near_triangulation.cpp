// Triangulation of tracked corners over a longer baseline (see the header).
#include "visnav/ipt_obstacles/near_triangulation.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

namespace visnav::ipt {

Status NearTriangulationParams::validate() const {
  if (auto st = schema().check(*this); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  if (max_height_m <= min_height_m)
    return Error{"max_height_m must exceed min_height_m", ErrorCode::inconsistent, ErrorLocation({}, 0, "max_height_m")};
  return ok();
}

const ParamSchema<NearTriangulationParams>& NearTriangulationParams::schema() {
  using P = NearTriangulationParams;
  static const auto s = ParamSchema<P>{}
                            .field("max_corners", &P::max_corners, "Shi-Tomasi corners per reference frame").range(1, 5000)
                            .field("quality_level", &P::quality_level, "goodFeaturesToTrack quality").range(1e-4, 1.0)
                            .field("min_distance_px", &P::min_distance_px, "corner spacing, px").range(0.0, 100.0)
                            .field("lk_window_px", &P::lk_window_px, "LK window, px").range(3, 101)
                            .field("lk_levels", &P::lk_levels, "LK pyramid levels").range(0, 8)
                            .field("forward_backward_px", &P::forward_backward_px, "forward-backward check, px")
                            .range(0.01, 20.0)
                            .field("baseline_m", &P::baseline_m, "lens travel before triangulating, m").range(0.02, 5.0)
                            .field("max_rotation_rad", &P::max_rotation_rad, "heading change that restarts the reference, rad")
                            .range(0.0, 1.0)
                            .field("min_parallax_rad", &P::min_parallax_rad, "smallest angle between the rays, rad")
                            .range(0.0, 1.0)
                            .field("max_ray_gap_m", &P::max_ray_gap_m, "largest distance between the rays, m")
                            .range(0.001, 5.0)
                            .field("min_height_m", &P::min_height_m, "lower points count as ground, m").range(0.0, 10.0)
                            .field("max_height_m", &P::max_height_m, "higher points are ignored, m").range(0.01, 50.0)
                            .field("max_range_m", &P::max_range_m, "farther points are ignored, m").range(0.1, 100.0);
  return s;
}

Result<NearTriangulation> NearTriangulation::create(const IptCamera& camera, const NearTriangulationParams& params) {
  VISNAV_TRY(camera.validate());
  VISNAV_TRY(params.validate());
  return NearTriangulation(camera, params);
}

cv::Vec3d NearTriangulation::ray(const IptCamera& camera, const LensPose& lens, const cv::Point2d& pixel_px) {
  // The right (r), optical-axis (o) and up (w) vectors of project_point(): Δ = λ(o + xn r + yn w).
  const double theta = lens.azimuth_rad - CV_PI / 2.0;
  const double ct = std::cos(theta), st = std::sin(theta);
  const double cp = std::cos(camera.pitch_rad), sp = std::sin(camera.pitch_rad);
  const cv::Vec3d r(ct, st, 0.0), o(-cp * st, cp * ct, sp), w(sp * st, -sp * ct, cp);
  const double xn = (pixel_px.x - camera.cx_px) / camera.fx_px;
  const double yn = (camera.cy_px - pixel_px.y) / camera.fy_px;
  const cv::Vec3d d = o + xn * r + yn * w;
  return d / cv::norm(d);
}

std::optional<cv::Vec3d> NearTriangulation::intersect(const cv::Vec3d& o1, const cv::Vec3d& d1, const cv::Vec3d& o2,
                                                      const cv::Vec3d& d2, double& gap_m) {
  const cv::Vec3d w0 = o1 - o2;
  const double a = d1.dot(d1), b = d1.dot(d2), c = d2.dot(d2), d = d1.dot(w0), e = d2.dot(w0);
  const double den = a * c - b * b;
  if (den < 1e-12) return std::nullopt;
  const double t1 = (b * e - c * d) / den, t2 = (a * e - b * d) / den;
  if (t1 <= 0.0 || t2 <= 0.0) return std::nullopt;  // behind a lens
  const cv::Vec3d p1 = o1 + t1 * d1, p2 = o2 + t2 * d2;
  gap_m = cv::norm(p1 - p2);
  return 0.5 * (p1 + p2);
}

void NearTriangulation::start_reference(const cv::Mat& grey, const Pose2D& robot) {
  cv::goodFeaturesToTrack(grey, reference_px_, params_.max_corners, params_.quality_level, params_.min_distance_px);
  current_px_ = reference_px_;
  reference_pose_ = robot;
  grey.copyTo(previous_);
  have_reference_ = true;
}

Result<std::vector<NearPoint>> NearTriangulation::observe(const cv::Mat& grey, const Pose2D& robot) {
  if (grey.type() != CV_8UC1 || grey.rows != camera_.height_px || grey.cols != camera_.width_px)
    return Error{"near triangulation: expected a " + std::to_string(camera_.width_px) + "x" +
                     std::to_string(camera_.height_px) + " grey image",
                 ErrorCode::invalid_value};
  std::vector<NearPoint> out;
  if (!have_reference_ || current_px_.empty()) {
    start_reference(grey, robot);
    return out;
  }
  // Frame to frame: small motion for LK; the forward-backward check drops drifting tracks.
  const cv::Size window(params_.lk_window_px, params_.lk_window_px);
  cv::calcOpticalFlowPyrLK(previous_, grey, current_px_, next_px_, status_, errors_, window, params_.lk_levels);
  cv::calcOpticalFlowPyrLK(grey, previous_, next_px_, back_px_, back_status_, errors_, window, params_.lk_levels);
  std::size_t kept = 0;
  for (std::size_t i = 0; i < current_px_.size(); ++i) {
    const cv::Point2f& p = next_px_[i];
    const bool inside = p.x >= 0.0f && p.y >= 0.0f && p.x < static_cast<float>(grey.cols) && p.y < static_cast<float>(grey.rows);
    if (status_[i] == 0 || back_status_[i] == 0 || !inside ||
        cv::norm(back_px_[i] - current_px_[i]) > params_.forward_backward_px)
      continue;
    reference_px_[kept] = reference_px_[i];
    current_px_[kept] = p;
    ++kept;
  }
  reference_px_.resize(kept);
  current_px_.resize(kept);
  grey.copyTo(previous_);
  if (std::abs(std::remainder(robot.heading_rad - reference_pose_.heading_rad, 2.0 * CV_PI)) > params_.max_rotation_rad) {
    start_reference(grey, robot);
    return out;
  }
  const LensPose a = lens_pose(camera_, reference_pose_), b = lens_pose(camera_, robot);
  if (std::hypot(b.x_m - a.x_m, b.y_m - a.y_m) < params_.baseline_m) return out;
  const cv::Vec3d oa(a.x_m, a.y_m, camera_.height_m), ob(b.x_m, b.y_m, camera_.height_m);
  for (std::size_t i = 0; i < kept; ++i) {
    const cv::Vec3d da = ray(camera_, a, reference_px_[i]), db = ray(camera_, b, current_px_[i]);
    if (std::acos(std::clamp(da.dot(db), -1.0, 1.0)) < params_.min_parallax_rad) continue;
    double gap = 0.0;
    const auto p = intersect(oa, da, ob, db, gap);
    if (!p || gap > params_.max_ray_gap_m) continue;
    const double height = (*p)[2];
    const double range = std::hypot((*p)[0] - b.x_m, (*p)[1] - b.y_m);
    if (height < params_.min_height_m || height > params_.max_height_m || range > params_.max_range_m) continue;
    out.push_back({cv::Point2d((*p)[0], (*p)[1]), height});
  }
  start_reference(grey, robot);
  return out;
}

}  // namespace visnav::ipt
