// Moving obstacles in the simulator (issue 16): a walking person moves along its polyline at its
// speed, renders and labels where it is at the frame's time, collides with the robot's body;
// obstacle files placed per run; bad specs name their key and line.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "error_expect.hpp"
#include "visnav/ipt_obstacles/crossing_policy.hpp"
#include "visnav/ipt_obstacles/motion_watch.hpp"
#include "visnav_sim/camera.hpp"
#include "visnav_sim/movers.hpp"
#include "visnav_sim/render.hpp"
#include "visnav_sim/robot.hpp"
#include "visnav_sim/world.hpp"

namespace visnav::sim {
namespace {

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;

// A person walks from 4 m left of the robot's line to 4 m right of it, 3 m ahead, at 1 m/s,
// starting at t = 2 s.
constexpr const char* kWorld = R"(world:
  textures:
    grass: {procedural: noise, color: [90, 130, 60], size_m: 2.0}
    cloth: {procedural: planks, color: [60, 40, 150], color2: [30, 20, 80], size_m: 1.0, cell_m: 0.1, grout_m: 0.02}
  default_ground: {texture: grass, class: grass}
  obstacles:
    - {name: walker, kind: person, at: [3, 4], path: [[3, -4]], speed_mps: 1.0, start_s: 2, texture: cloth}
)";

std::shared_ptr<const World> world_or_die(const std::string& text) {
  auto w = parse_world(text, "inline.yaml", ".");
  EXPECT_TRUE(w.ok()) << (w.ok() ? "" : w.error().message);
  return w.ok() ? *w : nullptr;
}

TEST(MovingObstacles, PositionFollowsThePolylineAtTheSpeed) {
  MovingObstacle m;
  m.path = {{0, 0}, {2, 0}, {2, 1}};  // 3 m
  m.speed_mps = 0.5;
  m.start_s = 1.0;
  EXPECT_EQ(m.position_at(0.0), cv::Point2d(0, 0));  // waits for start_s
  EXPECT_NEAR(cv::norm(m.position_at(3.0) - cv::Point2d(1, 0)), 0.0, 1e-12);
  EXPECT_NEAR(cv::norm(m.position_at(6.0) - cv::Point2d(2, 0.5)), 0.0, 1e-12);
  EXPECT_NEAR(cv::norm(m.position_at(100.0) - cv::Point2d(2, 1)), 0.0, 1e-12);  // once: stays at the end
  m.motion = MovingObstacle::Motion::back_and_forth;
  EXPECT_NEAR(cv::norm(m.position_at(1.0 + 8.0) - cv::Point2d(2, 0)), 0.0, 1e-12);  // 4 m: 1 m back from the end
  EXPECT_NEAR(cv::norm(m.position_at(1.0 + 12.0) - cv::Point2d(0, 0)), 0.0, 1e-12);  // 6 m: at the start again
  m.motion = MovingObstacle::Motion::loop;  // closed: 3 m + sqrt(5) back to the start
  const double lap_s = (3.0 + std::sqrt(5.0)) / 0.5;
  EXPECT_NEAR(cv::norm(m.position_at(1.0 + lap_s + 2.0) - cv::Point2d(1, 0)), 0.0, 1e-9);
  EXPECT_NEAR(cv::norm(m.position_at(1.0 + 6.0 + std::sqrt(5.0)) - cv::Point2d(1, 0.5)), 0.0, 1e-9);
}

TEST(MovingObstacles, APauseStandsAtEveryWaypoint) {
  MovingObstacle m;
  m.path = {{0, 0}, {2, 0}, {2, 1}};  // legs of 2 m and 1 m
  m.speed_mps = 1.0;
  m.start_s = 1.0;
  m.pause_s = 3.0;
  EXPECT_NEAR(cv::norm(m.position_at(2.0) - cv::Point2d(1, 0)), 0.0, 1e-12);
  EXPECT_NEAR(cv::norm(m.position_at(3.5) - cv::Point2d(2, 0)), 0.0, 1e-12);   // standing at the turn
  EXPECT_NEAR(cv::norm(m.position_at(5.9) - cv::Point2d(2, 0)), 0.0, 1e-12);
  EXPECT_NEAR(cv::norm(m.position_at(6.5) - cv::Point2d(2, 0.5)), 0.0, 1e-12);  // walks on after 3 s
  EXPECT_NEAR(cv::norm(m.position_at(100.0) - cv::Point2d(2, 1)), 0.0, 1e-12);  // once: stays at the end
  m.motion = MovingObstacle::Motion::back_and_forth;  // a cycle: 2 + 1 + 1 + 2 m and 4 pauses = 18 s
  EXPECT_NEAR(cv::norm(m.position_at(1.0 + 8.0) - cv::Point2d(2, 1)), 0.0, 1e-12);  // standing at the far end
  EXPECT_NEAR(cv::norm(m.position_at(1.0 + 9.5) - cv::Point2d(2, 0.5)), 0.0, 1e-12);
  EXPECT_NEAR(cv::norm(m.position_at(1.0 + 18.0 + 1.0) - cv::Point2d(1, 0)), 0.0, 1e-9);  // the next cycle
  m.motion = MovingObstacle::Motion::loop;  // 2 + 1 + sqrt(5) m and 3 pauses
  const double lap_s = 3.0 + std::sqrt(5.0) + 9.0;
  EXPECT_NEAR(cv::norm(m.position_at(1.0 + lap_s + 0.5) - cv::Point2d(0.5, 0)), 0.0, 1e-9);
  EXPECT_NEAR(cv::norm(m.position_at(1.0 + lap_s - 1.0) - cv::Point2d(0, 0)), 0.0, 1e-9);  // standing at the start
  m.pause_s = 0.0;  // without pauses as before
  EXPECT_NEAR(m.walked_at(11.0), 10.0, 1e-12);
}

TEST(MovingObstacles, PersonWallsMoveWithTime) {
  auto world = world_or_die(kWorld);
  ASSERT_NE(world, nullptr);
  ASSERT_EQ(world->movers.size(), 1u);
  ASSERT_EQ(world->walls.size(), 8u);  // person: 8 faces
  for (const auto& w : world->walls) {
    EXPECT_EQ(w.mover, 0);
    EXPECT_EQ(w.label, LabelClass::obstacle);
    EXPECT_NEAR(w.top_m, 1.75, 1e-12);
    EXPECT_NEAR(cv::norm(w.from - cv::Point2d(3, 4)), 0.25, 1e-12);
  }
  EXPECT_EQ(world->wall_offset(world->walls[0], 0.0), cv::Point2d(0, 0));
  EXPECT_NEAR(cv::norm(world->wall_offset(world->walls[0], 6.0) - cv::Point2d(0, -4)), 0.0, 1e-12);
}

TEST(MovingObstacles, RenderedAndLabelledWhereItIsAtTheFrameTime) {
  auto world = world_or_die(kWorld);
  ASSERT_NE(world, nullptr);
  CameraModel model;  // 320x240, 60 deg
  Renderer renderer(world, model);
  cv::Mat bgr, labels, mask;
  auto centre_obstacle_px = [&](double t) {
    renderer.render({0.0, 0.0, 0.0}, bgr, &labels, nullptr, t);
    label_mask(labels, LabelClass::obstacle, mask);
    return std::pair{cv::countNonZero(mask(cv::Rect(120, 0, 80, 240))), cv::countNonZero(mask)};
  };
  const auto [centre_0, all_0] = centre_obstacle_px(0.0);  // 4 m to the left: outside the 60 deg view
  EXPECT_EQ(all_0, 0);
  EXPECT_EQ(centre_0, 0);
  const auto [centre_6, all_6] = centre_obstacle_px(6.0);  // straight ahead at 3 m
  EXPECT_GT(centre_6, 1500);                                 // 0.5 m x 1.75 m at 3 m: ~46 x 160 px
  EXPECT_EQ(centre_6, all_6);
  const auto [centre_5, all_5] = centre_obstacle_px(5.0);  // 1 m left of the line
  EXPECT_GT(all_5, 1500);
  EXPECT_LT(centre_5, all_5 / 4);
}

TEST(MovingObstacles, CollisionWithAStandingRobotIsRecorded) {
  auto world = world_or_die(kWorld);
  ASSERT_NE(world, nullptr);
  RobotParams p;
  p.body_radius_m = 0.25;
  RobotCore on_the_line(p, Pose2D{3.0, 0.0, 0.0}, world);   // where the person walks through
  RobotCore clear(p, Pose2D{3.8, 0.0, 0.0}, world);          // 0.8 m from the person's line: > 0.5 m
  for (int i = 0; i < 100; ++i) {
    ASSERT_TRUE(on_the_line.step(0.1).ok());
    ASSERT_TRUE(clear.step(0.1).ok());
  }
  const auto hits = on_the_line.collisions();
  ASSERT_EQ(hits.size(), 1u);  // one contact while it walks through the disc
  EXPECT_EQ(hits[0].obstacle, "walker");
  EXPECT_NEAR(hits[0].time_s, 2.0 + 3.5, 0.15);  // its disc (0.25) meets ours (0.25) 0.5 m before the centre
  EXPECT_TRUE(clear.collisions().empty());
  // Driving into a person standing still (before start_s) stops the robot like a wall.
  RobotCore driving(p, Pose2D{3.0, 2.5, CV_PI / 2}, world);  // 1.5 m south of the person, facing it
  for (int i = 0; i < 15; ++i) {
    driving.command(Twist{1.0, 0.0});
    ASSERT_TRUE(driving.step(0.1).ok());
  }
  ASSERT_EQ(driving.collisions().size(), 1u);
  EXPECT_LT(driving.ground_truth().y_m, 4.0 - 0.5 + 1e-6);
}

// A yielding walker (yield_m) stands while the robot's body is on its way within that gap, and
// the sim camera draws it where the collision check has it.
TEST(MovingObstacles, YieldingWalkerStopsBeforeAStandingRobotAndTheCameraShowsIt) {
  std::string yielding_text = kWorld;
  const std::string from = "start_s: 2, texture: cloth}";
  yielding_text.replace(yielding_text.find(from), from.size(), "start_s: 2, yield_m: 0.6, texture: cloth}");
  auto yielding = world_or_die(yielding_text);
  auto blind = world_or_die(kWorld);
  ASSERT_NE(yielding, nullptr);
  ASSERT_NE(blind, nullptr);
  ASSERT_EQ(yielding->movers.size(), 1u);
  EXPECT_DOUBLE_EQ(yielding->movers[0].yield_m, 0.6);
  EXPECT_NEAR(yielding->movers[0].radius_m, 0.25, 1e-9);
  RobotParams p;
  p.body_radius_m = 0.25;
  // The robot stands on the walker's line 1 m south of the middle, facing north (towards it).
  const Pose2D on_its_way{3.0, -1.0, CV_PI / 2};
  auto run = [&](const std::shared_ptr<const World>& world, std::vector<double>* walker_y) {
    auto robot = std::make_shared<RobotCore>(p, on_its_way, world);
    CameraParams cp;
    CameraCore camera(cp, robot, world);
    int centre_px = 0;
    for (int i = 0; i < 100; ++i) {  // 10 s
      EXPECT_TRUE(robot->step(0.1).ok());
      if (walker_y != nullptr) walker_y->push_back(robot->mover_offset(world.get(), 0, robot->time_s()).y + 4.0);
    }
    if (camera.grab()) {
      cv::Mat labels, mask;
      camera.last_labels(labels);
      label_mask(labels, LabelClass::obstacle, mask);
      centre_px = cv::countNonZero(mask(cv::Rect(mask.cols / 2 - 40, 0, 80, mask.rows)));
    }
    return std::pair{robot->collisions().size(), centre_px};
  };
  std::vector<double> first, second;
  const auto [yield_hits, yield_px] = run(yielding, &first);
  const auto [blind_hits, blind_px] = run(blind, nullptr);
  EXPECT_EQ(yield_hits, 0u);
  EXPECT_EQ(blind_hits, 1u);  // the blind walker walks into it
  // It stopped with its body 0.6 m before the robot's: centre y = -1 + 0.25 + 0.25 + 0.6 = 0.1.
  ASSERT_FALSE(first.empty());
  EXPECT_NEAR(first.back(), 0.1, 0.12);
  EXPECT_GT(yield_px, 1500);  // drawn standing 1.1 m ahead of the camera
  EXPECT_EQ(blind_px, 0);     // the blind one has walked on past the robot (behind the camera)
  // Deterministic: the same run again gives the same walker positions.
  run(yielding, &second);
  EXPECT_EQ(first, second);
  // The robot leaves its way: the walker walks on.
  auto robot = std::make_shared<RobotCore>(p, on_its_way, yielding);
  for (int i = 0; i < 80; ++i) ASSERT_TRUE(robot->step(0.1).ok());
  robot->teleport(Pose2D{5.0, -1.0, CV_PI / 2});  // 2 m to the side
  for (int i = 0; i < 40; ++i) ASSERT_TRUE(robot->step(0.1).ok());
  EXPECT_LT(robot->mover_offset(yielding.get(), 0, robot->time_s()).y + 4.0, -2.5);
  // Pure test: a robot beside the way (lateral 0.7 m > 0.25 + 0.25 + 0.1) or behind does not stop it.
  const MovingObstacle& m = yielding->movers[0];
  EXPECT_TRUE(MoverStates::yields(m, {0, 0}, {0, -1}, {0.0, -1.0}, 0.25));
  EXPECT_FALSE(MoverStates::yields(m, {0, 0}, {0, -1}, {0.7, -1.0}, 0.25));
  EXPECT_FALSE(MoverStates::yields(m, {0, 0}, {0, -1}, {0.0, 1.0}, 0.25));
  EXPECT_FALSE(MoverStates::yields(m, {0, 0}, {0, -1}, {0.0, -1.2}, 0.25));  // gap 0.7 > 0.6
}

TEST(MovingObstacles, BadMotionSpecsNameTheKeyAndLine) {
  const std::string head = R"(world:
  textures:
    cloth: {procedural: noise, color: [60, 40, 150], size_m: 1.0}
  default_ground: {texture: cloth}
  obstacles:
)";
  auto parse = [&](const std::string& entry) { return parse_world(head + entry, "inline.yaml", "."); };
  EXPECT_TRUE(fails_with(parse("    - {name: a, kind: person, at: [0, 0], speed_mps: 1, texture: cloth}\n"),
                         ErrorCode::missing, At{"inline.yaml", 6, "path"}));
  EXPECT_TRUE(fails_with(parse("    - {name: a, kind: person, at: [0, 0], path: [[1, 0]], texture: cloth}\n"),
                         ErrorCode::missing, At{"inline.yaml", 6, "speed_mps"}));
  EXPECT_TRUE(fails_with(parse("    - {name: a, kind: person, at: [0, 0], path: [[1, 0]], speed_mps: 0, texture: cloth}\n"),
                         ErrorCode::out_of_range, At{"inline.yaml", 6, "speed_mps"}));
  EXPECT_TRUE(fails_with(parse("    - {name: a, kind: person, at: [0, 0], path: [[1, 0]], speed_mps: 1, motion: fly, texture: cloth}\n"),
                         ErrorCode::out_of_range, At{"inline.yaml", 6, "motion"}));
  EXPECT_TRUE(fails_with(parse("    - {name: a, kind: person, at: [0, 0], path: [[0, 0]], speed_mps: 1, texture: cloth}\n"),
                         ErrorCode::invalid_value, At{"inline.yaml", 6, "path"}));
  EXPECT_TRUE(fails_with(parse("    - {name: a, kind: person, at: [0, 0], size_m: [1, 1], texture: cloth}\n"),
                         ErrorCode::invalid_value, At{"inline.yaml", 6, "size_m"}));
  EXPECT_TRUE(fails_with(parse("    - {name: a, kind: person, at: [0, 0], path: [[1, 0]], speed_mps: 1, yield_m: -0.5, texture: cloth}\n"),
                         ErrorCode::out_of_range, At{"inline.yaml", 6, "yield_m"}));
  EXPECT_TRUE(fails_with(parse("    - {name: a, kind: person, at: [0, 0], path: [[1, 0]], speed_mps: 1, yield_m: 9, texture: cloth}\n"),
                         ErrorCode::out_of_range, At{"inline.yaml", 6, "yield_m"}));
  EXPECT_TRUE(fails_with(parse("    - {name: a, kind: person, at: [0, 0], yield_m: 0.6, texture: cloth}\n"),
                         ErrorCode::missing, At{"inline.yaml", 6, "path"}));
  EXPECT_TRUE(fails_with(parse("    - {name: a, kind: person, at: [0, 0], pause_s: 2, texture: cloth}\n"),
                         ErrorCode::missing, At{"inline.yaml", 6, "path"}));
  EXPECT_TRUE(fails_with(parse("    - {name: a, kind: person, at: [0, 0], path: [[1, 0]], speed_mps: 1, pause_s: -1, texture: cloth}\n"),
                         ErrorCode::out_of_range, At{"inline.yaml", 6, "pause_s"}));
  EXPECT_TRUE(fails_with(parse("    - {name: a, kind: person, at: [0, 0], path: [[1, 0]], speed_mps: 1, pause_s: 2, yield_m: 0.6, texture: cloth}\n"),
                         ErrorCode::inconsistent, At{"inline.yaml", 6, "pause_s"}));
}

