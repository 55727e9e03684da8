// visnav detectors — the detector types of the `detector` plugins, usable directly from code.
//
// Types (config `type:`): star_brief (CenSurE/STAR + BRIEF, written here), orb, agast_brief,
// fast_brief, gftt_brief (OpenCV detector + our BRIEF), sift, akaze, brisk (OpenCV). Every type
//  * parses its `params:` block with a ParamSchema (unknown keys, wrong types and out-of-range
//    values are errors naming file:line and key) and checks cross-field rules in validate();
//  * adapts one detector threshold per frame toward `target_keypoints` (AdaptiveThreshold) and
//    keeps the `target_keypoints` strongest keypoints (by KeyPoint::response);
//  * supports reconfigure() (live reload): the adapted threshold survives unless `threshold`
//    itself was changed;
//  * accepts grey CV_8UC1, BGR CV_8UC3 or BGRA CV_8UC4 images; an empty image or another type
//    is an error; images smaller than kMinImageSidePx on a side, and blank images, give empty
//    Features and ok(). OpenCV exceptions are caught and returned as errors.
//
// From a test or benchmark (link `visnav_detector_core`):
//   auto det = visnav::detectors::create_detector("star_brief",
//                  visnav::detectors::make_params({{"target_keypoints", "500"}}));
//   if (!det) ...;  visnav::Features f;  (*det)->detect(image, f);
//
// Thread-safety: one detector object per thread (each owns its buffers).
#pragma once

#include <initializer_list>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <opencv2/features2d.hpp>

#include "visnav/detectors/adaptive_threshold.hpp"
#include "visnav/detectors/brief.hpp"
#include "visnav/detectors/star.hpp"
#include "visnav/devices.hpp"
#include "visnav/host.hpp"
#include "visnav/params.hpp"

namespace visnav::detectors {

/// Images with a side shorter than this give no features (ok(), nothing detected).
inline constexpr int kMinImageSidePx = 32;

/// Parameters shared by all types; each type's struct sets its own threshold defaults.
struct CommonParams {
  int target_keypoints = 500;       ///< keypoints per frame (the N strongest are kept)
  /// > 0: the target scales with the image, target = round(this × width × height / 1e6), within
  /// [1, 20000], replacing target_keypoints (0 = off).
  double keypoints_per_mpx = 0.0;
  double threshold = 1.0;           ///< initial detector threshold (meaning per type)
  double min_threshold = 0.1;       ///< adaptive threshold lower clamp
  double max_threshold = 100.0;     ///< adaptive threshold upper clamp
  bool adaptive_threshold = true;   ///< false: the threshold stays at `threshold`
  double adaptation_exponent = 0.5; ///< first-step exponent e of threshold·(found/aim)^e
  double max_step_ratio = 4.0;      ///< max threshold change factor per frame
  double headroom_ratio = 1.2;      ///< adapt toward target × this raw keypoints
  bool upright = true;              ///< no orientation (planar robots); false: rotation invariant

  [[nodiscard]] Status validate_common() const;
  [[nodiscard]] AdaptiveThresholdParams adaptive() const;
};

/// Adds the CommonParams fields to a schema; `threshold_doc` states the threshold's meaning
/// and unit, [lo, hi] its hard range.
template <typename P>
void add_common_fields(ParamSchema<P>& s, const std::string& threshold_doc, double lo, double hi) {
  s.field("target_keypoints", static_cast<int P::*>(&P::target_keypoints), "keypoints wanted per frame; the strongest are kept")
      .range(1, 20000)
      .field("keypoints_per_mpx", static_cast<double P::*>(&P::keypoints_per_mpx),
             "> 0: keypoints per megapixel of the image, replacing target_keypoints (0 = off)")
      .range(0, 200000)
      .field("threshold", static_cast<double P::*>(&P::threshold), "initial threshold: " + threshold_doc)
      .range(lo, hi)
      .field("min_threshold", static_cast<double P::*>(&P::min_threshold), "lower clamp of the adaptive threshold")
      .range(lo, hi)
      .field("max_threshold", static_cast<double P::*>(&P::max_threshold), "upper clamp of the adaptive threshold")
      .range(lo, hi)
      .field("adaptive_threshold", static_cast<bool P::*>(&P::adaptive_threshold),
             "adapt the threshold each frame toward target_keypoints × headroom_ratio")
      .field("adaptation_exponent", static_cast<double P::*>(&P::adaptation_exponent),
             "exponent e of threshold·(found/aim)^e until the count/threshold slope is known")
      .range(0.05, 5)
      .field("max_step_ratio", static_cast<double P::*>(&P::max_step_ratio), "max threshold change factor per frame")
      .range(1.01, 10)
      .field("headroom_ratio", static_cast<double P::*>(&P::headroom_ratio),
             "raw keypoints aimed at = target_keypoints × this (the strongest target_keypoints are kept)")
      .range(1, 3)
      .field("upright", static_cast<bool P::*>(&P::upright),
             "skip orientation (planar motion); false: rotation-invariant descriptors");
}

/// Base of every detector type: image checks, grey conversion, adaptive threshold, top-N.
class DetectorBase : public Detector {
 public:
  [[nodiscard]] virtual const char* type_name() const = 0;
  /// Threshold that the next detect() will use.
  [[nodiscard]] double threshold() const { return adaptive_.threshold(); }
  /// Keypoints found by the last detect() before keeping the strongest target_keypoints.
  [[nodiscard]] int last_raw_count() const { return last_raw_count_; }
  [[nodiscard]] int target_keypoints() const { return adaptive_.params().target_keypoints; }

