// The NLopt tuning driver on toy objectives, its resume cache and the summary.json scoring.
#include <gtest/gtest.h>

#include <cmath>

#include "error_expect.hpp"
#include "visnav_stability/tune.hpp"

namespace vs = visnav::stability;

namespace {
std::vector<vs::TuneParam> box2() { return {{"a.gain", -1.0, 1.0, 0.9}, {"b.alpha", -1.0, 1.0, 0.9}}; }
}  // namespace

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST(Tune, FindsTheKnownOptimumOfAToyObjective) {
  int calls = 0;
  const vs::TuneObjective f = [&](const std::vector<double>& x, int) -> visnav::Result<double> {
    ++calls;
    return (x[0] - 0.3) * (x[0] - 0.3) + 2.0 * (x[1] + 0.5) * (x[1] + 0.5) + 0.1;
  };
  vs::TuneOptions o;
  o.max_evals = 300;
  o.xtol_rel = 1e-6;
  o.ftol_abs = 1e-10;
  for (auto algo : {vs::TuneAlgorithm::sbplx, vs::TuneAlgorithm::bobyqa}) {
    o.algorithm = algo;
    calls = 0;
    auto r = vs::tune(box2(), o, f);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_NEAR(r->best_x[0], 0.3, 1e-3) << vs::to_string(algo);
    EXPECT_NEAR(r->best_x[1], -0.5, 1e-3) << vs::to_string(algo);
    EXPECT_NEAR(r->best_objective, 0.1, 1e-6);
    EXPECT_EQ(static_cast<int>(r->history.size()), calls);
    EXPECT_LE(calls, 300);
    if (algo == vs::TuneAlgorithm::sbplx) {
      EXPECT_NEAR(r->history.front().x[0], 0.9, 1e-12);  // starts where asked
    }
  }
}

TEST(Tune, StaysInsideTheBoundsAndFindsAnOptimumOnOne) {
  std::vector<vs::TuneParam> p{{"k", 0.2, 2.0, 1.5}, {"j", 0.0, 1.0, 0.5}};
  const vs::TuneObjective f = [](const std::vector<double>& x, int) -> visnav::Result<double> {
    EXPECT_GE(x[0], 0.2);
    EXPECT_LE(x[0], 2.0);
    return x[0] + (x[1] - 0.25) * (x[1] - 0.25);
  };
  vs::TuneOptions o;
  o.max_evals = 200;
  auto r = vs::tune(p, o, f);
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->best_x[0], 0.2, 1e-3);
  EXPECT_NEAR(r->best_x[1], 0.25, 1e-2);
}

TEST(Tune, ResumesFromTheCacheWithoutCallingTheObjectiveAgain) {
  int calls = 0;
  const vs::TuneObjective f = [&](const std::vector<double>& x, int) -> visnav::Result<double> {
    ++calls;
    return std::abs(x[0] - 0.2) + std::abs(x[1] + 0.1);
  };
  vs::TuneOptions o;
  o.max_evals = 25;
  std::map<std::string, double> cache;
  auto first = vs::tune(box2(), o, f, &cache);
  ASSERT_TRUE(first.ok());
  EXPECT_EQ(calls, 25);
  EXPECT_EQ(cache.size(), 25u);
  // A second run with the same cache replays the same path from the cache alone...
  calls = 0;
  auto again = vs::tune(box2(), o, f, &cache);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(calls, 0);
  EXPECT_EQ(again->best_x, first->best_x);
  EXPECT_TRUE(again->history.back().cached);
  // ...and a larger budget continues where the first run stopped.
  o.max_evals = 35;
  auto more = vs::tune(box2(), o, f, &cache);
  ASSERT_TRUE(more.ok());
  EXPECT_EQ(calls, 10);
  EXPECT_LE(more->best_objective, first->best_objective);
}

TEST(Tune, AnObjectiveErrorStopsTheRunWithThatError) {
  const vs::TuneObjective f = [](const std::vector<double>&, int index) -> visnav::Result<double> {
    if (index == 3) return visnav::fail("experiment binary missing");
    return 1.0;
  };
  auto r = vs::tune(box2(), vs::TuneOptions{}, f);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "experiment binary missing");
}

