// TeachVisualMemoryEdge / ReplayVisualMemoryEdge end to end: the real loader loads
// libvisnav_visual_memory.so, the runtime's primitive adapter makes the nodes, the sim robot and
// camera plugins (error models of config/sim_experiment.yaml on the odometry and the camera),
// lock-step at 10 Hz, the map store. Teach a 7 m visual_memory edge on straight15m, validate
// the map (the plugin's payload check), replay it alone and through PlanRoute + FollowRoute
// (the default kind mapping), and refuse a corrupt payload before moving.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "visnav/runner.hpp"

namespace fs = std::filesystem;
using namespace visnav;

namespace {

fs::path temp_dir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("visnav_visual_memory_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::unique_ptr<Session> make_session(const fs::path& dir, int seed) {
  const fs::path cfg = dir / "setup.yaml";
  std::ofstream(cfg) << "robot: {type: sim, params: {world: straight15m, seed: " << seed
                     << ", actuation_delay_s: 0.05, odom_scale_error_sd_pct: 3, odom_wheel_asymmetry_sd_pct: 0.2,"
                        " odom_heading_drift_sd_degpm: 0.05, odom_distance_noise_m_per_sqrt_m: 0.01,"
                        " odom_heading_noise_deg_per_sqrt_m: 0.5, slip_path_pct: 3, slip_grass_pct: 5}}\n"
                     << "camera: {type: sim, params: {width_px: 320, height_px: 240, noise_std: 3, seed: " << seed
                     << ", exposure_jitter: 0.06, motion_blur_exposure_s: 0.01, latency_s: 0.05, drop_probability: 0.03}}\n"
                     << "nodes: [navigation, visual_memory]\n"
                     << "run: {tick: frame, rate_hz: 10, lockstep: on, log_level: warn}\n";
  auto config = load_run_config(cfg.string(), {});
  EXPECT_TRUE(config.ok()) << (config.ok() ? "" : config.error().message);
  if (!config.ok()) return nullptr;
  SessionOptions so;
  so.map_path = (dir / "map").string();
  auto session = Session::create(std::move(*config), so);
  EXPECT_TRUE(session.ok()) << (session.ok() ? "" : session.error().message);
  return session.ok() ? std::move(*session) : nullptr;
}

Result<bt::Tree> tree_from(Session& s, const fs::path& dir, const std::string& body) {
  const fs::path file = dir / "tree.xml";
  std::ofstream(file) << "<root BTCPP_format=\"4\"><BehaviorTree ID=\"Main\">" << body << "</BehaviorTree></root>";
  return s.load_tree(file.string());
}

/// Teaches one visual_memory edge of `length_m` along y = 0 (steered on the ground truth).
std::string teach_edge(Session& session, const fs::path& dir, double length_m) {
  SimulationControl* sim = session.robot().simulation();
  auto teach = tree_from(session, dir, R"(<TeachVisualMemoryEdge edge_from="" edge_to="" finish="{finish}"/>)");
  EXPECT_TRUE(teach.ok()) << (teach.ok() ? "" : teach.error().message);
  if (!teach.ok()) return {};
  teach->blackboard().set("finish", false);
  RunOptions ro;
  ro.after_tick = [&](const TickInfo&) {
    const auto odom = session.robot().latest_odometry();
    const Pose2D p = sim->ground_truth_pose();
    if (odom && odom->distance_m >= length_m) {
      teach->blackboard().set("finish", true);
      (void)session.robot().stop();
    } else {
      (void)session.robot().send_command({0.3, -1.5 * p.heading_rad - 0.8 * p.y_m});
    }
    return true;
  };
  const RunReport report = run_tree(session, *teach, ro);
  EXPECT_EQ(report.outcome, RunOutcome::success) << report.reason;
  return session.map()->edges().empty() ? std::string() : session.map()->edges().back().id;
}

}  // namespace

