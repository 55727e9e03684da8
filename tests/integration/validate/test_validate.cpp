// check_setup — what `visnav validate` reports and `visnav run` stops on before its first tick —
// catches each case of issue 14 with a code and a location, lists all of them, and run_mission
// refuses the same setup without ticking. Uses the real sim robot/camera, star_brief detector
// and feature_replay nodes from the build's plugin folder.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "visnav/bt/registry.hpp"
#include "visnav/edge_progress.hpp"
#include "visnav/params.hpp"
#include "visnav/runner.hpp"
#include "visnav/runtime_host.hpp"

namespace fs = std::filesystem;
using visnav::Error;
using visnav::ErrorCode;
using visnav::ErrorLocation;

namespace {

class ValidateTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("visnav_validate_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }

  /// A valid sim setup; `robot_params` and `detector_params` are spliced into lines 3 and 7.
  std::string config(const std::string& robot_params = "{world: straight6m}",
                     const std::string& detector_params = "{target_keypoints: 200}") {
    return write("config.yaml",
                 "robot:\n"                                                  // 1
                 "  type: sim\n"                                             // 2
                 "  params: " + robot_params + "\n"                          // 3
                 "camera: {type: sim, params: {width_px: 160, height_px: 120}}\n"  // 4
                 "detector:\n"                                               // 5
                 "  type: star_brief\n"                                      // 6
                 "  params: " + detector_params + "\n"                       // 7
                 "nodes: [feature_replay, navigation, sim_operator]\n"       // 8
                 "run: {tick: frame, rate_hz: 10, lockstep: on, reload_poll_s: 0, max_duration_s: 2}\n");
  }

  /// A tree whose line 3 is `leaf`.
  std::string tree(const std::string& leaf) {
    return write("tree.xml",
                 "<root BTCPP_format=\"4\">\n"   // 1
                 "  <BehaviorTree ID=\"Main\">\n"  // 2
                 "    " + leaf + "\n"            // 3
                 "  </BehaviorTree>\n"
                 "</root>\n");
  }

  static std::vector<Error> check(const std::string& config_file, const std::string& tree_file = {},
                                  const std::string& map = {}, const std::vector<std::string>& bb = {}) {
    visnav::SetupCheck s;
    s.config_file = config_file;
    s.tree_file = tree_file;
    s.map_path = map;
    s.blackboard_values = bb;
    return visnav::check_setup(s);
  }

  static std::string dump(const std::vector<Error>& errors) {
    std::string out;
    for (const auto& e : errors) out += std::string(visnav::to_string(e.code)) + " @ " + e.where.str() + ": " + e.message + "\n";
    return out;
  }

  fs::path dir_;
};

TEST_F(ValidateTest, AGoodSetupHasNoProblems) {
  const auto problems = check(config(), tree("<Sleep msec=\"5\"/>"));
  EXPECT_TRUE(problems.empty()) << dump(problems);
}

// min_threshold: 50, max_threshold: 10 — each value is in range, the struct's validate() refuses
// the pair. Before, validate accepted it and the run failed when it built the detector.
TEST_F(ValidateTest, DetectorCrossFieldRuleIsChecked) {
  const std::string c = config("{world: straight6m}", "{min_threshold: 50, max_threshold: 10, threshold: 20}");
  const auto problems = check(c);
  ASSERT_EQ(problems.size(), 1u) << dump(problems);
  EXPECT_EQ(problems[0].code, ErrorCode::inconsistent);
  EXPECT_EQ(problems[0].where, (ErrorLocation{c, 7, "detector.params"}));
}

TEST_F(ValidateTest, OutOfRangeDetectorParamNamesItsKey) {
  const std::string c = config("{world: straight6m}", "\n    target_keypoints: 0");
  const auto problems = check(c);
  ASSERT_EQ(problems.size(), 1u) << dump(problems);
  EXPECT_EQ(problems[0].code, ErrorCode::out_of_range);
  EXPECT_EQ(problems[0].where, (ErrorLocation{c, 8, "detector.params.target_keypoints"}));
}

// speed_mps="9" on a primitive's port: before, it failed only when the robot reached that edge.
TEST_F(ValidateTest, PrimitivePortLiteralOutOfRange) {
  const std::string t = tree("<ReplayFeatureEdge edge=\"e1\" speed_mps=\"9\"/>");
  const auto problems = check(config(), t);
  ASSERT_EQ(problems.size(), 1u) << dump(problems);
  EXPECT_EQ(problems[0].code, ErrorCode::out_of_range);
  EXPECT_EQ(problems[0].where.file, t);
  EXPECT_EQ(problems[0].where.line, 3);
  EXPECT_EQ(problems[0].where.key, "Main/ReplayFeatureEdge[0]");
  // A value inside (0, 3] passes, and a blackboard reference is the node's to check.
  EXPECT_TRUE(check(config(), tree("<ReplayFeatureEdge edge=\"e1\" speed_mps=\"3\"/>")).empty());
  EXPECT_TRUE(check(config(), tree("<ReplayFeatureEdge edge=\"e1\" speed_mps=\"{v}\"/>")).empty());
}

TEST_F(ValidateTest, BuiltInNodeAttributeIsChecked) {
  const std::string t = tree("<Sleep msec=\"-5\"/>");
  const auto problems = check(config(), t);
  ASSERT_EQ(problems.size(), 1u) << dump(problems);
  EXPECT_EQ(problems[0].code, ErrorCode::invalid_value);
  EXPECT_EQ(problems[0].where, (ErrorLocation{t, 3, "Main/Sleep[0]"}));
}

// A built-in count below -1 made Repeat fail at its first tick without a reason; now the literal
// is refused before, with the range.
TEST_F(ValidateTest, BuiltInCountBelowMinusOneIsOutOfRange) {
  const std::string t = tree("<Repeat num_cycles=\"-5\"><AlwaysSuccess/></Repeat>");
  const auto problems = check(config(), t);
  ASSERT_EQ(problems.size(), 1u) << dump(problems);
  EXPECT_EQ(problems[0].code, ErrorCode::out_of_range);
  EXPECT_EQ(problems[0].where, (ErrorLocation{t, 3, "Main/Repeat[0]"}));
  EXPECT_TRUE(check(config(), tree("<Repeat num_cycles=\"-1\"><AlwaysSuccess/></Repeat>")).empty());
}

TEST_F(ValidateTest, MissingWorldFileIsNotFoundAtItsKey) {
  const std::string c = config("{world: " + (dir_ / "no_such_world.yaml").string() + "}");
  const auto problems = check(c);
  ASSERT_EQ(problems.size(), 1u) << dump(problems);
  EXPECT_EQ(problems[0].code, ErrorCode::not_found);
  EXPECT_EQ(problems[0].where, (ErrorLocation{c, 3, "robot.params.world"}));
}

TEST_F(ValidateTest, CorruptWorldFileIsAParseError) {
  const std::string w = write("broken_world.yaml", "walls: [ {from: [0, 0], to: \n");
  const std::string c = config("{world: " + w + "}");
  const auto problems = check(c);
  ASSERT_EQ(problems.size(), 1u) << dump(problems);
  EXPECT_EQ(problems[0].code, ErrorCode::parse_error);
  EXPECT_EQ(problems[0].where, (ErrorLocation{c, 3, "robot.params.world"}));
}

// Rules across ports and the ranges a node checks when it starts are checked on literals too, and
// `visnav run` refuses the very same trees before its first tick (issue 37: validate = run).
// Before, each of these passed validate and failed only when the robot reached the node.
TEST_F(ValidateTest, CrossPortRulesAndStartChecksRefuseTheSameTreesAsRun) {
  std::string c = config();
  {
    std::ifstream in(c);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string from = "nodes: [feature_replay, navigation, sim_operator]";
    text.replace(text.find(from), from.size(), "nodes: [feature_replay, navigation, sim_operator, ipt_obstacles]");
    c = write("config.yaml", text);
  }
  struct Case {
    std::string leaf;
    ErrorCode code;
    std::string says;
  };
  const std::vector<Case> bad = {
      {"<ReplayFeatureEdge edge=\"e1\" slow_after_m=\"9\" max_blind_m=\"5\"/>", ErrorCode::inconsistent, "slow_after_m"},
      {"<ReplayFeatureEdge edge=\"e1\" distance_scale=\"3\"/>", ErrorCode::out_of_range, "distance_scale"},
      {"<ReplayAvoiding crossing=\"kerb_m=9\"><ReplayFeatureEdge edge=\"e1\"/></ReplayAvoiding>", ErrorCode::out_of_range,
       "port 'crossing': key 'kerb_m'"},
      {"<ReplayAvoiding distance_scale=\"3\"><ReplayFeatureEdge edge=\"e1\"/></ReplayAvoiding>", ErrorCode::out_of_range,
       "distance_scale"},
      {"<ReplayAvoiding look=\"look_frames=-1\"><ReplayFeatureEdge edge=\"e1\"/></ReplayAvoiding>", ErrorCode::out_of_range,
       "key 'look_frames'"},
      // Group ports: an unknown key, a key given twice, a rule across keys, and the detour mode.
      {"<ReplayAvoiding corridor=\"lookahead=3\"><ReplayFeatureEdge edge=\"e1\"/></ReplayAvoiding>",
       ErrorCode::unknown_key, "unknown key 'lookahead'"},
      {"<ReplayAvoiding corridor=\"lookahead_m=3; lookahead_m=4\"><ReplayFeatureEdge edge=\"e1\"/></ReplayAvoiding>",
       ErrorCode::invalid_value, "key 'lookahead_m' is given twice"},
      {"<ReplayAvoiding standing=\"min_points=6; min_face_share=0.3\"><ReplayFeatureEdge edge=\"e1\"/></ReplayAvoiding>",
       ErrorCode::inconsistent, "key 'min_face_share' needs extent_m > 0"},
      {"<ReplayAvoiding detour=\"sideways\"><ReplayFeatureEdge edge=\"e1\"/></ReplayAvoiding>", ErrorCode::invalid_value,
       "'sideways' is not one of: lane thesis"},
  };
  for (const Case& k : bad) {
    const std::string t = tree(k.leaf);
    const auto problems = check(c, t);
    ASSERT_EQ(problems.size(), 1u) << k.leaf << "\n" << dump(problems);
    EXPECT_EQ(problems[0].code, k.code) << k.leaf << "\n" << dump(problems);
    EXPECT_EQ(problems[0].where.line, 3) << k.leaf;
    EXPECT_NE(problems[0].message.find(k.says), std::string::npos) << problems[0].message;
    visnav::MissionOptions m;
    m.config_file = c;
    m.tree_file = t;
    const visnav::RunReport r = visnav::run_mission(m);
    EXPECT_EQ(r.outcome, visnav::RunOutcome::error) << k.leaf;
    EXPECT_EQ(r.ticks, 0u) << k.leaf;
    EXPECT_NE(r.reason.find(problems[0].message), std::string::npos) << r.reason;
  }
  // The same values where they are allowed pass; a rule over a bound port is the node's to check.
  const std::vector<std::string> good = {
      "<ReplayFeatureEdge edge=\"e1\" slow_after_m=\"2\" max_blind_m=\"5\"/>",
      "<ReplayFeatureEdge edge=\"e1\" slow_after_m=\"9\" max_blind_m=\"{blind}\"/>",
      "<ReplayFeatureEdge edge=\"e1\" distance_scale=\"1.02\"/>",
      "<ReplayAvoiding crossing=\"kerb_m=1.2\" look=\"look_frames=0\"><ReplayFeatureEdge edge=\"e1\"/></ReplayAvoiding>",
      // ReplayPathAvoiding's defaults have the extent on: the share alone is fine there.
      "<ReplayPathAvoiding standing=\"min_face_share=0.5\"><ReplayFeatureEdge edge=\"e1\"/></ReplayPathAvoiding>",
      "<ReplayAvoiding corridor=\" lookahead_m = 3 ; confirm_views=4;\"><ReplayFeatureEdge edge=\"e1\"/></ReplayAvoiding>",
  };
  for (const std::string& leaf : good) {
    const auto problems = check(c, tree(leaf));
    EXPECT_TRUE(problems.empty()) << leaf << "\n" << dump(problems);
  }
}

// All problems are listed, not just the first; and `visnav run` (run_mission) stops on the very
// same list before it builds anything or ticks.
TEST_F(ValidateTest, ListsEveryProblemAndRunRefusesTheSame) {
  const std::string c = config("{world: " + (dir_ / "missing.yaml").string() + "}",
                               "{min_threshold: 50, max_threshold: 10, threshold: 20}");
  const std::string t = write("tree.xml",
                              "<root BTCPP_format=\"4\">\n"
                              "  <BehaviorTree ID=\"Main\">\n"
                              "    <Sequence>\n"
                              "      <Sleep msec=\"-5\"/>\n"
                              "      <ReplayFeatureEdge edge=\"e1\" speed_mps=\"9\"/>\n"
                              "    </Sequence>\n"
                              "  </BehaviorTree>\n"
                              "</root>\n");
  const auto problems = check(c, t);
  ASSERT_EQ(problems.size(), 4u) << dump(problems);
  std::vector<std::pair<ErrorCode, int>> got;
  for (const auto& p : problems) got.emplace_back(p.code, p.where.line);
  const std::vector<std::pair<ErrorCode, int>> want = {
      {ErrorCode::not_found, 3}, {ErrorCode::inconsistent, 7}, {ErrorCode::invalid_value, 4}, {ErrorCode::out_of_range, 5}};
  EXPECT_EQ(got, want) << dump(problems);

  visnav::MissionOptions m;
  m.config_file = c;
  m.tree_file = t;
  auto prepared = visnav::prepare_mission(m);
  ASSERT_FALSE(prepared.ok());
  EXPECT_EQ(prepared.error().code, ErrorCode::not_found);
  EXPECT_EQ(prepared.error().where, problems.front().where);
  const visnav::RunReport r = visnav::run_mission(m);
  EXPECT_EQ(r.outcome, visnav::RunOutcome::error);
  EXPECT_EQ(r.ticks, 0u);
  for (const auto& p : problems) EXPECT_NE(r.reason.find(p.message), std::string::npos) << r.reason;
}

// A route script written in the tree is opened and parsed before the first tick too.
TEST_F(ValidateTest, RouteFileLiteralIsOpenedAndParsed) {
  const std::string missing = tree("<ScriptedOperator route_file=\"" + (dir_ / "no_route.yaml").string() + "\"/>");
  auto problems = check(config(), missing);
  ASSERT_EQ(problems.size(), 1u) << dump(problems);
  EXPECT_EQ(problems[0].code, ErrorCode::not_found);
  EXPECT_EQ(problems[0].where, (ErrorLocation{missing, 3, "Main/ScriptedOperator[0]"}));

  const std::string route = write("route.yaml", "route: {name: r, waypoints: [ {at: [0, 0]\n");
  const std::string broken = tree("<ScriptedOperator route_file=\"" + route + "\"/>");
  problems = check(config(), broken);
  ASSERT_EQ(problems.size(), 1u) << dump(problems);
  EXPECT_EQ(problems[0].code, ErrorCode::parse_error);
  EXPECT_EQ(problems[0].where.line, 3);

  const std::string good = tree("<ScriptedOperator route_file=\"" +
                                (fs::path(VISNAV_TEST_SOURCE_DIR) / "config/routes/curve20m_polygon.yaml").string() + "\"/>");
  problems = check(config(), good);
  EXPECT_TRUE(problems.empty()) << dump(problems);
}

// `--bb key=value` values are checked by every port that reads {key}, as literals are: the
// common way to give a speed or a route file.
TEST_F(ValidateTest, BlackboardValuesAreCheckedByThePortsThatReadThem) {
  const std::string t = write("tree.xml",
                              "<root BTCPP_format=\"4\">\n"
                              "  <BehaviorTree ID=\"Main\">\n"
                              "    <Sequence>\n"
                              "      <ScriptedOperator route_file=\"{route_file}\"/>\n"
                              "      <ReplayFeatureEdge edge=\"e1\" speed_mps=\"{v}\"/>\n"
                              "    </Sequence>\n"
                              "  </BehaviorTree>\n"
                              "</root>\n");
  const std::string route = (fs::path(VISNAV_TEST_SOURCE_DIR) / "config/routes/curve20m_polygon.yaml").string();
  EXPECT_TRUE(check(config(), t, {}, {"route_file=" + route, "v=0.4"}).empty());
  EXPECT_TRUE(check(config(), t).empty());  // unset keys are the nodes' to check when they run

  auto problems = check(config(), t, {}, {"route_file=" + (dir_ / "none.yaml").string(), "v=9"});
  ASSERT_EQ(problems.size(), 2u) << dump(problems);
  EXPECT_EQ(problems[0].code, ErrorCode::not_found);
  EXPECT_EQ(problems[0].where, (ErrorLocation{t, 4, "Main/Sequence[0]/ScriptedOperator[0]"}));
  EXPECT_EQ(problems[1].code, ErrorCode::out_of_range);
  EXPECT_EQ(problems[1].where, (ErrorLocation{t, 5, "Main/Sequence[0]/ReplayFeatureEdge[1]"}));

  problems = check(config(), t, {}, {"v=fast", "novalue"});
  ASSERT_EQ(problems.size(), 2u) << dump(problems);
  EXPECT_EQ(problems[0].code, ErrorCode::invalid_value);
  EXPECT_EQ(problems[0].where, (ErrorLocation{"--bb", 0, "novalue"}));
  EXPECT_EQ(problems[1].code, ErrorCode::invalid_value);
  EXPECT_EQ(problems[1].where.line, 5);

  visnav::MissionOptions m;
  m.config_file = config();
  m.tree_file = t;
  m.blackboard_values = {"route_file=" + route, "v=9"};
  const visnav::RunReport r = visnav::run_mission(m);
  EXPECT_EQ(r.outcome, visnav::RunOutcome::error);
  EXPECT_EQ(r.ticks, 0u);
}

// `--port Node.port=value` (visnav run/validate): applied before validation, so a bad value is
// the literal's error at the node, a misspelt node or a malformed entry is a problem of its own.
TEST_F(ValidateTest, PortOverridesAreCheckedAsLiteralsAndNeverIgnored) {
  const std::string t = tree("<ReplayFeatureEdge edge=\"e1\" speed_mps=\"0.3\"/>");
  visnav::SetupCheck s;
  s.config_file = config();
  s.tree_file = t;
  s.port_overrides = {"ReplayFeatureEdge.speed_mps=0.5"};
  EXPECT_TRUE(visnav::check_setup(s).empty()) << dump(visnav::check_setup(s));
  s.port_overrides = {"ReplayFeatureEdge.speed_mps=9", "ReplayFeatureEge.speed_mps=1", "speed"};
  const auto problems = visnav::check_setup(s);
  ASSERT_EQ(problems.size(), 3u) << dump(problems);
  EXPECT_EQ(problems[0].code, ErrorCode::parse_error) << dump(problems);
  EXPECT_EQ(problems[0].where, (ErrorLocation{"--port", 0, "speed"}));
  const auto has = [&](ErrorCode code, const std::string& key) {
    return std::any_of(problems.begin(), problems.end(), [&](const Error& e) { return e.code == code && e.where.key == key; });
  };
  EXPECT_TRUE(has(ErrorCode::not_found, "ReplayFeatureEge.speed_mps")) << dump(problems);
  EXPECT_TRUE(has(ErrorCode::out_of_range, "Main/ReplayFeatureEdge[0]")) << dump(problems);

  visnav::MissionOptions m;
  m.config_file = config();
  m.tree_file = t;
  m.port_overrides = {"ReplayFeatureEdge.speed_mps=9"};
  const visnav::RunReport r = visnav::run_mission(m);
  EXPECT_EQ(r.outcome, visnav::RunOutcome::error);
  EXPECT_EQ(r.ticks, 0u);
}

// The camera mount keys of a file camera: a partial set is reported before the first tick with
// the missing key (camera_mount.hpp), and run refuses the same; the full set passes.
TEST_F(ValidateTest, PartialCameraMountNamesTheMissingKey) {
  const auto camera_config = [&](const std::string& mount) {
    return write("config.yaml",
                 "robot: {type: sim, params: {world: straight6m}}\n"          // 1
                 "camera:\n"                                                  // 2
                 "  type: image_folder\n"                                     // 3
                 "  params: {folder: " + dir_.string() + mount + "}\n"        // 4
                 "run: {tick: frame, rate_hz: 10, reload_poll_s: 0, max_duration_s: 2}\n");
  };
  const std::string c = camera_config(", hfov_deg: 70, mount_height_m: 0.4");
  const auto problems = check(c);
  ASSERT_EQ(problems.size(), 1u) << dump(problems);
  EXPECT_EQ(problems[0].code, ErrorCode::missing) << dump(problems);
  EXPECT_EQ(problems[0].where, (ErrorLocation{c, 4, "camera.params.mount_pitch_down_deg"})) << dump(problems);
  EXPECT_NE(problems[0].message.find("key 'mount_pitch_down_deg' in camera.params is missing"), std::string::npos)
      << problems[0].message;

  visnav::MissionOptions m;
  m.config_file = c;
  const visnav::RunReport r = visnav::run_mission(m);
  EXPECT_EQ(r.outcome, visnav::RunOutcome::error);
  EXPECT_EQ(r.ticks, 0u);
  EXPECT_NE(r.reason.find("mount_pitch_down_deg"), std::string::npos) << r.reason;

  const auto bad = check(camera_config(", hfov_deg: 70, mount_height_m: 0.4, mount_pitch_down_deg: 95"));
  ASSERT_EQ(bad.size(), 1u) << dump(bad);
  EXPECT_EQ(bad[0].code, ErrorCode::out_of_range);
  EXPECT_EQ(bad[0].where.key, "camera.params.mount_pitch_down_deg");

  const auto full = check(camera_config(", hfov_deg: 70, mount_height_m: 0.4, mount_pitch_down_deg: 10"));
  EXPECT_TRUE(full.empty()) << dump(full);
  EXPECT_TRUE(check(camera_config("")).empty());  // no mount keys: no mount, no problem
}

TEST_F(ValidateTest, MissingMapFolderIsNotFound) {
  const std::string missing = (dir_ / "no_map").string();
  const auto problems = check(config(), {}, missing);
  ASSERT_EQ(problems.size(), 1u) << dump(problems);
  EXPECT_EQ(problems[0].code, ErrorCode::not_found);
  EXPECT_EQ(problems[0].where.file, missing);
}

// The edge-progress hand-over (FollowRoute, the replay adapter, ReplayAvoiding) works only when
// every side names the same blackboard entries: every registered port whose default is an
// {edge_*} or {nav_*} entry names one of visnav/edge_progress.hpp's, and each of those entries
// has a writer and a reader among the shipped nodes.
TEST(EdgeProgress, EveryPortNamesAnEntryOfTheVocabularyAndEachHasAWriterAndAReader) {
  auto loader = visnav::PluginLoader::with_default_path({VISNAV_TEST_PLUGIN_DIR});
  ASSERT_TRUE(loader.scan());
  visnav::StderrLogger logger(visnav::LogLevel::error);
  visnav::WallClock clock;
  visnav::RuntimeHost host(loader, logger, clock);
  visnav::bt::NodeRegistry registry;
  ASSERT_TRUE(visnav::register_all_nodes(registry, loader, host, std::nullopt));
  const auto& all = visnav::edge_progress::all;
  std::vector<int> writers(all.size(), 0), readers(all.size(), 0);
  int progress_ports = 0;
  for (const visnav::bt::NodeManifest* m : registry.manifests()) {
    for (const visnav::bt::PortInfo& p : m->ports) {
      if (!p.default_value) continue;
      const std::string& d = *p.default_value;
      const auto it = std::find(all.begin(), all.end(), d);
      if (it == all.end()) {
        EXPECT_FALSE(d.rfind("{edge_", 0) == 0 || d.rfind("{nav_", 0) == 0)
            << m->id << "." << p.name << " defaults to " << d << ", not an entry of visnav/edge_progress.hpp";
        continue;
      }
      ++progress_ports;
      const auto i = static_cast<std::size_t>(it - all.begin());
      if (p.direction != visnav::bt::PortDirection::input) ++writers[i];
      if (p.direction != visnav::bt::PortDirection::output) ++readers[i];
    }
  }
  EXPECT_GE(progress_ports, 20);  // FollowRoute, every replay primitive, ReplayAvoiding
  for (std::size_t i = 0; i < all.size(); ++i) {
    EXPECT_GT(writers[i], 0) << all[i] << " has no writer";
    EXPECT_GT(readers[i], 0) << all[i] << " has no reader";
  }
}

TEST(MapPath, BareNamesLiveInMaps) {
  ::unsetenv("VISNAV_MAPS_DIR");
  EXPECT_EQ(visnav::resolve_map_path("demo"), "maps/demo");
  EXPECT_EQ(visnav::resolve_map_path("./demo"), "./demo");
  EXPECT_EQ(visnav::resolve_map_path("/tmp/m"), "/tmp/m");
  EXPECT_EQ(visnav::resolve_map_path("a/b"), "a/b");
  EXPECT_EQ(visnav::resolve_map_path(".."), "..");
  ::setenv("VISNAV_MAPS_DIR", "/srv/maps", 1);
  EXPECT_EQ(visnav::resolve_map_path("demo"), "/srv/maps/demo");
  ::unsetenv("VISNAV_MAPS_DIR");
}

// The Error model: codes and locations survive context, and the text stays complete.
TEST(ErrorCodes, CodeAndLocationTravelWithContext) {
  const Error e = visnav::fail(ErrorCode::out_of_range, {"c.yaml", 12, "speed_mps"}, "value 9 is out of range [0, 3]");
  EXPECT_EQ(e.message, "c.yaml:12: speed_mps: value 9 is out of range [0, 3]");
  const Error outer = e.with_context("robot 'sim'");
  EXPECT_EQ(outer.code, ErrorCode::out_of_range);
  EXPECT_EQ(outer.where, e.where);
  EXPECT_EQ(visnav::fail("plain").code, ErrorCode::unspecified);
  EXPECT_EQ(visnav::fail("plain").with_default_code(ErrorCode::io).code, ErrorCode::io);
  EXPECT_EQ(e.with_default_code(ErrorCode::io).code, ErrorCode::out_of_range);
  EXPECT_STREQ(visnav::to_string(ErrorCode::parse_error), "parse_error");
}

struct Pair {
  int lo = 1;
  int hi = 2;
  [[nodiscard]] visnav::Status validate() const { return lo <= hi ? visnav::ok() : visnav::fail("lo > hi"); }
  static const visnav::ParamSchema<Pair>& schema() {
    static const auto s = visnav::ParamSchema<Pair>{}.field("lo", &Pair::lo, "low").range(0, 10).field("hi", &Pair::hi, "high").range(0, 10);
    return s;
  }
};

TEST(ErrorCodes, ParamSchemaListsEveryKeyProblemWithItsCode) {
  visnav::ConfigNode node = visnav::ConfigNode::make_map({"p.yaml", 4});
  node.set("lo", visnav::ConfigNode::make_scalar("11", {"p.yaml", 5}));
  node.set("nope", visnav::ConfigNode::make_scalar("1", {"p.yaml", 6}));
  node.set("hi", visnav::ConfigNode::make_scalar("x", {"p.yaml", 7}));
  const auto problems = Pair::schema().problems(node);
  ASSERT_EQ(problems.size(), 3u);
  EXPECT_EQ(problems[0].code, ErrorCode::out_of_range);
  EXPECT_EQ(problems[0].where, (ErrorLocation{"p.yaml", 5, "lo"}));
  EXPECT_EQ(problems[1].code, ErrorCode::unknown_key);
  EXPECT_EQ(problems[1].where, (ErrorLocation{"p.yaml", 6, "nope"}));
  EXPECT_EQ(problems[2].code, ErrorCode::invalid_value);
  EXPECT_EQ(problems[2].where, (ErrorLocation{"p.yaml", 7, "hi"}));
  // parse() reports the first of them; with the keys fine, validate()'s verdict is `inconsistent`.
  EXPECT_EQ(Pair::schema().parse(node).error().where, problems[0].where);
  visnav::ConfigNode crossed = visnav::ConfigNode::make_map({"p.yaml", 4});
  crossed.set("lo", visnav::ConfigNode::make_scalar("5", {"p.yaml", 5}));
  crossed.set("hi", visnav::ConfigNode::make_scalar("3", {"p.yaml", 6}));
  const auto c = Pair::schema().problems(crossed);
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c[0].code, ErrorCode::inconsistent);
  EXPECT_EQ(c[0].where, (ErrorLocation{"p.yaml", 4, ""}));
}

}  // namespace
