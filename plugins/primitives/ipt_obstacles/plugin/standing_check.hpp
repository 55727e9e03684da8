// visnav IPT obstacles — ReplayAvoiding's watch for a standing obstacle on the path while the
// replay child drives (issue 16, docs/obstacles.md "A van the path follower keeps the path up
// to"): the longer-baseline triangulation (near_triangulation.hpp) runs on every frame while the
// child drives and StandingWatch (standing_watch.hpp) judges its points; when it fires, the node
// stops the child and starts the lane detour with the face's points. Thin: the logic is in
// standing_watch.hpp.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "avoiding_params.hpp"
#include "visnav/bt/node.hpp"
#include "visnav/ipt_obstacles/face_extent.hpp"
#include "visnav/ipt_obstacles/lane_detour.hpp"
#include "visnav/ipt_obstacles/standing_watch.hpp"

namespace visnav::ipt {

/// One log line's description of a face's extent ("... to ... m left, ... m ahead (n face, m other columns...)").
[[nodiscard]] std::string describe_extent(const FaceExtent& e);
/// A found extent steers the lane detour: its points are added and the side is chosen for the
/// span of the seen points (seen_right_m..seen_left_m) and the extent together. Not found: nothing.
void steer_by_extent(LaneDetour& lane, double seen_right_m, double seen_left_m, const FaceExtent& e);

class StandingCheck {
 public:
  /// nullopt when standing.min_points is 0 (off). Error: a bad value (naming the port and key).
  static Result<std::optional<StandingCheck>> create(const StandingPortParams& standing, double corridor_half_width_m);
  /// One triangulation's points (possibly none) at `pose`, odometer `odometer_m`. A jump of the
  /// odometer since the last call (the watch was not asked: a detour, a back-off, a stop) forgets
  /// the points first; `restarted` tells the caller to restart the triangulation's reference too.
  /// One frame (CV_8UC1) at `pose`, odometer `odometer_m`: triangulates (its own
  /// NearTriangulation with StandingWatch::triangulation_params()) and judges. A jump of the
  /// odometer since the last frame (the watch was not asked: a detour, a back-off, a stop) first
  /// forgets the points and the triangulation's reference. `new_points` receives the count of
  /// this frame's triangulated points. Error: wrong image.
  Result<StandingVerdict> observe(const cv::Mat& grey, const IptCamera& camera, const Pose2D& pose, double odometer_m,
                                  int& new_points);
  /// Forgets the points (a new place).
  void reset() {
    watch_.reset();
    have_last_ = false;
    if (near_) near_->reset();
    trail_.clear();
  }
  [[nodiscard]] double min_range_m() const { return min_range_m_; }
  /// A firing whose extent judges less of the image a face than this is dropped (0 = never).
  [[nodiscard]] double min_face_share() const { return min_face_share_; }
  /// The face's full extent (face_extent.hpp) for a verdict that fired on the last frame observed
  /// (`grey` at `pose`, `odometer_m`), from the frame extent_m back; nullopt when off
  /// (extent_m 0) or no frame is that far back. Error: bad image (a bug).
  Result<std::optional<FaceExtent>> extent(const cv::Mat& grey, const IptCamera& camera, const Pose2D& pose,
                                           double odometer_m, const StandingVerdict& verdict) const;

 private:
  explicit StandingCheck(const StandingWatchParams& params, double min_range_m, double extent_baseline_m,
                         double min_face_share)
      : watch_(params), min_range_m_(min_range_m), extent_baseline_m_(extent_baseline_m), min_face_share_(min_face_share) {}
  StandingWatch watch_;
  double min_range_m_;
  std::optional<NearTriangulation> near_;
  std::vector<cv::Point2d> ground_;
  bool have_last_ = false;
  double last_odometer_m_ = 0.0;
  double extent_baseline_m_ = 0.0;  // 0: no extent from the image
  double min_face_share_ = 0.0;     // 0: every firing starts a detour
  FrameTrail trail_{0.05, 1.2};
};

}  // namespace visnav::ipt
