#include "visnav/ipt_obstacles/ipt.hpp"

#include <cmath>
#include <string>

namespace visnav::ipt {

Status IptCamera::validate() const {
  if (auto st = schema().check(*this); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  const double v_h = horizon_row_px(*this);
  if (!(v_h < height_px - 1.0))
    return Error{"no ground visible: the horizon row " + std::to_string(v_h) + " px is at or below the bottom row " +
                     std::to_string(height_px - 1) + " (pitch_rad " + std::to_string(pitch_rad) +
                     " looks too far up for fy_px " + std::to_string(fy_px) + ")",
                 ErrorCode::out_of_range, {{}, 0, "pitch_rad"}};
  return ok();
}

const ParamSchema<IptCamera>& IptCamera::schema() {
  using P = IptCamera;
  static const auto s = ParamSchema<P>{}
                            .field("width_px", &P::width_px, "image width").range(16, 8192)
                            .field("height_px", &P::height_px, "image height").range(16, 8192)
                            .field("fx_px", &P::fx_px, "focal length along u, pixels").range(1.0, 1e5)
                            .field("fy_px", &P::fy_px, "focal length along v, pixels").range(1.0, 1e5)
                            .field("cx_px", &P::cx_px, "principal point u").range(-1e4, 1e4)
                            .field("cy_px", &P::cy_px, "principal point v").range(-1e4, 1e4)
                            .field("height_m", &P::height_m, "lens height above the ground").range(0.05, 5.0)
                            .field("pitch_rad", &P::pitch_rad, "camera pitch, negative looks down (thesis sign)")
                            .range(-1.4, 0.5)
                            .field("forward_m", &P::forward_m, "lens ahead of the robot origin").range(-5.0, 5.0)
                            .field("lateral_m", &P::lateral_m, "lens left of the robot origin").range(-5.0, 5.0);
  return s;
}

LensPose lens_pose(const IptCamera& camera, const Pose2D& robot) {
  const double c = std::cos(robot.heading_rad), s = std::sin(robot.heading_rad);
  return LensPose{robot.x_m + c * camera.forward_m - s * camera.lateral_m,
                  robot.y_m + s * camera.forward_m + c * camera.lateral_m, robot.heading_rad};
}

std::optional<cv::Point2d> project_point(const IptCamera& camera, const LensPose& lens, const cv::Vec3d& point_m) {
  const double theta = lens.azimuth_rad - CV_PI / 2.0;  // thesis yaw, from +y
  const double ct = std::cos(theta), st = std::sin(theta);
  const double cp = std::cos(camera.pitch_rad), sp = std::sin(camera.pitch_rad);
  const double dx = point_m[0] - lens.x_m, dy = point_m[1] - lens.y_m, dz = point_m[2] - camera.height_m;
  // Spec §1.2: Δ·r, Δ·o, Δ·w with the right, optical-axis and up vectors of (4.6).
  const double dr = dx * ct + dy * st;
  const double dot_o = -dx * cp * st + dy * cp * ct + dz * sp;
  const double dw = dx * sp * st - dy * sp * ct + dz * cp;
  if (dot_o <= 1e-9) return std::nullopt;
  const double xn = dr / dot_o, yn = dw / dot_o;
  return cv::Point2d(camera.cx_px + camera.fx_px * xn, camera.cy_px - camera.fy_px * yn);
}

GroundHit back_project(const IptCamera& camera, const LensPose& lens, const cv::Point2d& pixel) {
  const double theta = lens.azimuth_rad - CV_PI / 2.0;
  const double ct = std::cos(theta), st = std::sin(theta);
  const double cp = std::cos(camera.pitch_rad), sp = std::sin(camera.pitch_rad);
  const double xn = (pixel.x - camera.cx_px) / camera.fx_px;  // x_p / f
  const double yn = (camera.cy_px - pixel.y) / camera.fy_px;  // y_p / f
  const double z0 = camera.height_m;
  const double den = yn * cp + sp;  // (y_p cosφ + f sinφ) / f
  GroundHit hit;
  if (den == 0.0) return hit;  // the horizon row itself: the ray is parallel to the ground
  hit.lambda = -z0 / den;      // (4.13)
  // (4.7), (4.8)
  hit.ground_m.x = lens.x_m - (z0 * xn * ct + (yn * sp - cp) * z0 * st) / den;
  hit.ground_m.y = lens.y_m - (z0 * xn * st - (yn * sp - cp) * z0 * ct) / den;
  return hit;
}

double horizon_row_px(const IptCamera& camera) { return camera.cy_px + camera.fy_px * std::tan(camera.pitch_rad); }

RangeBearing range_bearing(const Pose2D& robot, const cv::Point2d& ground_m) {
  const cv::Point2d local = to_robot_frame(robot, ground_m);
  return RangeBearing{std::hypot(local.x, local.y), std::atan2(local.y, local.x)};
}

cv::Point2d to_robot_frame(const Pose2D& robot, const cv::Point2d& ground_m) {
  const double c = std::cos(robot.heading_rad), s = std::sin(robot.heading_rad);
  const double dx = ground_m.x - robot.x_m, dy = ground_m.y - robot.y_m;
  return {c * dx + s * dy, -s * dx + c * dy};
}

}  // namespace visnav::ipt
