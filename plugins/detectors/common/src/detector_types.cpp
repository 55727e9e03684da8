// The detector types: parameter schemas, validation, and the per-type detection pipelines.
#include "visnav/detectors/detector_types.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "output_buffer.hpp"

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

BriefParams brief_params(int patch, int kernel, bool upright) {
  BriefParams b;
  b.patch_size_px = patch;
  b.kernel_size_px = kernel;
  b.upright = upright;
  return b;
}

Status validate_brief(int patch, int kernel, bool upright) { return brief_params(patch, kernel, upright).validate(); }

int rounded(double threshold) { return std::max(1, static_cast<int>(std::lround(threshold))); }

// Removes keypoints the BRIEF patch cannot describe, so the adaptive count sees usable ones.
void drop_border(std::vector<cv::KeyPoint>& kps, int border, int w, int h) {
  std::erase_if(kps, [&](const cv::KeyPoint& kp) {
    const long xi = std::lround(kp.pt.x);
    const long yi = std::lround(kp.pt.y);
    return xi < border || yi < border || xi >= w - border || yi >= h - border;
  });
}

}  // namespace

// ------------------------------------------------------------------------------ star_brief

Status StarBriefParams::validate() const {
  VISNAV_TRY(validate_common());
  StarParams sp;
  sp.max_size_px = max_size_px;
  sp.line_threshold_projected = line_threshold_projected;
  sp.line_threshold_binarized = line_threshold_binarized;
  sp.suppress_nonmax_size_px = suppress_nonmax_size_px;
  VISNAV_TRY(sp.validate());
  return validate_brief(patch_size_px, kernel_size_px, upright);
}

const ParamSchema<StarBriefParams>& StarBriefParams::schema() {
  static const ParamSchema<StarBriefParams> s = [] {
    ParamSchema<StarBriefParams> sc;
    add_common_fields(sc, "STAR response, absolute mean(inner) − mean(ring), grey levels", 0.5, 255);
    sc.field("max_size_px", &StarBriefParams::max_size_px, "largest outer filter diameter (45 → 7 scales)")
        .range(5, 129)
        .field("line_threshold_projected", &StarBriefParams::line_threshold_projected,
               "reject line-like points: trace²/det of response gradients ≥ this")
        .range(1, 1000)
        .field("line_threshold_binarized", &StarBriefParams::line_threshold_binarized,
               "reject line-like points: trace²/det on the binarised scale image ≥ this")
        .range(1, 1000)
        .field("suppress_nonmax_size_px", &StarBriefParams::suppress_nonmax_size_px,
               "non-maximum suppression window side (odd)")
        .range(3, 31)
        .field("patch_size_px", &StarBriefParams::patch_size_px, "BRIEF patch side S (tests ~ N(0, (S/5)²))")
        .range(16, 96)
        .field("kernel_size_px", &StarBriefParams::kernel_size_px, "BRIEF smoothing box side (odd; 7 ≈ Gaussian σ = 2)")
        .range(1, 15);
    return sc;
  }();
  return s;
}

Status StarBriefDetector::apply(const StarBriefParams& p, bool first) {
  VISNAV_TRY(p.validate());
  BriefParams bp = brief_params(p.patch_size_px, p.kernel_size_px, p.upright);
  VISNAV_TRY(brief_.set_params(bp));
  StarParams sp;
  sp.max_size_px = p.max_size_px;
  sp.response_threshold = p.threshold;
  sp.line_threshold_projected = p.line_threshold_projected;
  sp.line_threshold_binarized = p.line_threshold_binarized;
  sp.suppress_nonmax_size_px = p.suppress_nonmax_size_px;
  sp.border_px = brief_.border_px();
  VISNAV_TRY(star_.set_params(sp));
  apply_common(p, first);
  return ok();
}

Status StarBriefDetector::run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) {
  star_.set_response_threshold(threshold);
  star_.detect(grey, raw_keypoints_);
  raw_count = static_cast<int>(raw_keypoints_.size());
  keep_strongest(params_.target_keypoints);
  brief_.compute(grey, raw_keypoints_, out.descriptors, star_.integral());
  out.keypoints.swap(raw_keypoints_);
  return ok();
}

// ------------------------------------------------------------------------------ agast_brief

Status AgastBriefParams::validate() const {
  VISNAV_TRY(validate_common());
  return validate_brief(patch_size_px, kernel_size_px, upright);
}