  Status detect(const cv::Mat& image, Features& out) final;

 protected:
  /// Detects on `grey` (CV_8UC1, both sides ≥ kMinImageSidePx) with `threshold`, fills `out`
  /// (at most target_keypoints) and `raw_count` (keypoints before the top-N cut).
  virtual Status run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) = 0;
  /// The detector's own keypoint cap for this frame (0: none); see AdaptiveThreshold::update.
  [[nodiscard]] virtual int raw_cap() const { return 0; }

  /// Keeps the `n` strongest of raw_keypoints_ (ties: earlier first) in raw_keypoints_.
  void keep_strongest(int n);
  /// Writes the `n` strongest of raw_keypoints_/raw_descriptors_ to `out`.
  void select_strongest(int n, Features& out);

  /// Finishes a detector + our BRIEF frame: drops the raw keypoints BRIEF cannot describe (so
  /// the adaptive count sees usable ones), sets `raw_count`, keeps the target_keypoints
  /// strongest and describes them into `out`. `integral`: optional integral image of `grey`.
  void describe_strongest(BriefExtractor& brief, const cv::Mat& grey, Features& out, int& raw_count,
                          const cv::Mat& integral = cv::Mat());
  /// Finishes a detector-with-descriptor frame (raw_keypoints_/raw_descriptors_): sets
  /// `raw_count` and writes the target_keypoints strongest to `out`.
  void output_strongest(Features& out, int& raw_count);

  AdaptiveThreshold adaptive_;
  double keypoints_per_mpx_ = 0.0;  ///< CommonParams::keypoints_per_mpx, set by apply()
  std::vector<cv::KeyPoint> raw_keypoints_;
  cv::Mat raw_descriptors_;

 private:
  void rank(int n);
  cv::Mat grey_;
  std::vector<int> order_;
  std::vector<cv::KeyPoint> kept_;
  int last_raw_count_ = 0;
};

/// CRTP helper: schema parsing for create() and reconfigure(), and apply(): validate() the
/// params, let Derived set its detector up, then store them and (re)initialise the adaptive
/// threshold. Derived implements `Status setup(const P& params)` (called once validate()
/// passed; reachable through `friend DetectorType`) and `static constexpr const char* kTypeName`.
template <typename Derived, typename P>
class DetectorType : public DetectorBase {
 public:
  using Params = P;

  static Result<std::unique_ptr<Derived>> create(const ConfigNode& params) {
    auto parsed = P::schema().parse(params);
    if (!parsed) return std::move(parsed).error().with_context(std::string("detector '") + Derived::kTypeName + "'");
    auto made = std::make_unique<Derived>();
    auto applied = made->apply(*parsed, true);
    if (!applied) return std::move(applied).error().with_context(std::string("detector '") + Derived::kTypeName + "'");
    return made;
  }
  static Result<std::unique_ptr<Derived>> create(const ConfigNode& params, HostServices& /*host*/) {
    return create(params);
  }

  Status reconfigure(const ConfigNode& params) override {
    auto parsed = P::schema().parse(params);
    if (!parsed) return std::move(parsed).error().with_context(std::string("detector '") + Derived::kTypeName + "'");
    return static_cast<Derived*>(this)->apply(*parsed, false);
  }
  [[nodiscard]] const char* type_name() const override { return Derived::kTypeName; }
  [[nodiscard]] const P& params() const { return params_; }

  /// Validates and applies `params`; `first`: on creation (the adaptive threshold starts at
  /// `threshold`), else a live reload (the adapted threshold survives unless `threshold` changed).
  Status apply(const P& params, bool first) {
    VISNAV_TRY(params.validate());
    VISNAV_TRY(static_cast<Derived*>(this)->setup(params));
    params_ = params;
    keypoints_per_mpx_ = params.keypoints_per_mpx;
    if (first) adaptive_ = AdaptiveThreshold(params.adaptive());
    else adaptive_.reconfigure(params.adaptive());
    return ok();
  }

