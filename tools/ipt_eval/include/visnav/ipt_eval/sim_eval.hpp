// visnav IPT obstacles — classifier evaluation on frames rendered by the simulator with
// per-pixel ground truth (issue 16, "Classifier ROC on rendered frames").
//
// For each pair: render frame k−1 at a pose, frame k `step_m` further along the heading;
// Shi-Tomasi corners (≤ max_features) in k−1 tracked by pyramidal Lucas-Kanade into k;
// RANSAC on F (8-point, 1 px, 500 iterations: thesis §4.2.1); classification with the lens
// poses from the true robot poses plus optional odometry noise. Truth per inlier from the
// label image of frame k: the ground classes (path, grass, floor, pavement, ground) are
// negatives, every other class (wall, fence, tree, obstacle, sky) is a positive ("not on the
// ground", the thesis's definition). Features whose 3×3 label neighbourhood mixes the two
// sides (object borders) are left out of the counts and reported.
//
// Library `visnav_ipt_obstacles_sim_eval` (links libvisnav_sim); used by `visnav ipt-roc` and
// the tests. Deterministic for a given options struct.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "visnav/ipt_obstacles/calibration.hpp"
#include "visnav/ipt_obstacles/classifier.hpp"
#include "visnav/ipt_obstacles/ground_odometry.hpp"
#include "visnav/ipt_obstacles/pipeline.hpp"
#include "visnav/ipt_obstacles/profiles.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::ipt {

/// A straight run: pairs from `start` along its heading for `length_m` (world frame).
struct RocRun {
  Pose2D start;
  double length_m = 0.0;
};

/// Runs past every obstacle of config/worlds/obstacle_course.yaml without touching one.
[[nodiscard]] std::vector<RocRun> obstacle_course_runs();

struct RocOptions {
  std::string world = "obstacle_course";   ///< world name or path (visnav_sim resolution)
  std::vector<RocRun> runs = obstacle_course_runs();
  double pair_every_m = 0.25;              ///< one pair per this distance along a run
  double step_m = 0.02;                    ///< baseline of a pair (thesis: ~2 cm, §3.6)
  int width_px = 320;
  int height_px = 240;
  double hfov_deg = 65.5;                  ///< thesis FOV_H
  double mount_height_m = 0.43;            ///< thesis Z0
  double pitch_down_deg = 9.0;             ///< thesis φ = −9°
  double noise_std = 2.0;                  ///< sensor noise, grey levels
  double odom_position_sd_m = 0.0;         ///< noise on the pair's relative translation
  double odom_heading_sd_rad = 0.0;        ///< noise on the pair's relative heading
  int max_features = 250;                  ///< thesis KLT count (Ch. 5); also the detectors' cap
  /// How the pair's matches are found (spec §11 item 26, the thesis's tracker comparison):
  /// "klt" (Shi-Tomasi + pyramidal LK, the pipeline's), "sift" (SIFT, L2, ratio 0.8), "orb" (ORB,
  /// Hamming, ratio 0.8; stands in for SURF, which Debian's OpenCV does not ship), "fast" (FAST
  /// corners, threshold 20, described by the 16 pixels of their Bresenham circle and matched by
  /// the smallest SSD within 30 px, mutual best). All go through the same RANSAC on F.
  std::string tracker = "klt";
  PipelineParams tracking;                 ///< corners, LK and RANSAC settings (max_features above wins)
  int seed = 1;
  int picture_run = -1;                    ///< the picture shows the last pair of this run (−1: of the last run)
  ClassifierParams classifier;
  ProfileParams profiles;
};

struct Counts {
  long tp = 0, fp = 0, tn = 0, fn = 0;     ///< positives = OBSTACLE; unclassified are not counted here
  long unclassified_obstacle = 0;          ///< true obstacles left unclassified
  long unclassified_ground = 0;
  long border = 0;                         ///< left out: mixed label neighbourhood
  long ransac_outliers = 0;
  [[nodiscard]] double precision() const { return tp + fp > 0 ? static_cast<double>(tp) / (tp + fp) : 0.0; }
  [[nodiscard]] double recall() const { return tp + fn > 0 ? static_cast<double>(tp) / (tp + fn) : 0.0; }
  /// Recall counting unclassified true obstacles as missed.
  [[nodiscard]] double recall_all() const {
    const long p = tp + fn + unclassified_obstacle;
    return p > 0 ? static_cast<double>(tp) / p : 0.0;
  }
  [[nodiscard]] double fallout() const { return fp + tn > 0 ? static_cast<double>(fp) / (fp + tn) : 0.0; }
};