TEST(Tune, ParsesParameterListsAndRejectsBadOnes) {
  auto p = vs::parse_tune_params("feature_replay.gain=0.2:2,path_following.alpha_radps=0.5:3:1");
  ASSERT_TRUE(p.ok()) << p.error().message;
  ASSERT_EQ(p->size(), 2u);
  EXPECT_EQ((*p)[0].key, "feature_replay.gain");
  EXPECT_DOUBLE_EQ((*p)[0].start_value, 1.1);
  EXPECT_DOUBLE_EQ((*p)[1].start_value, 1.0);
  struct Bad { const char* text; const char* says; };
  for (const Bad& b : {Bad{"feature_replay.gain", "needs bounds"}, Bad{"g=2:1", "not below upper"},
                       Bad{"g=0:1:5", "outside"}, Bad{"g=0:x", "upper bound"}, Bad{"g=0:1,g=0:2", "given twice"},
                       Bad{"g=0:1,", "empty item"}, Bad{"a b=0:1", "may hold only"}}) {
    auto r = vs::parse_tune_params(b.text);
    ASSERT_FALSE(r.ok()) << b.text;
    EXPECT_NE(r.error().message.find(b.says), std::string::npos) << b.text << ": " << r.error().message;
  }
  EXPECT_FALSE(vs::parse_tune_algorithm("lbfgs").ok());
  vs::TuneOptions bobyqa1;
  bobyqa1.algorithm = vs::TuneAlgorithm::bobyqa;
  EXPECT_FALSE(vs::tune({{"g", 0, 1, 0.5}}, bobyqa1, [](const std::vector<double>&, int) -> visnav::Result<double> {
                 return 0.0;
               }).ok());
}

TEST(Objective, ScoresTheExperimentSummaryWithAPenaltyForFailedLoops) {
  const std::string json =
      R"({"styles":[{"style":"hybrid","attempted":25,"completed":24,"eps_acc_m":{"mean":0.1,"sd":0.02,"worst":0.2},)"
      R"("eps_rep_m":{"mean":0.05,"sd":0.01,"worst":0.08},"collisions":0,"lost":0},)"
      R"({"style":"feature","attempted":25,"completed":25,"eps_acc_m":{"mean":0.02},"eps_rep_m":{"mean":0.01},)"
      R"("collisions":1,"lost":0}]})";
  vs::ObjectiveWeights w;
  w.style = "hybrid";
  auto h = vs::objective_from_summary(json, w);
  ASSERT_TRUE(h.ok()) << h.error().message;
  EXPECT_NEAR(h->objective, 0.1 + 0.05 + 5.0 / 25.0, 1e-12);  // one failed loop of 25
  w.style = "feature";
  w.lambda = 2.0;
  auto f = vs::objective_from_summary(json, w);
  ASSERT_TRUE(f.ok());
  EXPECT_NEAR(f->objective, 0.02 + 2.0 * 0.01 + 5.0 / 25.0, 1e-12);  // a collision counts as failed
  w.style.clear();
  w.lambda = 1.0;
  auto both = vs::objective_from_summary(json, w);
  ASSERT_TRUE(both.ok());
  EXPECT_NEAR(both->objective, 0.5 * (0.35 + 0.23), 1e-12);

  auto none = vs::objective_from_summary(
      R"({"styles":[{"style":"feature","attempted":5,"completed":0,"eps_acc_m":{"mean":null},"eps_rep_m":{"mean":null}}]})",
      vs::ObjectiveWeights{});
  ASSERT_TRUE(none.ok()) << none.error().message;
  EXPECT_DOUBLE_EQ(none->objective, 5.0);  // nothing completed: the full penalty, never a free zero

  w.style = "visual";
  auto missing = vs::objective_from_summary(json, w);
  EXPECT_TRUE(fails_with(missing, ErrorCode::not_found, key_only("visual")));
  EXPECT_FALSE(vs::objective_from_summary("{not json", vs::ObjectiveWeights{}).ok());
  auto nokey = vs::objective_from_summary(R"({"styles":[{"style":"x","completed":2}]})", vs::ObjectiveWeights{});
  ASSERT_FALSE(nokey.ok());
  EXPECT_NE(nokey.error().message.find("\"attempted\""), std::string::npos);
}
