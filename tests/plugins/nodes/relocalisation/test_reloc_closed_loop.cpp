// Relocalisation and replay from the middle of a route in the simulator (issue 21), through the
// real loader and plugins (robot + camera sim, star_brief, feature_replay, navigation,
// sim_operator, path_following, relocalisation) with config/sim_reloc.yaml (3 % odometry scale
// error, lock-step at 10 Hz):
//  * curve20m: the 20 m rectangle taught as four feature_segment edges; the robot is then put
//    1.5 m into the second edge, 0.15 m off it and turned 15 deg, with no place index in the map:
//    trees/replay_from_here.xml builds the index on demand, relocalises onto the second edge,
//    turns to the taught heading and drives the rest of the route back to the start.
//    The same start with the lens covered (camera gain 0) is refused and the robot does not move.
//  * repetitive_loop: the same rectangle in a point-symmetric courtyard, where the first and the
//    third leg look alike: without a prior Relocalise answers ambiguous (never a guess), also
//    when it creeps forward (both ends advance alike); with the odometry prior of where the
//    robot stopped it answers the right leg. This map is taught with trees/teach_hybrid_route.xml,
//    which builds the place index at its end.
//  * visual_memory: the same rectangle taught as four visual_memory edges
//    (trees/teach_hybrid_visual_memory.xml, whose BuildPlaceIndex describes the reference images
//    with the config's detector); 1.5 m into the second leg, off it and turned,
//    trees/replay_from_here.xml (creeping 1 m) answers the second leg within 1 m and replays the
//    rest of it with ReplayVisualMemoryEdge to its end node; a prior on a
//    path_following edge is answered not_indexed without moving.
//  * BuildPlaceIndex as the teach trees use it (required="false") on a path-only map and on a
//    map of float descriptors: the teach never fails for want of an index.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "visnav/bt/node.hpp"
#include "visnav/bt/tree.hpp"
#include "visnav/feature_payloads.hpp"
#include "visnav/map.hpp"
#include "visnav/path_payload.hpp"
#include "visnav/relocalisation/place_index.hpp"
#include "visnav/runner.hpp"
#include "temp_folder.hpp"

namespace fs = std::filesystem;
using namespace visnav;

namespace {

const std::string kSource = VISNAV_TEST_SOURCE_DIR;

/// The suite's temporary folders (tests/support/temp_folder.hpp).
struct TempFolder : visnav::test::TempFolder {
  TempFolder() : visnav::test::TempFolder("visnav_reloc_loop") {}
};

std::unique_ptr<Session> make_session(const std::string& map_dir, const std::vector<std::string>& overrides) {
  auto config = load_run_config(kSource + "/config/sim_reloc.yaml", overrides);
  EXPECT_TRUE(config.ok()) << config.error().message;
  if (!config) return nullptr;
  SessionOptions options;
  options.use_default_plugin_path = false;
  options.extra_plugin_dirs = {VISNAV_TEST_PLUGIN_DIR};
  options.map_path = map_dir;
  options.overrides = overrides;
  auto session = Session::create(std::move(*config), options);
  EXPECT_TRUE(session.ok()) << session.error().message;
  if (!session) return nullptr;
  if (MapStore* map = (*session)->map()) map->set_sync(false);
  return std::move(*session);
}

/// Teaches `route` (four legs of kind `kind` of a closed rectangle) into `map_dir` with
/// trees/`teach_tree`.
/// `route` with a '/' is a route file path; `edges` the edges the teach must leave; an empty
/// `kind` keeps the route's own kinds; `closed` closes the loop at the start node.
void teach(const std::string& map_dir, const std::string& world, const std::string& route,
           const std::string& teach_tree = "teach_feature_edge.xml", const std::string& kind = "feature_segment",
           std::size_t edges = 4, bool closed = true) {
  auto session = make_session(map_dir, {"robot.params.world=" + world});
  ASSERT_NE(session, nullptr);
  auto tree = session->load_tree(kSource + "/trees/" + teach_tree);
  ASSERT_TRUE(tree.ok()) << tree.error().message;
  tree->blackboard().set("route_file", route.find('/') != std::string::npos
                                           ? route
                                           : kSource + "/config/routes/" + route + ".yaml");
  tree->blackboard().set("style", std::string("segment"));
  tree->blackboard().set("force_kind", kind);
  tree->blackboard().set("close_loop", closed);
  const RunReport report = run_tree(*session, *tree);
  ASSERT_EQ(report.outcome, RunOutcome::success) << report.reason;
  ASSERT_EQ(session->map()->edges().size(), edges);
  std::printf("teach %s: %.1f s wall\n", world.c_str(), report.wall_time_s);
}

std::string bb_string(bt::Tree& tree, const std::string& key) {
  auto v = tree.blackboard().get<std::string>(key);
  return v ? *v : std::string();
}

/// Runs a one-node Relocalise tree (attributes `attributes`) and returns the report.
RunReport relocalise_only(Session& session, const TempFolder& tmp, const std::string& attributes, bt::Tree** out_tree,
                          std::optional<bt::Tree>& holder) {
  const std::string xml = tmp.file("relocalise.xml");
  std::ofstream(xml) << R"(<root BTCPP_format="4" main_tree_to_execute="R"><BehaviorTree ID="R">
  <Relocalise )" << attributes << R"( edge="{reloc_edge}" distance_m="{reloc_distance_m}" status="{reloc_status}" reason="{reloc_reason}"/>
</BehaviorTree></root>)";
  auto tree = session.load_tree(xml);
  EXPECT_TRUE(tree.ok()) << tree.error().message;
  holder.emplace(std::move(*tree));
  *out_tree = &*holder;
  RunOptions run;
  run.after_tick = [](const TickInfo& t) { return t.t_s < 60.0; };
  return run_tree(session, *holder, run);
}

}  // namespace

