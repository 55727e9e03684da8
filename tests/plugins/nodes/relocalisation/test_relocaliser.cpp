// Sequence decision of the relocaliser (issue 21): agreement over frames, never one frame, the
// two ends of a loop, the odometry prior, a blocked camera, a robot off the map.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "visnav/relocalisation/relocaliser.hpp"

using namespace visnav::reloc;

namespace {

/// A closed loop of three 10 m edges: e0 a->b, e1 b->c, e2 c->a.
std::vector<RouteEdge> loop() {
  return {{"e0", "a", "b", 10.0}, {"e1", "b", "c", 10.0}, {"e2", "c", "a", 10.0}};
}

FrameVotes frame(std::vector<PlaceVote> votes, double odom_m = 0.0, double heading_rad = 0.0) {
  FrameVotes f;
  f.votes = std::move(votes);
  f.odom_distance_m = odom_m;
  f.odom_heading_rad = heading_rad;
  return f;
}

FrameVotes blank() {
  FrameVotes f;
  f.blank = true;
  return f;
}

}  // namespace

TEST(Relocaliser, AnswersOnlyAfterEnoughAgreeingFrames) {
  RelocaliseParams p;  // frames 5
  Relocaliser r(p, loop());
  for (int i = 0; i < 4; ++i) {
    r.add(frame({{1, 4.2, 0.8, 0.1}, {1, 4.4, 0.5, 0.1}}));
    EXPECT_EQ(r.decide().status, RelocStatus::pending) << "frame " << i + 1;
  }
  r.add(frame({{1, 4.2, 0.8, 0.1}}));
  const RelocAnswer a = r.decide();
  ASSERT_EQ(a.status, RelocStatus::localised) << a.reason;
  EXPECT_EQ(a.edge, 1u);
  EXPECT_NEAR(a.distance_m, 4.25, 0.05);
  EXPECT_NEAR(a.heading_offset_rad, 0.1, 1e-9);
  EXPECT_EQ(a.support, 5);
  EXPECT_GT(a.confidence, 0.5);
}

TEST(Relocaliser, SchemaRefusesASingleFrameAnswer) {
  RelocaliseParams p;
  p.frames = 1;
  EXPECT_FALSE(p.validate().ok());
  p.frames = 5;
  p.max_frames = 4;
  const auto st = p.validate();
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, visnav::ErrorCode::inconsistent);
  EXPECT_EQ(st.error().where.key, "max_frames");
}

TEST(Relocaliser, TwoEndsOfARepetitiveLoopAreAmbiguousWithoutAPrior) {
  // The same view matches 2 m into e0 and 2 m before the end of e1 (8 m): two distinct places.
  RelocaliseParams p;
  std::vector<FrameVotes> frames;
  for (int i = 0; i < p.max_frames; ++i) frames.push_back(frame({{0, 2.0, 0.7, 0.0}, {1, 8.0, 0.65, 0.0}}));
  Relocaliser r(p, loop());
  for (int i = 0; i < p.max_frames; ++i) {
    r.add(frames[static_cast<std::size_t>(i)]);
    if (i + 1 < p.max_frames) {
      EXPECT_EQ(r.decide().status, RelocStatus::pending) << "never answers early";
    }
  }
  const RelocAnswer a = r.decide();
  EXPECT_EQ(a.status, RelocStatus::ambiguous) << a.reason;
  EXPECT_NE(a.reason.find("e0"), std::string::npos);
  EXPECT_NE(a.reason.find("e1"), std::string::npos);

  // The odometry prior (the robot stopped at 7.5 m on e1) decides between them.
  RelocaliseParams with_prior = p;
  with_prior.prior_sigma_m = 2.0;
  Relocaliser r2(with_prior, loop());
  r2.set_prior(1, 7.5);
  for (int i = 0; i < p.frames; ++i) r2.add(frames[static_cast<std::size_t>(i)]);
  const RelocAnswer b = r2.decide();
  ASSERT_EQ(b.status, RelocStatus::localised) << b.reason;
  EXPECT_EQ(b.edge, 1u);
  EXPECT_NEAR(b.distance_m, 8.0, 1e-6);
}

TEST(Relocaliser, PlacesOnBothSidesOfANodeAreOnePlace) {
  // The end of e2 and the start of e0 are the same spot (node a): not ambiguous.
  RelocaliseParams p;
  Relocaliser r(p, loop());
  for (int i = 0; i < p.frames; ++i) r.add(frame({{2, 9.8, 0.7, 0.0}, {0, 0.2, 0.7, 0.0}}));
  const RelocAnswer a = r.decide();
  ASSERT_EQ(a.status, RelocStatus::localised) << a.reason;
  EXPECT_TRUE((a.edge == 2u && a.distance_m > 9.5) || (a.edge == 0u && a.distance_m < 0.5)) << a.reason;
}

