// The "must show": a simulated feature-based replay (ReplayFeatureEdge, map style B)
// recorded with `visnav record` and played back with `visnav play` on the same map makes the same
// replay decisions, frame for frame. Teach with TeachFeatureEdge (ScriptedOperator driving a
// gentle 5 m bend in the straight6m world), replay 0.3 m to the left of it so the steering works.
#include <gtest/gtest.h>

#include "recorded_test_support.hpp"
#include "visnav/map.hpp"

using namespace visnav::testing;

TEST(FeatureReplayPlay, RecordedReplayPlaysBackWithTheSameDecisions) {
  const std::string src = VISNAV_TEST_SOURCE_DIR;
  const std::string dir = (fs::path(VISNAV_TEST_BINARY_DIR) / "test_scratch" / "feature_replay_play").string();
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string cli = VISNAV_TEST_CLI;
  const std::string config = dir + "/config.yaml";
  put(config,
      "robot:\n  type: sim\n  params: {world: straight6m, odom_scale_error_pct: 3, odom_rate_hz: 50}\n"
      "camera:\n  type: sim\n  params: {width_px: 160, height_px: 120, hfov_deg: 60, noise_std: 1}\n"
      "detector:\n  type: orb\n  params: {target_keypoints: 300}\n"
      "nodes: [feature_replay, navigation, sim_operator, relocalisation]\n"
      "run:\n  tick: frame\n  rate_hz: 10\n  lockstep: on\n  log_level: warn\n  reload_poll_s: 0\n");
  const std::string route = dir + "/route.yaml";
  put(route,
      "route:\n  name: bend5m\n  world: straight6m\n  start: [0, 0, 0]\n"
      "  pursuit: {lookahead_m: 0.6, speed_mps: 0.4, min_speed_mps: 0.15, max_angular_radps: 1.0, command_rate_hz: 5,"
      " angular_step_radps: 0.05, goal_tolerance_m: 0.15}\n"
      "  waypoints:\n    - {at: [0, 0], kind: feature}\n    - {at: [2.5, 0.3]}\n    - {at: [5, 0]}\n");
  const std::string map = dir + "/map";
  const std::string log = dir + "/teach.log";
  ASSERT_EQ(shell("'" + cli + "' run --config " + config + " --map " + map + " --create --tree " + src + "/trees/teach_feature_edge.xml" +
                      " --bb route_file=" + route + " --bb style=localmaps" +
                      " --bb force_kind=feature_localmaps --bb close_loop=false",
                  log),
            0)
      << slurp(log);
  std::string goal;
  {
    auto m = visnav::MapStore::open(map);
    ASSERT_TRUE(m.ok()) << m.error().message;
    ASSERT_FALSE(m->edges().empty()) << slurp(log);
    EXPECT_EQ(m->edges().front().kind, "feature_localmaps");
    goal = m->edges().back().to;
  }
  // Replay (live, recorded) and playback each get their own copy of the taught map.
  fs::copy(map, dir + "/map_live", fs::copy_options::recursive);
  fs::copy(map, dir + "/map_play", fs::copy_options::recursive);
  const std::string run = dir + "/run";
  const std::string bb = " --bb start=start --bb goal=" + goal + " --bb loops=1 --bb laps=1 --bb speed_mps=0.4";
  const std::string tree = src + "/trees/replay_feature_edge.xml";
  const std::string rec_log = dir + "/record.log";
  ASSERT_EQ(shell("'" + cli + "' record --config " + config + " --map " + dir + "/map_live -o " + run + " --tree " + tree + bb +
                      " --set robot.params.displacement_lateral_m=0.3 --set run.telemetry_file=" + dir + "/live.jsonl",
                  rec_log),
            0)
      << slurp(rec_log);
  const auto live = lines_of(run + "/commands.csv");
  ASSERT_GT(live.size(), 50u) << slurp(rec_log);

  const std::string out = dir + "/play_commands.csv";
  const std::string play_log = dir + "/play.log";
  const int rc = shell("'" + cli + "' play " + run + " --map " + dir + "/map_play --tree " + tree + " --commands-out " + out +
                           " --set run.telemetry_file=" + dir + "/play.jsonl",
                       play_log);
  const std::string text = slurp(play_log);
  ASSERT_EQ(rc, 0) << text;
  const auto played = lines_of(out);
  ASSERT_EQ(played.size(), live.size()) << text;
  std::size_t same = 0;
  for (std::size_t i = 0; i < live.size(); ++i) same += played[i] == live[i] ? 1 : 0;
  EXPECT_EQ(same, live.size()) << text;
  const std::string n = std::to_string(live.size() - 1);
  EXPECT_NE(text.find("decisions: " + n + " of " + n + " ticks identical"), std::string::npos) << text;
  // The replay's per-frame status (offset, inliers, command) is identical as well.
  const std::string live_tm = slurp(dir + "/live.jsonl");
  EXPECT_NE(live_tm.find("\"inliers\""), std::string::npos);
  EXPECT_EQ(slurp(dir + "/play.jsonl"), live_tm);
}