TEST(RelocClosedLoopSim, ReplaysTheRestOfTheRouteFromTheMiddleOfAnEdge) {
  TempFolder tmp;
  const std::string map_dir = tmp.file("map");
  teach(map_dir, "curve20m", "curve20m_polygon");
  if (HasFatalFailure()) return;
  ASSERT_TRUE(fs::exists(map_dir + "/place_index.bin")) << "the teach tree builds the index";
  fs::remove(map_dir + "/place_index.bin");  // a map taught before the index existed: built on demand below
  std::string second_edge;
  {
    auto map = MapStore::open(map_dir);
    ASSERT_TRUE(map.ok());
    second_edge = map->edges()[1].id;
  }
  // 1.5 m into the second leg ((3, -2) -> (3, 2)), 0.15 m to its right, turned 15 deg left.
  auto session = make_session(map_dir, {"robot.params.start_pose=3.15;-0.5;105"});
  ASSERT_NE(session, nullptr);
  auto tree = session->load_tree(kSource + "/trees/replay_from_here.xml");
  ASSERT_TRUE(tree.ok()) << tree.error().message;
  tree->blackboard().set("goal", std::string("start"));
  SimulationControl* sim = session->robot().simulation();
  // The tree's Relocalise creeps 1 m forward before answering: the truth is where it answers.
  Pose2D at_answer{};
  tree->add_observer([&](double, const bt::TreeNode& node, bt::NodeStatus, bt::NodeStatus to) {
    if (node.registration_id() == "Relocalise" && to == bt::NodeStatus::success) at_answer = sim->ground_truth_pose();
  });
  RunOptions run;
  run.after_tick = [](const TickInfo& t) { return t.t_s < 300.0; };
  const RunReport report = run_tree(*session, *tree, run);
  EXPECT_EQ(report.outcome, RunOutcome::success) << report.reason << " / " << bb_string(*tree, "reloc_reason");
  const double truth_m = (at_answer.y_m + 2.0) * 1.03;  // the leg runs north from (3, -2); odometric metres
  EXPECT_GT(at_answer.y_m, -0.5 + 0.7) << "crept forward before answering";
  EXPECT_TRUE(fs::exists(map_dir + "/place_index.bin")) << "built on demand and kept in the map folder";
  EXPECT_EQ(bb_string(*tree, "reloc_edge"), second_edge) << bb_string(*tree, "reloc_reason");
  auto d = tree->blackboard().get<double>("reloc_distance_m");
  ASSERT_TRUE(d.ok());
  EXPECT_NEAR(*d, truth_m, 1.0) << "along-track error within 1 m (odometric map distances)";
  const Pose2D end = sim->ground_truth_pose();
  const double error_m = std::hypot(end.x_m + 3.0, end.y_m + 2.0);
  std::printf("relocalised on %s at %.2f m (truth ~%.2f m); replay ended at (%.2f, %.2f), %.2f m from the start, "
              "%.0f s simulated, %.1f s wall\n",
              bb_string(*tree, "reloc_edge").c_str(), *d, truth_m, end.x_m, end.y_m, error_m, report.run_time_s,
              report.wall_time_s);
  EXPECT_LT(error_m, 0.8) << "the rest of the route is driven to the start node";
  EXPECT_FALSE(fs::exists(map_dir + "/progress.yaml")) << "a finished route leaves no checkpoint to resume";
}

