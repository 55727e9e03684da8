// visnav path following — the segmentation-based path-following core (seed 000 Sec. 4, Fig. 2).
//
// Pipeline per frame (PathFollower::process):
//   horizon row (auto / configured) → crop the ground image below it → median blur →
//   Felzenszwalb-Huttenlocher graph segmentation → per-segment Gaussian colour model →
//   reference models: the pixels of the bottom trapezoid, grouped by segment, greedily merged
//   by Mahalanobis distance, kept when they cover ≥ ref_min_coverage of the trapezoid (optionally blended with
//   the previous frame's models) → every segment classified by the Mahalanobis distance of its
//   mean to the nearest reference model → binary mask → morphological opening → the connected
//   component with the largest overlap with the trapezoid → its external contour → row-wise
//   middle points → control law (1).
// Taught-appearance gate (taught_gate_distance > 0 and taught models set with
//   set_taught_models, e.g. the edge's appearance summary): every re-learned reference model
//   whose mean lies farther than taught_gate_distance from every taught model (classification
//   distance, measured in the taught model's spread) is rejected before blending. When all are
//   rejected (the trapezoid stands on another surface, e.g. asphalt crossing a gravel path) the
//   previous frame's accepted models are used, or the taught models when there are none.
//   Whenever the gate rejected a model, the trapezoid holds another surface and cannot anchor the
//   region: the region is then every path component of at least min_area_share of the ground
//   image (the gravel left and right of a crossing road and beyond it), not only the one
//   overlapping the trapezoid, so the row-wise middle points stay on the taught path.
// Edge-straddling fallback: when that component covers more than multi_model_max_share of the
//   ground image and several reference models were kept, the least covering model is dropped and the
//   classification repeated (the trapezoid then straddled the path edge and the surroundings'
//   model made everything "path"); with one model left the status is path_fills_image.
//
// Colour feature: 8-bit HSV (OpenCV: H in [0,180), S, V in [0,255]) mapped to the HSV cone
//   f = (S·cos h, S·sin h, V), h = 2·H degrees,
// which has no hue wrap-around and makes the (unreliable) hue of grey pixels irrelevant.
// A Gaussian model is the mean and covariance of f over a segment's pixels.
// Distances (λ = colour_noise_floor², I the identity):
//   merge (segment/segment):      d² = (μa−μb)ᵀ (Σa + Σb + λI)⁻¹ (μa−μb)
//   classify (segment/reference): d² = (μs−μr)ᵀ (Σr + λI)⁻¹ (μs−μr)
//
// Control law (1), normalised. x_i are the n middle points' columns, w the image width, H_g
// the number of ground rows (below the horizon):
//   offset = (1/n) Σ (x_i − w/2) / (w/2)          ∈ [−1, 1], positive = path right of centre
//   ω = −alpha_radps · (offset − target)          (clamped to ±max_angular_radps)
// target (set_target_offset, default 0) is the offset the follower steers to: 0 centres the
//   path's middle in the image; the replay of a taught edge sets where the middle lay in the
//   teacher's view (the taught lateral position), so the robot repeats the teacher's line.
//   v = beta_mps · n / H_g − turn_slowdown_mps_per_radps · |ω|   (clamped to [0, max_linear_mps])
// Sign: image x grows to the right; a path right of the image centre requires a right turn,
// which is a NEGATIVE ω in the SDK's counter-clockwise-positive convention (types.hpp).
// The command is zero whenever status != ok.
//
// Thread-safety: a PathFollower is not thread-safe (it owns per-frame buffers); use one per
// thread. Free functions are pure and thread-safe.
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "visnav/path_following/params.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace cv::ximgproc::segmentation { class GraphSegmentation; }

namespace visnav::path_following {

/// Outcome of one frame. Only `ok` yields a non-zero command.
enum class PathStatus {
  ok,
  path_lost,         ///< connected path region smaller than min_area_share of the ground image
  path_fills_image,  ///< region larger than fill_area_share: path and surroundings indistinguishable
  dark_frame,        ///< mean ground intensity below dark_mean_intensity
  no_reference,      ///< no merged reference model covers ref_min_coverage of the reference region
};

[[nodiscard]] std::string_view to_string(PathStatus status);

/// Origin of the reference models a frame was classified with (see the taught-appearance gate).
enum class ReferenceSource {
  learned,   ///< re-learned from this frame's reference region (possibly blended)
  previous,  ///< every re-learned model failed the gate: the previous frame's accepted models
  taught,    ///< every re-learned model failed the gate and there were none: the taught models
};

[[nodiscard]] std::string_view to_string(ReferenceSource source);

/// Smallest accepted input image.
inline constexpr int kMinImageWidthPx = 32;
inline constexpr int kMinImageHeightPx = 24;
/// The ground image keeps at least this many rows whatever the horizon says.
inline constexpr int kMinGroundRowsPx = 8;

/// Gaussian colour model in the HSV-cone feature space (see the file comment).
struct ColourModel {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  double pixels = 0.0;  ///< number of pixels the model was estimated from
};

/// Sufficient statistics of a set of feature vectors; merging is exact.
struct ColourMoments {
  double n = 0.0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d sum_sq = Eigen::Matrix3d::Zero();  ///< Σ f fᵀ