struct RocReport {
  Counts at_operating_point;               ///< the classifier params as given
  Counts below_horizon;                    ///< the same, only features below the horizon guard band (D decides)
  double auc_without_band = 0.0;           ///< ROC over β, D-interval filter off (thesis 4.16)
  double auc_with_band = 0.0;              ///< ROC over β with the band filter kept
  double best_beta_m = 0.0;                ///< minimiser of FP + 0.5·FN over the sweep (thesis §4.3)
  int pairs = 0;
  long features = 0;
  long contact_points = 0;
  long contact_points_on_obstacle_base = 0;  ///< contact points whose pixel lies within 3 px of an obstacle pixel
  // the tracker's cost and yield (spec §11 item 26), summed over the pairs
  double tracking_ms = 0.0;                ///< wall time of finding a pair's matches (detection in both frames included)
  long detected = 0;                       ///< features detected in the pairs' first frames
  long matched = 0;                        ///< matches before RANSAC
  long inliers = 0;                        ///< matches RANSAC kept
};

/// Runs the evaluation. Error when the world does not load or an option is out of range.
/// `picture` (optional): the last pair's frame with the classified features drawn (red
/// obstacle, blue ground, yellow unclassified, magenta contact points) and its label overlay.
[[nodiscard]] Result<RocReport> evaluate_classifier(const RocOptions& options, cv::Mat* picture = nullptr);

/// Draws classified features and contact points onto a BGR image (the colours above).
void draw_classification(cv::Mat& bgr, const std::vector<ClassifiedFeature>& features,
                         const std::vector<ContactPoint>& contacts);

/// `visnav calibrate-ipt` in the simulator: frames of flat ground rendered with a known mount,
/// Shi-Tomasi + LK tracks between frames baseline_m apart, RANSAC on F, then
/// calibrate_height_pitch() from a wrong initial guess.
struct CalibrationRunOptions {
  std::string world = "obstacle_course";
  Pose2D start{-5.0, -1.5, -CV_PI / 2};  ///< facing open grass, no wall in view
  int pairs = 12;
  double baseline_m = 0.10;
  double spacing_m = 0.3;               ///< travel between pairs
  int width_px = 320;
  int height_px = 240;
  double hfov_deg = 65.5;
  double true_height_m = 0.43;
  double true_pitch_down_deg = 9.0;
  double guess_height_m = 0.5;
  double guess_pitch_down_deg = 5.0;
  double noise_std = 2.0;
  int seed = 1;
};

[[nodiscard]] Result<CalibrationResult> calibrate_on_rendered_frames(const CalibrationRunOptions& options);

/// `visnav ipt-ekf`: the ground-feature EKF (ground_odometry.hpp) on frames rendered along a
/// run, against the wheel odometry it corrects. The true path starts at `run.start` and turns
/// at `turn_deg_per_m`; one frame every `frame_step_m`; the odometry reads each true increment
/// with a scale error, a heading bias (a turn the robot does not make: the wheel-size asymmetry
/// of spec §11 item 23) and Gaussian noise of the filter's own model (σ_t·d, σ_θ·d), so the NEES
/// tests the filter against what it was told. The frames go through the replay's pipeline
/// (ObstaclePipeline, default params) at the odometry's poses.
struct EkfRunOptions {
  std::string world = "campus";
  std::string obstacles_path;                  ///< optional obstacle file added to the world (sim docs)
  RocRun run{Pose2D{26.0, -26.0, CV_PI}, 7.0};  ///< default: the gravel leg e14, westbound, to the van's place
  double frame_step_m = 0.05;                  ///< travel between frames (0.5 m/s at 10 Hz)
  double turn_deg_per_m = 0.0;                 ///< the true path's curvature, deg/m (left positive)
  int width_px = 320;
  int height_px = 240;
  double hfov_deg = 60.0;                      ///< the campus robot's camera (config/sim_experiment.yaml)
  double mount_height_m = 0.5;
  double pitch_down_deg = 5.0;
  double noise_std = 3.0;                      ///< sensor noise, grey levels
  double odom_scale_error = 0.0;               ///< the odometry reads (1 + this) × the travel
  double odom_heading_bias_rad_per_m = 0.0;    ///< reported turn per metre the robot does not make
  bool odom_noise = true;                      ///< add the filter's modelled increment noise
  int seed = 1;
  GroundOdometryParams filter;
};

struct EkfRunReport {
  int frames = 0;
  int pairs = 0;
  double mean_observations = 0.0;              ///< ground features per pair the filter used
  Pose2D truth_end, odometry_end, filter_end;  ///< world frame
  // Errors at the run's end in the run's start frame: along = along its heading, lateral = left of it.
  double odometry_heading_error_rad = 0.0, filter_heading_error_rad = 0.0;
  double odometry_lateral_error_m = 0.0, filter_lateral_error_m = 0.0;
  double odometry_along_error_m = 0.0, filter_along_error_m = 0.0;
  double mean_nees = 0.0;                      ///< of the filter's pose (3 dof) over the pairs
  double ms_per_pair = 0.0;                    ///< pipeline + filter, wall time
};

/// Error when the world does not load, an option or a filter param is out of range.
[[nodiscard]] Result<EkfRunReport> evaluate_ground_odometry(const EkfRunOptions& options);

}  // namespace visnav::ipt