 protected:
  P params_;
};

// ---------------------------------------------------------------------------------------------
// star_brief

/// BRIEF fields of the types that describe with our BriefExtractor.
struct BriefFields {
  int patch_size_px = 48;
  int kernel_size_px = 7;
};

struct StarBriefParams : CommonParams, BriefFields {
  StarBriefParams() { threshold = 30; min_threshold = 2; max_threshold = 250; }
  int max_size_px = 45;
  double line_threshold_projected = 10;
  double line_threshold_binarized = 8;
  int suppress_nonmax_size_px = 5;
  [[nodiscard]] Status validate() const;
  static const ParamSchema<StarBriefParams>& schema();
};

class StarBriefDetector final : public DetectorType<StarBriefDetector, StarBriefParams> {
 public:
  static constexpr const char* kTypeName = "star_brief";
  [[nodiscard]] DescriptorNorm norm() const override { return DescriptorNorm::hamming; }

 protected:
  friend DetectorType;
  Status setup(const StarBriefParams& params);
  Status run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) override;

 private:
  StarDetector star_;
  BriefExtractor brief_;
};

// ---------------------------------------------------------------------------------------------
// grief: star_brief whose 256 comparison pairs come from a file (visnav/detectors/grief.hpp)

struct GriefParams : StarBriefParams {
  /// "seasonal" = the trained pattern that ships (kSeasonalPairsName, built in); "brief" (or
  /// empty) = the BRIEF pattern (then identical to star_brief); anything else = a pairs file path.
  std::string pairs = "seasonal";
  [[nodiscard]] Status validate() const;
  static const ParamSchema<GriefParams>& schema();
};

/// STAR keypoints + BRIEF-like 256-bit descriptor with trained comparison pairs (GRIEF,
/// Krajník et al. 2017). The pairs file is read in setup(): on creation and on every
/// reconfigure() (a changed file is picked up by a live reload); a bad file is an error naming
/// file:line, and a rejected reload leaves the detector unchanged.
class GriefDetector final : public DetectorType<GriefDetector, GriefParams> {
 public:
  static constexpr const char* kTypeName = "grief";
  [[nodiscard]] DescriptorNorm norm() const override { return DescriptorNorm::hamming; }

 protected:
  friend DetectorType;
  Status setup(const GriefParams& params);
  Status run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) override;

 private:
  StarDetector star_;
  BriefExtractor brief_;
};

// ---------------------------------------------------------------------------------------------
// OpenCV detectors + our BRIEF

struct AgastBriefParams : CommonParams, BriefFields {
  AgastBriefParams() { threshold = 15; min_threshold = 2; max_threshold = 120; }
  std::string agast_type = "OAST_9_16";
  bool nonmax_suppression = true;
  [[nodiscard]] Status validate() const;
  static const ParamSchema<AgastBriefParams>& schema();
};

class AgastBriefDetector final : public DetectorType<AgastBriefDetector, AgastBriefParams> {
 public:
  static constexpr const char* kTypeName = "agast_brief";
  [[nodiscard]] DescriptorNorm norm() const override { return DescriptorNorm::hamming; }

 protected:
  friend DetectorType;
  Status setup(const AgastBriefParams& params);
  Status run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) override;

 private:
  cv::Ptr<cv::AgastFeatureDetector> agast_;
  BriefExtractor brief_;
};

struct FastBriefParams : CommonParams, BriefFields {
  FastBriefParams() { threshold = 20; min_threshold = 2; max_threshold = 120; }
  std::string fast_type = "TYPE_9_16";
  bool nonmax_suppression = true;
  [[nodiscard]] Status validate() const;
  static const ParamSchema<FastBriefParams>& schema();
};

class FastBriefDetector final : public DetectorType<FastBriefDetector, FastBriefParams> {
 public:
  static constexpr const char* kTypeName = "fast_brief";
  [[nodiscard]] DescriptorNorm norm() const override { return DescriptorNorm::hamming; }

 protected:
  friend DetectorType;
  Status setup(const FastBriefParams& params);
  Status run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) override;

 private:
  cv::Ptr<cv::FastFeatureDetector> fast_;
  BriefExtractor brief_;
};

struct GfttBriefParams : CommonParams, BriefFields {
  GfttBriefParams() { threshold = 0.01; min_threshold = 0.0001; max_threshold = 0.5; }
  double min_distance_px = 5;
  int block_size_px = 3;
  bool use_harris = false;
  double harris_k = 0.04;
  [[nodiscard]] Status validate() const;
  static const ParamSchema<GfttBriefParams>& schema();
};

class GfttBriefDetector final : public DetectorType<GfttBriefDetector, GfttBriefParams> {
 public:
  static constexpr const char* kTypeName = "gftt_brief";
  [[nodiscard]] DescriptorNorm norm() const override { return DescriptorNorm::hamming; }

