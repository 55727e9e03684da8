// feature_replay core — map style A: straight segments with tracked landmarks (seed 000, Sec. 3,
// Algorithms 1 and 2).
//
// Teach (SegmentTeacher, Algorithm 1): every frame, the tracked landmarks are matched against the
// current features (ratio test + mutual best + a per-frame image step gate); a matched landmark
// updates its last image position and last distance and counts one more observation; an
// unmatched one stops being tracked and joins the segment's landmark set if it was seen in at
// least `min_observations` frames over at least `min_track_length_m`; unmatched current features
// start new tracks. finish() closes every track and caps the landmark density at
// `max_landmarks_per_m` (per 0.5 m window of the landmark's mid distance, highest count first).
// A landmark is the tuple (e, k, u, v, f, g) of the paper: descriptor, observation count, first
// and last image position, first and last distance from the segment start.
//
// Replay (SegmentReplayer, Algorithm 2): at distance d along the segment, landmarks with
// f - margin <= d <= g + margin are expected; each one's image position is interpolated linearly
// by distance between u and v; the expected landmarks are matched with the current features, the
// horizontal differences (current - expected) voted into the histogram, and
// omega = -gain_radps_per_px * offset_px (clamped), v = speed_mps (constant). The paper writes
// omega = gamma * mode(H); our gamma is -gain because omega is counter-clockwise positive and a
// scene seen right of where it is expected means the robot is turned left. Low confidence,
// no features or bad input give omega = 0 (no steering on noise). Per-frame cost depends only on
// the landmarks near d: they are sorted by f and found by binary search.
//
// Along-track correction (an addition to Algorithm 2; the paper corrects along-track error only
// through the turns of the route, seed 000 Sec. 5 / seed 002 Sec. 2.5): a landmark's expected
// position moves with distance (features spread away from the image centre as the robot approaches
// them); driving straight, x - c = A / (X - d) on each axis (c the principal point, taken at the
// image centre), so the landmark's track through its first and last positions is known and so is
// its slope s px/m at d. A robot that is delta metres further along than its counter says sees each
// matched landmark at track(d) + offset + s * delta, in both image axes; delta is the least-squares fit over the matches near the winning offset (per axis
// centred, so a common rotation or pitch does not bias it; one pass drops residuals > 8 px). With
// along_gain > 0 the correction c follows the estimate, c += gain * (delta - c) per frame (clamped
// per frame and in total; only while |offset_px| <= along_max_offset_px, i.e. facing the view),
// and the segment ends when odometric distance + c reaches its length: where the taught view was
// seen instead of where odometry says. The steering and the fit keep using the odometric distance
// (Algorithm 2 unchanged); distance_m in the output is the corrected one. Landmarks far
// away (s near 0) carry no along-track information and do not take part.
// End-window variant (along_end_window_m > 0, used instead of along_gain): the estimate is
// accurate where the robot has driven straight at the segment's last views for a while and poor
// right after a corner (heading and lateral error still large), so only the frames of the last
// along_end_window_m metres (facing the view) count; their mean becomes the correction once enough
// of them agree (count and spread gates), and nothing is corrected otherwise.
//
// Temporal filter (temporal_decay > 0, an addition to Algorithm 2, issue 36): a segment is
// straight, so its taught heading is one azimuth and the offset between two frames changes only by
// the robot's own rotation. Each frame's vote histogram is folded into a HeadingHistogramFilter
// with the odometric rotation since the previous frame as the predicted shift. The filter only
// continues a track that a frame's own valid estimate started: the anchor is the last own-valid
// offset steered on, moved by the odometric rotation since. When the filtered estimate is valid:
// if this frame's own estimate is valid and within one bin of it, the frame's refined offset is
// kept (with the larger of the two confidences); otherwise the filtered offset steers if it lies
// within kFilterGateBins bins of the anchor and the anchor is at most temporal_hold_m old (a weak
// frame still gets a heading; a stray single-frame peak is outvoted). In every other case the
// frame's own estimate stands: weak evidence that piles up somewhere no confident frame has been
// (a repeated structure in winter, seen frame after frame) never steers. The along-track fit uses
// this frame's matches, so it runs only on frames whose own offset steers.
//
// Distances: the replayer is given odometric distance (Odometry::distance_m) and subtracts the
// value given to begin(); the teacher is given distance from the segment start (>= 0,
// non-decreasing; a smaller value is treated as the previous one).
//
// Thread-safety: teacher and replayer are single-threaded objects; a SegmentMap is immutable once
// built and may be shared between threads (the replayer holds a shared_ptr<const SegmentMap>).
#pragma once