TEST(RelocClosedLoopSim, RelocalisesOnAPathEdgeByItsThumbnailsAndReplaysTheRestOfIt) {
  // straight15m's gravel path: a 4 m feature leg, then an 11 m path_following leg (thumbnails
  // every 0.5 m, the only places of that edge). The robot starts 6.5 m into the path leg, 0.15 m to
  // the side and turned 10 deg: replay_from_here.xml must place it on the path edge by the
  // thumbnails (two-pass search) and follow the path to the end of the route.
  TempFolder tmp;
  const std::string map_dir = tmp.file("map");
  const std::string route = tmp.file("straight_path.yaml");
  std::ofstream(route) << R"(route:
  name: straight_path
  world: straight15m
  start: [0, 0, 0]
  closed: false
  waypoints:
    - {at: [0, 0], kind: feature}
    - {at: [4, 0], kind: path}
    - {at: [15, 0]}
)";
  teach(map_dir, "straight15m", route, "teach_hybrid_route.xml", "", 2, false);
  if (HasFatalFailure()) return;
  std::string path_edge, goal;
  {
    auto map = MapStore::open(map_dir);
    ASSERT_TRUE(map.ok());
    ASSERT_EQ(map->edges()[1].kind, "path_following");
    path_edge = map->edges()[1].id;
    goal = map->edges()[1].to;
    auto index = reloc::load_place_index(map_dir);
    ASSERT_TRUE(index.ok()) << index.error().message;
    EXPECT_GE(index->thumbnail_places.size(), 20u) << "a thumbnail every 0.5 m of the 11 m path edge";
  }
  auto session = make_session(map_dir, {"robot.params.world=straight15m", "robot.params.start_pose=10.5;0.15;10"});
  ASSERT_NE(session, nullptr);
  auto tree = session->load_tree(kSource + "/trees/replay_from_here.xml");
  ASSERT_TRUE(tree.ok()) << tree.error().message;
  tree->blackboard().set("goal", goal);
  SimulationControl* sim = session->robot().simulation();
  Pose2D at_answer{};
  tree->add_observer([&](double, const bt::TreeNode& node, bt::NodeStatus, bt::NodeStatus to) {
    if (node.registration_id() == "Relocalise" && to == bt::NodeStatus::success) at_answer = sim->ground_truth_pose();
  });
  RunOptions run;
  run.after_tick = [](const TickInfo& t) { return t.t_s < 200.0; };
  const RunReport report = run_tree(*session, *tree, run);
  EXPECT_EQ(report.outcome, RunOutcome::success) << report.reason << " / " << bb_string(*tree, "reloc_reason");
  EXPECT_EQ(bb_string(*tree, "reloc_edge"), path_edge) << bb_string(*tree, "reloc_reason");
  auto d = tree->blackboard().get<double>("reloc_distance_m");
  ASSERT_TRUE(d.ok());
  const double truth_m = (at_answer.x_m - 4.0) * 1.03;  // odometric metres along the path leg
  EXPECT_NEAR(*d, truth_m, 1.0) << "along-track error within 1 m";
  const Pose2D end = sim->ground_truth_pose();
  const double error_m = std::hypot(end.x_m - 15.0, end.y_m);
  std::printf("path edge: relocalised at %.2f m (truth ~%.2f m); replay ended at (%.2f, %.2f), %.2f m from the "
              "route's end, %.0f s simulated, %.1f s wall\n",
              *d, truth_m, end.x_m, end.y_m, error_m, report.run_time_s, report.wall_time_s);
  EXPECT_LT(error_m, 1.0) << "the rest of the path edge is followed to the route's end";
}