TEST(MovingObstacles, ObstacleFileAddsToTheWorldPerRun) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("visnav_moving_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path world_file = dir / "w.yaml", good = dir / "good.yaml", bad = dir / "bad.yaml";
  std::ofstream(world_file) << R"(world:
  textures:
    cloth: {procedural: noise, color: [60, 40, 150], size_m: 1.0}
  default_ground: {texture: cloth}
)";
  std::ofstream(good) << "obstacles:\n  - {name: van, kind: van, at: [5, 0], texture: cloth}\n"
                         "  - {name: walker, kind: person, at: [8, 3], path: [[8, -3]], speed_mps: 1.2, motion: back_and_forth, texture: cloth}\n";
  std::ofstream(bad) << "obstacles:\n  - {name: van, kind: van, at: [5, 0], texture: cloth}\n  - {name: b, kind: box, at: [1, 1], texture: paint}\n";
  auto plain = load_world_with_obstacles(world_file.string(), "");
  ASSERT_TRUE(plain.ok()) << plain.error().message;
  EXPECT_TRUE((*plain)->walls.empty());
  auto placed = load_world_with_obstacles(world_file.string(), good.string());
  ASSERT_TRUE(placed.ok()) << placed.error().message;
  EXPECT_EQ((*placed)->walls.size(), 4u + 8u);
  ASSERT_EQ((*placed)->movers.size(), 1u);
  EXPECT_TRUE((*plain)->walls.empty());  // the cached world is not changed
  auto broken = load_world_with_obstacles(world_file.string(), bad.string());
  EXPECT_TRUE(fails_with(broken, ErrorCode::invalid_value, At{"bad.yaml", 3, {}}));
  EXPECT_TRUE(fails_with(load_world_with_obstacles(world_file.string(), (dir / "none.yaml").string()), ErrorCode::not_found));
  // Through the robot's params, as `visnav experiment --obstacles` sets them.
  RobotParams p;
  p.world = world_file.string();
  p.obstacles = good.string();
  auto robot = SimRobot::create(p);
  ASSERT_TRUE(robot.ok()) << robot.error().message;
  EXPECT_EQ((*robot)->core()->world()->movers.size(), 1u);
  p.obstacles = bad.string();
  EXPECT_FALSE(SimRobot::create(p).ok());
  // Teach without, replay with: the experiment reconfigures the running robot for the replay.
  p.obstacles.clear();
  p.body_radius_m = 0.25;
  auto taught = SimRobot::create(p);
  ASSERT_TRUE(taught.ok()) << taught.error().message;
  EXPECT_TRUE((*taught)->core()->world()->walls.empty());
  auto replay = visnav::parse_yaml_string("world: " + world_file.string() + "\nobstacles: " + good.string() +
                                              "\nbody_radius_m: 0.25\n",
                                          "replay.yaml");
  ASSERT_TRUE(replay.ok());
  ASSERT_TRUE((*taught)->reconfigure(*replay).ok());
  EXPECT_EQ((*taught)->core()->world()->movers.size(), 1u);
  for (int i = 0; i < 60; ++i) {  // drive from the origin into the van at x = 5 +- 2.4
    ASSERT_TRUE((*taught)->send_command(Twist{1.0, 0.0}).ok());
    ASSERT_TRUE((*taught)->step(0.1).ok());
  }
  // (pushing on against it records a contact again each time a sub-step ends clear of it)
  ASSERT_GE((*taught)->collisions().size(), 1u);
  EXPECT_EQ((*taught)->collisions()[0].obstacle, "van");
  EXPECT_NEAR((*taught)->core()->ground_truth().x_m, 5.0 - 2.4 - 0.25, 0.05);
  fs::remove_all(dir);
}

