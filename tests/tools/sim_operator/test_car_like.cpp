// Car-like teach and replay (issue 19, platform table): the 20 m rectangle of
// config/worlds/curve20m.yaml taught and replayed by a robot with the simulator's car_like
// kinematics (|w| <= |v| / 1 m), closed loop through the real loader, plugins, trees and the
// experiment core with the realistic error models on. Before the operator and FollowRoute drove
// arcs, the teach stalled at the first corner.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "experiment.hpp"
#include "visnav/map.hpp"

namespace fs = std::filesystem;
using namespace visnav;
using namespace visnav::simop;

TEST(CarLike, TeachesTheRectangleOnArcsAndTheReplayConvergesWithoutTurningOnTheSpot) {
  ExperimentOptions o;
  o.world = "curve20m";
  o.route = "curve20m_polygon";
  o.maps = {"feature"};
  o.seeds = 1;
  o.loops = 2;
  o.jobs = 1;
  o.progress = false;
  o.overrides = {"robot.params.kinematics=car_like", "robot.params.min_turning_radius_m=1"};
  o.config = std::string(VISNAV_TEST_SOURCE_DIR) + "/config/sim_experiment.yaml";
  o.out = (fs::temp_directory_path() / ("visnav_carlike_" + std::to_string(::getpid()))).string();
  fs::remove_all(o.out);
  // The replay's true motion: the robot never turns where it stands.
  Pose2D last{};
  bool have_last = false;
  int turned_in_place = 0;
  o.replay_hook = [&](SimulationControl& sim, Robot&, double) {
    const Pose2D p = sim.ground_truth_pose();
    if (have_last && std::hypot(p.x_m - last.x_m, p.y_m - last.y_m) < 1e-6 &&
        std::abs(std::remainder(p.heading_rad - last.heading_rad, 2.0 * M_PI)) > 1e-4)
      ++turned_in_place;
    last = p;
    have_last = true;
  };
  auto runs = run_experiment(o);
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  ASSERT_EQ(runs->size(), 1u);
  const ExperimentRun& r = runs->front();
  ASSERT_EQ(r.setup_error, "") << r.setup_error;
  EXPECT_EQ(turned_in_place, 0);
  // One node per corner: the four legs became four edges, each shorter than its leg by the two
  // 1 m corner arcs (the first by the closing arc's 1 m and the next corner's), ~2 m and ~4 m.
  auto map = MapStore::open(o.out + "/feature/seed1/map");
  ASSERT_TRUE(map.ok()) << map.error().message;
  ASSERT_EQ(map->edges().size(), 4u);
  for (const EdgeRecord& e : map->edges()) {
    EXPECT_TRUE(std::abs(e.length_m - 4.0) < 0.4 || std::abs(e.length_m - 2.0) < 0.4) << e.id << " " << e.length_m;
  }
  // Both loops completed, and the 1 m + 10 deg start error shrank.
  ASSERT_EQ(r.loops.size(), 2u);
  for (const auto& l : r.loops) EXPECT_TRUE(l.completed) << "loop " << l.loop << ": " << l.failure;
  EXPECT_LT(r.loops[1].error_m, 0.5);
  fs::remove_all(o.out);
}