TEST(RelocClosedLoopSim, ResumesAStoppedMissionFromItsCheckpointAfterRelocalising) {
  TempFolder tmp;
  const std::string map_dir = tmp.file("map");
  teach(map_dir, "curve20m", "curve20m_polygon");
  if (HasFatalFailure()) return;
  Pose2D stopped_at;
  {
    // 1 m into the first leg; the mission is stopped after 15 s (a pause turned into a restart,
    // or a crash: the checkpoint is all that survives).
    auto session = make_session(map_dir, {"robot.params.start_pose=-2;-2.1;5"});
    ASSERT_NE(session, nullptr);
    auto tree = session->load_tree(kSource + "/trees/replay_from_here.xml");
    ASSERT_TRUE(tree.ok()) << tree.error().message;
    tree->blackboard().set("goal", std::string("start"));
    RunOptions run;
    run.after_tick = [](const TickInfo& t) { return t.t_s < 15.0; };
    const RunReport report = run_tree(*session, *tree, run);
    EXPECT_NE(report.outcome, RunOutcome::success) << "stopped before the goal";
    stopped_at = session->robot().simulation()->ground_truth_pose();
  }
  ASSERT_TRUE(fs::exists(map_dir + "/progress.yaml"));
  auto values = progress_checkpoint_values(map_dir);
  ASSERT_TRUE(values.ok()) << values.error().message;
  std::string edge_entry;
  for (const auto& v : *values)
    if (v.rfind("resume_edge=", 0) == 0) edge_entry = v;
  EXPECT_FALSE(edge_entry.empty());
  EXPECT_NE(std::find(values->begin(), values->end(), "resume_goal=n0"), values->end());
  std::printf("stopped at (%.2f, %.2f); checkpoint: %s\n", stopped_at.x_m, stopped_at.y_m, edge_entry.c_str());

  // A new process: the robot stands where it stopped; resume_route.xml relocalises with the
  // checkpoint as prior, then drives on to the goal.
  char pose[96];
  std::snprintf(pose, sizeof pose, "robot.params.start_pose=%.4f;%.4f;%.3f", stopped_at.x_m, stopped_at.y_m,
                stopped_at.heading_rad * 180.0 / M_PI);
  auto session = make_session(map_dir, {pose});
  ASSERT_NE(session, nullptr);
  auto tree = session->load_tree(kSource + "/trees/resume_route.xml");
  ASSERT_TRUE(tree.ok()) << tree.error().message;
  ASSERT_TRUE(set_blackboard_values(*tree, *values).ok());
  RunOptions run;
  run.after_tick = [](const TickInfo& t) { return t.t_s < 300.0; };
  const RunReport report = run_tree(*session, *tree, run);
  EXPECT_EQ(report.outcome, RunOutcome::success) << report.reason << " / " << bb_string(*tree, "reloc_reason");
  const Pose2D end = session->robot().simulation()->ground_truth_pose();
  const double error_m = std::hypot(end.x_m + 3.0, end.y_m + 2.0);
  std::printf("resumed: %s; ended %.2f m from the start\n", bb_string(*tree, "reloc_reason").c_str(), error_m);
  EXPECT_LT(error_m, 0.8);
  EXPECT_FALSE(fs::exists(map_dir + "/progress.yaml"));

  // Nothing left to resume: a clear not_found error naming the file.
  auto none = progress_checkpoint_values(map_dir);
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().code, ErrorCode::not_found);
}