 protected:
  friend DetectorType;
  Status setup(const GfttBriefParams& params);
  Status run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) override;

 private:
  [[nodiscard]] int raw_cap() const override { return 2 * adaptive_.aim(); }
  cv::Ptr<cv::GFTTDetector> gftt_;
  BriefExtractor brief_;
  cv::Mat mask_;
  int mask_border_ = -1;
};

// ---------------------------------------------------------------------------------------------
// OpenCV detector + descriptor pairs

struct OrbParams : CommonParams {
  OrbParams() { threshold = 20; min_threshold = 2; max_threshold = 120; upright = false; }
  int pyramid_levels = 8;
  double scale_factor = 1.2;
  int patch_size_px = 31;
  int edge_threshold_px = 31;
  [[nodiscard]] Status validate() const;
  static const ParamSchema<OrbParams>& schema();
};

class OrbDetector final : public DetectorType<OrbDetector, OrbParams> {
 public:
  static constexpr const char* kTypeName = "orb";
  [[nodiscard]] DescriptorNorm norm() const override { return DescriptorNorm::hamming; }

 protected:
  friend DetectorType;
  Status setup(const OrbParams& params);
  Status run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) override;

 private:
  [[nodiscard]] int raw_cap() const override { return 2 * adaptive_.aim(); }
  cv::Ptr<cv::ORB> orb_;
};

struct SiftParams : CommonParams {
  SiftParams() { threshold = 0.04; min_threshold = 0.002; max_threshold = 0.3; upright = false; }
  int octave_layers = 3;
  double edge_threshold = 10;
  double sigma_px = 1.6;
  [[nodiscard]] Status validate() const;
  static const ParamSchema<SiftParams>& schema();
};

class SiftDetector final : public DetectorType<SiftDetector, SiftParams> {
 public:
  static constexpr const char* kTypeName = "sift";
  [[nodiscard]] DescriptorNorm norm() const override { return DescriptorNorm::l2; }

 protected:
  friend DetectorType;
  Status setup(const SiftParams& params);
  Status run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) override;

 private:
  [[nodiscard]] int raw_cap() const override { return 2 * adaptive_.aim(); }
  cv::Ptr<cv::SIFT> sift_;
  double sift_threshold_ = -1;
  int sift_features_ = -1;
};

struct AkazeParams : CommonParams {
  AkazeParams() { threshold = 0.001; min_threshold = 0.0002; max_threshold = 0.02; }
  int octaves = 4;
  int octave_layers = 4;
  int descriptor_size_bits = 0;
  [[nodiscard]] Status validate() const;
  static const ParamSchema<AkazeParams>& schema();
};

class AkazeDetector final : public DetectorType<AkazeDetector, AkazeParams> {
 public:
  static constexpr const char* kTypeName = "akaze";
  [[nodiscard]] DescriptorNorm norm() const override { return DescriptorNorm::hamming; }

 protected:
  friend DetectorType;
  Status setup(const AkazeParams& params);
  Status run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) override;

 private:
  cv::Ptr<cv::AKAZE> akaze_;
};

struct BriskParams : CommonParams {
  BriskParams() { threshold = 30; min_threshold = 3; max_threshold = 150; upright = false; }
  int octaves = 3;
  double pattern_scale = 1.0;
  [[nodiscard]] Status validate() const;
  static const ParamSchema<BriskParams>& schema();
};

class BriskDetector final : public DetectorType<BriskDetector, BriskParams> {
 public:
  static constexpr const char* kTypeName = "brisk";
  [[nodiscard]] DescriptorNorm norm() const override { return DescriptorNorm::hamming; }

 protected:
  friend DetectorType;
  Status setup(const BriskParams& params);
  Status run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) override;

 private:
  cv::Ptr<cv::BRISK> brisk_;
  int brisk_threshold_ = -1;
};

// ---------------------------------------------------------------------------------------------
// Factory (for tests, benchmarks and tools that do not go through the plugin loader)

/// All type names, in the order listed above.
[[nodiscard]] const std::vector<std::string>& detector_type_names();

/// Creates a detector of `type` from a `params:` block (null node: all defaults).
[[nodiscard]] Result<std::unique_ptr<DetectorBase>> create_detector(std::string_view type,
                                                                    const ConfigNode& params = ConfigNode{});

/// Parameter docs of `type`.
[[nodiscard]] Result<std::vector<ParamDoc>> detector_param_docs(std::string_view type);

/// A params map node from key/value text pairs: make_params({{"target_keypoints", "300"}}).
[[nodiscard]] ConfigNode make_params(std::initializer_list<std::pair<std::string, std::string>> entries);

}  // namespace visnav::detectors