const ParamSchema<AgastBriefParams>& AgastBriefParams::schema() {
  static const ParamSchema<AgastBriefParams> s = [] {
    ParamSchema<AgastBriefParams> sc;
    add_common_fields(sc, "AGAST intensity difference, grey levels (applied rounded)", 1, 255);
    sc.field("agast_type", &AgastBriefParams::agast_type, "AGAST mask")
        .one_of({"AGAST_5_8", "AGAST_7_12d", "AGAST_7_12s", "OAST_9_16"})
        .field("nonmax_suppression", &AgastBriefParams::nonmax_suppression, "AGAST non-maximum suppression");
    add_brief_fields(sc);
    return sc;
  }();
  return s;
}

Status AgastBriefDetector::apply(const AgastBriefParams& p, bool first) {
  VISNAV_TRY(p.validate());
  VISNAV_TRY(brief_.set_params(brief_params(p.patch_size_px, p.kernel_size_px, p.upright)));
  auto type = cv::AgastFeatureDetector::OAST_9_16;
  if (p.agast_type == "AGAST_5_8") type = cv::AgastFeatureDetector::AGAST_5_8;
  if (p.agast_type == "AGAST_7_12d") type = cv::AgastFeatureDetector::AGAST_7_12d;
  if (p.agast_type == "AGAST_7_12s") type = cv::AgastFeatureDetector::AGAST_7_12s;
  agast_ = cv::AgastFeatureDetector::create(rounded(p.threshold), p.nonmax_suppression, type);
  apply_common(p, first);
  return ok();
}

Status AgastBriefDetector::run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) {
  agast_->setThreshold(rounded(threshold));
  agast_->detect(grey, raw_keypoints_);
  drop_border(raw_keypoints_, brief_.border_px(), grey.cols, grey.rows);
  raw_count = static_cast<int>(raw_keypoints_.size());
  keep_strongest(params_.target_keypoints);
  brief_.compute(grey, raw_keypoints_, out.descriptors);
  out.keypoints.swap(raw_keypoints_);
  return ok();
}

// ------------------------------------------------------------------------------ fast_brief

Status FastBriefParams::validate() const {
  VISNAV_TRY(validate_common());
  return validate_brief(patch_size_px, kernel_size_px, upright);
}

const ParamSchema<FastBriefParams>& FastBriefParams::schema() {
  static const ParamSchema<FastBriefParams> s = [] {
    ParamSchema<FastBriefParams> sc;
    add_common_fields(sc, "FAST intensity difference, grey levels (applied rounded)", 1, 255);
    sc.field("fast_type", &FastBriefParams::fast_type, "FAST circle")
        .one_of({"TYPE_5_8", "TYPE_7_12", "TYPE_9_16"})
        .field("nonmax_suppression", &FastBriefParams::nonmax_suppression, "FAST non-maximum suppression");
    add_brief_fields(sc);
    return sc;
  }();
  return s;
}

Status FastBriefDetector::apply(const FastBriefParams& p, bool first) {
  VISNAV_TRY(p.validate());
  VISNAV_TRY(brief_.set_params(brief_params(p.patch_size_px, p.kernel_size_px, p.upright)));
  auto type = cv::FastFeatureDetector::TYPE_9_16;
  if (p.fast_type == "TYPE_5_8") type = cv::FastFeatureDetector::TYPE_5_8;
  if (p.fast_type == "TYPE_7_12") type = cv::FastFeatureDetector::TYPE_7_12;
  fast_ = cv::FastFeatureDetector::create(rounded(p.threshold), p.nonmax_suppression, type);
  apply_common(p, first);
  return ok();
}

Status FastBriefDetector::run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) {
  fast_->setThreshold(rounded(threshold));
  fast_->detect(grey, raw_keypoints_);
  drop_border(raw_keypoints_, brief_.border_px(), grey.cols, grey.rows);
  raw_count = static_cast<int>(raw_keypoints_.size());
  keep_strongest(params_.target_keypoints);
  brief_.compute(grey, raw_keypoints_, out.descriptors);
  out.keypoints.swap(raw_keypoints_);
  return ok();
}

// ------------------------------------------------------------------------------ gftt_brief

