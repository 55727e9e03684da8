// feature_replay core — evolutionary training of GRIEF comparison pairs (Krajník et al. 2017).
//
// GRIEF is BRIEF whose 256 comparison pairs are evolved so that the descriptor survives
// appearance change. Training data are aligned image pairs (A, B, SHIFT_PX: the scene is
// SHIFT_PX further right in B), e.g. two recordings of one route in different seasons, or the
// sets of `make_appearance_pairs`. Keypoints are detected once per image (STAR, threshold
// settled on that image alone); only the comparison pairs change during training.
//
// One generation (as in the paper): every comparison is scored over the kept matches of all
// pairs — on a correct match (|du − SHIFT_PX| ≤ match_tolerance_px) a test whose bit agrees
// scores +1 and one that differs −1; on a wrong match the signs flip. The `replace_per_generation`
// lowest-scoring comparisons are replaced by new random ones (BRIEF's sampling G II: Gaussian,
// σ = S/5, truncated to the patch disc). The candidate is kept when its fitness is not worse
// (elitism), else the previous pattern stays. Fitness (compared lexicographically): the number of
// pairs whose histogram-voting estimate (HeadingEstimator with `heading` params) is valid and
// within `tolerance_px` of SHIFT_PX — the paper's correct-shift rate — then the number of correct
// matches.
//
// Determinism: generation g draws from a generator seeded by (seed, g) only, and a generation
// depends only on the pattern it starts from, so a run resumed from a saved generation gives the
// same pattern as an uninterrupted one, on any platform (SplitMix64, no std distributions).
// Cost: bits are recomputed only for replaced comparisons; per generation one match + vote per
// pair (≈ 0.3 ms per pair of 600 keypoints).
// Thread-safety: a DescriptorTrainer is not thread-safe.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "visnav/detectors/brief.hpp"
#include "visnav/feature_replay/heading.hpp"
#include "visnav/result.hpp"

namespace visnav::feature_replay {

struct DescriptorTrainingParams {
  int patch_size_px = 48;            ///< BRIEF patch side S
  int kernel_size_px = 7;            ///< smoothing box side (odd)
  int replace_per_generation = 12;   ///< comparisons replaced per generation
  double tolerance_px = 35.0;        ///< a pair's estimate is correct within this of SHIFT_PX
  double match_tolerance_px = 10.0;  ///< a match is correct within this of SHIFT_PX
  std::uint64_t seed = 1;
  HeadingParams heading;             ///< matching + voting used for the fitness

  [[nodiscard]] Status validate() const;
};

/// One training pair: keypoints of A and B (positions only; they must lie at least
/// patch_size_px/2 − 1 + kernel_size_px/2 px inside the image), grey images, and the label.
struct TrainingPair {
  cv::Mat grey_a, grey_b;  ///< CV_8UC1
  std::vector<cv::KeyPoint> keypoints_a, keypoints_b;
  double shift_px = 0.0;
};

struct TrainingFitness {
  int correct_pairs = 0;    ///< pairs with a valid estimate within tolerance_px
  int correct_matches = 0;  ///< kept matches within match_tolerance_px of the label
  int pairs = 0;
  [[nodiscard]] bool operator<(const TrainingFitness& o) const {
    return correct_pairs != o.correct_pairs ? correct_pairs < o.correct_pairs : correct_matches < o.correct_matches;
  }
};

class DescriptorTrainer {
 public:
  /// Validates params and pairs (grey CV_8UC1 images, keypoints far enough from the border:
  /// others are dropped) and computes the integral images.
  static Result<DescriptorTrainer> create(const DescriptorTrainingParams& params, std::vector<TrainingPair> pairs);

  /// Sets the pattern (validated) and evaluates it.
  Status set_pattern(const std::vector<detectors::BriefTest>& pattern);
  [[nodiscard]] const std::vector<detectors::BriefTest>& pattern() const { return pattern_; }
  [[nodiscard]] const TrainingFitness& fitness() const { return fitness_; }

  /// Runs generation `generation` (0-based) from the current pattern; returns whether the
  /// candidate was kept.
  bool run_generation(int generation);

  /// Fitness of `pattern` on these pairs (does not change the trainer's pattern).
  TrainingFitness evaluate(const std::vector<detectors::BriefTest>& pattern);

 private:
  explicit DescriptorTrainer(const DescriptorTrainingParams& params) : params_(params), estimator_(params.heading) {}
  void compute_bit(std::size_t image, int test, const detectors::BriefTest& t);
  TrainingFitness score(bool with_test_scores);

  DescriptorTrainingParams params_;
  HeadingEstimator estimator_;
  std::vector<TrainingPair> pairs_;
  std::vector<cv::Mat> integrals_;      // per image (2 per pair): CV_32S integral
  std::vector<Features> features_;      // per image: keypoints + descriptors under pattern_
  std::vector<detectors::BriefTest> pattern_;
  TrainingFitness fitness_;
  std::vector<long> test_score_;        // per comparison, from the last score(true)
};

}  // namespace visnav::feature_replay
