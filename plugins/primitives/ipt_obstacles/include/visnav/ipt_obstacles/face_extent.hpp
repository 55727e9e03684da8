// visnav IPT obstacles — the full lateral extent of a standing face from two frames ([ours];
// issue 16, docs/obstacles.md "The face's extent from the image (plane sweep at the face's
// depth)").
//
// The standing watch (standing_watch.hpp) triangulates corners; on a plain face (the campus's
// concrete van on gravel of the same grey) they cover only part of it (campus seed 4: 6 corners
// over 0.56 m of a 1.9 m rear), and the lane detour then chooses its side for the part it saw.
// A face is one contiguous plane at one depth, so its image extent follows from the pixels, not
// only from the corners: for every image column, the pixels whose rays meet the vertical plane
// across the heading at the face's distance range_m, at heights min_height_m..max_height_m, are
// predicted in an earlier frame (taken baseline away) twice:
//  * face: the plane point projected into the earlier frame;
//  * no face: the ground point the ray meets behind the plane (below the horizon), or a point
//    far_m away along the ray (above it: the background);
// and the column's sums of absolute differences decide: face when the face prediction's error is
// at most max_ratio times the other and at least min_gain_grey lower per pixel; no face when the
// other way round; unknown when the two predictions hardly differ (no texture, no parallax). The
// extent grows from the columns of the seen points (seen_right_m..seen_left_m) to either side
// over face and unknown columns until non-face columns span max_gap_m across (or the image's
// edge: `clipped_*`); a side that starts with no face column keeps the seen edge. The result is
// its lateral edges at the face's distance and points every step_m across it (odom frame) for
// the lane detour.
// Frames: poses in one ground frame (odom), the robot frame's lateral offsets left +, metres.
// Pure; reentrant.
#pragma once

#include <vector>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include "visnav/ipt_obstacles/ipt.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::ipt {

struct FaceExtentParams {
  double min_height_m = 0.2;    ///< face band: heights on the plane from ...
  double max_height_m = 1.2;    ///< ... to (a van's rear; the camera sees ~1.4 m of it at 2 m)
  double far_m = 30.0;          ///< the background's distance above the horizon
  double max_ratio = 0.8;       ///< face: face error <= max_ratio x the other's (and vice versa)
  double min_gain_grey = 1.0;   ///< ... and lower by at least this per pixel (grey levels)
  double max_gap_m = 0.15;      ///< non-face columns spanning this across end the face
  double max_lateral_m = 2.5;   ///< the extent is searched within this of the heading
  double step_m = 0.1;          ///< spacing of the points put along the face
  int min_pixels = 6;           ///< a column with fewer band pixels (or predictions) is unknown

  [[nodiscard]] Status validate() const;
  static const ParamSchema<FaceExtentParams>& schema();
};

struct FaceExtent {
  double right_m = 0.0;        ///< lateral edges (left +) at the face's distance, robot frame of `now_pose`
  double left_m = 0.0;
  bool clipped_right = false;  ///< the face ran to the image's edge (or max_lateral_m) on that side
  bool clipped_left = false;
  int face_columns = 0;        ///< columns judged face in the extent
  int other_columns = 0;       ///< columns judged not face (any in the band)
  std::vector<cv::Point2d> points;  ///< every step_m from right_m to left_m at the face's distance, odom frame
};

/// `earlier`/`now`: CV_8UC1 frames of the camera's size with the robot's poses when they were
/// taken; `range_m`: the face's distance ahead of the robot at `now_pose`; `seen_right_m` <=
/// `seen_left_m`: the lateral span of the points that found it. Error: bad params, wrong images,
/// a non-positive range or an inverted span (invalid_argument / out_of_range).
[[nodiscard]] Result<FaceExtent> face_extent(const IptCamera& camera, const cv::Mat& earlier, const Pose2D& earlier_pose,
                                             const cv::Mat& now, const Pose2D& now_pose, double range_m,
                                             double seen_right_m, double seen_left_m, const FaceExtentParams& params);

/// The frames of the last stretch of travel, one every `spacing_m` of odometry, for an earlier
/// frame `baseline_m` back (face_extent's). Copies the frames it keeps (a 320x240 grey frame
/// is 77 kB; spacing 0.05 m over 1 m keeps about 20). Not thread-safe.
class FrameTrail {
 public:
  FrameTrail(double spacing_m, double length_m) : spacing_m_(spacing_m), length_m_(length_m) {}
  /// A frame at `pose`, odometer `odometer_m`; kept when spacing_m past the last kept one.
  void add(const cv::Mat& grey, const Pose2D& pose, double odometer_m);
  /// The kept frame nearest to `baseline_m` before `odometer_m` (at least half of it back);
  /// nullptr when none.
  struct Kept {
    cv::Mat grey;
    Pose2D pose;
    double odometer_m = 0.0;
  };
  [[nodiscard]] const Kept* back(double odometer_m, double baseline_m) const;
  void clear() { kept_.clear(); }

 private:
  double spacing_m_, length_m_;
  std::vector<Kept> kept_;
};

}  // namespace visnav::ipt
