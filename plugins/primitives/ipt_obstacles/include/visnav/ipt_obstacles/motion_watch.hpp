// visnav IPT obstacles — watching the corridor ahead for motion while the robot stands (issue 16:
// a person crossing in front of a replaying robot).
//
// The IPT needs the lens to move between two frames (a pair): a standing robot sees nothing
// new, and a crossing person's features break the epipolar geometry of a pair anyway. With the
// camera standing, motion is what a frame difference shows: MotionWatch counts the pixels of
// the corridor mask whose grey level changed by more than diff_threshold between two frames,
// after a 5x5 box blur (sensor noise) and with the second frame scaled to the first's mean
// brightness inside the mask (auto-exposure flicker changes every pixel at once).
//
// The corridor mask: pixels from 2 rows below the horizon down whose ground point (IPT with the
// robot at the origin, robot frame x forward, y left) lies near_m < x ≤ far_m, |y| ≤
// half_width_m, plus those whose ground point lies beyond far_m within the corridor's angular
// width |y|·far_m/x ≤ half_width_m (a person standing in the corridor occludes the ground behind
// it, so its legs and body cover those pixels).
//
// A moving robot (observe(grey, motion)) compares the previous frame warped through the ground
// plane by the odometry motion: ground texture lines up, things above the ground or moving do not.
//
// Not thread-safe (scratch buffers); one per node.
#pragma once

#include <array>
#include <cstddef>
#include <optional>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include "visnav/ipt_obstacles/ipt.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav::ipt {

struct MotionWatchParams {
  double near_m = 0.3;          ///< corridor starts this far ahead of the robot centre, m
  double far_m = 3.5;           ///< and ends here, m
  double half_width_m = 0.8;    ///< half width of the corridor, m
  double diff_threshold = 18.0;  ///< grey levels (after blur and brightness normalisation)
  int min_changed_px = 80;      ///< changed mask pixels that count as motion

  [[nodiscard]] Status validate() const;
  static const ParamSchema<MotionWatchParams>& schema();
};

class MotionWatch {
 public:
  /// Error: camera or params invalid, or the corridor is not in view (empty mask).
  static Result<MotionWatch> create(const IptCamera& camera, const MotionWatchParams& params);

  /// Changed pixels inside the corridor between the previous frame and `grey` (CV_8UC1 of the
  /// camera's size); nullopt for the first frame after reset() (nothing to compare with).
  /// Error: wrong image size/type.
  Result<std::optional<int>> observe(const cv::Mat& grey) { return observe(grey, Pose2D{}); }
  /// The same for a moving robot: `motion` is the robot's pose now in its frame at the previous
  /// frame (odometry). The previous frame is warped onto this one through the ground plane
  /// (the homography of the IPT camera for that motion, its scale searched over 0.5-1.5 for
  /// the odometry's error and timing), so the ground lines up and what changes is what stands
  /// above it (parallax, growing with nearness) or moves.
  Result<std::optional<int>> observe(const cv::Mat& grey, const Pose2D& motion);
  /// True when the last observe() counted at least min_changed_px.
  [[nodiscard]] bool moving() const { return last_changed_px_ >= params_.min_changed_px; }
  void reset() { have_previous_ = false; last_changed_px_ = 0; }
  /// The changed pixels of the last comparison (CV_8UC1, 255 = changed, inside the mask; for a
  /// standing camera those of the last observe(), for a moving one those of the best scale;
  /// empty before the first comparison): where the
  /// moving thing is (crossing_policy.hpp, locate_moving()).
  [[nodiscard]] const cv::Mat& last_changed() const { return changed_; }
  /// The corridor mask (CV_8UC1, 255 inside).
  [[nodiscard]] const cv::Mat& mask() const { return mask_; }

 private:
  MotionWatch(const IptCamera& camera, const MotionWatchParams& params) : camera_(camera), params_(params) {}
  IptCamera camera_;
  MotionWatchParams params_;
  cv::Mat mask_;
  /// Pixels of the mask `valid` whose blurred grey level differs from `previous` by more than
  /// the threshold, after scaling to the same mean brightness.
  int count_changed(const cv::Mat& previous, const cv::Mat& valid);
  cv::Mat previous_, blurred_, diff_, warped_, valid_, prev16_, changed_, best_changed_;
  bool have_previous_ = false;
  int last_changed_px_ = 0;
};

/// The grain of a frame difference's changed pixels (MotionWatch::last_changed()): something
/// standing close ahead (a face 0.6-1.5 m away) shows its texture magnified, so the pixels that
/// do not line up with the ground warp come in solid pieces of hundreds of pixels; the shimmer of
/// fine ground texture 0.8-2 m away (gravel, tiles) comes in specks of a few pixels, however many
/// of them there are. Counted over 4-connected pieces of the changed pixels (no joining: dense
/// specks would chain). Measured on ray-cast frames (test ChangeShape.*): a textured face 0.6 m
/// ahead 4308 changed pixels, mostly in pieces of 100-700 px; 6 mm ground texture 5535, specks.
struct ChangeShapeParams {
  int min_piece_px = 60;      ///< a piece this large (pixels) is solid
  double min_share = 0.5;     ///< solid pieces hold at least this share of the changed pixels ...
  int min_solid_px = 300;     ///< ... and at least this many pixels

  [[nodiscard]] Status validate() const;
  static const ParamSchema<ChangeShapeParams>& schema();
};

struct ChangeShape {
  int changed_px = 0;    ///< all changed pixels
  int solid_px = 0;      ///< changed pixels in pieces of at least min_piece_px
  int pieces = 0;        ///< 4-connected pieces of changed pixels
  int largest_px = 0;    ///< the largest piece
  double share = 0.0;    ///< solid_px / changed_px
  bool compact = false;  ///< share >= min_share and solid_px >= min_solid_px: something close stands ahead
};

/// Measures `changed` (CV_8UC1, 255 = changed). `scratch_*`: reused buffers. Params must validate().
ChangeShape change_shape(const cv::Mat& changed, const ChangeShapeParams& params, cv::Mat& scratch_labels,
                         cv::Mat& scratch_stats, cv::Mat& scratch_centroids);

/// Tells a real change from texture shimmer in the ground-compensated difference while driving.
/// Fine ground texture shimmers as the camera moves (a few hundred pixels change on gravel with
/// nothing there, more at higher speed), so a frame's changed-pixel count triggers only when it
/// is above 3 x the median of the last 10 counts taken at cruising speed (>= 5 of them known),
/// the watch calls it motion, and that holds on 2 frames in a row. Counts while starting or
/// stopping (not cruising) and the triggering counts themselves do not enter the level.
/// Fixed storage: no allocation per frame. Not thread-safe.
class ShimmerTrigger {
 public:
  /// One frame: `changed_px` the watch's count, `cruising` the robot moved >= 2 cm since the
  /// previous frame, `moving` the watch's own verdict. True when the trigger fires.
  bool update(int changed_px, bool cruising, bool moving);
  /// Forgets the run of frames in a row (the level is kept).
  void reset_hits() { hits_ = 0; }

 private:
  static constexpr std::size_t kHistory = 10;
  std::array<int, kHistory> counts_{};  // ring buffer of the last cruising counts
  std::size_t count_n_ = 0, next_ = 0;
  int hits_ = 0;
};

}  // namespace visnav::ipt
