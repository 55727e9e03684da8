// An experiment that can fail and a replay that knows when it is lost (issue 12), closed loop
// through the real loader, plugins, trees and `visnav experiment` core, with the realistic
// error models of config/sim_experiment.yaml on: the 20 m rectangle of config/worlds/curve20m.yaml
// taught as feature segments, one replay loop per run.
//  * seeds: the same seed gives the identical run, another seed another run;
//  * the first edge no longer depends on the teach run's heading drift;
//  * each lost case (frozen camera, covered lens, kidnapping, a turn by an outside command,
//    large heading drift, a route replayed in the wrong world) and a collision stops the
//    replay with the right reason, the robot at rest, within a bounded distance.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>

#include "experiment.hpp"

namespace fs = std::filesystem;
using namespace visnav;
using namespace visnav::simop;

namespace {

ExperimentOptions rectangle(const std::string& name) {
  ExperimentOptions o;
  o.world = "curve20m";
  o.route = "curve20m_polygon";
  o.maps = {"feature"};
  o.seeds = 1;
  o.loops = 1;
  o.jobs = 1;
  o.displace_m = 0.3;
  o.displace_heading_deg = 5.0;
  o.progress = false;
  o.config = std::string(VISNAV_TEST_SOURCE_DIR) + "/config/sim_experiment.yaml";
  o.out = (fs::temp_directory_path() / ("visnav_lost_" + std::to_string(::getpid()) + "_" + name)).string();
  fs::remove_all(o.out);
  return o;
}

ExperimentRun run_single(const ExperimentOptions& o) {
  auto runs = run_experiment(o);
  EXPECT_TRUE(runs.ok()) << (runs ? "" : runs.error().message);
  if (!runs || runs->size() != 1) return {};
  const ExperimentRun r = runs->front();
  EXPECT_EQ(r.setup_error, "") << r.setup_error;
  std::error_code ec;
  fs::remove_all(o.out, ec);
  return r;
}

/// The replay stopped early for `reason` with the robot at rest, no farther than `max_m` driven.
void expect_stopped(const ExperimentRun& r, const std::string& reason, double max_m) {
  ASSERT_EQ(r.loops.size(), 1u);
  EXPECT_FALSE(r.loops[0].finished);
  EXPECT_FALSE(r.loops[0].completed);
  EXPECT_NE(r.stop_reason.find(reason), std::string::npos) << "stop reason: " << r.stop_reason;
  EXPECT_NE(r.loops[0].failure.find(reason), std::string::npos) << r.loops[0].failure;
  EXPECT_LE(r.replay_odometry_m, max_m) << r.stop_reason;
  // braking from 0.3 m/s at 1 m/s² after a 50 ms actuation delay rolls about 6 cm; more means
  // the robot was still being driven
  EXPECT_LT(r.coast_after_stop_m, 0.12) << "the robot must come to rest after the stop";
}

}  // namespace

TEST(HonestExperiment, SameSeedSameRunOtherSeedOtherRunAndTheLoopCompletes) {
  ExperimentOptions o = rectangle("seeds");
  const ExperimentRun a = run_single(o);
  const ExperimentRun a2 = run_single(o);
  o.first_seed = 2;
  const ExperimentRun b = run_single(o);
  ASSERT_EQ(a.loops.size(), 1u);
  ASSERT_EQ(b.loops.size(), 1u);
  // realistic errors on: the replay still closes the loop well inside the radius
  EXPECT_TRUE(a.loops[0].completed) << a.loops[0].failure;
  EXPECT_TRUE(b.loops[0].completed) << b.loops[0].failure;
  EXPECT_LT(a.loops[0].error_m, 0.5);
  EXPECT_EQ(a.loops[0].error_m, a2.loops[0].error_m);  // bit for bit
  EXPECT_EQ(a.teach_errors, a2.teach_errors);
  EXPECT_NE(a.loops[0].error_m, b.loops[0].error_m);
  EXPECT_NE(a.teach_errors, b.teach_errors);
  // teach and replay draw their own odometry errors: they do not cancel
  EXPECT_NE(a.teach_errors, a.replay_errors);
}

namespace {

/// Two loops replayed after a teach run with `drift_degpm` of odometric heading drift: both
/// complete within 0.5 m.
void expect_two_loops_despite_teach_drift(const std::string& name, double drift_degpm) {
  ExperimentOptions o = rectangle(name);
  o.teach_overrides = {"robot.params.odom_heading_drift_degpm=" + std::to_string(drift_degpm)};
  o.loops = 2;
  const ExperimentRun r = run_single(o);
  ASSERT_EQ(r.loops.size(), 2u);
  for (const auto& l : r.loops) {
    EXPECT_TRUE(l.completed) << "loop " << l.loop << ": " << l.failure;
    EXPECT_LT(l.error_m, 0.5) << "loop " << l.loop;
  }
}

}  // namespace

TEST(HonestExperiment, FirstEdgeDoesNotDependOnTheTeachRunsHeadingDrift) {
  // 0.5 deg/m while teaching: 10 deg of odometric heading error by the end of the 20 m loop.
  expect_two_loops_despite_teach_drift("drift", 0.5);
}