  void add(const Eigen::Vector3d& f) { n += 1.0; sum += f; sum_sq.noalias() += f * f.transpose(); }
  void merge(const ColourMoments& o) { n += o.n; sum += o.sum; sum_sq += o.sum_sq; }
  /// Mean and (population) covariance; zero model when n == 0.
  [[nodiscard]] ColourModel model() const;
};

/// HSV-cone feature of one 8-bit HSV pixel (H in [0,180)).
[[nodiscard]] Eigen::Vector3d hsv_cone_feature(std::uint8_t h, std::uint8_t s, std::uint8_t v);

/// Squared symmetric distance used to merge models (see file comment). noise_floor is a std.
[[nodiscard]] double merge_distance_sq(const ColourModel& a, const ColourModel& b, double noise_floor);
/// Squared distance of `segment`'s mean to `reference` (see file comment).
[[nodiscard]] double class_distance_sq(const ColourModel& segment, const ColourModel& reference,
                                       double noise_floor);

/// Pools two models as a pixel-weighted mixture (moment matching); pixels add up. A model with
/// no pixels counts as one pixel.
[[nodiscard]] ColourModel pool_models(const ColourModel& a, const ColourModel& b);

/// The appearance summary of a taught edge (TeachPathEdge): a streaming clustering of the
/// reference models of the frames seen while teaching. Each frame's models are matched to the
/// nearest cluster within ref_merge_distance (merge distance) and pooled into it, or start a new
/// cluster; a cluster counts the frames it was seen in. summary() keeps the clusters seen in at
/// least `min_frame_share` of the frames (always the most frequent one), most frequent first — so
/// a surface crossed briefly (a road at a junction, a shadow) stays out of the summary wherever
/// the edge ends. Memory grows with the number of distinct surfaces, not with the edge length.
/// Not thread-safe; plain value type.
class AppearanceSummary {
 public:
  /// `params` supplies ref_merge_distance and colour_noise_floor; min_frame_share in (0, 1].
  explicit AppearanceSummary(const PathFollowerParams& params, double min_frame_share = 0.5);
  /// One frame's reference models (ignored when empty: the path was not seen).
  void add_frame(std::span<const ColourModel> models);
  [[nodiscard]] std::vector<ColourModel> summary() const;
  [[nodiscard]] int frames() const { return frames_; }
  void clear();

