// feature_replay core — map style B: local maps plus recorded operator commands (seed 002,
// Sec. 2.1, 2.3, 2.4; the stroll_bearnav scheme).
//
// Teach (LocalMapTeacher): at the start and whenever the distance since the last local map reaches
// `map_interval_m` (default 0.2 m; the paper: 0.1-0.5 m) the current features (optionally the
// strongest `max_features_per_map`) and optionally a JPEG of the image become a local map indexed
// by distance. Every operator command that differs from the previous one (by more than
// `command_tolerance`) is stored with the distance at which it was issued. finish() stores the
// stop command and the last local map.
//
// Replay (LocalMapReplayer): at distance d it applies the last recorded command issued at or
// before d, picks the local map nearest d, estimates the histogram offset of the current features
// against it and adds the heading correction omega += -gain_radps_per_px * offset_px (clamped to
// +-max_correction_radps). Low confidence, no features or bad input: the recorded command is sent
// unchanged (no steering on noise). No correction is added while |recorded v| is below
// `min_speed_for_correction_mps` (turning on the spot). Closed paths: with laps > 1, when d passes
// the path length the next lap starts at d - length (the distance overshoot is carried over, not
// dropped). Per-frame cost is independent of path length (binary search over distances).
//
// Limitation: the path is indexed by travelled distance, so a command taught while standing
// still (pure rotation) is replayed only until the robot moves again.
//
// Distances: teacher distances are measured from the path start (>= 0; a smaller value than the
// previous one is treated as the previous one); the replayer takes Odometry::distance_m and
// subtracts the value given to begin().
// Thread-safety: teacher and replayer are single-threaded; a LocalMapPath is immutable once built.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "visnav/devices.hpp"
#include "visnav/feature_payloads.hpp"
#include "visnav/feature_replay/heading.hpp"
#include "visnav/feature_replay/replay_common.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::feature_replay {

// RecordedCommand, LocalMap and LocalMapPath (the payload): visnav/feature_payloads.hpp.

struct LocalMapTeachParams {
  double map_interval_m = 0.2;      ///< distance between local maps
  int max_features_per_map = 0;     ///< keep the strongest (by response); 0 = all
  bool store_image = false;         ///< also store a JPEG of the image in each local map
  int jpeg_quality = 75;
  double command_tolerance = 1e-3;  ///< a command is recorded when v or omega changes by more

  /// The schema's ranges (declared once there).
  [[nodiscard]] Status validate() const { return schema().check(*this); }
  static const ParamSchema<LocalMapTeachParams>& schema();
};

class LocalMapTeacher {
 public:
  explicit LocalMapTeacher(const LocalMapTeachParams& params = {});

  /// Starts a new path; forgets any previous state.
  void begin();
  /// A frame at `distance_m`: becomes a local map if it is the first or the interval has passed.
  /// `image` is only used (and JPEG-encoded) when store_image is on and a map is created.
  /// Errors: inconsistent features, descriptor type/width changed, JPEG encoding failed.
  Status add_frame(double distance_m, const Features& features, const cv::Mat& image = {});
  /// The operator's command at `distance_m` (stored only when it changed).
  void record_command(double distance_m, const Twist& command);
  /// Ends the path at `distance_m`: stores the stop command and a last local map from `features`
  /// (if it has any), and returns the path. The teacher is empty afterwards.
  Result<LocalMapPath> finish(double distance_m, const Features& features, const cv::Mat& image = {});

  [[nodiscard]] std::size_t map_count() const { return path_.maps.size(); }

 private:
  Status store_map(double distance_m, const Features& features, const cv::Mat& image);

  LocalMapTeachParams params_;
  LocalMapPath path_;
  double last_distance_m_ = 0.0;
  double last_map_m_ = 0.0;
  int desc_type_ = -1;
  int desc_cols_ = 0;
  std::vector<int> order_;
};

struct LocalMapReplayParams {
  double gain_radps_per_px = 0.003;        ///< omega correction = -gain * offset_px
  double max_correction_radps = 0.3;       ///< |correction| clamp
  int laps = 1;                            ///< traversals of a closed path (overshoot carried over)
  double min_speed_for_correction_mps = 0.02;  ///< no correction while |recorded v| is below

  /// The schema's ranges (declared once there).
  [[nodiscard]] Status validate() const { return schema().check(*this); }
  static const ParamSchema<LocalMapReplayParams>& schema();
};

struct LocalMapReplayOutput {
  Twist command;                 ///< recorded command plus correction (zero when finished)
  Twist recorded;                ///< the recorded command for this distance
  double correction_radps = 0.0; ///< what was added to the recorded omega
  double distance_m = 0.0;       ///< along the path, within the current lap
  int lap = 0;                   ///< 0-based lap index
  bool lap_completed = false;    ///< this step started a new lap
  int map_index = -1;            ///< local map used
  HeadingEstimate estimate;
  ReplayState state = ReplayState::no_features;
  bool finished = false;
};

class LocalMapReplayer {
 public:
  /// A null or invalid path (LocalMapPath::validate() fails) is not replayed: every step reports
  /// bad_input with a zero command (check path_valid()).
  LocalMapReplayer(std::shared_ptr<const LocalMapPath> path, const LocalMapReplayParams& params = {},
                   const HeadingParams& heading = {});

  /// Starts lap 0 at odometric distance `odometry_distance_m` (Odometry::distance_m).
  void begin(double odometry_distance_m);
  /// One frame at the current Odometry::distance_m.
  LocalMapReplayOutput step(double odometry_distance_m, const Features& current, double image_width_px);
  /// Distance beyond the end of the last lap (>= 0), to carry into the next edge.
  [[nodiscard]] double overshoot_m(double odometry_distance_m) const;

  void set_params(const LocalMapReplayParams& params, const HeadingParams& heading);
  [[nodiscard]] const HeadingEstimator& estimator() const { return estimator_; }
  [[nodiscard]] const LocalMapPath& path() const { return *path_; }
  [[nodiscard]] int lap() const { return lap_; }
  [[nodiscard]] bool path_valid() const { return path_valid_; }

 private:
  std::shared_ptr<const LocalMapPath> path_;
  LocalMapReplayParams params_;
  HeadingEstimator estimator_;
  double origin_m_ = 0.0;
  int lap_ = 0;
  bool path_valid_ = true;
};

}  // namespace visnav::feature_replay
