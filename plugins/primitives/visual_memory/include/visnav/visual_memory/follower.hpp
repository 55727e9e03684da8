// visnav visual memory — replay core (seed 003 Sec. II-B/C with seed 004's control laws).
//
// Per frame (image + odometric distance along the edge):
//  1. Tracking against the next reference I_i: the reference's features are tracked frame to
//     frame with KLT (forward-backward check).
//  2. Pose: PnP (RANSAC) of the reference's triangulated points against their tracked pixels
//     gives the current camera pose relative to I_i, metric (the teach's odometric scale).
//  3. Occlusion handling (seed 003 Fig. 3): every 3D point is reprojected; a tracked point
//     farther than reprojection_gate_px from its projection stops being tracked, an untracked one
//     whose projection is inside the image is resumed there (refined by KLT from the reference
//     image, accepted within the gate).
//  4. Switching: with switch_rule "pose" the robot has passed I_i when its position in I_i's
//     frame has z ≥ -switch_margin_m (seed 003); without a pose, or with "image_error", when ε_i
//     (seed 004) has been below switch_error_px and rises by rise_px. A reference taught
//     switch_odometry_margin_m behind the odometric distance is passed regardless (a safety net,
//     reported as "switched by odometry"). Tracks of features shared with I_{i+1} carry over;
//     the rest are resumed by reprojection through the taught relative pose.
//  5. Goal: the last reference is reached when ε starts to rise below switch_error_px or the
//     pose says passed (seed 003 Sec. II-C); goal_overshoot_m past the edge's length ends the
//     edge by odometry with its own status.
//  6. Control: the selected law (controllers.hpp), plus lateral_gain_radps_per_m times the
//     camera's lateral offset from the pose (not in the seeds; 0 = off); a law that cannot be evaluated this frame
//     (RH/IJP/IJC without a pose or depths) falls back to AIJCA and says so in the status.
//     Turns (seed 003): the centroid offset to I_i, or the taught offset I_i → I_{i+1}, above
//     turn_offset_norm slows to turn_speed_mps.
//  7. Lost: fewer than min_tracked features → wide-baseline relocalisation (ORB, or SIFT as in
//     seed 003 with relocalise_detector=sift, + ratio test +
//     homography RANSAC against references current ± relocalise_window, the best one becomes
//     I_i and its features are initialised through the homography and KLT); after
//     max_lost_frames failed frames the step fails with a reason. The first frame localises
//     the same way (seed 003's initial localisation, without the user's choice).
// Output: a finite command always (zero while lost), a per-frame status and figures.
// Thread-safety: one thread. No clock, no I/O.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "visnav/result.hpp"
#include "visnav/types.hpp"
#include "visnav/visual_memory/controllers.hpp"
#include "visnav/visual_memory/geometry.hpp"
#include "visnav/visual_memory/memory.hpp"
#include "visnav/visual_memory/params.hpp"

namespace visnav::visual_memory {

enum class FollowStatus {
  following,          ///< tracked, pose estimated, controlling
  no_pose,            ///< tracked, but no pose this frame (too few 3D points / degenerate): image-only
  switched,           ///< passed the reference, now heading for the next
  relocalised,        ///< tracking (re)started by wide-baseline matching
  lost,               ///< not tracking; relocalisation failed this frame (command zero)
  bad_frame,          ///< the frame is unusable (command zero)
  goal,               ///< the last reference is reached
  goal_by_odometry,   ///< past the edge's length without the goal image
  failed,             ///< lost for too long; see failure
};
[[nodiscard]] const char* to_string(FollowStatus s);

struct FollowStep {
  Twist command;
  FollowStatus status = FollowStatus::lost;
  std::string detail;           ///< one line: fallbacks, reasons
  std::string failure;          ///< set with FollowStatus::failed
  int target = 0;               ///< index of I_i
  int tracked = 0;
  int tracked_3d = 0;
  int resumed = 0;              ///< resumed by reprojection this frame
  int dropped = 0;              ///< stopped by reprojection this frame
  bool pose_ok = false;
  double image_error_px = 0.0;  ///< ε_i
  double offset_norm = 0.0;     ///< centroid offset x_c - x_n, normalised
  /// The camera's lateral offset from the taught chord (previous reference → I_i), along I_i's x
  /// axis (right positive), m, from the pose; 0 without a pose.
  double lateral_m = 0.0;
  bool turning = false;
  bool saturated = false;
  double confidence = 0.0;      ///< tracked share of I_i's features, scaled, [0, 1]
  [[nodiscard]] bool finished() const { return status == FollowStatus::goal || status == FollowStatus::goal_by_odometry; }
};

class MemoryFollower {
 public:
  /// Errors: invalid params, unknown controller, an empty memory.
  static Result<MemoryFollower> create(const ReplayParams& params, VisualMemory memory, double edge_length_m);

  /// One frame (BGR or grey, the taught size) at `edge_distance_m`. Never throws.
  FollowStep step(const cv::Mat& image, double edge_distance_m);

  [[nodiscard]] const VisualMemory& memory() const { return memory_; }
  [[nodiscard]] int target() const { return target_; }
  /// Current tracked pixel per feature of I_i (valid where tracked()).
  [[nodiscard]] const std::vector<cv::Point2f>& points() const { return points_; }
  [[nodiscard]] const std::vector<std::uint8_t>& tracked() const { return tracked_; }

 private:
  MemoryFollower(const ReplayParams& params, VisualMemory memory, double edge_length_m, Controller controller);
  FollowStep process(const cv::Mat& grey, double edge_distance_m);
  /// The switching rule's verdict for the current target (process' "switching / goal" step).
  struct SwitchDecision {
    bool passed = false;  ///< the target is passed (switch, or the goal if `last`)
    bool last = false;    ///< the target is the last reference
    std::string how;      ///< which rule decided
    double error_px = 0.0;
  };
  // process' steps, in order
  void track_points(const cv::Mat& grey);
  void report_lost(FollowStep& out);
  SwitchDecision decide_switch(const PoseEstimate& pose, double edge_distance_m);
  void switch_to_next(FollowStep& out, const PoseEstimate& pose, const cv::Mat& grey);
  void finish_step(FollowStep& out, const PoseEstimate& pose, bool relocalised, bool passed);
  [[nodiscard]] int count_tracked() const;
  bool relocalise(const cv::Mat& grey);
  void set_target(int index);
  int resume_by_projection(const PoseEstimate& pose, const cv::Mat& grey, int* dropped);
  PoseEstimate pose_now() const;
  /// `grey` with the reference's brightness (illumination_compensation), else `grey` itself.
  const cv::Mat& as_reference_lit(const cv::Mat& grey, const cv::Mat& reference);
  void control(FollowStep& out, const PoseEstimate& pose);
  double taught_offset_norm(int from) const;

  ReplayParams params_;
  VisualMemory memory_;
  double edge_length_m_ = 0.0;
  Controller controller_;
  Intrinsics intrinsics_;
  KltParams klt_;
  ControlGains gains_;
  cv::Ptr<cv::Feature2D> orb_;  ///< the relocalisation detector (ORB or SIFT)
  std::vector<std::optional<std::pair<std::vector<cv::KeyPoint>, cv::Mat>>> orb_cache_;

  int target_ = 0;
  std::vector<cv::Point2f> points_;
  std::vector<std::uint8_t> tracked_;
  cv::Mat previous_;
  cv::Mat lit_;  ///< scratch of as_reference_lit
  bool initialised_ = false;
  int lost_frames_ = 0;
  double min_error_px_ = 0.0;
  bool have_min_error_ = false;
};

}  // namespace visnav::visual_memory