Status GfttBriefParams::validate() const {
  VISNAV_TRY(validate_common());
  if (block_size_px % 2 == 0) return fail("block_size_px must be odd");
  return validate_brief(patch_size_px, kernel_size_px, upright);
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

Status GfttBriefDetector::apply(const GfttBriefParams& p, bool first) {
  VISNAV_TRY(p.validate());
  VISNAV_TRY(brief_.set_params(brief_params(p.patch_size_px, p.kernel_size_px, p.upright)));
  gftt_ = cv::GFTTDetector::create(p.target_keypoints, p.threshold, p.min_distance_px, p.block_size_px, p.use_harris,
                                   p.harris_k);
  apply_common(p, first);
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
  drop_border(raw_keypoints_, border, grey.cols, grey.rows);
  raw_count = static_cast<int>(raw_keypoints_.size());
  keep_strongest(params_.target_keypoints);
  brief_.compute(grey, raw_keypoints_, out.descriptors);
  out.keypoints.swap(raw_keypoints_);
  return ok();
}

// ------------------------------------------------------------------------------ orb

Status OrbParams::validate() const {
  VISNAV_TRY(validate_common());
  if (edge_threshold_px < patch_size_px / 2 + 1)
    return fail("edge_threshold_px (" + std::to_string(edge_threshold_px) + ") must be > patch_size_px / 2");
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

Status OrbDetector::apply(const OrbParams& p, bool first) {
  VISNAV_TRY(p.validate());
  orb_ = cv::ORB::create(static_cast<int>(std::ceil(p.target_keypoints * p.headroom_ratio)),
                         static_cast<float>(p.scale_factor), p.pyramid_levels, p.edge_threshold_px, 0, 2,
                         cv::ORB::HARRIS_SCORE, p.patch_size_px, rounded(p.threshold));
  apply_common(p, first);
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
  raw_count = static_cast<int>(raw_keypoints_.size());
  select_strongest(params_.target_keypoints, out);
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

Status SiftDetector::apply(const SiftParams& p, bool first) {
  VISNAV_TRY(p.validate());
  apply_common(p, first);
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
  raw_count = static_cast<int>(raw_keypoints_.size());
  select_strongest(params_.target_keypoints, out);
  return ok();
}

// ------------------------------------------------------------------------------ akaze

Status AkazeParams::validate() const {
  VISNAV_TRY(validate_common());
  if (descriptor_size_bits != 0 && (descriptor_size_bits < 8 || descriptor_size_bits > 486))
    return fail("descriptor_size_bits must be 0 (full, 486) or in [8, 486]");
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

Status AkazeDetector::apply(const AkazeParams& p, bool first) {
  VISNAV_TRY(p.validate());
  akaze_ = cv::AKAZE::create(p.upright ? cv::AKAZE::DESCRIPTOR_MLDB_UPRIGHT : cv::AKAZE::DESCRIPTOR_MLDB,
                             p.descriptor_size_bits, 3, static_cast<float>(p.threshold), p.octaves, p.octave_layers);
  apply_common(p, first);
  return ok();
}

Status AkazeDetector::run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) {
  akaze_->setThreshold(threshold);
  akaze_->detectAndCompute(grey, cv::noArray(), raw_keypoints_, raw_descriptors_);
  raw_count = static_cast<int>(raw_keypoints_.size());
  select_strongest(params_.target_keypoints, out);
  return ok();
}

// ------------------------------------------------------------------------------ brisk

Status BriskParams::validate() const {
  VISNAV_TRY(validate_common());
  if (upright)
    return fail("upright: OpenCV's BRISK always estimates the keypoint orientation; set upright: false");
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

Status BriskDetector::apply(const BriskParams& p, bool first) {
  VISNAV_TRY(p.validate());
  apply_common(p, first);
  brisk_.release();
  return ok();
}

Status BriskDetector::run(const cv::Mat& grey, double threshold, Features& out, int& raw_count) {
  const int t = rounded(threshold);
  if (brisk_.empty() || t != brisk_threshold_) {
    brisk_ = cv::BRISK::create(t, params_.octaves, static_cast<float>(params_.pattern_scale));
    brisk_threshold_ = t;
  }
  brisk_->detectAndCompute(grey, cv::noArray(), raw_keypoints_, raw_descriptors_);
  raw_count = static_cast<int>(raw_keypoints_.size());
  select_strongest(params_.target_keypoints, out);
  return ok();
}

}  // namespace visnav::detectors
