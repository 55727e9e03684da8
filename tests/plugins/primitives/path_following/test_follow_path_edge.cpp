// FollowPathEdge / TeachPathEdge end to end: the real loader, the real sim robot and camera
// plugins, the behaviour-tree engine and the map store. Teach a 5 m path edge on straight6m,
// then replay it from 0.5 m beside the path and check the ground truth.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>

#include "visnav/path_payload.hpp"
#include "path_session.hpp"
#include "visnav/runner.hpp"

namespace fs = std::filesystem;
using namespace visnav;
using visnav::test::tree_from;

namespace {

fs::path temp_dir(const std::string& name) { return visnav::test::path_test_dir(name); }

std::unique_ptr<Session> make_session(const fs::path& dir) {
  return visnav::test::make_path_session(dir, "world: straight6m, odom_scale_error_pct: 2");
}

}  // namespace

TEST(FollowPathEdge, TeachesThenFollowsThePathBackToItsCentreFromHalfAMetreOff) {
  const fs::path dir = temp_dir("closed_loop");
  auto session = make_session(dir);
  ASSERT_TRUE(session);
  SimulationControl* sim = session->robot().simulation();
  ASSERT_NE(sim, nullptr);

  {  // teach: the "operator" drives 5 m along the path centre
    auto teach = tree_from(*session, dir, R"(<TeachPathEdge edge_from="" edge_to="" finish="{finish}"/>)");
    ASSERT_TRUE(teach.ok()) << teach.error().message;
    teach->blackboard().set("finish", false);
    RunOptions ro;
    ro.after_tick = [&](const TickInfo&) {
      const auto odom = session->robot().latest_odometry();
      if (odom && odom->distance_m >= 5.0) teach->blackboard().set("finish", true);
      else (void)session->robot().send_command({0.4, 0.0});
      return true;
    };
    const RunReport report = run_tree(*session, *teach, ro);
    ASSERT_EQ(report.outcome, RunOutcome::success) << report.reason;
  }
  MapStore& map = *session->map();
  ASSERT_EQ(map.edges().size(), 1u);
  const EdgeRecord edge = map.edges()[0];
  EXPECT_EQ(edge.kind, "path_following");
  EXPECT_NEAR(edge.length_m, 5.0, 0.1);
  EXPECT_GE(edge.statistics.at("colour_models"), 1.0);
  // The edge stores almost nothing for following (seed 000 Sec. 2, 4.): the colour models, a 64x24
  // grey thumbnail every 0.5 m for relocalisation's place index and the along-track estimate, and
  // the path's offset in the learn frames (VPF3, visnav/path_payload.hpp): the teacher drove the
  // centre line, so the taught offsets are near 0.
  auto body = map.read_payload(edge.id);
  ASSERT_TRUE(body.ok()) << body.error().message;
  auto payload = path_payload::PathPayload::decode(*body);
  ASSERT_TRUE(payload.ok()) << payload.error().message;
  EXPECT_EQ(payload->version, 3u);
  ASSERT_GE(payload->offsets.size(), 15u);  // 5 m at 0.4 m/s and 10 Hz, every 5th frame: ~25
  for (const auto& o : payload->offsets) EXPECT_LT(std::abs(o.offset), 0.1) << o.distance_m;
  ASSERT_GE(payload->thumbnails.size(), 10u);
  ASSERT_LE(payload->thumbnails.size(), 11u);
  EXPECT_EQ(edge.statistics.at("thumbnails"), static_cast<double>(payload->thumbnails.size()));
  for (std::size_t k = 1; k < payload->thumbnails.size(); ++k)
    EXPECT_NEAR(payload->thumbnails[k].distance_m - payload->thumbnails[k - 1].distance_m, 0.5, 0.06);
  EXPECT_EQ(payload->thumbnails[0].image.size(),
            cv::Size(path_payload::kThumbnailWidthPx, path_payload::kThumbnailHeightPx));
  EXPECT_LT(edge.payload_bytes, 2000u + payload->thumbnails.size() * (8u + 64u * 24u));
  EXPECT_TRUE(map.validate().empty());

  // replay from 0.5 m to the left of the centre line (the path is 1.6 m wide along +x)
  ASSERT_TRUE(sim->set_ground_truth_pose({0.0, 0.5, 0.0}).ok());
  auto replay = tree_from(*session, dir, "<FollowPathEdge edge=\"" + edge.id + "\"/>");
  ASSERT_TRUE(replay.ok()) << replay.error().message;
  double max_abs_y = 0.0;
  RunOptions ro;
  ro.after_tick = [&](const TickInfo&) {
    max_abs_y = std::max(max_abs_y, std::abs(sim->ground_truth_pose().y_m));
    return true;
  };
  const RunReport report = run_tree(*session, *replay, ro);
  ASSERT_EQ(report.outcome, RunOutcome::success) << report.reason;
  const Pose2D end = sim->ground_truth_pose();
  std::printf("closed loop: start offset 0.50 m, max |offset| %.3f m, end offset %.3f m after %.2f m\n", max_abs_y,
              end.y_m, end.x_m);
  EXPECT_LT(max_abs_y, 0.8) << "left the path polygon";
  EXPECT_LE(std::abs(end.y_m), 0.2) << "end offset from the centre line";
  EXPECT_GT(end.x_m, 4.0);  // it travelled the edge
  fs::remove_all(dir);
}

