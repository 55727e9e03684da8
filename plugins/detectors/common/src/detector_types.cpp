// The detector types: parameter schemas, validation, and the per-type detection pipelines.
// The shared parts (params → adaptive threshold, BRIEF fields and their validation, the
// detect → top-N → describe tail) live in DetectorType::apply, DetectorBase and the helpers
// below; each type keeps only what is its own.
#include "visnav/detectors/detector_types.hpp"

#include "visnav/detectors/grief.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>


namespace visnav::detectors {

namespace {

template <typename P>
void add_brief_fields(ParamSchema<P>& s) {
  s.field("patch_size_px", static_cast<int P::*>(&P::patch_size_px), "BRIEF patch side S (tests ~ N(0, (S/5)²))")
      .range(16, 96)
      .field("kernel_size_px", static_cast<int P::*>(&P::kernel_size_px),
             "BRIEF smoothing box side (odd; 7 ≈ Gaussian σ = 2)")
      .range(1, 15);
}

/// BriefParams of a type with BriefFields.
template <typename P>
BriefParams brief_params(const P& p) {
  BriefParams b;
  b.patch_size_px = p.patch_size_px;
  b.kernel_size_px = p.kernel_size_px;
  b.upright = p.upright;
  return b;
}

/// Common fields + BRIEF fields of a type with BriefFields.
template <typename P>
Status validate_common_and_brief(const P& p) {
  VISNAV_TRY(p.validate_common());
  return brief_params(p).validate();
}

int rounded(double threshold) { return std::max(1, static_cast<int>(std::lround(threshold))); }

/// Config name → OpenCV enum; the names also give the schema's one_of list.
template <typename E>
using NamedValues = std::vector<std::pair<std::string, E>>;

template <typename E>
std::vector<std::string> names_of(const NamedValues<E>& table) {
  std::vector<std::string> names;
  for (const auto& [name, value] : table) names.push_back(name);
  return names;
}

template <typename E>
E value_of(const NamedValues<E>& table, const std::string& name) {
  for (const auto& [n, value] : table)
    if (n == name) return value;
  return table.front().second;  // unreachable after one_of(): the schema rejects other names
}

const NamedValues<cv::AgastFeatureDetector::DetectorType>& agast_types() {
  static const NamedValues<cv::AgastFeatureDetector::DetectorType> t = {
      {"OAST_9_16", cv::AgastFeatureDetector::OAST_9_16},
      {"AGAST_5_8", cv::AgastFeatureDetector::AGAST_5_8},
      {"AGAST_7_12d", cv::AgastFeatureDetector::AGAST_7_12d},
      {"AGAST_7_12s", cv::AgastFeatureDetector::AGAST_7_12s}};
  return t;
}

const NamedValues<cv::FastFeatureDetector::DetectorType>& fast_types() {
  static const NamedValues<cv::FastFeatureDetector::DetectorType> t = {
      {"TYPE_9_16", cv::FastFeatureDetector::TYPE_9_16},
      {"TYPE_5_8", cv::FastFeatureDetector::TYPE_5_8},
      {"TYPE_7_12", cv::FastFeatureDetector::TYPE_7_12}};
  return t;
}

// The STAR part of star_brief's params (response threshold: the adaptive one, set per frame).
StarParams star_params(const StarBriefParams& p, int border_px) {
  StarParams sp;
  sp.max_size_px = p.max_size_px;
  sp.response_threshold = p.threshold;
  sp.line_threshold_projected = p.line_threshold_projected;
  sp.line_threshold_binarized = p.line_threshold_binarized;
  sp.suppress_nonmax_size_px = p.suppress_nonmax_size_px;
  sp.border_px = border_px;
  return sp;
}

}  // namespace

// ----------------------------------------------------------------------- shared frame tails

void DetectorBase::describe_strongest(BriefExtractor& brief, const cv::Mat& grey, Features& out, int& raw_count,
                                      const cv::Mat& integral) {
  const int border = brief.border_px();
  const int w = grey.cols;
  const int h = grey.rows;
  std::erase_if(raw_keypoints_, [&](const cv::KeyPoint& kp) {
    const long xi = std::lround(kp.pt.x);
    const long yi = std::lround(kp.pt.y);
    return xi < border || yi < border || xi >= w - border || yi >= h - border;
  });
  raw_count = static_cast<int>(raw_keypoints_.size());
  keep_strongest(target_keypoints());
  brief.compute(grey, raw_keypoints_, out.descriptors, integral);
  out.keypoints.swap(raw_keypoints_);
}

void DetectorBase::output_strongest(Features& out, int& raw_count) {
  raw_count = static_cast<int>(raw_keypoints_.size());
  select_strongest(target_keypoints(), out);
}

// ------------------------------------------------------------------------------ star_brief

Status StarBriefParams::validate() const {
  VISNAV_TRY(validate_common());
  VISNAV_TRY(star_params(*this, 0).validate());
  return brief_params(*this).validate();
}

namespace {

template <typename P>
void add_star_fields(ParamSchema<P>& sc) {
  add_common_fields(sc, "STAR response, absolute mean(inner) − mean(ring), grey levels", 0.5, 255);
  sc.field("max_size_px", static_cast<int P::*>(&P::max_size_px), "largest outer filter diameter (45 → 7 scales)")
      .range(5, 129)
      .field("line_threshold_projected", static_cast<double P::*>(&P::line_threshold_projected),
             "reject line-like points: trace²/det of response gradients ≥ this")
      .range(1, 1000)
      .field("line_threshold_binarized", static_cast<double P::*>(&P::line_threshold_binarized),
             "reject line-like points: trace²/det on the binarised scale image ≥ this")
      .range(1, 1000)
      .field("suppress_nonmax_size_px", static_cast<int P::*>(&P::suppress_nonmax_size_px),
             "non-maximum suppression window side (odd)")
      .range(3, 31);
  add_brief_fields(sc);
}

}  // namespace

const ParamSchema<StarBriefParams>& StarBriefParams::schema() {
  static const ParamSchema<StarBriefParams> s = [] {
    ParamSchema<StarBriefParams> sc;
    add_star_fields(sc);
    return sc;
  }();
  return s;
}

Status StarBriefDetector::setup(const StarBriefParams& p) {
  VISNAV_TRY(brief_.set_params(brief_params(p)));
  return star_.set_params(star_params(p, brief_.border_px()));
}

Status StarBriefDetector::run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) {
  star_.set_response_threshold(threshold);
  star_.detect(grey, raw_keypoints_);  // border_px = BRIEF's border: every keypoint can be described
  describe_strongest(brief_, grey, out, raw_count, star_.integral());
  return ok();
}

