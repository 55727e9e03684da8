// The seed 002 Sec. 3.8 scenario generator and replay.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "error_expect.hpp"
#include "visnav_stability/error_model.hpp"
#include "visnav_stability/scenario_sim.hpp"

namespace vs = visnav::stability;
using std::numbers::pi;

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST(ScenarioGenerator, DrawsThePapersRanges) {
  const vs::ScenarioRanges r;
  constexpr int kN = 20000;
  int low_curvature = 0, arcs = 0, corners_seen[9] = {};
  double sum_l = 0.0, sum_abs_x0 = 0.0, min_l = 1e9, max_l = 0.0, max_odo = 0.0, max_head = 0.0;
  std::vector<double> log_k;
  for (int i = 0; i < kN; ++i) {
    const vs::Scenario s = vs::draw_scenario(r, static_cast<std::uint64_t>(i));
    ASSERT_GE(s.arcs.size(), 3u);
    ASSERT_LE(s.arcs.size(), 8u);
    ++corners_seen[s.arcs.size()];
    for (const auto& a : s.arcs) {
      const double k = std::abs(a.curvature_per_m);
      ASSERT_GE(k, 0.001 - 1e-12);
      ASSERT_LE(k, 1.0 + 1e-12);
      log_k.push_back(std::log10(k));
      if (k < 0.01) ++low_curvature;
      ++arcs;
      ASSERT_LE(std::abs(a.curvature_per_m * a.length_m), 2.0 * std::asin(0.95) + 1e-9);  // arc fits its side
    }
    min_l = std::min(min_l, s.landmark_m);
    max_l = std::max(max_l, s.landmark_m);
    sum_l += s.landmark_m;
    ASSERT_LE(std::abs(s.x0_m), 1.0);
    ASSERT_LE(std::abs(s.y0_m), 1.0);
    sum_abs_x0 += std::abs(s.x0_m);
    max_odo = std::max(max_odo, std::abs(s.odom_scale_error));
    max_head = std::max(max_head, s.heading_error_bound_rad);
  }
  // Curvature log-uniform over three decades: median 10^-1.5, a third below 0.01.
  std::nth_element(log_k.begin(), log_k.begin() + static_cast<std::ptrdiff_t>(log_k.size() / 2), log_k.end());
  EXPECT_NEAR(log_k[log_k.size() / 2], -1.5, 0.05);
  EXPECT_NEAR(static_cast<double>(low_curvature) / arcs, 1.0 / 3.0, 0.02);
  // Landmark distance uniform in [0.1, 2]; |x0| uniform in [0, 1].
  EXPECT_GE(min_l, 0.1);
  EXPECT_LE(max_l, 2.0);
  EXPECT_NEAR(sum_l / kN, 1.05, 0.02);
  EXPECT_NEAR(sum_abs_x0 / kN, 0.5, 0.01);
  EXPECT_LE(max_odo, 0.05);
  EXPECT_GT(max_odo, 0.049);
  EXPECT_LE(max_head, 5.0 * pi / 180.0);
  EXPECT_GT(max_head, 4.9 * pi / 180.0);
  for (int n = 3; n <= 8; ++n) EXPECT_NEAR(corners_seen[n] / static_cast<double>(kN), 1.0 / 6.0, 0.02) << n;
}

TEST(ScenarioGenerator, RoutesAreClosedAndDeterministic) {
  const vs::ScenarioRanges r;
  for (std::uint64_t seed : {1ull, 77ull, 123456ull}) {
    const vs::Scenario s = vs::draw_scenario(r, seed);
    const vs::Scenario again = vs::draw_scenario(r, seed);
    EXPECT_EQ(s.landmark_m, again.landmark_m);
    EXPECT_EQ(s.arcs.size(), again.arcs.size());
    for (std::size_t j = 0; j < s.arcs.size(); ++j) {
      const vs::Arc& a = s.arcs[j];
      const vs::Arc& next = s.arcs[(j + 1) % s.arcs.size()];
      double ex, ey;
      if (std::abs(a.curvature_per_m) < 1e-12) {
        ex = a.x_m + a.length_m * std::cos(a.heading_rad);
        ey = a.y_m + a.length_m * std::sin(a.heading_rad);
      } else {
        const double k = a.curvature_per_m, h1 = a.heading_rad + k * a.length_m;
        ex = a.x_m + (std::sin(h1) - std::sin(a.heading_rad)) / k;
        ey = a.y_m - (std::cos(h1) - std::cos(a.heading_rad)) / k;
        // The corner turn at the next arc joins its heading to this arc's end heading.
        EXPECT_NEAR(std::remainder(next.heading_rad - h1 - s.corner_turn_rad[(j + 1) % s.arcs.size()], 2 * pi), 0.0, 1e-9);
      }
      EXPECT_NEAR(ex, next.x_m, 1e-9) << "seed " << seed << " arc " << j;
      EXPECT_NEAR(ey, next.y_m, 1e-9) << "seed " << seed << " arc " << j;
    }
  }
}

