// The seed 000 Sec. 5 error model on maps whose answer can be checked by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>

#include "visnav/map.hpp"
#include "visnav_stability/error_model.hpp"
#include "error_expect.hpp"

namespace vs = visnav::stability;
namespace fs = std::filesystem;
using std::numbers::pi;

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;

namespace {

vs::ConvergenceModels test_models() {
  vs::ConvergenceModels m = vs::ConvergenceModels::defaults();
  m.k_per_m["test_kind"] = 0.2;
  m.k_per_m["blind"] = 0.0;
  return m;
}

std::vector<vs::ModelEdge> square(double side_m, double rotation_rad, const std::string& kind = "test_kind") {
  std::vector<vs::ModelEdge> e;
  for (int i = 0; i < 4; ++i) {
    char id[16];
    std::snprintf(id, sizeof id, "s%d", i);
    e.push_back({id, kind, side_m, rotation_rad + i * pi / 2.0});
  }
  return e;
}

}  // namespace

TEST(ErrorModel, StraightOutAndBackNeverCorrectsAlongTrack) {
  // Out 10 m and back: both edges act on the same axes, N̆ = diag(1, m1·m2).
  const std::vector<vs::ModelEdge> edges{{"out", "path_following", 10.0, 0.0}, {"back", "path_following", 10.0, pi}};
  auto rep = vs::analyse_loop(edges, test_models());
  ASSERT_TRUE(rep.ok()) << rep.error().message;
  const double m = std::exp(-0.366 * 10.0);
  EXPECT_NEAR(rep->spectral_radius, 1.0, 1e-12);
  EXPECT_NEAR(std::abs(rep->eigenvalue[1]), m * m, 1e-12);
  EXPECT_NEAR(rep->along_track_contraction, 1.0, 1e-12);
  EXPECT_NEAR(rep->lateral_contraction, m * m, 1e-12);
  EXPECT_EQ(rep->verdict, vs::Verdict::does_not_converge);
  EXPECT_TRUE(std::isinf(rep->loops_to_halve));
  ASSERT_FALSE(rep->notes.empty());
  EXPECT_NE(rep->notes.back().find("collinear"), std::string::npos);
}

TEST(ErrorModel, SquareContractsBothComponentsByMSquared) {
  // Square of 5 m sides, k = 0.2/m: m = e^-1 per edge; edges 0 and 2 shrink y, 1 and 3 shrink x,
  // so N̆ = m²·I: both eigenvalues e^-2, whatever the square's orientation.
  for (double rot : {0.0, 0.5, -2.0}) {
    auto rep = vs::analyse_loop(square(5.0, rot), test_models());
    ASSERT_TRUE(rep.ok()) << rep.error().message;
    const double m2 = std::exp(-2.0);
    EXPECT_NEAR(std::abs(rep->eigenvalue[0]), m2, 1e-12) << rot;
    EXPECT_NEAR(std::abs(rep->eigenvalue[1]), m2, 1e-12) << rot;
    EXPECT_NEAR(rep->along_track_contraction, m2, 1e-12);
    EXPECT_NEAR(rep->lateral_contraction, m2, 1e-12);
    EXPECT_NEAR(rep->loops_to_halve, std::log(0.5) / -2.0, 1e-12);
    EXPECT_EQ(rep->verdict, vs::Verdict::converges);
    for (const auto& e : rep->edges) {
      EXPECT_NEAR(e.lateral_factor, std::exp(-1.0), 1e-12);
      EXPECT_NEAR(e.turn_to_next_rad, pi / 2.0, 1e-12);
    }
  }
}

TEST(ErrorModel, TheOnlyEdgeCorrectingOneAxisLimitsTheLoop) {
  // Square where edge 2 is blind (k = 0): y (lateral to edges 0/2) is corrected by edge 0 alone
  // (factor m), x by edges 1 and 3 (m²). ρ = m, and edge 0 is the one that limits it.
  auto edges = square(5.0, 0.0);
  edges[2].kind = "blind";
  auto rep = vs::analyse_loop(edges, test_models());
  ASSERT_TRUE(rep.ok()) << rep.error().message;
  const double m = std::exp(-1.0);
  EXPECT_NEAR(rep->spectral_radius, m, 1e-12);
  EXPECT_NEAR(rep->lateral_contraction, m, 1e-12);
  EXPECT_NEAR(rep->along_track_contraction, m * m, 1e-12);
  ASSERT_FALSE(rep->limiting.empty());
  EXPECT_EQ(rep->edges[rep->limiting.front()].edge.id, "s0");
  EXPECT_NEAR(rep->edges[0].radius_gain_if_doubled, m - m * m, 1e-12);
  bool blind_note = false;
  for (const auto& n : rep->notes) blind_note |= n.find("'s2'") != std::string::npos;
  EXPECT_TRUE(blind_note);
}