 private:
  struct Cluster {
    ColourModel model;
    int frames = 0;
    int last_frame = -1;
  };
  double merge_distance_ = 2.0;
  double noise_floor_ = 4.0;
  double min_frame_share_ = 0.5;
  int frames_ = 0;
  std::vector<Cluster> clusters_;
};

/// Horizon estimate for one image.
struct HorizonEstimate {
  int row_px = 0;          ///< first row of the sky/far part's boundary; ground starts below it
  double contrast = 0.0;   ///< auto mode: L2 distance of the band means at row_px (BGR levels)
  bool detected = false;   ///< auto mode found a change ≥ horizon_min_contrast
};

/// Horizon row of a BGR image per params (auto / row / ratio); clamped to
/// [0, rows − kMinGroundRowsPx]. `row_means_scratch` is a reusable buffer (may be empty).
[[nodiscard]] HorizonEstimate detect_horizon(const cv::Mat& bgr, const PathFollowerParams& params,
                                             cv::Mat& row_means_scratch);

/// Control law (1) as documented above. `middle_points` in image pixels; `ground_rows` = H_g;
/// `path_rows` = n, the rows that contain path (default: one per middle point). Returns the
/// command and writes the mean normalised offset to `offset` (0 when no points). `target_offset`
/// is the offset steered to (normalised, [-1, 1]; 0 = the path's middle in the image centre).
[[nodiscard]] Twist steering_command(std::span<const cv::Point2f> middle_points, int image_width_px,
                                     int ground_rows, const PathFollowerParams& params, double& offset,
                                     int path_rows = -1, double target_offset = 0.0);

/// Result of one frame. Geometry is in input-image pixels (origin top-left, u right, v down).
struct PathEstimate {
  PathStatus status = PathStatus::no_reference;
  HorizonEstimate horizon;
  int ground_top_px = 0;                  ///< first processed row (horizon + margin)
  cv::Mat mask;                           ///< CV_8UC1, input size; 255 = final path region
  std::vector<cv::Point> contour;         ///< external contour of the path region (may be empty)
  std::vector<cv::Point2f> middle_points; ///< one per region row: ((left + right) / 2, row)
  double area_share = 0.0;                ///< region pixels / ground-image pixels
  double mean_offset = 0.0;               ///< normalised offset of control law (1), + = right
  /// The offset with every path row (junction mode off) and with the junction-mode rows, whichever
  /// mode steered (one of them equals mean_offset): what the teacher records, so that the replay
  /// compares like with like in either mode (set_target_offset). 0 unless a region was found.
  double plain_offset = 0.0;
  double junction_offset = 0.0;
  double mean_intensity = 0.0;            ///< mean grey level of the ground image
  int segments = 0;                       ///< number of superpixels
  int reference_models = 0;               ///< reference models used for classification
  int gated_models = 0;                   ///< re-learned models rejected by the taught-appearance gate
  ReferenceSource reference_source = ReferenceSource::learned;  ///< where the models in use came from
  Twist command;                          ///< (v, ω); zero unless status == ok
};

/// Intermediate images of the last processed frame, for drawing and debugging. All Mats are
/// views into the follower's buffers, sized like the ground image (rows below ground_top_px),
/// valid until the next process() call; clone() to keep them.
struct PathStages {
  int ground_top_px = 0;
  cv::Mat blurred;        ///< CV_8UC3 median-blurred ground image
  cv::Mat labels;         ///< CV_32SC1 superpixel ids 0..segments−1
  cv::Mat reference_roi;  ///< CV_8UC1 trapezoid, 255 inside
  cv::Mat classified;     ///< CV_8UC1 per-segment classification (before opening)
  cv::Mat opened;         ///< CV_8UC1 after morphological opening
  std::vector<std::uint8_t> segment_is_reference;  ///< per segment: behind a reference model in use
  std::vector<ColourModel> reference_models;      ///< in use, largest coverage first
};

/// The path follower. Owns its parameters, the segmenter and every per-frame buffer; after
/// the first frame of a given size, process() into a reused PathEstimate allocates nothing of
/// its own (OpenCV's graph segmentation and contour search still allocate internally).
class PathFollower {
 public:
  /// Fails when params.validate() fails.
  static Result<PathFollower> create(const PathFollowerParams& params);

  PathFollower(PathFollower&&) noexcept;
  PathFollower& operator=(PathFollower&&) noexcept;
  ~PathFollower();

  /// Processes one 8-bit BGR frame (CV_8UC3, at least kMinImageWidthPx × kMinImageHeightPx).
  /// Errors (input only): empty, wrong type, too small. Path-level outcomes are a status.
  /// `out` is overwritten; reusing the same object keeps its buffers.
  Status process(const cv::Mat& bgr, PathEstimate& out);
  /// Convenience form returning a fresh estimate (allocates).
  Result<PathEstimate> process(const cv::Mat& bgr);

  /// Forgets the reference models carried to the next frame for blending, the taught models
  /// of the gate and the target offset (call at the start of a new edge, then set_taught_models / set_prior_models).
  /// Frames without reference models (dark, no reference) keep the previous ones.
  void reset();

  /// Sets the taught appearance the re-learned reference models are gated against (see the file
  /// comment; active when taught_gate_distance > 0). Empty: no gate. Models with a non-finite
  /// mean or covariance are ignored.
  void set_taught_models(std::vector<ColourModel> models);
  [[nodiscard]] const std::vector<ColourModel>& taught_models() const { return taught_models_; }

  /// Sets the models the next frame blends with (model_blend > 0), e.g. the appearance summary
  /// recorded when the edge was taught (reference_models() at teach time).
  void set_prior_models(std::vector<ColourModel> models) { previous_models_ = std::move(models); }

  /// Junction mode, for the first metres after a node where several path arms meet (an L
  /// corner, a T junction): rows whose path run reaches an image border are wider than the view,
  /// say nothing about the centre of the arm ahead and pull towards the arm the robot came
  /// from, so they are left out of the steering (when at least 5 rows and a fifth of the path
  /// rows remain). Off by default: on bends those near rows are the ones that keep the robot
  /// from cutting the curve. Speed still counts every path row.
  void set_junction_mode(bool on) { junction_mode_ = on; }

  /// The normalised offset control law (1) steers to (clamped to [-1, 1]; 0 after create and
  /// reset(): the path's middle in the image centre). PathEstimate::mean_offset stays the
  /// measured offset. The path replay sets the taught offset at its edge distance each frame.
  void set_target_offset(double target) { target_offset_ = std::clamp(target, -1.0, 1.0); }
  [[nodiscard]] double target_offset() const { return target_offset_; }
  [[nodiscard]] bool junction_mode() const { return junction_mode_; }