// The thesis rig's mount (0.43 m, 9 deg down, 65.5 deg field of view) for the renderer, and the
// IPT camera of the same mount.
CameraModel thesis_rig_model() {
  CameraModel model;
  model.hfov_deg = 65.5;
  model.height_m = 0.43;
  model.pitch_down_deg = 9.0;
  return model;
}

ipt::IptCamera ipt_camera_of(const CameraModel& model) {
  ipt::IptCamera camera;
  camera.fx_px = camera.fy_px = model.fx();
  camera.height_m = model.height_m;
  camera.pitch_rad = -model.pitch_down_deg * CV_PI / 180.0;
  return camera;
}

// MotionWatch on frames of a standing camera (the thesis rig): the person crossing the corridor
// is motion, sensor noise and an exposure step are not, a person walking beside the corridor is not.
TEST(MotionWatch, SeesAPersonCrossingTheCorridorAndNothingElse) {
  auto world = world_or_die(kWorld);
  ASSERT_NE(world, nullptr);
  const CameraModel model = thesis_rig_model();
  Renderer renderer(world, model);
  const ipt::IptCamera camera = ipt_camera_of(model);
  auto watch = ipt::MotionWatch::create(camera, ipt::MotionWatchParams{});
  ASSERT_TRUE(watch.ok()) << watch.error().message;
  cv::RNG rng(7);
  cv::Mat bgr, grey, noise(240, 320, CV_16S);
  auto frame = [&](const Pose2D& robot, double t, double gain) {
    renderer.render(robot, bgr, nullptr, nullptr, t);
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
    grey.convertTo(noise, CV_16S, gain);
    cv::Mat n(240, 320, CV_16S);
    rng.fill(n, cv::RNG::NORMAL, 0.0, 3.0);  // the experiment's sensor noise
    noise += n;
    noise.convertTo(grey, CV_8U);
    auto changed = watch->observe(grey);
    EXPECT_TRUE(changed.ok());
    return changed.ok() && changed->has_value() ? **changed : -1;
  };
  // Person crossing 3 m ahead (it is on the robot's line at t = 6 s).
  EXPECT_EQ(frame({0, 0, 0}, 5.6, 1.0), -1);  // first frame: nothing to compare with
  EXPECT_TRUE(frame({0, 0, 0}, 5.7, 1.0) > 0 && watch->moving());
  // Nothing moves (before start_s), with a 6 % exposure step: no motion.
  watch->reset();
  frame({0, 0, 0}, 0.0, 1.0);
  const int still = frame({0, 0, 0}, 0.1, 1.06);
  EXPECT_FALSE(watch->moving()) << still << " changed pixels";
  // Robot facing away from the person's line (looking down -x): the person walks behind it.
  watch->reset();
  frame({0, 0, CV_PI}, 5.6, 1.0);
  frame({0, 0, CV_PI}, 5.7, 1.0);
  EXPECT_FALSE(watch->moving());
  // Driving 3 cm per frame over the empty grass (before the person starts): the ground-plane
  // warp lines the frames up, nothing counts; driving while the person crosses 1.5 m ahead of
  // the robot (person at x = 3, robot at x = 1.5): it does.
  ipt::MotionWatchParams near;
  near.far_m = 2.0;
  near.half_width_m = 1.2;
  auto driving = ipt::MotionWatch::create(camera, near);
  ASSERT_TRUE(driving.ok());
  std::swap(*watch, *driving);
  frame({0.0, 0.0, 0.0}, 0.0, 1.0);
  for (int k = 1; k <= 5; ++k) {
    renderer.render({0.03 * k, 0.0, 0.0}, bgr, nullptr, nullptr, 0.1 * k);
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
    auto changed = watch->observe(grey, Pose2D{0.03, 0.0, 0.0});
    ASSERT_TRUE(changed.ok() && changed->has_value());
    EXPECT_FALSE(watch->moving()) << "frame " << k << ": " << **changed << " changed pixels";
  }
  watch->reset();
  renderer.render({1.5, 0.0, 0.0}, bgr, nullptr, nullptr, 5.6);
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  ASSERT_TRUE(watch->observe(grey, Pose2D{}).ok());
  renderer.render({1.53, 0.0, 0.0}, bgr, nullptr, nullptr, 5.7);
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  auto crossing = watch->observe(grey, Pose2D{0.03, 0.0, 0.0});
  ASSERT_TRUE(crossing.ok() && crossing->has_value());
  EXPECT_TRUE(watch->moving()) << **crossing << " changed pixels";
  // Bad input: wrong image size.
  EXPECT_TRUE(fails_with(watch->observe(cv::Mat(10, 10, CV_8UC1)), ErrorCode::invalid_value));
  ipt::MotionWatchParams bad;
  bad.far_m = 0.2;
  EXPECT_TRUE(fails_with(ipt::MotionWatch::create(camera, bad), ErrorCode::inconsistent, At{{}, 0, "far_m"}));
}