// ----------------------------------------------------------------------------------- grief

Status GriefParams::validate() const { return StarBriefParams::validate(); }

const ParamSchema<GriefParams>& GriefParams::schema() {
  static const ParamSchema<GriefParams> s = [] {
    ParamSchema<GriefParams> sc;
    add_star_fields(sc);
    sc.field("pairs", &GriefParams::pairs,
             "comparison pairs: seasonal = the trained pattern that ships (built in); brief = the BRIEF pattern; "
             "else a pairs file (YAML, e.g. from `visnav train-descriptor`)");
    return sc;
  }();
  return s;
}

Status GriefDetector::setup(const GriefParams& p) {
  std::vector<BriefTest> pattern;  // empty: BRIEF's
  if (!p.pairs.empty() && p.pairs != "brief") {
    VISNAV_ASSIGN(PairsFile file, p.pairs == kSeasonalPairsName ? seasonal_pairs() : read_pairs_file(p.pairs));
    if (file.patch_size_px != p.patch_size_px)
      return fail(ErrorCode::inconsistent, p.pairs + ": the pairs were made for patch_size_px " + std::to_string(file.patch_size_px) +
                  " but the detector has patch_size_px " + std::to_string(p.patch_size_px) +
                  " (set it to match, or pairs: brief for the BRIEF pattern of any patch size)");
    pattern = std::move(file.pairs);
  }
  VISNAV_TRY(brief_.set_params(brief_params(p)));
  VISNAV_TRY(brief_.set_pattern(std::move(pattern)));
  return star_.set_params(star_params(p, brief_.border_px()));
}

Status GriefDetector::run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) {
  star_.set_response_threshold(threshold);
  star_.detect(grey, raw_keypoints_);
  describe_strongest(brief_, grey, out, raw_count, star_.integral());
  return ok();
}

// ------------------------------------------------------------------------------ agast_brief

Status AgastBriefParams::validate() const { return validate_common_and_brief(*this); }

