// visnav IPT obstacles — one cycle of the thesis pipeline on a frame stream (spec §0 steps
// 2-6): Shi-Tomasi corners tracked by pyramidal Lucas-Kanade from the pair's first frame,
// RANSAC on F, classification, reduced Canny and contact points.
//
// Frames are paired by travelled distance, not by time (spec §3.6 [I]): the first frame of a
// pair is kept until the lens has moved pair_distance_m (thesis ≈ 2 cm), so β keeps its meaning
// at any frame rate and speed. Turning in place gives no pair (no parallax, spec §3.5), and a
// pair that turned more than max_pair_rotation_rad restarts (tracks across a fast turn fail).
//
// Input: grey CV_8UC1 frames of the IptCamera's size (undistorted) and the odometry pose of
// each (odom frame). Output: the classified inliers and the contact points of the latest pair.
// Not thread-safe; owns its buffers (no allocation once sizes are stable, except OpenCV's
// feature and flow internals).
#pragma once

#include <optional>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "visnav/ipt_obstacles/classifier.hpp"
#include "visnav/ipt_obstacles/ipt.hpp"
#include "visnav/ipt_obstacles/profiles.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::ipt {

struct PipelineParams {
  int max_features = 250;            ///< KLT corners (thesis Ch. 5)
  double quality_level = 0.01;       ///< goodFeaturesToTrack [spec §2 I]
  double min_distance_px = 5.0;      ///< [spec §2 I]
  int lk_window_px = 15;             ///< calcOpticalFlowPyrLK window [spec §2 I]
  int lk_levels = 3;
  double ransac_threshold_px = 1.0;  ///< thesis §4.2.1
  int ransac_iterations = 500;       ///< thesis §4.2.1
  double pair_distance_m = 0.02;     ///< lens travel between the frames of a pair (thesis ≈ 2 cm)
  double max_pair_distance_m = 0.2;  ///< a longer gap (stall, jump) restarts the pair
  double max_pair_rotation_rad = 0.05;  ///< a larger turn within a pair restarts it (KLT needs small motion) [ours]
  double forward_backward_px = 0.2;  ///< [ours, measured] > 0: drop tracks whose backward LK track misses the corner by more
  double odometry_epipolar_px = 0.0;  ///< [ours] > 0: also drop matches farther than this from the epipolar
                                      ///< line the odometry's lens motion predicts (0 = off: RANSAC alone)

  [[nodiscard]] Status validate() const;
  static const ParamSchema<PipelineParams>& schema();
};

/// The lens motion of a pair from the odometry: with it every first-frame pixel has one
/// epipolar line in the second frame (the second view of its ray), with no model to fit.
struct OdometryEpipolar {
  IptCamera camera;
  LensPose first, second;
};

/// Distance in pixels of `b` from the epipolar line of `a` that the lens motion predicts (the
/// line through the second views of the ray's points 0.3 and 1000 optical-axis units out); the
/// distance to the one view when both coincide (a point at the epipole), infinity when the
/// ray's points are not both in front of the second lens.
[[nodiscard]] double odometry_epipolar_distance_px(const OdometryEpipolar& motion, const cv::Point2d& a,
                                                   const cv::Point2d& b);

/// Scratch of track_pair() (no allocation once sizes are stable).
struct TrackScratch {
  std::vector<cv::Point2f> corners, tracked, back;
  std::vector<std::uint8_t> status, back_status, inliers;
  std::vector<float> errors;
};

/// Steps 2-3 of the cycle for one pair: Shi-Tomasi corners in `first`, pyramidal LK into
/// `second` (with the forward-backward check when forward_backward_px > 0), RANSAC on F.
/// Fills the inlier tracks `a` → `b`; returns the number of RANSAC outliers.
/// With `motion` and odometry_epipolar_px > 0 the odometric check follows RANSAC.
int track_pair(const cv::Mat& first, const cv::Mat& second, const PipelineParams& params, std::vector<cv::Point2f>& a,
               std::vector<cv::Point2f>& b, TrackScratch& scratch, const OdometryEpipolar* motion = nullptr);

/// Step 3 alone: RANSAC on the fundamental matrix (ransac_threshold_px, ransac_iterations,
/// confidence 0.99) over the matches a[i] → b[i]; keeps the inliers in a and b (in order) and
/// returns how many were dropped. Fewer than 8 matches (or sizes that differ): nothing dropped.
/// `inliers` is scratch (the mask of the last call, 0 for every dropped match). With `motion`
/// and odometry_epipolar_px > 0, a RANSAC inlier farther than odometry_epipolar_px from its
/// odometric epipolar line (odometry_epipolar_distance_px) is dropped too: at the thesis's 2 cm
/// baseline the flow is a few pixels and many F fit the inliers, so RANSAC alone keeps 5-8 % of
/// the outliers (docs/obstacles.md, "Other measurements").
int reject_epipolar_outliers(std::vector<cv::Point2f>& a, std::vector<cv::Point2f>& b, const PipelineParams& params,
                             std::vector<std::uint8_t>& inliers, const OdometryEpipolar* motion = nullptr);

struct PairResult {
  std::vector<ClassifiedFeature> features;
  std::vector<ContactPoint> contacts;
  std::vector<cv::Point2d> span_points;  ///< fill_obstacle_spans() of the contacts (ground frame)
  Pose2D pose;                       ///< odometry pose of the pair's second frame
  Pose2D first_pose;                 ///< odometry pose of the pair's first frame
  int ransac_outliers = 0;
};

class ObstaclePipeline {
 public:
  /// All params must validate() (checked by create()).
  static Result<ObstaclePipeline> create(IptCamera camera, PipelineParams pipeline, ClassifierParams classifier,
                                         ProfileParams profiles);

  /// Feeds one frame. Returns a result when this frame closes a pair, nullopt while waiting
  /// for enough travel. Error (invalid_value) for a frame of the wrong size or type.
  Result<std::optional<PairResult>> process(const cv::Mat& grey, const Pose2D& odom_pose);
  void restart();

  [[nodiscard]] const IptCamera& camera() const { return camera_; }

 private:
  ObstaclePipeline(IptCamera camera, PipelineParams pipeline, ClassifierParams classifier, ProfileParams profiles)
      : camera_(camera), pipeline_(pipeline), classifier_(std::move(classifier)), profiles_(profiles) {}

  IptCamera camera_;
  PipelineParams pipeline_;
  ClassifierParams classifier_;
  ProfileParams profiles_;
  cv::Mat first_;                    // the pair's first frame
  Pose2D first_pose_;
  bool have_first_ = false;
  std::vector<cv::Point2f> a_, b_;
  TrackScratch tracks_;
  cv::Mat edges_;
  EdgeScratch scratch_;
};

}  // namespace visnav::ipt
