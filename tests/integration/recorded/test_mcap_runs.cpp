// MCAP recorded runs end to end in the simulator:
//  * `visnav record --format mcap` of a feature replay, `visnav play RUN.mcap` makes the same
//    decisions tick for tick; `visnav convert` MCAP -> folder -> MCAP -> folder is exact;
//  * `visnav teach --run DRIVE.mcap` builds a map from a recorded teaching drive that matches the
//    map the live teach wrote, and `visnav evaluate --run DRIVE.mcap` against it is accurate.
#include <gtest/gtest.h>

#include <fstream>

#include "recorded_test_support.hpp"
#include "visnav/map.hpp"

using namespace visnav::testing;

namespace {

struct McapSetup {
  std::string src = VISNAV_TEST_SOURCE_DIR;
  std::string cli = VISNAV_TEST_CLI;
  std::string dir, config, route;

  explicit McapSetup(const std::string& name) {
    dir = (fs::path(VISNAV_TEST_BINARY_DIR) / "test_scratch" / name).string();
    fs::remove_all(dir);
    fs::create_directories(dir);
    config = dir + "/config.yaml";
    put(config,
        "robot:\n  type: sim\n  params: {world: straight6m, odom_scale_error_pct: 3, odom_rate_hz: 50}\n"
        "camera:\n  type: sim\n  params: {width_px: 160, height_px: 120, hfov_deg: 60, noise_std: 1}\n"
        "detector:\n  type: orb\n  params: {target_keypoints: 300}\n"
        "nodes: [feature_replay, navigation, sim_operator, teleop, path_following, relocalisation]\n"
        "run:\n  tick: frame\n  rate_hz: 10\n  lockstep: on\n  log_level: warn\n  reload_poll_s: 0\n");
    route = dir + "/route.yaml";
    put(route,
        "route:\n  name: straight5m\n  world: straight6m\n  start: [0, 0, 0]\n"
        "  pursuit: {lookahead_m: 0.6, speed_mps: 0.4, min_speed_mps: 0.15, max_angular_radps: 1.0, command_rate_hz: 5,"
        " angular_step_radps: 0.05, goal_tolerance_m: 0.15}\n"
        "  waypoints:\n    - {at: [0, 0], kind: feature}\n    - {at: [5, 0]}\n");
  }
  /// The teaching drive: ScriptedOperator along the 5 m straight, one edge of `style`.
  [[nodiscard]] std::string teach_args(const std::string& style) const {
    return " --tree " + src + "/trees/teach_feature_edge.xml --bb route_file=" + route + " --bb style=" + style +
           " --bb force_kind=feature_" + style + " --bb close_loop=false";
  }
};

TEST(McapRuns, RecordedReplayPlaysBackFromMcapWithTheSameDecisionsAndConvertsExactly) {
  McapSetup s("mcap_replay");
  const std::string map = s.dir + "/map";
  ASSERT_EQ(shell("'" + s.cli + "' run --config " + s.config + " --map " + map + " --create" + s.teach_args("localmaps"), s.dir + "/teach.log"), 0)
      << slurp(s.dir + "/teach.log");
  std::string goal;
  {
    auto m = visnav::MapStore::open(map);
    ASSERT_TRUE(m.ok()) << m.error().message;
    ASSERT_FALSE(m->edges().empty());
    goal = m->edges().back().to;
  }
  fs::copy(map, s.dir + "/map_live", fs::copy_options::recursive);
  fs::copy(map, s.dir + "/map_play", fs::copy_options::recursive);
  const std::string run = s.dir + "/replay.mcap";
  const std::string tree = s.src + "/trees/replay_feature_edge.xml";
  const std::string bb = " --bb start=start --bb goal=" + goal + " --bb loops=1 --bb laps=1 --bb speed_mps=0.4";
  ASSERT_EQ(shell("'" + s.cli + "' record --format mcap --config " + s.config + " --map " + s.dir + "/map_live --create -o " + run +
                      " --tree " + tree + bb + " --set robot.params.displacement_lateral_m=0.3",
                  s.dir + "/record.log"),
            0)
      << slurp(s.dir + "/record.log");
  const std::string play_log = s.dir + "/play.log";
  ASSERT_EQ(shell("'" + s.cli + "' play " + run + " --map " + s.dir + "/map_play --create --tree " + tree, play_log), 0) << slurp(play_log);
  const std::string text = slurp(play_log);
  const auto pos = text.find("decisions: ");
  ASSERT_NE(pos, std::string::npos) << text;
  int same = -1, total = -2;
  ASSERT_EQ(std::sscanf(text.c_str() + pos, "decisions: %d of %d", &same, &total), 2) << text;
  EXPECT_GT(total, 50);
  EXPECT_EQ(same, total) << text;

  // MCAP -> folder -> MCAP -> folder: the two folders are identical, file by file.
  ASSERT_EQ(shell("'" + s.cli + "' convert " + run + " " + s.dir + "/a", s.dir + "/c1.log"), 0) << slurp(s.dir + "/c1.log");
  EXPECT_NE(slurp(s.dir + "/c1.log").find("exact"), std::string::npos);
  ASSERT_EQ(shell("'" + s.cli + "' convert " + s.dir + "/a " + s.dir + "/b.mcap", s.dir + "/c2.log"), 0) << slurp(s.dir + "/c2.log");
  ASSERT_EQ(shell("'" + s.cli + "' convert " + s.dir + "/b.mcap " + s.dir + "/b", s.dir + "/c3.log"), 0) << slurp(s.dir + "/c3.log");
  for (const char* f : {"frames.csv", "odometry.csv", "commands.csv", "ground_truth.csv", "run.yaml", "config.yaml",
                        "frames/000000.png", "frames/000010.png"}) {
    const std::string a = slurp(s.dir + "/a/" + f);
    EXPECT_FALSE(a.empty()) << f;
    EXPECT_EQ(a, slurp(s.dir + "/b/" + f)) << f;
  }
  EXPECT_GT(lines_of(s.dir + "/a/frames.csv").size(), 40u);
}

TEST(McapRuns, OfflineTeachFromARecordedDriveMatchesTheLiveTeach) {
  McapSetup s("mcap_teach");
  const std::string live = s.dir + "/map_live";
  const std::string drive = s.dir + "/drive.mcap";
  ASSERT_EQ(shell("'" + s.cli + "' record --format mcap --config " + s.config + " --map " + live + " --create -o " + drive + s.teach_args("segment"),
                  s.dir + "/record.log"),
            0)
      << slurp(s.dir + "/record.log");
  const std::string offline = s.dir + "/map_offline";
  ASSERT_EQ(shell("'" + s.cli + "' teach --run " + drive + " --map " + offline + " --primitive feature_segment --set " +
                      "run.log_level=warn",
                  s.dir + "/teach.log"),
            0)
      << slurp(s.dir + "/teach.log");
  auto a = visnav::MapStore::open(live);
  auto b = visnav::MapStore::open(offline);
  ASSERT_TRUE(a.ok()) << a.error().message;
  ASSERT_TRUE(b.ok()) << b.error().message << "\n" << slurp(s.dir + "/teach.log");
  ASSERT_EQ(a->edges().size(), 1u);
  ASSERT_EQ(b->edges().size(), 1u);
  EXPECT_EQ(b->edges()[0].kind, "feature_segment");
  // The live edge starts once the operator has turned to the leg and ends at the goal; the
  // offline one covers the whole drive but the last 0.5 s (--end-margin-s).
  EXPECT_NEAR(b->edges()[0].length_m, a->edges()[0].length_m, 0.35);
  EXPECT_GT(b->edges()[0].length_m, 4.0);
  // The drive against the offline map: every frame matches (it is the drive the map came from).
  const std::string eval_log = s.dir + "/evaluate.log";
  ASSERT_EQ(shell("'" + s.cli + "' evaluate --map " + offline + " --run " + drive + " -o " + s.dir + "/eval.csv --detector orb",
                  eval_log),
            0)
      << slurp(eval_log);
  const std::string text = slurp(eval_log);
  long frames = 0, valid = 0;
  double mean = 0, median = 99;
  ASSERT_EQ(std::sscanf(text.c_str(), "frames %ld valid %ld mean_abs_offset_px %lf median_abs_offset_px %lf", &frames, &valid,
                        &mean, &median),
            4)
      << text;
  EXPECT_GT(frames, 40);
  EXPECT_GE(valid, frames * 9 / 10) << text;
  EXPECT_LT(median, 2.0) << text;

  // The bag topics can come from a config (run.bag_image_topic); the command line still wins.
  const std::string topics = s.dir + "/topics.yaml";
  { std::ofstream(topics) << "robot: {type: sim}\ncamera: {type: sim}\nrun: {bag_image_topic: /no/such/images}\n"; }
  const std::string wrong_log = s.dir + "/evaluate_wrong_topic.log";
  EXPECT_EQ(shell("'" + s.cli + "' evaluate --map " + offline + " --run " + drive + " -o " + s.dir + "/eval2.csv --detector orb" +
                      " --config " + topics,
                  wrong_log),
            1)
      << slurp(wrong_log);
  const std::string right_log = s.dir + "/evaluate_right_topic.log";
  EXPECT_EQ(shell("'" + s.cli + "' evaluate --map " + offline + " --run " + drive + " -o " + s.dir + "/eval3.csv --detector orb" +
                      " --config " + topics + " --image-topic /camera/image_raw/compressed",
                  right_log),
            0)
      << slurp(right_log);
}

}  // namespace