const ParamSchema<AgastBriefParams>& AgastBriefParams::schema() {
  static const ParamSchema<AgastBriefParams> s = [] {
    ParamSchema<AgastBriefParams> sc;
    add_common_fields(sc, "AGAST intensity difference, grey levels (applied rounded)", 1, 255);
    sc.field("agast_type", &AgastBriefParams::agast_type, "AGAST mask")
        .one_of(names_of(agast_types()))
        .field("nonmax_suppression", &AgastBriefParams::nonmax_suppression, "AGAST non-maximum suppression");
    add_brief_fields(sc);
    return sc;
  }();
  return s;
}

Status AgastBriefDetector::setup(const AgastBriefParams& p) {
  VISNAV_TRY(brief_.set_params(brief_params(p)));
  agast_ = cv::AgastFeatureDetector::create(rounded(p.threshold), p.nonmax_suppression, value_of(agast_types(), p.agast_type));
  return ok();
}

Status AgastBriefDetector::run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) {
  agast_->setThreshold(rounded(threshold));
  agast_->detect(grey, raw_keypoints_);
  describe_strongest(brief_, grey, out, raw_count);
  return ok();
}

// ------------------------------------------------------------------------------ fast_brief

Status FastBriefParams::validate() const { return validate_common_and_brief(*this); }

const ParamSchema<FastBriefParams>& FastBriefParams::schema() {
  static const ParamSchema<FastBriefParams> s = [] {
    ParamSchema<FastBriefParams> sc;
    add_common_fields(sc, "FAST intensity difference, grey levels (applied rounded)", 1, 255);
    sc.field("fast_type", &FastBriefParams::fast_type, "FAST circle")
        .one_of(names_of(fast_types()))
        .field("nonmax_suppression", &FastBriefParams::nonmax_suppression, "FAST non-maximum suppression");
    add_brief_fields(sc);
    return sc;
  }();
  return s;
}

Status FastBriefDetector::setup(const FastBriefParams& p) {
  VISNAV_TRY(brief_.set_params(brief_params(p)));
  fast_ = cv::FastFeatureDetector::create(rounded(p.threshold), p.nonmax_suppression, value_of(fast_types(), p.fast_type));
  return ok();
}

Status FastBriefDetector::run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) {
  fast_->setThreshold(rounded(threshold));
  fast_->detect(grey, raw_keypoints_);
  describe_strongest(brief_, grey, out, raw_count);
  return ok();
}

// ------------------------------------------------------------------------------ gftt_brief

Status GfttBriefParams::validate() const {
  VISNAV_TRY(validate_common());
  if (block_size_px % 2 == 0) return Error{"block_size_px must be odd", ErrorCode::invalid_value, {{}, 0, "block_size_px"}};
  return brief_params(*this).validate();
}

const ParamSchema<GfttBriefParams>& GfttBriefParams::schema() {
  static const ParamSchema<GfttBriefParams> s = [] {
    ParamSchema<GfttBriefParams> sc;
    add_common_fields(sc, "GFTT quality level, fraction of the strongest corner's score", 1e-6, 1);
    sc.field("min_distance_px", &GfttBriefParams::min_distance_px, "minimum distance between corners")
        .range(0, 100)
        .field("block_size_px", &GfttBriefParams::block_size_px, "corner measure window side (odd)")
        .range(3, 31)
        .field("use_harris", &GfttBriefParams::use_harris, "Harris measure instead of the minimum eigenvalue")
        .field("harris_k", &GfttBriefParams::harris_k, "Harris k")
        .range(0.001, 0.5);
    add_brief_fields(sc);
    return sc;
  }();
  return s;
}

Status GfttBriefDetector::setup(const GfttBriefParams& p) {
  VISNAV_TRY(brief_.set_params(brief_params(p)));
  gftt_ = cv::GFTTDetector::create(p.target_keypoints, p.threshold, p.min_distance_px, p.block_size_px, p.use_harris,
                                   p.harris_k);
  return ok();
}