TEST(ErrorModel, WeakFeatureEdgesGiveAMarginalVerdict) {
  // A 4 x 2 m rectangle of feature edges (k = 0.055/m): ρ ≈ e^(-2·0.055·2) ≈ 0.80 → converges;
  // with --marginal 0.7 it is reported as marginal.
  std::vector<vs::ModelEdge> rect{{"a", "feature_segment", 4.0, 0.0}, {"b", "feature_segment", 2.0, pi / 2},
                                  {"c", "feature_segment", 4.0, pi}, {"d", "feature_segment", 2.0, -pi / 2}};
  auto rep = vs::analyse_loop(rect, test_models());
  ASSERT_TRUE(rep.ok());
  EXPECT_NEAR(rep->spectral_radius, std::exp(-0.055 * 4.0), 1e-12);  // x: edges b, d (2+2 m)
  EXPECT_EQ(rep->verdict, vs::Verdict::converges);
  vs::StabilityParams p;
  p.marginal_radius = 0.7;
  auto marginal = vs::analyse_loop(rect, test_models(), p);
  ASSERT_TRUE(marginal.ok());
  EXPECT_EQ(marginal->verdict, vs::Verdict::marginal);
}

TEST(ErrorModel, BadInputGivesAClearAnswer) {
  auto one = vs::analyse_loop({{"e1", "path_following", 5.0, 0.0}}, test_models());
  EXPECT_TRUE(fails_with(one, ErrorCode::inconsistent));

  auto unknown = vs::analyse_loop({{"e1", "path_following", 5.0, 0.0}, {"e7", "visual_memory", 5.0, pi}}, test_models());
  EXPECT_TRUE(fails_with(unknown, ErrorCode::not_found, visnav::test::key_only("e7")));
  EXPECT_NE(unknown.error().message.find("--k visual_memory="), std::string::npos) << unknown.error().message;  // the fix

  auto zero = vs::analyse_loop({{"e1", "path_following", 0.0, 0.0}, {"e2", "path_following", 5.0, pi}}, test_models());
  EXPECT_TRUE(fails_with(zero, ErrorCode::out_of_range, visnav::test::key_only("e1")));

  vs::ConvergenceModels bad;
  bad.k_per_m["path_following"] = -1.0;
  auto neg = vs::analyse_loop(square(5.0, 0.0, "path_following"), bad);
  EXPECT_TRUE(fails_with(neg, ErrorCode::out_of_range, visnav::test::key_only("path_following")));
}

TEST(ErrorModel, ClosedRouteFromAMapUsesTheTaughtNodePositions) {
  const fs::path dir = fs::temp_directory_path() / ("visnav_stability_map_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  auto map = visnav::MapStore::create(dir.string(), "square");
  ASSERT_TRUE(map.ok()) << map.error().message;
  map->set_sync(false);
  const double xy[4][2] = {{0, 0}, {6, 0}, {6, 6}, {0, 6}};
  std::vector<std::string> ids;
  for (auto& p : xy) {
    visnav::NodeRecord n;
    n.position_hint = visnav::Pose2D{p[0], p[1], 0.0};
    auto id = map->add_node(n);
    ASSERT_TRUE(id.ok());
    ids.push_back(*id);
  }
  const std::vector<std::uint8_t> body{1, 2, 3};
  for (int i = 0; i < 4; ++i) {
    visnav::EdgeRecord e;
    e.from = ids[static_cast<std::size_t>(i)];
    e.to = ids[static_cast<std::size_t>((i + 1) % 4)];
    e.kind = i % 2 == 0 ? "path_following" : "feature_segment";
    e.length_m = 6.0;
    e.azimuth_rad = 0.3;  // deliberately wrong: the node positions win
    ASSERT_TRUE(map->add_edge(e, body).ok());
  }
  auto route = vs::closed_route(*map);
  ASSERT_TRUE(route.ok()) << route.error().message;
  ASSERT_EQ(route->size(), 4u);
  EXPECT_NEAR((*route)[1].direction_rad, pi / 2.0, 1e-12);
  EXPECT_NEAR(std::abs((*route)[2].direction_rad), pi, 1e-12);
  auto rep = vs::analyse_loop(*route, vs::ConvergenceModels::defaults());
  ASSERT_TRUE(rep.ok());
  // y corrected by the path edges (0, 2), x by the feature edges (1, 3).
  EXPECT_NEAR(rep->lateral_contraction, std::exp(-0.366 * 12.0), 1e-12);
  EXPECT_NEAR(rep->along_track_contraction, std::exp(-0.055 * 12.0), 1e-12);

  // Taught on corner arcs (a car-like robot, start gap > 0.5 m): the nodes are where the arcs
  // start, so the edges' start azimuths are used instead of the chords.
  ASSERT_TRUE(map->set_edge_statistic("e1", "start_gap_m", 1.6).ok());
  auto arcs = vs::closed_route(*map);
  ASSERT_TRUE(arcs.ok()) << arcs.error().message;
  for (const auto& e : *arcs) EXPECT_NEAR(e.direction_rad, 0.3, 1e-12) << e.id;
  ASSERT_TRUE(map->set_edge_statistic("e1", "start_gap_m", 0.05).ok());  // a stop after a turn on the spot
  auto spot = vs::closed_route(*map);
  ASSERT_TRUE(spot.ok());
  EXPECT_NEAR((*spot)[1].direction_rad, pi / 2.0, 1e-12);

  auto open = vs::closed_route(*map, {"e1", "e2"});
  EXPECT_TRUE(fails_with(open, ErrorCode::inconsistent, At{"graph.yaml"}));
  auto missing = vs::closed_route(*map, {"nope"});
  EXPECT_TRUE(fails_with(missing, ErrorCode::not_found, At{"graph.yaml", 0, "nope"}));
  fs::remove_all(dir);
}