TEST(RelocClosedLoopSim, CoveredCameraAndRepetitiveLoopAreRefusedNotGuessed) {
  TempFolder tmp;
  const std::string map_dir = tmp.file("map");
  teach(map_dir, "repetitive_loop", "repetitive_loop", "teach_hybrid_route.xml");
  if (HasFatalFailure()) return;
  {
    // The shipped teach tree builds the place index at its end.
    auto map = MapStore::open(map_dir);
    ASSERT_TRUE(map.ok());
    auto index = reloc::load_place_index(map_dir);
    ASSERT_TRUE(index.ok()) << index.error().message;
    EXPECT_TRUE(index->matches(*map).ok());
    EXPECT_EQ(index->edges.size(), 4u);
  }
  const std::string creep = R"(creep_m="1" creep_unrecognised="1" min_answer_confidence="0.35")";
  std::string first_edge, third_edge;
  {
    auto map = MapStore::open(map_dir);
    ASSERT_TRUE(map.ok());
    first_edge = map->edges()[0].id;
    third_edge = map->edges()[2].id;
  }
  // 1.5 m into the first leg; the third leg, seen from (1.5, 2) heading west, looks the same.
  const std::vector<std::string> at = {"robot.params.world=repetitive_loop", "robot.params.start_pose=-1.5;-2;0"};
  {
    std::vector<std::string> covered = at;
    covered.push_back("camera.params.gain=0");
    auto session = make_session(map_dir, covered);
    ASSERT_NE(session, nullptr);
    const Pose2D before = session->robot().simulation()->ground_truth_pose();
    std::optional<bt::Tree> holder;
    bt::Tree* tree = nullptr;
    const RunReport report = relocalise_only(*session, tmp, creep, &tree, holder);
    EXPECT_EQ(report.outcome, RunOutcome::failure);
    EXPECT_EQ(bb_string(*tree, "reloc_status"), "camera_blocked") << bb_string(*tree, "reloc_reason");
    const Pose2D after = session->robot().simulation()->ground_truth_pose();
    EXPECT_LT(std::hypot(after.x_m - before.x_m, after.y_m - before.y_m), 0.01)
        << "a blocked camera never creeps, even when asked to";
  }
  {
    // Creeping does not separate the two ends of a point-symmetric loop: they advance alike.
    auto session = make_session(map_dir, at);
    ASSERT_NE(session, nullptr);
    std::optional<bt::Tree> holder;
    bt::Tree* tree = nullptr;
    const RunReport report = relocalise_only(*session, tmp, creep, &tree, holder);
    std::printf("no prior, creeping: %s: %s\n", bb_string(*tree, "reloc_status").c_str(),
                bb_string(*tree, "reloc_reason").c_str());
    EXPECT_EQ(report.outcome, RunOutcome::failure);
    EXPECT_EQ(bb_string(*tree, "reloc_status"), "ambiguous") << bb_string(*tree, "reloc_reason");
  }
  {
    auto session = make_session(map_dir, at);
    ASSERT_NE(session, nullptr);
    std::optional<bt::Tree> holder;
    bt::Tree* tree = nullptr;
    const RunReport report = relocalise_only(*session, tmp, "", &tree, holder);
    std::printf("no prior: %s: %s\n", bb_string(*tree, "reloc_status").c_str(), bb_string(*tree, "reloc_reason").c_str());
    EXPECT_EQ(report.outcome, RunOutcome::failure);
    EXPECT_EQ(bb_string(*tree, "reloc_status"), "ambiguous") << bb_string(*tree, "reloc_reason");
  }
  {
    auto session = make_session(map_dir, at);
    ASSERT_NE(session, nullptr);
    std::optional<bt::Tree> holder;
    bt::Tree* tree = nullptr;
    const RunReport report = relocalise_only(
        *session, tmp, "prior_edge=\"" + first_edge + "\" prior_distance_m=\"1.2\" prior_sigma_m=\"2\"", &tree, holder);
    std::printf("with prior: %s: %s\n", bb_string(*tree, "reloc_status").c_str(), bb_string(*tree, "reloc_reason").c_str());
    EXPECT_EQ(report.outcome, RunOutcome::success);
    EXPECT_EQ(bb_string(*tree, "reloc_edge"), first_edge);
    auto d = tree->blackboard().get<double>("reloc_distance_m");
    ASSERT_TRUE(d.ok());
    EXPECT_NEAR(*d, 1.5 * 1.03, 1.0);
  }
}

