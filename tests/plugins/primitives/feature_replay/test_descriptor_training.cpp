// GRIEF training core: deterministic with a seed, a resumed run equals an uninterrupted one,
// fitness never decreases (elitism), and the fitness tells a useful pattern from a useless one.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "test_support.hpp"
#include "visnav/detectors/detector_types.hpp"
#include "visnav/feature_replay/descriptor_training.hpp"

namespace fr = visnav::feature_replay;
namespace d = visnav::detectors;

namespace {

// Crops of real photos; B is shifted and photometrically changed (gamma, contrast, a gradient).
std::vector<fr::TrainingPair> make_pairs() {
  std::vector<fr::TrainingPair> pairs;
  auto det = d::create_detector("star_brief", d::make_params({{"target_keypoints", "250"}}));
  if (!det) return pairs;
  int k = 0;
  for (const char* name : {"astronaut.png", "camera.png", "coffee.png", "motorcycle_left.png", "chelsea.png"}) {
    const cv::Mat img = fr_test::load_grey(name);
    if (img.empty()) continue;
    for (int shift : {-31, 17}) {
      fr::TrainingPair p;
      const int w = std::min(360, img.cols - 80), h = std::min(280, img.rows - 20);
      p.grey_a = img(cv::Rect(40, 10, w, h)).clone();
      cv::Mat b = img(cv::Rect(40 - shift, 10, w, h)).clone();  // scene `shift` px further right
      cv::Mat f;
      b.convertTo(f, CV_32F, 1.0 / 255.0);
      cv::pow(f, k % 2 == 0 ? 0.5 : 1.8, f);
      for (int y = 0; y < f.rows; ++y) f.row(y) *= 0.6 + 0.5 * y / f.rows;
      f.convertTo(p.grey_b, CV_8U, 255.0);
      ++k;
      visnav::Features fa, fb;
      for (int i = 0; i < 6; ++i) {  // settle the adaptive threshold on each image
        if (!(*det)->detect(p.grey_a, fa).ok() || !(*det)->detect(p.grey_b, fb).ok()) return {};
      }
      p.keypoints_a = fa.keypoints;
      p.keypoints_b = fb.keypoints;
      p.shift_px = shift;
      pairs.push_back(std::move(p));
    }
  }
  return pairs;
}

fr::DescriptorTrainingParams params(std::uint64_t seed) {
  fr::DescriptorTrainingParams p;
  p.seed = seed;
  p.replace_per_generation = 16;
  return p;
}

bool same(const std::vector<d::BriefTest>& a, const std::vector<d::BriefTest>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i].x1 != b[i].x1 || a[i].y1 != b[i].y1 || a[i].x2 != b[i].x2 || a[i].y2 != b[i].y2) return false;
  return true;
}

}  // namespace

TEST(DescriptorTraining, SeededResumableAndElitist) {
  const auto pairs = make_pairs();
  if (pairs.size() < 6) GTEST_SKIP() << "python3-skimage photos not installed";
  auto a = fr::DescriptorTrainer::create(params(7), pairs);
  ASSERT_TRUE(a.ok()) << a.error().message;
  const fr::TrainingFitness start = a->fitness();
  EXPECT_EQ(start.pairs, static_cast<int>(pairs.size()));
  EXPECT_TRUE(same(a->pattern(), d::BriefExtractor::make_pattern(48)));  // starts from BRIEF
  fr::TrainingFitness last = start;
  int kept = 0;
  for (int g = 0; g < 6; ++g) {
    kept += a->run_generation(g) ? 1 : 0;
    EXPECT_FALSE(a->fitness() < last) << "generation " << g;  // elitism: never worse
    last = a->fitness();
  }
  EXPECT_GT(kept, 0);
  EXPECT_FALSE(same(a->pattern(), d::BriefExtractor::make_pattern(48)));
  EXPECT_TRUE(d::BriefExtractor::validate_pattern(a->pattern(), 48).ok());

  // Same seed, interrupted after 3 generations and resumed from the saved pattern: same result.
  auto b = fr::DescriptorTrainer::create(params(7), pairs);
  ASSERT_TRUE(b.ok());
  for (int g = 0; g < 3; ++g) b->run_generation(g);
  auto c = fr::DescriptorTrainer::create(params(7), pairs);
  ASSERT_TRUE(c.ok());
  ASSERT_TRUE(c->set_pattern(b->pattern()).ok());
  for (int g = 3; g < 6; ++g) c->run_generation(g);
  EXPECT_TRUE(same(a->pattern(), c->pattern()));
  EXPECT_EQ(a->fitness().correct_matches, c->fitness().correct_matches);

  // Another seed: another pattern.
  auto e = fr::DescriptorTrainer::create(params(8), pairs);
  ASSERT_TRUE(e.ok());
  for (int g = 0; g < 6; ++g) e->run_generation(g);
  EXPECT_FALSE(same(a->pattern(), e->pattern()));
}

TEST(DescriptorTraining, FitnessSeparatesUsefulFromUselessPatterns) {
  const auto pairs = make_pairs();
  if (pairs.size() < 6) GTEST_SKIP() << "python3-skimage photos not installed";
  auto t = fr::DescriptorTrainer::create(params(1), pairs);
  ASSERT_TRUE(t.ok());
  const fr::TrainingFitness brief = t->fitness();
  EXPECT_GE(brief.correct_pairs, static_cast<int>(pairs.size()) / 2);
  // 256 copies of one comparison: a 1-bit descriptor, useless for matching.
  const std::vector<d::BriefTest> flat(256, d::BriefTest{-3, 0, 3, 0});
  const fr::TrainingFitness useless = t->evaluate(flat);
  EXPECT_LT(useless.correct_matches, brief.correct_matches / 4);
  EXPECT_LT(useless.correct_pairs, brief.correct_pairs);
  // evaluate() leaves the trainer's own pattern and fitness alone.
  EXPECT_TRUE(same(t->pattern(), d::BriefExtractor::make_pattern(48)));
  EXPECT_EQ(t->fitness().correct_matches, brief.correct_matches);
  // Bad input.
  EXPECT_FALSE(fr::DescriptorTrainer::create(params(1), {}).ok());
  fr::DescriptorTrainingParams bad = params(1);
  bad.kernel_size_px = 4;
  EXPECT_FALSE(fr::DescriptorTrainer::create(bad, pairs).ok());
}