// The crossing policy on rendered frames of a standing camera (the thesis rig's mount at
// 320x240): the frame difference over a band wider than the corridor (±4 m) locates the walker
// (kWorld: at x = 3 m, walking y = 4 -> -4 at 1 m/s from t = 2 s); while it approaches the
// robot's line the policy waits, once it has crossed and walks away it goes.
TEST(CrossingPolicy, TracksARenderedPersonWaitsWhileItApproachesGoesWhenItWalksAway) {
  auto world = world_or_die(kWorld);
  ASSERT_NE(world, nullptr);
  const CameraModel model = thesis_rig_model();
  Renderer renderer(world, model);
  const ipt::IptCamera camera = ipt_camera_of(model);
  ipt::MotionWatchParams band;
  band.far_m = 8.0;
  band.half_width_m = 4.0;
  auto watch = ipt::MotionWatch::create(camera, band);
  ASSERT_TRUE(watch.ok()) << watch.error().message;
  cv::RNG rng(5);
  cv::Mat bgr, grey, noisy(240, 320, CV_16S), n(240, 320, CV_16S);
  ipt::CrossingPolicy policy(ipt::CrossingParams{});
  int located = 0;
  auto feed = [&](double t) {
    renderer.render({0, 0, 0}, bgr, nullptr, nullptr, t);
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
    grey.convertTo(noisy, CV_16S);
    rng.fill(n, cv::RNG::NORMAL, 0.0, 3.0);
    noisy += n;
    noisy.convertTo(grey, CV_8U);
    auto changed = watch->observe(grey);
    ASSERT_TRUE(changed.ok());
    if (!changed->has_value() || !watch->moving()) return;
    auto p = ipt::locate_moving(watch->last_changed(), camera, 80);
    ASSERT_TRUE(p.ok());
    if (!p->has_value()) return;
    ++located;
    const double truth_y = 4.0 - (t - 2.0) - 0.05;  // between this frame's and the last one's position
    EXPECT_NEAR((*p)->ground_m.y, truth_y, 0.35) << "t = " << t;
    EXPECT_NEAR((*p)->ground_m.x, 3.0, 0.6) << "t = " << t;
    policy.observe(t, **p);
  };
  // Approaching from the left: y = 1.8 .. 1.2 (1.8 m in view at 3 m with the 65.5 deg lens).
  for (double t = 4.1; t <= 4.85; t += 0.1) feed(t);
  EXPECT_GE(located, 5);
  const auto approaching = policy.decide(4.8);
  EXPECT_EQ(approaching.kind, ipt::CrossingDecision::Kind::wait) << approaching.reason;
  EXPECT_LT(approaching.lateral_speed_mps, -0.6);
  // It has crossed and walks away to the right: y = -0.5 .. -1.2.
  watch->reset();
  policy.reset();
  located = 0;
  for (double t = 6.4; t <= 7.25; t += 0.1) feed(t);
  EXPECT_GE(located, 5);
  const auto away = policy.decide(7.2);
  EXPECT_EQ(away.kind, ipt::CrossingDecision::Kind::go) << away.reason;
  EXPECT_LT(away.lateral_m, -0.9);
}

}  // namespace
}  // namespace visnav::sim