  [[nodiscard]] const PathFollowerParams& params() const { return params_; }
  /// Stages of the last successful process() call.
  [[nodiscard]] const PathStages& stages() const { return stages_; }
  /// Reference models of the last frame (empty before the first frame or after reset()).
  [[nodiscard]] const std::vector<ColourModel>& reference_models() const { return stages_.reference_models; }

 private:
  explicit PathFollower(const PathFollowerParams& params);
  void ensure_buffers(cv::Size size);
  /// Clears `out` and the stages for a new frame whose ground starts at image row `top`.
  void begin_frame(PathEstimate& out, const cv::Mat& bgr, int top);
  /// Sec. 4.1: blurs the ground rows into blurred_, segments them into labels_ (at seg_scale);
  /// returns the number of segments. `blurred`/`labels` are set to the views used.
  int segment_ground(const cv::Mat& ground, int ground_rows, cv::Mat& blurred, cv::Mat& labels);
  /// Sec. 4.2 step 4: the region of the first reference models, fewer while it is larger than
  /// multi_model_max_share of the ground; records the models used. Returns the region's pixels.
  int extract_path_region(int segments, const cv::Mat& labels, const cv::Mat& roi, double ground_pixels,
                          PathEstimate& out);
  /// Sec. 4.3: contour, middle points, offsets, status and command of the region at row `top`.
  void trace_path(const cv::Mat& region, int top, int width, int ground_rows, PathEstimate& out);
  void build_reference_roi(int ground_rows, int width);
  void accumulate_segment_statistics(const cv::Mat& hsv, const cv::Mat& labels, const cv::Mat& roi, int segments);
  int learn_reference_models(double roi_pixels);
  /// The taught-appearance gate on stages_.reference_models / kept_clusters_ (parallel);
  /// sets gated_models_ and reference_source_.
  void gate_reference_models();
  void classify_segments(int segments, int used_models);
  /// Classifies with the first `used_models` reference models, opens, keeps the component
  /// overlapping the reference region most in region_ (with `all_large_components`: every
  /// component of at least min_area_share of the ground image); returns the region's pixel count.
  int extract_region(int segments, int used_models, const cv::Mat& labels, const cv::Mat& roi,
                     bool all_large_components);
  /// Row-wise middle points of the region (junction mode: see set_junction_mode); returns the
  /// number of rows containing path.
  int extract_middle_points(const cv::Mat& region, int row_offset, std::vector<cv::Point2f>& out,
                            bool junction) const;

  struct SegmentStats {
    ColourMoments moments;      // all pixels of the segment
    ColourMoments roi_moments;  // its pixels inside the reference region
    double roi_pixels = 0.0;
  };
  struct Cluster {
    ColourMoments moments;
    ColourModel model;
    double roi_pixels = 0.0;
  };

  PathFollowerParams params_;
  cv::Ptr<cv::ximgproc::segmentation::GraphSegmentation> segmenter_;
  cv::Mat opening_kernel_;
  cv::Size buffer_size_;
  // Full-size buffers; ground-image views are row ranges of these.
  cv::Mat row_means_, blurred_, hsv_, labels_, roi_, classified_, opened_, components_, region_;
  cv::Mat small_, small_labels_;  // segmentation-resolution buffers (seg_scale < 1)
  int roi_rows_ = -1, roi_cols_ = -1;
  std::vector<SegmentStats> segment_stats_;
  std::vector<int> order_;
  std::vector<int> segment_cluster_;
  std::vector<Cluster> clusters_;
  std::vector<int> kept_clusters_;  // cluster id of each reference model (−1: not from this frame)
  std::vector<ColourModel> previous_models_;
  std::vector<ColourModel> taught_models_;
  std::vector<Eigen::Matrix3d> taught_inverse_;  // (Σt + λI)⁻¹ per taught model
  int gated_models_ = 0;
  double target_offset_ = 0.0;
  ReferenceSource reference_source_ = ReferenceSource::learned;
  bool junction_mode_ = false;
  std::vector<Eigen::Matrix3d> reference_inverse_;
  std::vector<std::uint8_t> segment_is_path_;
  std::vector<double> component_overlap_;
  std::vector<double> component_pixels_;
  std::vector<std::vector<cv::Point>> contours_;
  std::vector<cv::Point2f> other_points_;  // middle points of the mode not steered on
  std::vector<cv::Vec4i> hierarchy_;
  PathStages stages_;
};

}  // namespace visnav::path_following
