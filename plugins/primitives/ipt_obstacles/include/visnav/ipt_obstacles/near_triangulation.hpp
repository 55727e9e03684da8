// visnav IPT obstacles — obstacle points by triangulating tracked corners over a longer baseline
// ([ours]; issue 16, docs/obstacles.md "A van hiding the path").
//
// The IPT classifies features by their motion between two frames about 2 cm apart and finds an
// obstacle's ground contact from its vertical borders; a plain, path-coloured face (a concrete
// van on gravel) gives it nothing until 1 m away. Such a face still has corners (its texture,
// its outline against the scenery, above the horizon too). NearTriangulation tracks Shi-Tomasi
// corners frame to frame (pyramidal LK with a forward-backward check) from a reference frame,
// and once the lens has travelled baseline_m from it, intersects each track's two viewing rays
// (the midpoint of their closest approach; odometry gives the lens poses): a corner that lies
// min_height_m..max_height_m above the ground and at most max_range_m ahead is an obstacle point
// (its ground-plane position). Ground corners triangulate onto the ground, far scenery far away;
// rays closer than min_parallax_rad in angle (corners near the focus of expansion, far ones) or
// passing farther than max_ray_gap_m from each other (a bad track) are skipped. A heading change
// of more than max_rotation_rad from the reference restarts it: meant for a robot driving straight. After each
// triangulation the current frame becomes the reference.
// Frames: the poses and points in the odom frame (x, y), metres. Not thread-safe (scratch).
#pragma once

#include <optional>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "visnav/ipt_obstacles/ipt.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::ipt {

struct NearTriangulationParams {
  int max_corners = 300;
  double quality_level = 0.01;
  double min_distance_px = 5.0;
  int lk_window_px = 15;
  int lk_levels = 3;
  double forward_backward_px = 0.5;  ///< drop a track whose backward LK misses its corner by more
  double baseline_m = 0.3;           ///< lens travel from the reference frame before triangulating
  double max_rotation_rad = 0.05;    ///< a larger heading change from the reference restarts it (odometry's
                                     ///< heading error would dominate the parallax)
  double min_parallax_rad = 0.012;   ///< smallest angle between the two rays (~3 px at f = 277 px)
  double max_ray_gap_m = 0.08;       ///< largest distance between the two rays at their closest
  double min_height_m = 0.15;        ///< above the ground: lower points count as ground
  double max_height_m = 2.5;
  double max_range_m = 4.0;          ///< horizontal distance from the lens now

  [[nodiscard]] Status validate() const;
  static const ParamSchema<NearTriangulationParams>& schema();
};

/// A triangulated corner above the ground.
struct NearPoint {
  cv::Point2d ground_m;  ///< its position projected on the ground, odom frame
  double height_m = 0.0;
};

class NearTriangulation {
 public:
  /// Error: camera or params invalid.
  static Result<NearTriangulation> create(const IptCamera& camera, const NearTriangulationParams& params);

  /// One frame (CV_8UC1 of the camera's size) with the robot's pose when it was taken. Returns
  /// the obstacle points of a triangulation when this frame completes a baseline, else an empty
  /// vector. Error: wrong image size/type.
  Result<std::vector<NearPoint>> observe(const cv::Mat& grey, const Pose2D& robot);
  /// Forgets the reference frame (the next frame becomes it).
  void reset() { have_reference_ = false; }

  /// The midpoint of the closest approach of two rays (origin, direction); nullopt when they are
  /// (nearly) parallel. `gap_m` receives their distance there.
  static std::optional<cv::Vec3d> intersect(const cv::Vec3d& o1, const cv::Vec3d& d1, const cv::Vec3d& o2,
                                            const cv::Vec3d& d2, double& gap_m);
  /// The viewing ray of a pixel (unit direction, ground frame) for the lens at `lens`.
  static cv::Vec3d ray(const IptCamera& camera, const LensPose& lens, const cv::Point2d& pixel_px);

 private:
  NearTriangulation(const IptCamera& camera, const NearTriangulationParams& params) : camera_(camera), params_(params) {}
  void start_reference(const cv::Mat& grey, const Pose2D& robot);

  IptCamera camera_;
  NearTriangulationParams params_;
  bool have_reference_ = false;
  Pose2D reference_pose_;
  std::vector<cv::Point2f> reference_px_, current_px_, next_px_, back_px_;
  std::vector<std::uint8_t> status_, back_status_;
  std::vector<float> errors_;
  cv::Mat previous_;
};

}  // namespace visnav::ipt