TEST(ScenarioReplay, SmallErrorsFollowTheLinearModelOfSeed000) {
  // Square of 3 m straight sides, landmarks at l = 1.5 m, no disturbance, a 1 cm initial error:
  // the replay is then seed 000's model with k = 1/l, so one loop multiplies the error by
  // N̆ = e^(-2·3/1.5)·I (error model of the same square).
  vs::Scenario s;
  s.seed = 5;
  for (int i = 0; i < 4; ++i) {
    vs::Arc a;
    a.heading_rad = i * pi / 2;
    a.length_m = 3.0;
    s.arcs.push_back(a);
    s.corner_turn_rad.push_back(pi / 2);
  }
  s.landmark_m = 1.5;
  s.x0_m = 0.006;
  s.y0_m = -0.008;
  vs::SimParams p;
  p.loops = 2;
  p.max_step_m = 0.01;
  const vs::ScenarioOutcome o = vs::simulate(s, p);
  std::vector<vs::ModelEdge> edges;
  for (int i = 0; i < 4; ++i) {
    char id[16];
    std::snprintf(id, sizeof id, "e%d", i);
    edges.push_back({id, "f", 3.0, i * pi / 2});
  }
  vs::ConvergenceModels m;
  m.k_per_m["f"] = 1.0 / 1.5;
  auto rep = vs::analyse_loop(edges, m);
  ASSERT_TRUE(rep.ok());
  EXPECT_NEAR(o.loop_error_m[0] / o.initial_error_m, rep->spectral_radius, 0.02 * rep->spectral_radius);
  EXPECT_NEAR(o.loop_error_m[1] / o.loop_error_m[0], rep->spectral_radius, 0.02 * rep->spectral_radius);
  EXPECT_TRUE(o.converged);
  EXPECT_NEAR(o.steady_error_m, 0.0, 1e-12);  // no disturbance: the zero-start robot stays on the route
}

TEST(ScenarioReplay, WithoutDisturbancesScenariosWithinTheModelsAssumptionAllConverge) {
  vs::ScenarioRanges r;
  r.odom_error_max = 0.0;
  r.heading_error_max_deg = 0.0;
  auto sum = vs::run_batch(r, vs::SimParams{}, 1, 2000, 2);
  ASSERT_TRUE(sum.ok()) << sum.error().message;
  // l > |initial error|: every one converges. Outside it (the heading correction saturates near
  // 90 deg while |y| >> l) a few take longer than 10 loops; seeds 709 and 758 are two of them.
  EXPECT_GT(sum->assumption_met, 500u);
  EXPECT_EQ(sum->assumption_met_converged, sum->assumption_met);
  EXPECT_GE(sum->converged, 1980u);
  EXPECT_NE(std::find(sum->failed_seeds.begin(), sum->failed_seeds.end(), 758u), sum->failed_seeds.end());
  EXPECT_EQ(sum->not_finite, 0u);
  EXPECT_LT(sum->steady_error_quantiles_m.back(), 1e-9);
}

TEST(ScenarioReplay, BatchIsIndependentOfThreadsAndReportsFailures) {
  const vs::ScenarioRanges r;  // the paper's disturbances
  auto one = vs::run_batch(r, vs::SimParams{}, 1, 3000, 1);
  auto two = vs::run_batch(r, vs::SimParams{}, 1, 3000, 2);
  ASSERT_TRUE(one.ok() && two.ok());
  EXPECT_EQ(one->converged, two->converged);
  EXPECT_EQ(one->failed_seeds, two->failed_seeds);
  EXPECT_EQ(one->gap_ratio_quantiles, two->gap_ratio_quantiles);
  EXPECT_GT(one->converged, 2850u);  // the large majority converges (1,000,000 scenarios: 99.08 %)
  // Every reported failure really fails when replayed alone.
  for (auto seed : one->failed_seeds) EXPECT_FALSE(vs::simulate(vs::draw_scenario(r, seed), vs::SimParams{}).converged);

  vs::SimParams bad;
  bad.loops = 0;
  EXPECT_FALSE(vs::run_batch(r, bad, 1, 10, 1).ok());
  vs::ScenarioRanges bad_r;
  bad_r.landmark_min_m = 0.0;
  auto e = vs::run_batch(bad_r, vs::SimParams{}, 1, 10, 1);
  EXPECT_TRUE(fails_with(e, ErrorCode::out_of_range, key_only("landmark_min_m")));
}