TEST(HonestExperiment, TheTurnIntoTheNextLapDoesNotDependOnTheTeachRunsHeadingDrift) {
  // 2 deg/m while teaching: the last edge's taught headings are 40 deg off the first edge's by
  // the end of the 20 m loop. The turn into lap 2 is the closing turn recorded when teaching.
  expect_two_loops_despite_teach_drift("lap_drift", 2.0);
}

TEST(LostDetection, FrozenCameraStops) {
  ExperimentOptions o = rectangle("frozen");
  o.replay_overrides = {"camera.params.freeze_probability=1"};
  const ExperimentRun r = run_single(o);
  expect_stopped(r, "camera frozen", 1.0);
  EXPECT_EQ(r.lost_stops, 1);
}

TEST(LostDetection, CoveredLensStops) {
  ExperimentOptions o = rectangle("covered");
  o.replay_overrides = {"camera.params.gain=0"};  // black frames with sensor noise
  const ExperimentRun r = run_single(o);
  expect_stopped(r, "lost", 6.5);  // the start-view search or the blind distance
}

TEST(LostDetection, KidnappedRobotStops) {
  ExperimentOptions o = rectangle("kidnapped");
  bool done = false;
  o.replay_hook = [&done](SimulationControl& sim, Robot&, double driven_m) {
    if (done || driven_m < 2.0) return;
    done = true;  // carried 1.5 m away and turned 150 deg (7 m of open courtyard ahead); odometry sees nothing
    Pose2D p = sim.ground_truth_pose();
    p.y_m += 1.5;
    p.heading_rad += 2.6;
    (void)sim.set_ground_truth_pose(p);
  };
  const ExperimentRun r = run_single(o);
  EXPECT_TRUE(done);
  // Carried next to the route and turned, the robot still sees parts of the same courtyard walls:
  // spurious partial matches keep it "seeing" now and then, so detection took 9 m (measured with
  // seed 1); the bound says it stops within one edge-and-a-half, never drives the loop on.
  expect_stopped(r, "lost", 2.0 + 12.0);
}

TEST(LostDetection, RobotTurnedByAnOutsideCommandStops) {
  ExperimentOptions o = rectangle("turned");
  double turn_started_s = -1.0;
  o.replay_hook = [&turn_started_s](SimulationControl& sim, Robot& robot, double driven_m) {
    if (driven_m < 1.5) return;
    if (turn_started_s < 0.0) turn_started_s = sim.time_s();
    // another participant commands a turn on the spot for 2.5 s (about 170 deg); the
    // mission's own command of this tick is overridden
    if (sim.time_s() - turn_started_s < 2.5) (void)robot.send_command(Twist{0.0, 1.2});
  };
  const ExperimentRun r = run_single(o);
  EXPECT_GE(turn_started_s, 0.0);
  expect_stopped(r, "lost", 1.5 + 6.5);
}

TEST(LostDetection, LargeHeadingDriftStops) {
  ExperimentOptions o = rectangle("drift_stop");
  o.replay_overrides = {"robot.params.odom_heading_drift_degpm=25"};
  const ExperimentRun r = run_single(o);
  expect_stopped(r, "lost", 20.0);
}

TEST(LostDetection, RouteReplayedInTheWrongWorldStops) {
  ExperimentOptions o = rectangle("wrong_world");
  o.replay_overrides = {"camera.params.world=straight6m"};
  const ExperimentRun r = run_single(o);
  // Spurious matches in the wrong world may count as seeing for a moment, and the start-view
  // scan turns the robot to wherever they are best: measured with seed 1, the first 6 m edge was
  // driven on such glimpses and the second stopped after 5 m blind (9.9 m). The bound: one edge
  // plus the blind distance, well short of the 20 m loop.
  expect_stopped(r, "lost", 6.2 + 5.0);
}

TEST(HonestExperiment, ACollisionFailsTheLoopAndSaysWhere) {
  ExperimentOptions o = rectangle("collision");
  // 1 m into the replay the robot is carried to 0.15 m in front of the south wall (y = -5.5)
  // and turned to face it: the mission drives on for the few frames the lost policy needs, and
  // the 0.25 m body touches the wall first.
  bool carried = false;
  o.replay_hook = [&carried](SimulationControl& sim, Robot&, double driven_m) {
    if (carried || driven_m < 1.0) return;
    carried = true;
    Pose2D p = sim.ground_truth_pose();
    p.y_m = -5.5 + 0.25 + 0.15;
    p.heading_rad = -std::numbers::pi / 2;
    (void)sim.set_ground_truth_pose(p);
  };
  const ExperimentRun r = run_single(o);
  EXPECT_TRUE(carried);
  ASSERT_EQ(r.loops.size(), 1u);
  EXPECT_FALSE(r.loops[0].completed);
  ASSERT_FALSE(r.collisions.empty());
  EXPECT_NE(r.collisions[0].obstacle.find("south"), std::string::npos) << r.collisions[0].obstacle;
  EXPECT_NE(r.stop_reason.find("collision with"), std::string::npos) << r.stop_reason;
}
