// GRIEF training (see descriptor_training.hpp for the algorithm and the determinism contract).
#include "visnav/feature_replay/descriptor_training.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <string>
#include <utility>

#include <opencv2/imgproc.hpp>

namespace visnav::feature_replay {

namespace {

using detectors::BriefExtractor;
using detectors::BriefTest;

// SplitMix64: portable and fully specified, so a seed gives the same pattern everywhere.
struct SplitMix64 {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }
  double uniform() { return (static_cast<double>(next() >> 11) + 0.5) * (1.0 / 9007199254740992.0); }
};

// BRIEF's sampling G II: isotropic Gaussian, σ = S/5, truncated to the disc of radius S/2 − 1.
BriefTest random_test(SplitMix64& rng, int patch_size_px) {
  const int radius = patch_size_px / 2 - 1;
  const double sigma = patch_size_px / 5.0;
  auto point = [&](int& x, int& y) {
    for (;;) {
      const double mag = sigma * std::sqrt(-2.0 * std::log(rng.uniform()));
      const double ang = 2.0 * std::numbers::pi * rng.uniform();
      x = static_cast<int>(std::lround(mag * std::cos(ang)));
      y = static_cast<int>(std::lround(mag * std::sin(ang)));
      if (x * x + y * y <= radius * radius) return;
    }
  };
  for (;;) {
    BriefTest t{};
    point(t.x1, t.y1);
    point(t.x2, t.y2);
    if (t.x1 != t.x2 || t.y1 != t.y2) return t;
  }
}

}  // namespace

Status DescriptorTrainingParams::validate() const {
  detectors::BriefParams b;
  b.patch_size_px = patch_size_px;
  b.kernel_size_px = kernel_size_px;
  VISNAV_TRY(b.validate());
  if (replace_per_generation < 1 || replace_per_generation > BriefExtractor::kBits)
    return fail("replace_per_generation must be in [1, 256], got " + std::to_string(replace_per_generation));
  if (!(tolerance_px > 0.0) || !(match_tolerance_px > 0.0))
    return fail("tolerance_px and match_tolerance_px must be > 0");
  return heading.validate();
}

Result<DescriptorTrainer> DescriptorTrainer::create(const DescriptorTrainingParams& params,
                                                    std::vector<TrainingPair> pairs) {
  VISNAV_TRY(params.validate());
  if (pairs.empty()) return fail("no training pairs");
  DescriptorTrainer t(params);
  const int border = params.patch_size_px / 2 - 1 + params.kernel_size_px / 2 + 1;
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    TrainingPair& tp = pairs[p];
    for (int side = 0; side < 2; ++side) {
      const cv::Mat& g = side == 0 ? tp.grey_a : tp.grey_b;
      auto& kps = side == 0 ? tp.keypoints_a : tp.keypoints_b;
      if (g.empty() || g.type() != CV_8UC1)
        return fail("training pair " + std::to_string(p) + ": images must be grey CV_8UC1");
      std::erase_if(kps, [&](const cv::KeyPoint& k) {
        const long x = std::lround(k.pt.x), y = std::lround(k.pt.y);
        return x < border || y < border || x >= g.cols - border || y >= g.rows - border;
      });
      cv::Mat integral;
      cv::integral(g, integral, CV_32S);
      t.integrals_.push_back(std::move(integral));
      Features f;
      f.keypoints = kps;
      f.descriptors = cv::Mat::zeros(static_cast<int>(kps.size()), BriefExtractor::kBytes, CV_8U);
      f.norm = DescriptorNorm::hamming;
      t.features_.push_back(std::move(f));
    }
  }
  t.pairs_ = std::move(pairs);
  t.test_score_.assign(BriefExtractor::kBits, 0);
  VISNAV_TRY(t.set_pattern(BriefExtractor::make_pattern(params.patch_size_px)));
  return t;
}

void DescriptorTrainer::compute_bit(std::size_t image, int test, const BriefTest& t) {
  const cv::Mat& sum = integrals_[image];
  Features& f = features_[image];
  const int h = params_.kernel_size_px / 2;
  const int byte = test / 8;
  const auto mask = static_cast<std::uint8_t>(1u << (test % 8));
  auto box = [&](int x, int y) {
    return sum.at<int>(y + h + 1, x + h + 1) - sum.at<int>(y - h, x + h + 1) - sum.at<int>(y + h + 1, x - h) +
           sum.at<int>(y - h, x - h);
  };
  for (int i = 0; i < f.descriptors.rows; ++i) {
    const cv::KeyPoint& k = f.keypoints[static_cast<std::size_t>(i)];
    const int x = static_cast<int>(std::lround(k.pt.x)), y = static_cast<int>(std::lround(k.pt.y));
    std::uint8_t& d = f.descriptors.at<std::uint8_t>(i, byte);
    if (box(x + t.x1, y + t.y1) < box(x + t.x2, y + t.y2)) d = static_cast<std::uint8_t>(d | mask);
    else d = static_cast<std::uint8_t>(d & ~mask);
  }
}