TEST(RelocClosedLoopSim, RelocalisesOnAVisualMemoryEdgeAndRefusesAPriorOnAnUnindexedKind) {
  TempFolder tmp;
  const std::string map_dir = tmp.file("map");
  teach(map_dir, "curve20m", "curve20m_polygon", "teach_hybrid_visual_memory.xml", "visual_memory");
  if (HasFatalFailure()) return;
  std::string second_edge;
  std::string second_to;
  {
    auto map = MapStore::open(map_dir);
    ASSERT_TRUE(map.ok());
    second_edge = map->edges()[1].id;
    second_to = map->edges()[1].to;
    EXPECT_EQ(map->edges()[1].kind, "visual_memory");
    auto index = reloc::load_place_index(map_dir);
    ASSERT_TRUE(index.ok()) << "the teach tree indexes the reference images: " << index.error().message;
    EXPECT_TRUE(index->matches(*map).ok());
    EXPECT_EQ(index->edges.size(), 4u);
    EXPECT_GE(index->places.size(), 8u) << "a place per reference image";
  }
  {
    // 1.5 m into the second leg ((3, -2) -> (3, 2)), 0.15 m to its right, turned 15 deg left:
    // replay_from_here.xml relocalises (creeping 1 m) and replays the rest of the leg to its end
    // node with ReplayVisualMemoryEdge (FollowRoute fails on a visual_memory edge without it).
    auto session = make_session(map_dir, {"robot.params.start_pose=3.15;-0.5;105"});
    ASSERT_NE(session, nullptr);
    SimulationControl* sim = session->robot().simulation();
    auto tree = session->load_tree(kSource + "/trees/replay_from_here.xml");
    ASSERT_TRUE(tree.ok()) << tree.error().message;
    tree->blackboard().set("goal", second_to);
    Pose2D at{};
    tree->add_observer([&](double, const bt::TreeNode& node, bt::NodeStatus, bt::NodeStatus to) {
      if (node.registration_id() == "Relocalise" && to == bt::NodeStatus::success) at = sim->ground_truth_pose();
    });
    RunOptions run;
    run.after_tick = [](const TickInfo& t) { return t.t_s < 120.0; };
    const RunReport report = run_tree(*session, *tree, run);
    const double truth_m = (at.y_m + 2.0) * 1.03;  // odometric metres along the leg
    const Pose2D end = sim->ground_truth_pose();
    const double error_m = std::hypot(end.x_m - 3.0, end.y_m - 2.0);
    std::printf("visual memory: %s: %s (truth ~%.2f m); replay ended at (%.2f, %.2f), %.2f m from the leg's end\n",
                bb_string(*tree, "reloc_status").c_str(), bb_string(*tree, "reloc_reason").c_str(), truth_m, end.x_m,
                end.y_m, error_m);
    EXPECT_EQ(report.outcome, RunOutcome::success) << report.reason << " / " << bb_string(*tree, "reloc_reason");
    EXPECT_EQ(bb_string(*tree, "reloc_edge"), second_edge) << bb_string(*tree, "reloc_reason");
    auto d = tree->blackboard().get<double>("reloc_distance_m");
    ASSERT_TRUE(d.ok());
    EXPECT_NEAR(*d, truth_m, 1.0);
    EXPECT_LT(error_m, 0.8) << "the rest of the visual_memory leg is replayed to its end node";
  }
  {
    // A path_following edge taught before thumbnails (VPF1: colour models only) added to the map:
    // the index rebuilt (the stale one is refused) lists it without places, and a prior on it is
    // answered not_indexed at once.
    std::string path_edge;
    {
      auto map = MapStore::open(map_dir);
      ASSERT_TRUE(map.ok());
      EdgeRecord e;
      e.from = map->edges()[0].from;
      e.to = map->edges()[0].to;
      e.kind = "path_following";
      e.length_m = 4.0;
      PayloadWriter w;  // the VPF1 layout: magic, model count, 12 doubles per model
      w.put<std::uint32_t>(path_payload::kMagicV1);
      w.put<std::uint32_t>(1);
      for (int i = 0; i < 12; ++i) w.put<double>(i == 3 || i == 7 || i == 11 ? 4.0 : 1.0);
      auto id = map->add_edge(e, w.take());
      ASSERT_TRUE(id.ok()) << id.error().message;
      path_edge = *id;
    }
    auto session = make_session(map_dir, {"robot.params.start_pose=3.15;-0.5;105"});
    ASSERT_NE(session, nullptr);
    SimulationControl* sim = session->robot().simulation();
    const Pose2D before = sim->ground_truth_pose();
    std::optional<bt::Tree> holder;
    bt::Tree* tree = nullptr;
    const RunReport stale = relocalise_only(*session, tmp, "creep_m=\"1\"", &tree, holder);
    EXPECT_EQ(stale.outcome, RunOutcome::failure);
    EXPECT_NE(bb_string(*tree, "reloc_reason").find("stale place index"), std::string::npos)
        << bb_string(*tree, "reloc_reason");
    {
      const std::string xml = tmp.file("rebuild.xml");
      std::ofstream(xml) << R"(<root BTCPP_format="4" main_tree_to_execute="B"><BehaviorTree ID="B">
  <BuildPlaceIndex only_if_missing="true"/>
</BehaviorTree></root>)";
      auto rebuild = session->load_tree(xml);
      ASSERT_TRUE(rebuild.ok()) << rebuild.error().message;
      ASSERT_EQ(run_tree(*session, *rebuild).outcome, RunOutcome::success);
      auto index = reloc::load_place_index(map_dir);
      ASSERT_TRUE(index.ok()) << index.error().message;
      EXPECT_EQ(index->edges.size(), 5u);
      EXPECT_TRUE(index->thumbnail_places.empty());
    }
    const RunReport report = relocalise_only(
        *session, tmp, "creep_m=\"1\" prior_edge=\"" + path_edge + "\" prior_sigma_m=\"2\"", &tree, holder);
    EXPECT_EQ(report.outcome, RunOutcome::failure);
    EXPECT_EQ(bb_string(*tree, "reloc_status"), "not_indexed") << bb_string(*tree, "reloc_reason");
    const Pose2D after = sim->ground_truth_pose();
    EXPECT_LT(std::hypot(after.x_m - before.x_m, after.y_m - before.y_m), 0.01) << "answered before moving";
  }
}