Status GfttBriefDetector::run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) {
  gftt_->setQualityLevel(threshold);
  gftt_->setMaxFeatures(raw_cap());  // room above the aim, so the count can push the threshold up
  // A mask keeps GFTT's own cap (raw_cap) for corners BRIEF can describe.
  const int border = brief_.border_px();
  if (mask_.size() != grey.size() || mask_border_ != border) {
    mask_.create(grey.size(), CV_8UC1);
    mask_.setTo(0);
    if (grey.cols > 2 * border && grey.rows > 2 * border)
      mask_(cv::Rect(border, border, grey.cols - 2 * border, grey.rows - 2 * border)).setTo(255);
    mask_border_ = border;
  }
  gftt_->detect(grey, raw_keypoints_, mask_);
  describe_strongest(brief_, grey, out, raw_count);
  return ok();
}

// ------------------------------------------------------------------------------ orb

Status OrbParams::validate() const {
  VISNAV_TRY(validate_common());
  if (edge_threshold_px < patch_size_px / 2 + 1)
    return Error{"edge_threshold_px (" + std::to_string(edge_threshold_px) + ") must be > patch_size_px / 2", ErrorCode::inconsistent, {{}, 0, "edge_threshold_px"}};
  return ok();
}

const ParamSchema<OrbParams>& OrbParams::schema() {
  static const ParamSchema<OrbParams> s = [] {
    ParamSchema<OrbParams> sc;
    add_common_fields(sc, "FAST intensity difference of ORB, grey levels (applied rounded)", 1, 255);
    sc.field("pyramid_levels", &OrbParams::pyramid_levels, "ORB pyramid levels")
        .range(1, 16)
        .field("scale_factor", &OrbParams::scale_factor, "ORB pyramid scale ratio")
        .range(1.01, 2)
        .field("patch_size_px", &OrbParams::patch_size_px, "ORB descriptor patch side")
        .range(7, 101)
        .field("edge_threshold_px", &OrbParams::edge_threshold_px, "ORB border without keypoints")
        .range(4, 101);
    return sc;
  }();
  return s;
}

Status OrbDetector::setup(const OrbParams& p) {
  orb_ = cv::ORB::create(static_cast<int>(std::ceil(p.target_keypoints * p.headroom_ratio)),
                         static_cast<float>(p.scale_factor), p.pyramid_levels, p.edge_threshold_px, 0, 2,
                         cv::ORB::HARRIS_SCORE, p.patch_size_px, rounded(p.threshold));
  return ok();
}

Status OrbDetector::run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) {
  orb_->setFastThreshold(rounded(threshold));
  orb_->setMaxFeatures(raw_cap());  // room above the aim, so the count can push the threshold up
  if (params_.upright) {
    orb_->detect(grey, raw_keypoints_);
    for (auto& kp : raw_keypoints_) kp.angle = 0.0F;
    orb_->compute(grey, raw_keypoints_, raw_descriptors_);
  } else {
    orb_->detectAndCompute(grey, cv::noArray(), raw_keypoints_, raw_descriptors_);
  }
  output_strongest(out, raw_count);
  return ok();
}

// ------------------------------------------------------------------------------ sift

Status SiftParams::validate() const { return validate_common(); }

const ParamSchema<SiftParams>& SiftParams::schema() {
  static const ParamSchema<SiftParams> s = [] {
    ParamSchema<SiftParams> sc;
    add_common_fields(sc, "SIFT contrast threshold (DoG, image range 0..1, divided by octave_layers)", 1e-5, 1);
    sc.field("octave_layers", &SiftParams::octave_layers, "SIFT layers per octave")
        .range(1, 8)
        .field("edge_threshold", &SiftParams::edge_threshold, "SIFT edge rejection ratio")
        .range(1, 100)
        .field("sigma_px", &SiftParams::sigma_px, "SIFT base Gaussian sigma")
        .range(0.5, 5);
    return sc;
  }();
  return s;
}

Status SiftDetector::setup(const SiftParams& /*p*/) {
  sift_.release();  // rebuilt at the next frame with the current threshold
  return ok();
}

