// The `recorded` robot and camera through the real plugin loader, on small synthetic runs.
#include <gtest/gtest.h>

#include "camera_test_support.hpp"
#include "error_expect.hpp"

using namespace visnav::testing;

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;

namespace {

std::string run_params(const std::string& dir, const std::string& extra = "") {
  return "run_dir: " + dir + "\n" + extra;
}

}  // namespace

TEST(RecordedPlugins, RobotDrivesTimeAndCameraFollowsTheClock) {
  const std::string dir = scratch();
  write_run(dir, 5);
  LoaderHost h;
  auto robot = h.loader.create<visnav::Robot>("recorded", yaml(run_params(dir, "commands_file: " + dir + "/cmd_out.csv\n")), h.host,
                                              "robot_recorded");
  ASSERT_TRUE(robot.ok()) << robot.error().message;
  auto camera = h.loader.create<visnav::Camera>("recorded", yaml(run_params(dir)), h.host, "camera_recorded");
  ASSERT_TRUE(camera.ok()) << camera.error().message;
  visnav::SimulationControl* sim = (*robot)->simulation();
  ASSERT_NE(sim, nullptr);
  EXPECT_NEAR(sim->time_s(), 0.1, 1e-12);
  EXPECT_FALSE(sim->set_ground_truth_pose({}).ok());

  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(sim->step(0.05).ok());
    EXPECT_NEAR(sim->time_s(), 0.1 * (i + 1), 1e-9);
    h.clock.set(sim->time_s());
    auto frame = (*camera)->grab(0.0);
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    ASSERT_TRUE(frame->has_value());
    EXPECT_NEAR((*frame)->timestamp_s, 0.1 * (i + 1), 1e-9);
    EXPECT_EQ((*frame)->sequence, static_cast<std::uint64_t>(i + 1));
    EXPECT_EQ(cv::norm((*frame)->image, test_image(i), cv::NORM_INF), 0.0);  // PNG: bit-exact
    auto again = (*camera)->grab(0.0);  // nothing newer until the clock moves
    ASSERT_TRUE(again.ok());
    EXPECT_FALSE(again->has_value());
    auto odo = (*robot)->latest_odometry();
    ASSERT_TRUE(odo.has_value());
    EXPECT_NEAR(odo->timestamp_s, 0.1 * (i + 1), 1e-9);
    EXPECT_NEAR(odo->distance_m, 0.05 * (i + 1), 1e-9);
    EXPECT_TRUE((*robot)->send_command({0.3, -0.1}).ok());
  }
  auto end = sim->step(0.05);
  ASSERT_FALSE(end.ok());
  EXPECT_TRUE(fails_with(end, ErrorCode::missing, At{"frames.csv"}));
  h.clock.set(10.0);
  auto cam_end = (*camera)->grab(0.0);
  EXPECT_TRUE(fails_with(cam_end, ErrorCode::missing, At{"frames.csv"}));
  EXPECT_NE(cam_end.error().message.find("after 5 frames"), std::string::npos) << cam_end.error().message;  // how far it got
  std::ifstream cmds(dir + "/cmd_out.csv");
  std::string line;
  int rows = -1;
  while (std::getline(cmds, line)) ++rows;
  EXPECT_EQ(rows, 5);
}

TEST(RecordedPlugins, TicksOfAMissionRecordingDriveTime) {
  const std::string dir = scratch();
  write_run(dir, 3);
  // Two ticks per frame (e.g. a camera at half the tick rate).
  write_text(dir + "/commands.csv",
             "tick,t_s,frame_index,linear_mps,angular_radps,commands_sent\n1,0.1,0,0,0,1\n2,0.15,0,0,0,2\n3,0.2,1,0,0,3\n");
  LoaderHost h;
  auto robot = h.loader.create<visnav::Robot>("recorded", yaml(run_params(dir)), h.host, "robot_recorded");
  ASSERT_TRUE(robot.ok()) << robot.error().message;
  visnav::SimulationControl* sim = (*robot)->simulation();
  ASSERT_TRUE(sim->step(0.1).ok());
  ASSERT_TRUE(sim->step(0.1).ok());
  EXPECT_NEAR(sim->time_s(), 0.15, 1e-12);
  ASSERT_TRUE(sim->step(0.1).ok());
  EXPECT_FALSE(sim->step(0.1).ok());
}

TEST(RecordedPlugins, OdometryFarFromFramesOrOutOfOrderIsAnErrorNamingFileAndLine) {
  const std::string dir = scratch();
  write_run(dir, 5);
  write_text(dir + "/odometry.csv", "t_s,distance_m\n0,0\n0.1,0.1\n0.2,0.2\n");  // frames run to 0.5 s
  LoaderHost h;
  auto robot = h.loader.create<visnav::Robot>("recorded", yaml(run_params(dir, "max_frame_gap_s: 0.15\n")), h.host, "robot_recorded");
  ASSERT_FALSE(robot.ok());
  EXPECT_TRUE(fails_with(robot, ErrorCode::inconsistent, At{"frames.csv", 5}));  // t = 0.4
  write_text(dir + "/odometry.csv", "t_s,distance_m\n0,0\n0.3,0.1\n0.2,0.2\n");
  auto robot2 = h.loader.create<visnav::Robot>("recorded", yaml(run_params(dir)), h.host, "robot_recorded");
  ASSERT_FALSE(robot2.ok());
  EXPECT_TRUE(fails_with(robot2, ErrorCode::inconsistent, At{"odometry.csv", 4}));
}

TEST(RecordedPlugins, BadRunFoldersAreClearErrors) {
  LoaderHost h;
  auto missing = h.loader.create<visnav::Camera>("recorded", yaml("run_dir: /no/such/run\n"), h.host, "camera_recorded");
  ASSERT_FALSE(missing.ok());
  EXPECT_TRUE(fails_with(missing, ErrorCode::not_found, At{"/no/such/run"}));
  const std::string dir = scratch();
  write_run(dir, 2);
  write_text(dir + "/run.yaml", "format: visnav-recorded-run\nversion: 7\n");
  auto version = h.loader.create<visnav::Camera>("recorded", yaml(run_params(dir)), h.host, "camera_recorded");
  ASSERT_FALSE(version.ok());
  EXPECT_TRUE(fails_with(version, ErrorCode::out_of_range, At{"run.yaml", 2, "version"}));
  write_text(dir + "/run.yaml", "format: visnav-recorded-run\nversion: 1\n");
  std::filesystem::remove(dir + "/frames/000001.png");
  auto image = h.loader.create<visnav::Camera>("recorded", yaml(run_params(dir)), h.host, "camera_recorded");
  ASSERT_FALSE(image.ok());
  EXPECT_TRUE(fails_with(image, ErrorCode::not_found, At{"frames.csv", 3, "file"}));
  auto unknown = h.loader.create<visnav::Robot>("recorded", yaml("run_dir: " + dir + "\nspeed: 3\n"), h.host, "robot_recorded");
  ASSERT_FALSE(unknown.ok());
  EXPECT_TRUE(fails_with(unknown, ErrorCode::unknown_key, At{"test.yaml", 2}));
}