TEST(FollowPathEdge, FailsWithPathLostWhenNoPathIsInView) {
  const fs::path dir = temp_dir("lost");
  auto session = make_session(dir);
  ASSERT_TRUE(session);
  SimulationControl* sim = session->robot().simulation();
  {  // a short path edge
    auto teach = tree_from(*session, dir, R"(<TeachPathEdge edge_from="" edge_to="" finish="{finish}"/>)");
    ASSERT_TRUE(teach.ok());
    teach->blackboard().set("finish", false);
    RunOptions ro;
    ro.after_tick = [&](const TickInfo&) {
      const auto odom = session->robot().latest_odometry();
      if (odom && odom->distance_m >= 2.0) teach->blackboard().set("finish", true);
      else (void)session->robot().send_command({0.4, 0.0});
      return true;
    };
    ASSERT_EQ(run_tree(*session, *teach, ro).outcome, RunOutcome::success);
  }
  // Face away from the path, out in the grass: no path in view.
  ASSERT_TRUE(sim->set_ground_truth_pose({5.0, 6.0, 1.5708}).ok());
  auto replay = tree_from(*session, dir, "<FollowPathEdge edge=\"" + session->map()->edges()[0].id + "\" grace_s=\"0.5\"/>");
  ASSERT_TRUE(replay.ok());
  const double x0 = sim->ground_truth_pose().x_m, y0 = sim->ground_truth_pose().y_m;
  const RunReport report = run_tree(*session, *replay);
  EXPECT_EQ(report.outcome, RunOutcome::failure);
  // the primitive's own path-lost failure, not the lost policy's: a tree keys on the code
  const auto failure = replay->blackboard().get<std::string>("edge_failure");
  const auto code = replay->blackboard().get<std::string>("edge_failure_code");
  ASSERT_TRUE(failure.ok() && code.ok());
  EXPECT_NE(failure->find("path lost on edge"), std::string::npos) << *failure;
  EXPECT_EQ(*code, "view_lost") << *failure;
  // it did not wander off: at most the grace period at low speed
  const Pose2D p = sim->ground_truth_pose();
  EXPECT_LT(std::hypot(p.x_m - x0, p.y_m - y0), 0.5);
  fs::remove_all(dir);
}

TEST(FollowPathEdge, RejectsAnEdgeOfAnotherKindOrACorruptPayloadWithoutMoving) {
  const fs::path dir = temp_dir("bad_edge");
  auto session = make_session(dir);
  ASSERT_TRUE(session);
  MapStore& map = *session->map();
  NodeRecord n;
  n.name = "a";
  auto a = *map.add_node(n);
  EdgeRecord e;
  e.from = a;
  e.to = a;
  e.kind = "feature_segment";
  e.length_m = 3;
  std::vector<std::uint8_t> garbage(40, 0xAB);
  auto wrong_kind = *map.add_edge(e, garbage);
  e.kind = "path_following";
  auto corrupt = *map.add_edge(e, garbage);
  const std::pair<std::string, std::string> cases[] = {
      {wrong_kind, "bad_edge"}, {corrupt, "bad_payload"}, {"no_such_edge", "bad_edge"}};
  for (const auto& [id, expected_code] : cases) {
    auto replay = tree_from(*session, dir, "<FollowPathEdge edge=\"" + id + "\"/>");
    ASSERT_TRUE(replay.ok());
    const Pose2D before = session->robot().simulation()->ground_truth_pose();
    EXPECT_EQ(run_tree(*session, *replay).outcome, RunOutcome::failure) << id;
    const auto code = replay->blackboard().get<std::string>("edge_failure_code");
    EXPECT_EQ(code.ok() ? *code : std::string("<unset>"), expected_code) << id;
    const Pose2D after = session->robot().simulation()->ground_truth_pose();
    EXPECT_LT(std::hypot(after.x_m - before.x_m, after.y_m - before.y_m), 1e-6) << id;
  }
  fs::remove_all(dir);
}