TEST(Relocaliser, VotesFollowTheRobotsOwnMotion) {
  // The robot creeps 0.5 m per frame and turns 0.05 rad: the same place seen from a moving robot
  // agrees once moved to the newest frame.
  RelocaliseParams p;
  Relocaliser r(p, loop());
  for (int i = 0; i < p.frames; ++i)
    r.add(frame({{0, 3.0 + 0.5 * i, 0.6, 0.1 + 0.05 * i}}, 0.5 * i, 0.05 * i));
  const RelocAnswer a = r.decide();
  ASSERT_EQ(a.status, RelocStatus::localised) << a.reason;
  EXPECT_NEAR(a.distance_m, 5.0, 0.05);
  EXPECT_NEAR(a.heading_offset_rad, 0.1 + 0.05 * 4, 1e-6);
  // Frames whose places do not move with the robot do not agree: scattered support.
  Relocaliser still(p, loop());
  for (int i = 0; i < p.max_frames; ++i) still.add(frame({{0, 3.0, 0.6, 0.0}}, 1.5 * i));
  EXPECT_NE(still.decide().status, RelocStatus::localised);
}

TEST(Relocaliser, BlankFramesAreACameraProblemAndNoVotesAreNotOnTheMap) {
  RelocaliseParams p;
  Relocaliser covered(p, loop());
  for (int i = 0; i < p.frames; ++i) covered.add(blank());
  const RelocAnswer c = covered.decide();
  EXPECT_EQ(c.status, RelocStatus::camera_blocked) << c.reason;
  EXPECT_EQ(c.blank_frames, p.frames);

  Relocaliser off(p, loop());
  for (int i = 0; i < p.frames; ++i) off.add(frame({}));
  EXPECT_EQ(off.decide().status, RelocStatus::not_on_map);

  // Sporadic weak matches (1 frame in 4) are not an answer either: not on the map after max_frames.
  Relocaliser sporadic(p, loop());
  for (int i = 0; i < p.max_frames; ++i)
    sporadic.add(frame(i % 4 == 0 ? std::vector<PlaceVote>{{1, 6.0, 0.4, 0.0}} : std::vector<PlaceVote>{}));
  const RelocAnswer s = sporadic.decide();
  EXPECT_EQ(s.status, RelocStatus::not_on_map) << s.reason;

  // Agreeing but weak frames (confidence 0.35 each < min_answer_confidence 0.45): they wait for
  // more frames, then the answer is ambiguous, not a guess.
  Relocaliser weak(p, loop());
  for (int i = 0; i < p.max_frames; ++i) {
    weak.add(frame({{1, 6.0, 0.35, 0.0}}));
    if (i + 1 < p.max_frames) {
      EXPECT_EQ(weak.decide().status, RelocStatus::pending);
    }
  }
  EXPECT_EQ(weak.decide().status, RelocStatus::ambiguous) << weak.decide().reason;
}

TEST(Relocaliser, CreepingSeparatesALookAlikeThatDoesNotAdvanceWithTheRobot) {
  // Standing still, 4 m and 7 m into e0 match equally well (far scenery): ambiguous.
  RelocaliseParams p;
  Relocaliser still(p, loop());
  for (int i = 0; i < p.max_frames; ++i) still.add(frame({{0, 4.0, 0.9, 0.0}, {0, 7.0, 0.9, 0.0}}));
  EXPECT_EQ(still.decide().status, RelocStatus::ambiguous);

  // Creeping 0.1 m per frame: the true place advances with the robot, the look-alike's best
  // match slides backwards (0.3 m per frame) and no longer gathers the frames into one place.
  Relocaliser creep(p, loop());
  creep.hold(true);
  const int n = 21;
  for (int i = 0; i < n; ++i) {
    const double moved = 0.1 * i;
    creep.add(frame({{0, 4.0 + moved, 0.9, 0.0}, {0, 9.0 - 3.0 * moved, 0.9, 0.0}}, moved));
    const RelocAnswer held = creep.decide();
    EXPECT_EQ(held.status, RelocStatus::pending) << "held while creeping, frame " << i + 1;
    if (i + 1 >= p.frames) {
      EXPECT_TRUE(held.has_best);
    }
  }
  creep.hold(false);
  const RelocAnswer a = creep.decide();
  ASSERT_EQ(a.status, RelocStatus::localised) << a.reason;
  EXPECT_EQ(a.edge, 0u);
  EXPECT_NEAR(a.distance_m, 6.0, 0.05);
}

TEST(Relocaliser, HoldStillStopsARobotThatRecognisesNothing) {
  // Held for a creep, a robot that verified no place (or sees nothing) is answered at once, so it
  // never drives forward off the map.
  RelocaliseParams p;
  Relocaliser off(p, loop());
  off.hold(true);
  for (int i = 0; i < p.frames; ++i) off.add(frame({}));
  EXPECT_EQ(off.decide().status, RelocStatus::not_on_map);
  Relocaliser covered(p, loop());
  covered.hold(true);
  for (int i = 0; i < p.frames; ++i) covered.add(blank());
  EXPECT_EQ(covered.decide().status, RelocStatus::camera_blocked);
}