TEST(VisualMemoryNodes, TeachesAnEdgeThenReplaysItFromAnOffsetStart) {
  const fs::path dir = temp_dir("teach_replay");
  auto session = make_session(dir, 11);
  ASSERT_TRUE(session);
  const std::string id = teach_edge(*session, dir, 7.0);
  ASSERT_FALSE(id.empty());
  MapStore& map = *session->map();
  const EdgeRecord edge = *map.find_edge(id);
  EXPECT_EQ(edge.kind, "visual_memory");
  EXPECT_NEAR(edge.length_m, 7.0, 0.1);
  EXPECT_GE(edge.statistics.at("references"), 5.0);
  EXPECT_GT(edge.statistics.at("points_3d_per_reference"), 20.0);
  EXPECT_TRUE(map.validate().empty());  // decodes through the plugin's payload check
  // one render mark per reference, in order along the edge
  int marks = 0;
  double last = -1.0;
  for (const auto& [key, d] : edge.statistics)
    if (key.rfind("mark.ref", 0) == 0) {
      ++marks;
      EXPECT_GT(d, last) << key;
      EXPECT_LE(d, edge.length_m + 1e-6) << key;
      last = d;
    }
  EXPECT_EQ(marks, static_cast<int>(edge.statistics.at("references")));
  std::printf("taught: %.0f references, %.0f 3D points per reference, %llu payload bytes (%.0f B/m)\n",
              edge.statistics.at("references"), edge.statistics.at("points_3d_per_reference"),
              static_cast<unsigned long long>(edge.payload_bytes), edge.payload_bytes / edge.length_m);

  SimulationControl* sim = session->robot().simulation();
  ASSERT_TRUE(sim->set_ground_truth_pose({0.0, 0.3, 0.0}).ok());
  auto replay = tree_from(*session, dir, "<ReplayVisualMemoryEdge edge=\"" + id + "\" controller=\"IJCU\"/>");
  ASSERT_TRUE(replay.ok()) << replay.error().message;
  const RunReport report = run_tree(*session, *replay);
  ASSERT_EQ(report.outcome, RunOutcome::success) << report.reason;
  const Pose2D end = sim->ground_truth_pose();
  std::printf("replay (IJCU) from +0.30 m: end at x %.2f m, lateral %+.3f m\n", end.x_m, end.y_m);
  EXPECT_NEAR(end.x_m, 7.0, 0.6);
  EXPECT_LT(std::abs(end.y_m), 0.3);

  // PlanRoute + FollowRoute map the kind to ReplayVisualMemoryEdge by default.
  ASSERT_TRUE(sim->set_ground_truth_pose({0.0, 0.0, 0.0}).ok());
  auto route = tree_from(*session, dir,
                         "<Sequence><PlanRoute start=\"" + edge.from + "\" goal=\"" + edge.to +
                             "\" kind_costs=\"visual_memory=1.2\"/><FollowRoute turn_at_nodes=\"false\">"
                             "<ReplayVisualMemoryEdge edge=\"{edge}\"/></FollowRoute></Sequence>");
  ASSERT_TRUE(route.ok()) << route.error().message;
  const RunReport routed = run_tree(*session, *route);
  EXPECT_EQ(routed.outcome, RunOutcome::success) << routed.reason;
  EXPECT_NEAR(sim->ground_truth_pose().x_m, 7.0, 0.6);
  fs::remove_all(dir);
}

TEST(VisualMemoryNodes, ACorruptPayloadOrAnUnknownControllerFailsBeforeMoving) {
  const fs::path dir = temp_dir("bad_payload");
  auto session = make_session(dir, 12);
  ASSERT_TRUE(session);
  MapStore& map = *session->map();
  NodeRecord n;
  n.name = "a";
  const std::string a = *map.add_node(n);
  EdgeRecord e;
  e.from = a;
  e.to = a;
  e.kind = "visual_memory";
  e.length_m = 3;
  const std::string corrupt = *map.add_edge(e, std::vector<std::uint8_t>(64, 0xAB));
  EXPECT_FALSE(map.validate().empty());
  SimulationControl* sim = session->robot().simulation();
  const Pose2D before = sim->ground_truth_pose();
  auto replay = tree_from(*session, dir, "<ReplayVisualMemoryEdge edge=\"" + corrupt + "\"/>");
  ASSERT_TRUE(replay.ok());
  const RunReport report = run_tree(*session, *replay);
  EXPECT_EQ(report.outcome, RunOutcome::failure);
  const Pose2D after = sim->ground_truth_pose();
  EXPECT_LT(std::hypot(after.x_m - before.x_m, after.y_m - before.y_m), 1e-6);
  // a literal port value outside its declared choices is refused when the tree is loaded
  EXPECT_FALSE(tree_from(*session, dir, "<ReplayVisualMemoryEdge edge=\"" + corrupt + "\" controller=\"PID\"/>").ok());
  fs::remove_all(dir);
}