Status SiftDetector::run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) {
  const int features = raw_cap();
  if (sift_.empty() || threshold != sift_threshold_ || features != sift_features_) {
    sift_ = cv::SIFT::create(features, params_.octave_layers, threshold, params_.edge_threshold, params_.sigma_px);
    sift_threshold_ = threshold;
    sift_features_ = features;
  }
  if (params_.upright) {
    sift_->detect(grey, raw_keypoints_);
    // SIFT returns one keypoint per dominant orientation; upright keeps one per location.
    std::sort(raw_keypoints_.begin(), raw_keypoints_.end(), [](const cv::KeyPoint& a, const cv::KeyPoint& b) {
      if (a.pt.y != b.pt.y) return a.pt.y < b.pt.y;
      if (a.pt.x != b.pt.x) return a.pt.x < b.pt.x;
      if (a.size != b.size) return a.size < b.size;
      return a.response > b.response;
    });
    raw_keypoints_.erase(std::unique(raw_keypoints_.begin(), raw_keypoints_.end(),
                                     [](const cv::KeyPoint& a, const cv::KeyPoint& b) {
                                       return a.pt == b.pt && a.size == b.size;
                                     }),
                         raw_keypoints_.end());
    for (auto& kp : raw_keypoints_) kp.angle = 0.0F;
    sift_->compute(grey, raw_keypoints_, raw_descriptors_);
  } else {
    sift_->detectAndCompute(grey, cv::noArray(), raw_keypoints_, raw_descriptors_);
  }
  output_strongest(out, raw_count);
  return ok();
}

// ------------------------------------------------------------------------------ akaze

Status AkazeParams::validate() const {
  VISNAV_TRY(validate_common());
  if (descriptor_size_bits != 0 && (descriptor_size_bits < 8 || descriptor_size_bits > 486))
    return Error{"descriptor_size_bits must be 0 (full, 486) or in [8, 486]", ErrorCode::out_of_range, {{}, 0, "descriptor_size_bits"}};
  return ok();
}

const ParamSchema<AkazeParams>& AkazeParams::schema() {
  static const ParamSchema<AkazeParams> s = [] {
    ParamSchema<AkazeParams> sc;
    add_common_fields(sc, "AKAZE detector response threshold (Hessian, image range 0..1)", 1e-7, 1);
    sc.field("octaves", &AkazeParams::octaves, "AKAZE octaves")
        .range(1, 8)
        .field("octave_layers", &AkazeParams::octave_layers, "AKAZE sublevels per octave")
        .range(1, 8)
        .field("descriptor_size_bits", &AkazeParams::descriptor_size_bits, "MLDB descriptor bits (0 = full 486)")
        .range(0, 486);
    return sc;
  }();
  return s;
}

Status AkazeDetector::setup(const AkazeParams& p) {
  akaze_ = cv::AKAZE::create(p.upright ? cv::AKAZE::DESCRIPTOR_MLDB_UPRIGHT : cv::AKAZE::DESCRIPTOR_MLDB,
                             p.descriptor_size_bits, 3, static_cast<float>(p.threshold), p.octaves, p.octave_layers);
  return ok();
}

Status AkazeDetector::run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) {
  akaze_->setThreshold(threshold);
  akaze_->detectAndCompute(grey, cv::noArray(), raw_keypoints_, raw_descriptors_);
  output_strongest(out, raw_count);
  return ok();
}

// ------------------------------------------------------------------------------ brisk

Status BriskParams::validate() const {
  VISNAV_TRY(validate_common());
  if (upright)
    return Error{"upright: OpenCV's BRISK always estimates the keypoint orientation; set upright: false", ErrorCode::inconsistent, {{}, 0, "upright"}};
  return ok();
}

const ParamSchema<BriskParams>& BriskParams::schema() {
  static const ParamSchema<BriskParams> s = [] {
    ParamSchema<BriskParams> sc;
    add_common_fields(sc, "BRISK (AGAST) intensity difference, grey levels (applied rounded)", 1, 255);
    sc.field("octaves", &BriskParams::octaves, "BRISK detection octaves")
        .range(0, 8)
        .field("pattern_scale", &BriskParams::pattern_scale, "BRISK sampling pattern scale")
        .range(0.5, 4);
    return sc;
  }();
  return s;
}

Status BriskDetector::setup(const BriskParams& /*p*/) {
  brisk_.release();  // rebuilt at the next frame with the current threshold
  return ok();
}

Status BriskDetector::run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) {
  const int t = rounded(threshold);
  if (brisk_.empty() || t != brisk_threshold_) {
    brisk_ = cv::BRISK::create(t, params_.octaves, static_cast<float>(params_.pattern_scale));
    brisk_threshold_ = t;
  }
  brisk_->detectAndCompute(grey, cv::noArray(), raw_keypoints_, raw_descriptors_);
  output_strongest(out, raw_count);
  return ok();
}

}  // namespace visnav::detectors