TEST(Relocaliser, MotionIsProjectedOnTheEdgeWithTheHeadingOffset) {
  // Driving 2 m at 0.5 rad to the taught heading advances 2 cos(0.5) = 1.755 m along the edge.
  RelocaliseParams p;
  Relocaliser r(p, loop());
  for (int i = 0; i < p.frames; ++i) {
    const double moved = 0.5 * i;
    r.add(frame({{0, 3.0 + moved * std::cos(0.5), 0.7, 0.5}}, moved));
  }
  const RelocAnswer a = r.decide();
  ASSERT_EQ(a.status, RelocStatus::localised) << a.reason;
  EXPECT_NEAR(a.distance_m, 3.0 + 2.0 * std::cos(0.5), 0.01);
  EXPECT_EQ(a.support, p.frames);
}

TEST(Relocaliser, PlacesFarApartGiveAnUncertainAnswerThatALimitRefuses) {
  // Every frame's best vote is a place whose neighbours are 3 m away (+-1.5 m), or 0.25 m.
  auto run = [](double place_uncertainty_m, double limit_m) {
    RelocaliseParams p;
    p.max_along_uncertainty_m = limit_m;
    Relocaliser r(p, loop());
    for (int i = 0; i < p.max_frames; ++i) r.add(frame({{1, 4.0, 0.8, 0.0, 20.0, place_uncertainty_m}}));
    return r.decide();
  };
  const RelocAnswer coarse = run(1.5, 0.0);  // no limit: answered, saying how uncertain
  ASSERT_EQ(coarse.status, RelocStatus::localised) << coarse.reason;
  EXPECT_NEAR(coarse.along_uncertainty_m, 1.5, 1e-9);
  const RelocAnswer refused = run(1.5, 1.0);
  EXPECT_EQ(refused.status, RelocStatus::ambiguous) << refused.reason;
  const RelocAnswer fine = run(0.125, 1.0);
  ASSERT_EQ(fine.status, RelocStatus::localised) << fine.reason;
  EXPECT_NEAR(fine.along_uncertainty_m, 0.125, 1e-9);

  // Dense places but frames disagreeing where (best votes 1.5 m apart, alternating): the spread counts.
  RelocaliseParams p;
  p.max_along_uncertainty_m = 1.0;
  p.place_tolerance_m = 2.0;
  Relocaliser r(p, loop());
  for (int i = 0; i < p.max_frames; ++i) r.add(frame({{1, i % 2 == 0 ? 3.0 : 4.5, 0.8, 0.0, 20.0, 0.125}}));
  const RelocAnswer spread = r.decide();
  EXPECT_EQ(spread.status, RelocStatus::ambiguous) << spread.reason;
  EXPECT_GT(spread.along_uncertainty_m, 1.0);
}

TEST(Relocaliser, VotesMovedPastAnEdgesEndAreAnsweredOnTheNextEdge) {
  // Every frame saw the place 0.2 m before the end of e0 (10 m) and the robot crept 1.2 m since:
  // it is 1 m into e1, not on the node.
  RelocaliseParams p;
  Relocaliser r(p, loop());
  for (int i = 0; i < p.max_frames; ++i) r.add(frame({{0, 9.8, 0.8, 0.0, 20.0}}, 0.1 * i));
  r.add(frame({{0, 9.8, 0.8, 0.0, 20.0}}, 0.1 * (p.max_frames - 1) + 0.1));
  const RelocAnswer a = r.decide();
  ASSERT_EQ(a.status, RelocStatus::localised) << a.reason;
  EXPECT_EQ(a.edge, 1u) << a.reason;
  EXPECT_NEAR(a.distance_m, 0.4, 0.15) << a.reason;  // median of 9.8 + (1.2 .. 0) past 10 m
}