TEST(RelocClosedLoopSim, BuildPlaceIndexAtTheEndOfATeachNeverLosesTheTaughtMap) {
  // The shipped teach trees end with <BuildPlaceIndex required="false"/>: a map with nothing to
  // index succeeds without an index, a map that cannot be indexed (float descriptors) fails only
  // when the index is required.
  TempFolder tmp;
  const std::string map_dir = tmp.file("map");
  auto node = [](const std::string& name) {
    NodeRecord n;
    n.name = name;
    return n;
  };
  auto edge = [](const std::string& from, const std::string& to, const std::string& kind, double length_m) {
    EdgeRecord e;
    e.from = from;
    e.to = to;
    e.kind = kind;
    e.length_m = length_m;
    return e;
  };
  std::string a, b;
  {
    auto map = MapStore::create(map_dir, "path only");
    ASSERT_TRUE(map.ok()) << map.error().message;
    auto na = map->add_node(node("a"));
    auto nb = map->add_node(node("b"));
    ASSERT_TRUE(na.ok() && nb.ok());
    a = *na;
    b = *nb;
    ASSERT_TRUE(map->add_edge(edge(a, b, "path_following", 3.0), path_payload::PathPayload{}.encode()).ok());
  }
  auto tick_once = [&](const std::string& attributes) {
    auto session = make_session(map_dir, {});
    EXPECT_NE(session, nullptr);
    if (!session) return RunOutcome::failure;
    const std::string xml = tmp.file("build.xml");
    std::ofstream(xml) << R"(<root BTCPP_format="4" main_tree_to_execute="B"><BehaviorTree ID="B">
  <BuildPlaceIndex )" << attributes << R"(/>
</BehaviorTree></root>)";
    auto tree = session->load_tree(xml);
    EXPECT_TRUE(tree.ok()) << tree.error().message;
    if (!tree) return RunOutcome::failure;
    return run_tree(*session, *tree).outcome;
  };
  EXPECT_EQ(tick_once(""), RunOutcome::success) << "nothing to index is not an error";
  EXPECT_FALSE(fs::exists(map_dir + "/place_index.bin"));

  {
    auto map = MapStore::open(map_dir);
    ASSERT_TRUE(map.ok()) << map.error().message;
    feature_replay::LocalMapPath path;
    feature_replay::LocalMap m;
    m.descriptors = cv::Mat::ones(300, 16, CV_32FC1);
    m.positions_px.assign(300, cv::Point2f(5.f, 5.f));
    path.maps.push_back(m);
    ASSERT_TRUE(map->add_edge(edge(b, a, "feature_localmaps", 0.0), path.serialize()).ok());
  }
  EXPECT_EQ(tick_once(""), RunOutcome::failure) << "float descriptors cannot be indexed";
  EXPECT_EQ(tick_once(R"(required="false")"), RunOutcome::success) << "a warning at the end of a teach";
  EXPECT_FALSE(fs::exists(map_dir + "/place_index.bin"));
}
