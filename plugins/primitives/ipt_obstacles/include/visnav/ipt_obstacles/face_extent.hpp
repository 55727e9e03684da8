// visnav IPT obstacles — the full lateral extent of a standing face from two frames ([ours];
// issue 16, docs/obstacles.md "The face's extent from the image (plane sweep at the face's
// depth)").
//
// The standing watch (standing_watch.hpp) triangulates corners; on a plain face they cover only
// part of it, or lie at the wrong distance (campus seed 4: 6 corners over 0.56 m "2.24 m ahead",
// the van's 1.9 m rear 3.7 m ahead), and the lane detour chose its side for what it saw (or a gap
// between a face's corners). A face is one contiguous plane at one depth, so its image extent
// follows from the pixels, not only from the corners. For a plane across the heading at distance
// D, every image column's pixels whose rays meet the plane at heights min_height_m..max_height_m
// are predicted in an earlier frame (taken about 0.5 m back) twice:
//  * face: the plane point projected into the earlier frame;
//  * no face: the ground point the ray meets behind the plane (below the horizon), or a point
//    far_m away along the ray (above it: the background);
// the column is face when the face prediction's mean absolute error is at most max_ratio times
// the other's and at least min_gain_grey lower, other the other way round, else unknown (no
// texture, no parallax). Face columns with gaps narrower than max_gap_m between them form runs;
// the run that counts reaches the seen span or the corridor. D is swept from the seen distance
// − depth_below_m to + depth_above_m in depth_step_m; the plane whose run removes the most error
// (Σ other − face over its face columns) is the face's. Before that the earlier frame's heading is
// corrected (the odometry's heading change between the frames is off by up to a few pixels: the
// yaw within ±max_yaw_fix_rad that best aligns the near ground) and its exposure scaled (the
// auto-exposure flicker: one gain from the same ground). A run at least min_width_m wide is the
// face (`found`): its lateral edges at its distance (with the seen span when that distance is the
// seen one) and points every step_m across it (odom frame) for the lane detour; else the seen
// span. side_past() gives the side with the smaller shift for a span.
// Frames: poses in one ground frame (odom), the robot frame's lateral offsets left +, metres.
// Pure; reentrant. Runs once per firing of the standing watch (31 planes over one frame pair: the
// campus pair's test program, start included, took 0.4 s).
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
  double smooth_sigma_px = 0.8;  ///< Gaussian smoothing of both frames before comparing
  double max_yaw_fix_rad = 0.015;  ///< heading correction searched on the near ground; 0 = none
  double depth_below_m = 1.0;   ///< planes swept from this much nearer than the seen distance ...
  double depth_above_m = 2.0;   ///< ... to this much farther (campus seed 4: seen 2.24 m, the face at 3.7 m)
  double depth_step_m = 0.1;    ///< ... in these steps
  double corridor_half_width_m = 0.45;  ///< a face's columns must reach the seen span or this corridor
  double min_width_m = 0.3;     ///< a narrower run of face columns is no face
  int min_pixels = 6;           ///< a column with fewer band pixels (or predictions) is unknown

  [[nodiscard]] Status validate() const;
  static const ParamSchema<FaceExtentParams>& schema();
};

/// One image column's judgement (for logs and tests).
struct FaceColumn {
  int u_px = 0;
  double lateral_m = 0.0;     ///< mean lateral offset of its band pixels on the plane
  double err_face = 0.0;      ///< mean |now − earlier| with the face prediction, grey levels
  double err_other = 0.0;     ///< ... with the ground/background prediction
  int pixels = 0;
  int judged = 0;             ///< +1 face, −1 other, 0 unknown
};

struct FaceExtent {
  bool found = false;          ///< a run of face columns at least min_width_m wide (else the seen span at range_m)
  double range_m = 0.0;        ///< the face's distance: the swept plane with the most face columns
  double right_m = 0.0;        ///< lateral edges (left +) at the face's distance, robot frame of `now_pose`
  double left_m = 0.0;
  bool clipped_right = false;  ///< the face ran to the image's edge (or max_lateral_m) on that side
  bool clipped_left = false;
  double yaw_fix_rad = 0.0;    ///< heading correction applied to the earlier frame
  double gain = 1.0;           ///< exposure gain applied to the earlier frame
  int face_columns = 0;        ///< columns judged face in the extent
  int other_columns = 0;       ///< columns judged not face (any in the band)
  /// face_columns / (face_columns + other_columns), 0 when no column was judged: how much of
  /// what the image could judge looks like a standing face. Campus replays (docs/obstacles.md,
  /// "A standing face the image does not show"): the van's rear 0.57-0.89, the watch's false
  /// firings on the gravel border 0.07-0.10.
  [[nodiscard]] double face_share() const {
    const int judged = face_columns + other_columns;
    return judged > 0 ? static_cast<double>(face_columns) / judged : 0.0;
  }
  std::vector<cv::Point2d> points;  ///< every step_m from right_m to left_m at the face's distance, odom frame
  std::vector<FaceColumn> columns;  ///< every column with band pixels, left to right in the image
};

/// `earlier`/`now`: CV_8UC1 frames of the camera's size with the robot's poses when they were
/// taken; `range_m`: the face's distance ahead of the robot at `now_pose`; `seen_right_m` <=
/// `seen_left_m`: the lateral span of the points that found it. Error: bad params, wrong images,
/// a non-positive range or an inverted span (invalid_argument / out_of_range).
[[nodiscard]] Result<FaceExtent> face_extent(const IptCamera& camera, const cv::Mat& earlier, const Pose2D& earlier_pose,
                                             const cv::Mat& now, const Pose2D& now_pose, double range_m,
                                             double seen_right_m, double seen_left_m, const FaceExtentParams& params);

/// The side (+1 left, −1 right) on which an obstacle spanning right_m..left_m across the heading
/// (left +) is passed with the smaller shift: left when left_m <= −right_m.
[[nodiscard]] int side_past(double right_m, double left_m);

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
