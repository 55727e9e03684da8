// Ray-cast test frames of a textured ground (a lighter path band |y| <= 1.2 on it) with an
// optional textured face standing across the way (the van's rear), for the standing watch and
// the face extent tests. Pure, deterministic.
#pragma once

#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "value_noise.hpp"
#include "visnav/ipt_obstacles/ipt.hpp"
#include "visnav/ipt_obstacles/near_triangulation.hpp"

namespace visnav::ipt::testing {

/// A face x = x_m, y_right_m <= y <= y_left_m, 0 <= z <= height_m, facing the robot.
struct Face {
  double x_m = 7.1, y_right_m = -1.55, y_left_m = 0.35, height_m = 1.9;
};

/// Ray-cast frame of textured ground (a lighter path band |y| <= 1.2 on it), the face if given.
inline cv::Mat render(const IptCamera& camera, const Pose2D& pose, const std::optional<Face>& face) {
  cv::Mat img(camera.height_px, camera.width_px, CV_8UC1, cv::Scalar(128));
  const LensPose lens = lens_pose(camera, pose);
  const cv::Vec3d o(lens.x_m, lens.y_m, camera.height_m);
  // The rays at heading 0, once; a pose's rays are them turned by its heading.
  static std::vector<cv::Vec3d> rays;
  if (rays.empty()) {
    const LensPose level = lens_pose(camera, Pose2D{});
    for (int v = 0; v < camera.height_px; ++v)
      for (int u = 0; u < camera.width_px; ++u)
        rays.push_back(NearTriangulation::ray(camera, level, {static_cast<double>(u), static_cast<double>(v)}));
  }
  const double c = std::cos(pose.heading_rad), sn = std::sin(pose.heading_rad);
  for (int v = 0; v < camera.height_px; ++v) {
    for (int u = 0; u < camera.width_px; ++u) {
      const cv::Vec3d& r = rays[static_cast<std::size_t>(v * camera.width_px + u)];
      const cv::Vec3d d(c * r[0] - sn * r[1], sn * r[0] + c * r[1], r[2]);
      double best = 1e9, value = 210.0;  // sky
      if (d[2] < -1e-9) {
        const double t = -o[2] / d[2];
        const cv::Vec3d p = o + t * d;
        best = t;
        value = 0.5 * value_noise(p[0], p[1], 0.05) + (std::fabs(p[1]) <= 1.2 ? 90.0 : 40.0);
      }
      if (face && std::fabs(d[0]) > 1e-9) {
        const double t = (face->x_m - o[0]) / d[0];
        const cv::Vec3d p = o + t * d;
        if (t > 0.0 && t < best && p[1] >= face->y_right_m && p[1] <= face->y_left_m && p[2] >= 0.0 &&
            p[2] <= face->height_m)
          value = 0.6 * value_noise(p[1], p[2], 0.06) + 60.0;
      }
      img.at<std::uint8_t>(v, u) = cv::saturate_cast<std::uint8_t>(value);
    }
  }
  return img;
}

}  // namespace visnav::ipt::testing
