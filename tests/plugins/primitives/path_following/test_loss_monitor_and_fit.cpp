// PathLossMonitor grace-period timing and the NLopt exponential-decay fit (issue 5).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "error_expect.hpp"
#include "visnav/path_following/exp_fit.hpp"
#include "visnav/path_following/path_loss_monitor.hpp"

namespace pf = visnav::path_following;
using Verdict = pf::PathLossMonitor::Verdict;

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST(PathLossMonitor, FailsOnlyAfterTheGracePeriodOfContinuousBadFrames) {
  pf::PathLossMonitor m(1.0);
  EXPECT_EQ(m.update(0.0, pf::PathStatus::ok), Verdict::ok);
  EXPECT_EQ(m.update(0.1, pf::PathStatus::path_lost), Verdict::grace);
  EXPECT_EQ(m.update(0.6, pf::PathStatus::dark_frame), Verdict::grace);
  EXPECT_EQ(m.update(1.1, pf::PathStatus::path_lost), Verdict::grace);  // exactly grace_s: not yet
  EXPECT_NEAR(m.bad_duration_s(), 1.0, 1e-12);
  EXPECT_EQ(m.update(1.15, pf::PathStatus::path_fills_image), Verdict::lost);
  ASSERT_TRUE(m.last_bad_status().has_value());
  EXPECT_EQ(*m.last_bad_status(), pf::PathStatus::path_fills_image);
  // One good frame ends the streak; a new streak starts its own grace period.
  EXPECT_EQ(m.update(1.2, pf::PathStatus::ok), Verdict::ok);
  EXPECT_EQ(m.bad_duration_s(), 0.0);
  EXPECT_EQ(m.update(1.3, pf::PathStatus::no_reference), Verdict::grace);
  EXPECT_EQ(m.update(2.3, pf::PathStatus::no_reference), Verdict::grace);
  EXPECT_EQ(m.update(2.31, pf::PathStatus::no_reference), Verdict::lost);
}

TEST(PathLossMonitor, ZeroGraceFailsOnTheSecondBadFrameAndTimeNeverRunsBackwards) {
  pf::PathLossMonitor m(0.0);
  EXPECT_EQ(m.update(5.0, pf::PathStatus::path_lost), Verdict::grace);  // no elapsed time yet
  EXPECT_EQ(m.update(5.01, pf::PathStatus::path_lost), Verdict::lost);

  pf::PathLossMonitor n(0.5);
  EXPECT_EQ(n.update(10.0, pf::PathStatus::path_lost), Verdict::grace);
  EXPECT_EQ(n.update(3.0, pf::PathStatus::path_lost), Verdict::grace);  // treated as t = 10
  EXPECT_EQ(n.bad_duration_s(), 0.0);
  EXPECT_EQ(n.update(10.6, pf::PathStatus::path_lost), Verdict::lost);
  n.reset();
  EXPECT_FALSE(n.last_bad_status().has_value());
  EXPECT_EQ(n.update(0.0, pf::PathStatus::path_lost), Verdict::grace);  // reset also forgets the clock

  pf::PathLossMonitor negative(-3.0);
  EXPECT_EQ(negative.grace_s(), 0.0);
  EXPECT_EQ(pf::to_string(Verdict::lost), "path lost");
}

TEST(ExpDecayFit, RecoversParametersFromNoisyConvergence) {
  std::mt19937 rng(42);
  std::normal_distribution<double> noise(0.0, 0.01);
  for (double a : {0.5, -0.5}) {
    for (double k : {0.4, 1.5}) {
      std::vector<double> x, y;
      for (int i = 0; i <= 56; ++i) {
        x.push_back(0.1 * i);  // 5.6 m straight segment as in seed 000 Fig. 3
        y.push_back(a * std::exp(-k * x.back()) + noise(rng));
      }
      auto fit = pf::fit_exponential_decay(x, y);
      ASSERT_TRUE(fit.ok()) << fit.error().message;
      EXPECT_NEAR(fit->a, a, 0.02) << "a " << a << " k " << k;
      EXPECT_NEAR(fit->k, k, 0.05 * k + 0.02) << "a " << a << " k " << k;
      EXPECT_NEAR(fit->rms, 0.01, 0.004);
    }
  }
}

TEST(ExpDecayFit, ExactDataFitsExactlyEvenWhenTheLogStartIsUnavailable) {
  // Crossing zero (overshoot) defeats the log-linear start for some points; the optimiser still
  // finds the exact decay of the rest.
  std::vector<double> x{0, 1, 2, 3, 4, 5};
  std::vector<double> y;
  for (double xi : x) y.push_back(0.8 * std::exp(-0.7 * xi));
  auto fit = pf::fit_exponential_decay(x, y);
  ASSERT_TRUE(fit.ok());
  EXPECT_NEAR(fit->a, 0.8, 1e-6);
  EXPECT_NEAR(fit->k, 0.7, 1e-6);
  EXPECT_LT(fit->rms, 1e-6);

  std::vector<double> y2{0.5, 0.2, -0.02, 0.01, -0.005, 0.0};
  auto fit2 = pf::fit_exponential_decay(x, y2);
  ASSERT_TRUE(fit2.ok());
  EXPECT_GT(fit2->k, 0.5);
  EXPECT_NEAR(fit2->a, 0.5, 0.05);
}

TEST(ExpDecayFit, RejectsBadInput) {
  const std::vector<double> three{0, 1, 2};
  const std::vector<double> two{0, 1};
  EXPECT_FALSE(pf::fit_exponential_decay(three, two).ok());
  EXPECT_FALSE(pf::fit_exponential_decay(two, two).ok());
  const std::vector<double> same{1, 1, 1};
  EXPECT_FALSE(pf::fit_exponential_decay(same, three).ok());
  const std::vector<double> nan{0, std::numeric_limits<double>::quiet_NaN(), 2};
  auto r = pf::fit_exponential_decay(three, nan);
  EXPECT_TRUE(fails_with(r, ErrorCode::invalid_value));
}