#include <cstdint>
#include <limits>
#include <utility>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "visnav/devices.hpp"
#include "visnav/feature_payloads.hpp"
#include "visnav/feature_replay/heading.hpp"
#include "visnav/feature_replay/heading_filter.hpp"
#include "visnav/feature_replay/replay_common.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::feature_replay {

// Landmark and SegmentMap (the payload): visnav/feature_payloads.hpp.

struct SegmentTeachParams {
  double track_ratio = 0.8;          ///< ratio test when matching tracked landmarks (1 = off)
  double max_track_step_px = 40.0;   ///< max image motion of a landmark between consecutive frames
  double max_descriptor_distance = 0.0;  ///< absolute gate on the tracking match; 0 = off
  int min_observations = 3;          ///< k below this: the track is dropped
  double min_track_length_m = 0.05;  ///< g - f below this: the track is dropped
  double max_landmarks_per_m = 250.0;  ///< density cap applied by finish() (50 B each -> 12.5 KB/m)

  /// The schema's ranges (declared once there).
  [[nodiscard]] Status validate() const { return schema().check(*this); }
  static const ParamSchema<SegmentTeachParams>& schema();
};

/// Algorithm 1: builds a SegmentMap from a stream of (distance, features).
class SegmentTeacher {
 public:
  explicit SegmentTeacher(const SegmentTeachParams& params = {});

  /// Starts a new segment at `azimuth_rad`; forgets any previous state.
  void begin(double azimuth_rad);
  /// Processes one frame taken at `distance_m` from the segment start. Empty features are fine
  /// (every track ends). Errors: inconsistent features, or a descriptor type/width different from
  /// the first frame's; state is unchanged on error.
  Status add_frame(double distance_m, const Features& features);
  /// Ends the segment at `length_m` (>= 0), closes every track and returns the map. The teacher
  /// is empty afterwards (call begin() for another segment).
  Result<SegmentMap> finish(double length_m);

  [[nodiscard]] std::size_t tracked_count() const { return tracks_.size(); }
  [[nodiscard]] std::size_t landmark_count() const { return done_.size(); }

 private:
  struct Track {
    std::uint32_t count;
    cv::Point2f first_px, last_px;
    float first_m, last_m;
  };
  void close_track(std::size_t i);
  void ensure_track_capacity(int rows, int cols, int type);

  SegmentTeachParams params_;
  double azimuth_rad_ = 0.0;
  double last_distance_m_ = 0.0;
  int desc_type_ = -1;
  int desc_cols_ = 0;
  std::vector<Track> tracks_;
  cv::Mat track_desc_, next_desc_;  // capacity buffers; the first tracks_.size() rows are live
  std::vector<Track> next_tracks_;
  std::vector<Landmark> done_;
  std::vector<std::uint8_t> done_desc_;  // row bytes of done_ landmarks, concatenated
  std::vector<int> best_, cur_best_;
  std::vector<float> best_d_, second_d_, cur_best_d_;
  std::vector<char> used_;
};

/// Temporal filter (SegmentReplayParams::temporal_decay): the filtered offset steers only within
/// this many histogram bins of the last own-valid offset (moved by the odometric rotation since),
/// and only while that offset was taken at most temporal_hold_m back along the segment.
inline constexpr double kFilterGateBins = 2.0;