// junction_approach_m (junction mode before the edge's end node): on the campus gravel loop the
// west arm (x = -2, northwards) meets an L corner at y = -6 turning east. A path edge taught
// along the arm's centre up to y = -9 is replayed from the same start; without the approach
// mode the follower sees the east arm in the far rows and drifts right towards it in the last
// metres (about 0.2 m: cutting the corner, which the turn at the next node turns into
// along-track error); in junction mode for the last 2 m it ends markedly closer to the centre.
// Steering to the taught offsets (taught_offset_gain 1) it ends on the taught centre line.
TEST(FollowPathEdge, JunctionApproachReducesTheDriftTowardsAnLCornerAhead) {
  const fs::path dir = temp_dir("approach");
  auto session = visnav::test::make_path_session(dir, "world: campus, start_pose: \"-2;-20;90\"");
  ASSERT_TRUE(session);
  SimulationControl* sim = session->robot().simulation();
  ASSERT_NE(sim, nullptr);
  const Pose2D start{-2.0, -20.0, std::acos(0.0)};
  ASSERT_TRUE(sim->set_ground_truth_pose(start).ok());
  {  // teach: 11 m along the arm's centre line, steered on the ground truth
    auto teach = tree_from(*session, dir, R"(<TeachPathEdge edge_from="" edge_to="" finish="{finish}"/>)");
    ASSERT_TRUE(teach.ok()) << teach.error().message;
    teach->blackboard().set("finish", false);
    RunOptions ro;
    ro.after_tick = [&](const TickInfo&) {
      const Pose2D p = sim->ground_truth_pose();
      if (p.y_m >= -9.0) {
        teach->blackboard().set("finish", true);
        (void)session->robot().stop();
      } else {
        (void)session->robot().send_command({0.5, 1.5 * (start.heading_rad - p.heading_rad) - 0.8 * (p.x_m + 2.0)});
      }
      return true;
    };
    ASSERT_EQ(run_tree(*session, *teach, ro).outcome, RunOutcome::success);
  }
  const std::string edge = session->map()->edges().at(0).id;
  auto replay_end_offset = [&](const std::string& approach, const std::string& taught_offset_gain) {
    EXPECT_TRUE(sim->set_ground_truth_pose(start).ok());
    // along_gain 0: both replays end at the same odometric distance, so only the junction mode
    // differs (the along-track estimate moves the end by a few cm, and the drift grows there).
    auto replay = tree_from(*session, dir,
                            "<FollowPathEdge edge=\"" + edge + "\" along_gain=\"0\" junction_approach_m=\"" + approach +
                                "\" taught_offset_gain=\"" + taught_offset_gain + "\"/>");
    EXPECT_TRUE(replay.ok()) << replay.error().message;
    if (!replay.ok()) return 1e9;
    const RunReport report = run_tree(*session, *replay);
    EXPECT_EQ(report.outcome, RunOutcome::success) << report.reason;
    return sim->ground_truth_pose().x_m + 2.0;  // right of the centre line (east) positive
  };
  const double plain = replay_end_offset("0", "0");
  const double approach = replay_end_offset("2", "0");
  // The taught lateral position (the teacher's view had the path's middle where it lay on the
  // centre line, also with the east arm in view): the robot keeps the taught line without the
  // approach mode.
  const double taught = replay_end_offset("0", "1");
  std::printf("end offset right of the centre line: junction_approach_m=0 %.3f m, =2 %.3f m; taught offsets, "
              "junction_approach_m=0 %.3f m\n", plain, approach, taught);
  EXPECT_GT(plain, 0.12) << "the follower no longer cuts towards the corner: the test lost its point";
  EXPECT_LT(std::abs(approach), 0.75 * plain);
  EXPECT_LT(std::abs(taught), 0.05);
  fs::remove_all(dir);
}