Status DescriptorTrainer::set_pattern(const std::vector<BriefTest>& pattern) {
  VISNAV_TRY(BriefExtractor::validate_pattern(pattern, params_.patch_size_px));
  pattern_ = pattern;
  for (std::size_t img = 0; img < features_.size(); ++img)
    for (int i = 0; i < BriefExtractor::kBits; ++i) compute_bit(img, i, pattern_[static_cast<std::size_t>(i)]);
  fitness_ = score(true);
  return ok();
}

TrainingFitness DescriptorTrainer::score(bool with_test_scores) {
  TrainingFitness fit;
  fit.pairs = static_cast<int>(pairs_.size());
  if (with_test_scores) std::fill(test_score_.begin(), test_score_.end(), 0);
  for (std::size_t p = 0; p < pairs_.size(); ++p) {
    const Features& fa = features_[2 * p];
    const Features& fb = features_[2 * p + 1];
    const double shift = pairs_[p].shift_px;
    auto est = estimator_.estimate(fa, fb, static_cast<double>(pairs_[p].grey_b.cols));
    if (!est) continue;  // cannot happen: both sides are consistent CV_8U features
    if (est->valid && std::abs(est->offset_px - shift) <= params_.tolerance_px) ++fit.correct_pairs;
    for (const FeatureMatch& m : estimator_.last_matches()) {
      const bool correct = std::abs(m.du_px - shift) <= params_.match_tolerance_px;
      fit.correct_matches += correct ? 1 : 0;
      if (!with_test_scores) continue;
      const std::uint8_t* a = fa.descriptors.ptr<std::uint8_t>(m.reference_index);
      const std::uint8_t* b = fb.descriptors.ptr<std::uint8_t>(m.current_index);
      const long sign = correct ? 1 : -1;
      for (int byte = 0; byte < BriefExtractor::kBytes; ++byte) {
        const unsigned diff = static_cast<unsigned>(a[byte] ^ b[byte]);
        for (int bit = 0; bit < 8; ++bit) test_score_[static_cast<std::size_t>(byte * 8 + bit)] += ((diff >> bit) & 1u) != 0 ? -sign : sign;
      }
    }
  }
  return fit;
}

bool DescriptorTrainer::run_generation(int generation) {
  SplitMix64 rng{params_.seed * 0x9E3779B97F4A7C15ULL ^ (static_cast<std::uint64_t>(generation) + 1) * 0xD1B54A32D192ED03ULL};
  // The lowest-scoring comparisons (ties: lower index first) are replaced.
  std::vector<int> order(BriefExtractor::kBits);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return test_score_[static_cast<std::size_t>(a)] < test_score_[static_cast<std::size_t>(b)];
  });
  const std::vector<long> old_scores = test_score_;
  std::vector<std::pair<int, BriefTest>> replaced;
  for (int k = 0; k < params_.replace_per_generation; ++k) {
    const int i = order[static_cast<std::size_t>(k)];
    replaced.emplace_back(i, pattern_[static_cast<std::size_t>(i)]);
    pattern_[static_cast<std::size_t>(i)] = random_test(rng, params_.patch_size_px);
    for (std::size_t img = 0; img < features_.size(); ++img) compute_bit(img, i, pattern_[static_cast<std::size_t>(i)]);
  }
  const TrainingFitness candidate = score(true);
  if (!(candidate < fitness_)) {
    fitness_ = candidate;
    return true;
  }
  for (const auto& [i, t] : replaced) {  // worse: restore the previous pattern and its scores
    pattern_[static_cast<std::size_t>(i)] = t;
    for (std::size_t img = 0; img < features_.size(); ++img) compute_bit(img, i, t);
  }
  test_score_ = old_scores;
  return false;
}

TrainingFitness DescriptorTrainer::evaluate(const std::vector<BriefTest>& pattern) {
  const auto saved = pattern_;
  const auto saved_fitness = fitness_;
  const auto saved_scores = test_score_;
  if (!set_pattern(pattern)) return {};
  const TrainingFitness f = fitness_;
  pattern_ = saved;
  for (std::size_t img = 0; img < features_.size(); ++img)
    for (int i = 0; i < BriefExtractor::kBits; ++i) compute_bit(img, i, pattern_[static_cast<std::size_t>(i)]);
  fitness_ = saved_fitness;
  test_score_ = saved_scores;
  return f;
}

}  // namespace visnav::feature_replay