struct SegmentReplayParams {
  double speed_mps = 0.3;              ///< constant forward speed v0
  double gain_radps_per_px = 0.003;    ///< omega = -gain * offset_px
  double max_angular_radps = 0.5;      ///< |omega| clamp
  double distance_margin_m = 0.0;      ///< widen the [f, g] visibility window by this much
  /// Along-track correction (see SegmentReplayer): each frame with an estimate moves the segment's
  /// distance counter by along_gain times the estimated along-track error; 0 = off (seed 000:
  /// odometry alone decides where the segment ends).
  double along_gain = 0.0;
  double max_along_step_m = 0.02;      ///< clamp of one frame's correction, m
  double max_along_correction_m = 0.5; ///< clamp of the correction accumulated over the segment, m
  double along_window_px = 40.0;       ///< matches within this of the winning offset take part, px
  double along_max_offset_px = 20.0;   ///< the correction is updated only while |offset_px| <= this, px
  int min_along_matches = 12;          ///< fewer such matches: no along-track estimate this frame
  double min_along_slope_px_per_m = 100.0;  ///< sqrt(sum of squared slopes) below this: uninformative
  /// End-window correction (replaces the per-frame tracking when > 0): only estimates made while
  /// the odometric distance is within this of the segment's end are used; the correction is their
  /// mean once there are at least along_min_frames of them with sd <= along_max_sd_m (else it
  /// keeps its last accepted value, 0 at first), clamped to max_along_correction_m. m; 0 = off.
  double along_end_window_m = 0.0;
  int along_min_frames = 8;            ///< end window: fewer estimates give no correction
  double along_max_sd_m = 0.08;        ///< end window: estimates spread more than this give no correction, m
  /// Temporal filter of the vote histograms (heading_filter.hpp; see SegmentReplayer): the weight
  /// kept per frame from the votes of earlier frames, shifted by the odometric rotation since;
  /// 0 = off (each frame on its own, Algorithm 2). Its vote and confidence gates are the
  /// HeadingParams' (min_inliers, full_confidence_inliers, min_confidence).
  double temporal_decay = 0.0;
  /// Temporal filter: the filtered offset steers only while the last offset a frame's own valid
  /// estimate steered on is at most this far back along the segment, m.
  double temporal_hold_m = 1.0;

  /// The schema's ranges (declared once there).
  [[nodiscard]] Status validate() const { return schema().check(*this); }
  static const ParamSchema<SegmentReplayParams>& schema();
};

struct SegmentReplayOutput {
  Twist command;                 ///< (v0, omega), or zero when finished
  double distance_m = 0.0;       ///< along the segment: odometric plus the along-track correction (the end criterion)
  /// This frame's along-track error estimate (taught distance the view matches minus the odometric
  /// distance along the segment), m; NaN when the frame gave none.
  double along_error_m = std::numeric_limits<double>::quiet_NaN();
  double along_correction_m = 0.0;  ///< correction accumulated since begin(), m (positive: ahead)
  int expected_landmarks = 0;    ///< |T|: landmarks visible at this distance during teach
  /// The estimate steered on: this frame's own, or with the temporal filter on the filtered one
  /// (offset, heading, confidence, ambiguity and valid from the accumulated histogram; matches and
  /// inliers stay this frame's).
  HeadingEstimate estimate;
  bool filtered = false;         ///< the temporal filter's offset replaced this frame's own
  ReplayState state = ReplayState::no_features;
  bool finished = false;         ///< distance >= segment length
};

/// Algorithm 2: replays one segment.
class SegmentReplayer {
 public:
  /// A null or invalid map (SegmentMap::validate() fails) is not used: every step reports
  /// bad_input with a zero command (check map_valid()).
  SegmentReplayer(std::shared_ptr<const SegmentMap> map, const SegmentReplayParams& params = {},
                  const HeadingParams& heading = {});