TEST(Relocaliser, PlacesWithKnownGapsAreAnsweredWhereTheFramesCellsOverlap) {
  // References 2 m apart on e1 (2.0, 4.0); the robot creeps from 2.6 m to 3.6 m. The frames up to
  // 3.1 m see the reference behind (2.0) best, the later ones the one ahead (4.0). Moved to the
  // newest frame, the votes are 2.5-3.0 m and 4.0-4.4 m: their median (3.0 m) is 0.6 m behind
  // the robot. Each vote's cell ([2.0 - 1.0, 2.0 + 1.5], [4.0 - 1.0, 4.0 + 1.5] moved) overlaps in
  // every frame only on 3.4-4.0 m.
  RelocaliseParams p;
  p.place_tolerance_m = 2.0;  // one hypothesis for both references
  auto run = [&](double gap_m) {
    Relocaliser r(p, loop());
    for (int i = 0; i <= 10; ++i) {
      const double odom_m = 0.1 * i;
      const double place_m = 2.6 + odom_m < 3.15 ? 2.0 : 4.0;
      PlaceVote v{1, place_m, 0.8, 0.0};
      v.gap_before_m = gap_m;
      v.gap_after_m = gap_m;
      r.add(frame({v}, odom_m));
    }
    return r.decide();
  };
  const RelocAnswer cells = run(2.0);
  ASSERT_EQ(cells.status, RelocStatus::localised) << cells.reason;
  EXPECT_EQ(cells.edge, 1u);
  EXPECT_NEAR(cells.distance_m, 3.7, 0.05);  // the truth is 3.6 m
  EXPECT_NEAR(cells.along_uncertainty_m, 0.3, 0.05);  // half the stretch all cells cover
  const RelocAnswer median = run(0.0);        // gaps not given: the median of the moved votes
  ASSERT_EQ(median.status, RelocStatus::localised) << median.reason;
  EXPECT_NEAR(median.distance_m, 3.0, 0.05);
}

TEST(Relocaliser, AdjacentReferencesMoreThanThePlaceToleranceApartAreOneStretch) {
  // The scenario above with the default place_tolerance_m (1 m): the frames' best votes, 2.5-3.0 m
  // and 4.0-4.4 m moved, are two places by the tolerance, neither supported by 85 % of the
  // frames. Votes with known gaps (visual_memory references, 2 m apart here) join a place within
  // their gap: one stretch, placed by the cells where the robot is.
  RelocaliseParams p;
  p.min_agreement = 0.85;
  Relocaliser r(p, loop());
  for (int i = 0; i <= 10; ++i) {
    const double odom_m = 0.1 * i;
    PlaceVote v{1, 2.6 + odom_m < 3.15 ? 2.0 : 4.0, 0.8, 0.0};
    v.gap_before_m = 2.0;
    v.gap_after_m = 2.0;
    r.add(frame({v}, odom_m));
  }
  const RelocAnswer a = r.decide();
  ASSERT_EQ(a.status, RelocStatus::localised) << a.reason;
  EXPECT_EQ(a.edge, 1u);
  EXPECT_NEAR(a.distance_m, 3.7, 0.05);  // the truth is 3.6 m
  EXPECT_EQ(a.support, 11);
  // Without gaps (feature places) the same votes stay two places 1.5 m apart: not one answer.
  Relocaliser f(p, loop());
  for (int i = 0; i <= 10; ++i) {
    const double odom_m = 0.1 * i;
    f.add(frame({PlaceVote{1, 2.6 + odom_m < 3.15 ? 2.0 : 4.0, 0.8, 0.0}}, odom_m));
  }
  EXPECT_NE(f.decide().status, RelocStatus::localised);
}

TEST(Relocaliser, PlacesFarApartAreAmbiguousWhenTheFramesCannotSayWhereBetweenThem) {
  // References 3 m apart (2.0, 5.0); the robot creeps 1 m and sees 2.0 best all the way: it was
  // always within 2.0's cell [0.5, 4.25], so now anywhere on 1.5-4.25 m (+-1.4 m): refused.
  RelocaliseParams p;
  auto run = [&](auto place_of) {
    Relocaliser r(p, loop());
    for (int i = 0; i < 12; ++i) {  // max_frames: the refusal is final
      const double odom_m = 0.09 * i;
      PlaceVote v{1, place_of(i), 0.8, 0.0};
      v.gap_before_m = 3.0;
      v.gap_after_m = 3.0;
      r.add(frame({v}, odom_m));
    }
    return r.decide();
  };
  const RelocAnswer wide = run([](int) { return 2.0; });
  EXPECT_EQ(wide.status, RelocStatus::ambiguous) << wide.reason;
  EXPECT_NE(wide.reason.find("within"), std::string::npos) << wide.reason;
  // Standing still, frames alternating between two references 0.6 m apart (one hypothesis)
  // whose cells (+-0.2 m) do not overlap: 6 of 12 frames agree where, below min_cell_agreement.
  const RelocAnswer torn = [&] {
    Relocaliser r(p, loop());
    for (int i = 0; i < 12; ++i) {  // max_frames: the refusal is final
      PlaceVote v{1, i % 2 == 0 ? 2.0 : 2.6, 0.8, 0.0};
      v.gap_before_m = 0.4;
      v.gap_after_m = 0.4;
      r.add(frame({v}, 0.0));
    }
    return r.decide();
  }();
  EXPECT_EQ(torn.status, RelocStatus::ambiguous) << torn.reason;
  EXPECT_NE(torn.reason.find("disagree"), std::string::npos) << torn.reason;
}
