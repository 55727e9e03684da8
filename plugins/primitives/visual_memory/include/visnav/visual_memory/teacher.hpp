// visnav visual memory — teaching core (seed 003 Sec. II-A, Fig. 1).
//
// The first usable frame becomes reference 0: Harris corners (goodFeaturesToTrack with the
// Harris measure) start the KLT tracker. Each later frame updates the tracks (KLT, forward-
// backward check). The current frame becomes the next reference when the tracked set has lost
// `lost_fraction` of the last reference's features, or the 5-point geometry between the last
// reference and the frame has an inlier error above `max_reconstruction_error_px`, or the robot
// has driven `max_reference_spacing_m` since it (never before `min_reference_spacing_m`). A new
// reference stores its relative pose to the previous one (E + cheirality, metric with the
// odometric baseline) and the triangulated shared features; the tracker is then topped up with
// new Harris corners. `finish()` adds the last frame as the final (goal) reference, replacing a
// reference made less than `min_reference_spacing_m` before it (the goal needs a baseline).
// Input: the frame (BGR or grey) and the odometry (odom frame, metres/radians).
// Thread-safety: one thread. No clock, no I/O.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "visnav/result.hpp"
#include "visnav/types.hpp"
#include "visnav/visual_memory/geometry.hpp"
#include "visnav/visual_memory/memory.hpp"
#include "visnav/visual_memory/params.hpp"

namespace visnav::visual_memory {

/// What one teach frame did (telemetry, tests).
struct TeachFrameResult {
  int tracked = 0;               ///< features of the last reference still tracked
  bool new_reference = false;
  std::string reason;            ///< why a reference was made ("features lost", "reconstruction error", ...)
  GeometryStatus geometry = GeometryStatus::ok;  ///< of the new reference (when one was made)
};

class MemoryTeacher {
 public:
  static Result<MemoryTeacher> create(const TeachParams& params);

  /// One frame with the odometry at its capture. Errors: empty image, size change.
  Result<TeachFrameResult> add_frame(const cv::Mat& image, const Odometry& odometry, double edge_distance_m);
  /// Closes the memory: the last frame becomes the final reference (if it is not one already).
  /// Error when no frame was usable.
  Result<VisualMemory> finish();

  [[nodiscard]] const VisualMemory& memory() const { return memory_; }
  [[nodiscard]] int references_without_3d() const { return without_3d_; }

 private:
  explicit MemoryTeacher(const TeachParams& params);
  void detect_more(const cv::Mat& grey);
  TeachFrameResult make_reference(const std::string& reason);

  TeachParams params_;
  KltParams klt_;
  GeometryParams geometry_;
  Intrinsics intrinsics_;
  VisualMemory memory_;
  cv::Mat previous_;                       ///< last frame, grey
  std::vector<cv::Point2f> tracks_;        ///< current positions
  std::vector<std::int32_t> track_ids_;
  std::int32_t next_id_ = 0;
  // the last frame, kept for finish()
  Odometry last_odometry_;
  double last_distance_m_ = 0.0;
  bool last_is_reference_ = false;
  double reference_distance_m_ = 0.0;
  Pose2D reference_pose_;
  std::vector<Pose2D> reference_poses_;  ///< odometry pose of every reference
  int without_3d_ = 0;
};

/// The grey CV_8UC1 view of a BGR or grey frame (no copy for grey).
void to_grey(const cv::Mat& image, cv::Mat& grey);

}  // namespace visnav::visual_memory