  /// Sets the odometric distance at which the segment starts (Odometry::distance_m) and forgets
  /// the temporal filter's accumulation.
  void begin(double odometry_distance_m) {
    origin_m_ = odometry_distance_m;
    correction_m_ = 0.0;
    window_n_ = 0;
    window_sum_m_ = window_sum_sq_m2_ = 0.0;
    if (filter_) filter_->reset();
    last_heading_rad_ = std::numeric_limits<double>::quiet_NaN();
    anchor_px_ = std::numeric_limits<double>::quiet_NaN();
  }
  /// One frame: `odometry_distance_m` is the current Odometry::distance_m; `image_width_px` the
  /// width of the image the features come from (for the heading in the estimate); the principal
  /// point is taken at the image centre for the along-track estimate (`image_height_px` 0: the
  /// vertical axis does not take part). `odometry_heading_rad` (Odometry pose heading, CCW) lets
  /// the temporal filter shift earlier votes by the rotation since; NaN: no shift.
  SegmentReplayOutput step(double odometry_distance_m, const Features& current, double image_width_px,
                           double image_height_px = 0.0,
                           double odometry_heading_rad = std::numeric_limits<double>::quiet_NaN());
  /// Distance travelled beyond the segment end (>= 0), to carry into the next edge (counted with
  /// the along-track correction).
  [[nodiscard]] double overshoot_m(double odometry_distance_m) const;
  /// Along-track correction accumulated since begin(), m (positive: the robot was found ahead of
  /// its odometric counter, so the segment ends that much earlier in odometric distance).
  [[nodiscard]] double along_correction_m() const { return correction_m_; }

  void set_params(const SegmentReplayParams& params, const HeadingParams& heading);
  [[nodiscard]] const HeadingEstimator& estimator() const { return estimator_; }
  [[nodiscard]] const SegmentMap& map() const { return *map_; }
  [[nodiscard]] bool map_valid() const { return map_valid_; }
  /// Expected positions of the landmarks used in the last step (valid until the next step).
  [[nodiscard]] std::span<const cv::Point2f> last_expected_px() const {
    return {expected_.data(), static_cast<std::size_t>(active_count_)};
  }

 private:
  std::shared_ptr<const SegmentMap> map_;
  SegmentReplayParams params_;
  HeadingEstimator estimator_;
  // A landmark's position on its hyperbolic image track at distance d and the track's slope, per
  // axis (NaN where the model does not apply).
  struct AlongModel {
    float u_px = std::numeric_limits<float>::quiet_NaN(), v_px = std::numeric_limits<float>::quiet_NaN();
    float slope_u = std::numeric_limits<float>::quiet_NaN(), slope_v = std::numeric_limits<float>::quiet_NaN();
    float inverse_depth = 0.0f;  // slope_u / (u - c): 1 / depth, 1/m
  };
  struct AlongSample {
    float slope;          // px/m
    float inverse_depth;  // 1/m (0 on the vertical axis: a lateral shift does not move v)
    float residual;       // px
    int axis;             // 0 = u, 1 = v
  };
  static AlongModel along_model(const Landmark& l, double d, double cx, double cy);
  double estimate_along_m();  // from the last estimate's matches; NaN when uninformative
  void make_filter();
  // Folds this frame's histogram into the filter; returns true when the filtered offset replaced
  // the frame's own in `est`.
  bool apply_filter(HeadingEstimate& est, double d_m, double image_width_px, double odometry_heading_rad);

  std::optional<HeadingHistogramFilter> filter_;  // temporal_decay > 0
  double last_heading_rad_ = std::numeric_limits<double>::quiet_NaN();
  double anchor_px_ = std::numeric_limits<double>::quiet_NaN();  // last own-valid offset, moved by the rotation since
  double anchor_d_m_ = 0.0;                                      // segment distance where it was taken

  double origin_m_ = 0.0;
  double correction_m_ = 0.0;
  int window_n_ = 0;                    // end window: estimates so far, their sum and sum of squares
  double window_sum_m_ = 0.0, window_sum_sq_m2_ = 0.0;
  double max_span_m_ = 0.0;
  bool map_valid_ = true;
  cv::Mat ref_desc_;                   // capacity buffer
  std::vector<cv::Point2f> expected_;  // capacity buffer
  std::vector<AlongModel> along_model_;  // capacity buffer: per active landmark
  std::vector<AlongSample> along_;     // capacity buffer: the samples of one fit
  int active_count_ = 0;
};

}  // namespace visnav::feature_replay
