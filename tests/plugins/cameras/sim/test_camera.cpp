// The sim camera: determinism, appearance changes, faults, latency and the plugin object.
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/core.hpp>

#include "error_expect.hpp"
#include "visnav_sim/camera.hpp"
#include "visnav/config.hpp"
#include "visnav/host.hpp"
#include "visnav_sim/robot.hpp"

namespace vs = visnav::sim;
using visnav::Pose2D;

namespace {

std::shared_ptr<vs::RobotCore> robot(double v = 0.5) {
  vs::RobotParams p;
  auto path = vs::resolve_world_path("straight6m");
  EXPECT_TRUE(path.ok());
  auto world = vs::load_world_cached(*path);
  EXPECT_TRUE(world.ok());
  p.start_pose = {0, 0, 0};
  p.command_timeout_s = 0;
  auto core = std::make_shared<vs::RobotCore>(p, vs::resolve_start(p, world->get()), *world);
  core->command({v, 0.1});
  return core;
}

vs::CameraParams small() {
  vs::CameraParams c;
  c.width_px = 96;
  c.height_px = 72;
  return c;
}

/// A host with nothing but a robot slot, as the run's host is when it makes the camera.
class RobotSlotHost final : public visnav::HostServices {
 public:
  visnav::Logger& logger() override { return logger_; }
  const visnav::Clock& clock() override { return clock_; }
  visnav::Result<std::unique_ptr<visnav::Detector>> create_detector(std::string_view, const visnav::ConfigNode&) override {
    return visnav::fail("no detectors here");
  }
  visnav::Robot* robot() override { return robot_; }
  void set_robot(visnav::Robot* robot) { robot_ = robot; }

 private:
  struct Quiet final : visnav::Logger {
    void log(visnav::LogLevel, std::string_view, std::string_view) override {}
  } logger_;
  struct Zero final : visnav::Clock {
    [[nodiscard]] double now_s() const override { return 0.0; }
  } clock_;
  visnav::Robot* robot_ = nullptr;
};

/// A robot that is not simulated.
class WheelRobot final : public visnav::Robot {
 public:
  visnav::Status send_command(const visnav::Twist&) override { return visnav::ok(); }
  std::optional<visnav::Odometry> latest_odometry() override { return std::nullopt; }
};

bool same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

}  // namespace

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST(SimCamera, FramesAreDeterministicForASeed) {
  vs::CameraParams c = small();
  c.noise_std = 6;
  c.drop_probability = 0.2;
  c.freeze_probability = 0.1;
  c.motion_blur_exposure_s = 0.05;
  auto r1 = robot(), r2 = robot(), r3 = robot();
  vs::CameraCore a(c, r1, r1->world()), b(c, r2, r2->world());
  c.seed = 2;
  vs::CameraCore d(c, r3, r3->world());
  int differing = 0;
  for (int i = 0; i < 20; ++i) {
    for (auto* r : {r1.get(), r2.get(), r3.get()}) ASSERT_TRUE(r->step(0.1).ok());
    auto fa = a.grab(), fb = b.grab(), fd = d.grab();
    ASSERT_EQ(fa.has_value(), fb.has_value());
    if (fa) {
      EXPECT_TRUE(same(fa->image, fb->image)) << "frame " << i;
      EXPECT_EQ(fa->sequence, fb->sequence);
      if (!fd || !same(fa->image, fd->image)) ++differing;
    }
  }
  EXPECT_GT(differing, 5);  // another seed gives other noise
}

TEST(SimCamera, DroppedFrames) {
  vs::CameraParams c = small();
  c.drop_probability = 1.0;
  auto r = robot();
  vs::CameraCore all_dropped(c, r, r->world());
  for (int i = 0; i < 5; ++i) EXPECT_FALSE(all_dropped.grab().has_value());
  c.drop_probability = 0.3;
  vs::CameraCore some(c, r, r->world());
  int dropped = 0;
  for (int i = 0; i < 300; ++i) dropped += !some.grab().has_value();
  EXPECT_GT(dropped, 60);
  EXPECT_LT(dropped, 120);
}

// After a compute freeze (simulated time jumped past several frame periods) the camera kept
// capturing: a drop loses the newest frame only, and the one a period earlier arrives.
TEST(SimCamera, ADropAfterAStallLosesOnlyTheNewestFrame) {
  vs::CameraParams c = small();
  c.frame_rate_hz = 10;
  c.drop_probability = 1.0;
  auto r = robot();
  vs::CameraCore cam(c, r, r->world());
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(r->step(0.1).ok());
    EXPECT_FALSE(cam.grab().has_value()) << "grab " << i;  // on time: a drop is a drop
  }
  ASSERT_TRUE(r->step(2.0).ok());  // the caller stalled for 2 s
  const auto late = cam.grab();
  ASSERT_TRUE(late.has_value());
  EXPECT_NEAR(late->timestamp_s, r->time_s() - 0.1, 1e-9);
  ASSERT_TRUE(r->step(0.1).ok());
  EXPECT_FALSE(cam.grab().has_value());  // back on time

  // One frame per grab (frame_rate_hz 0, the experiment's setting): the period is the grabs' cadence.
  c.frame_rate_hz = 0;
  vs::CameraCore per_grab(c, r, r->world());
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(r->step(0.1).ok());
    EXPECT_FALSE(per_grab.grab().has_value());
  }
  ASSERT_TRUE(r->step(2.5).ok());
  const auto after = per_grab.grab();
  ASSERT_TRUE(after.has_value());
  EXPECT_NEAR(after->timestamp_s, r->time_s() - 0.1, 1e-9);
}

TEST(SimCamera, FrozenFramesRepeatThePreviousImage) {
  vs::CameraParams c = small();
  c.freeze_probability = 1.0;
  auto r = robot();
  vs::CameraCore cam(c, r, r->world());
  auto first = cam.grab();
  ASSERT_TRUE(first.has_value());
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(r->step(0.1).ok());
  auto second = cam.grab();
  ASSERT_TRUE(second.has_value());
  EXPECT_TRUE(same(first->image, second->image));
  EXPECT_GT(second->sequence, first->sequence);
  EXPECT_GT(second->timestamp_s, first->timestamp_s);
  // without freezing the view changes as the robot moves
  c.freeze_probability = 0.0;
  vs::CameraCore live(c, r, r->world());
  auto a = live.grab();
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(r->step(0.1).ok());
  auto b = live.grab();
  ASSERT_TRUE(a && b);
  EXPECT_FALSE(same(a->image, b->image));
  EXPECT_FALSE(a->image.data == b->image.data && a->image.data != nullptr)
      << "a handed-out frame must not be overwritten while it is held";
}

TEST(SimCamera, LatencyShowsAnEarlierPose) {
  vs::CameraParams c = small();
  c.latency_s = 0.5;
  auto r = robot();
  vs::CameraCore cam(c, r, r->world());
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(r->step(0.1).ok());
  auto f = cam.grab();
  ASSERT_TRUE(f.has_value());
  EXPECT_NEAR(f->timestamp_s, 1.5, 1e-9);
  vs::Renderer ref(r->world(), c.model());
  cv::Mat expected;
  ref.render(r->pose_at(1.5), expected);
  EXPECT_TRUE(same(f->image, expected));
  cv::Mat now;
  ref.render(r->ground_truth(), now);
  EXPECT_FALSE(same(f->image, now));
}

TEST(SimCamera, AppearanceChangesAltersTheImage) {
  auto r = robot();
  vs::CameraParams base = small();
  vs::CameraCore plain(base, r, r->world());
  const cv::Mat ref = plain.grab()->image.clone();
  const double mean = cv::mean(ref)[1];
  {
    vs::CameraParams c = base;
    c.gain = 0.5;
    vs::CameraCore cam(c, r, r->world());
    EXPECT_NEAR(cv::mean(cam.grab()->image)[1], mean * 0.5, 2.0);
  }
  {
    vs::CameraParams c = base;
    c.season = "winter";
    vs::CameraCore cam(c, r, r->world());
    EXPECT_GT(cv::mean(cam.grab()->image)[1], mean + 20);  // snow is brighter than grass
  }
  {
    vs::CameraParams c = base;
    c.shadow_strength = 0.8;
    vs::CameraCore cam(c, r, r->world());
    EXPECT_LT(cv::mean(cam.grab()->image)[1], mean - 3);
  }
  {
    vs::CameraParams c = base;
    c.grey = true;
    vs::CameraCore cam(c, r, r->world());
    EXPECT_EQ(cam.grab()->image.type(), CV_8UC1);
  }
}

TEST(SimCamera, PluginObjectRidesTheRunsRobotFoundThroughTheHost) {
  // No process-wide registry: the camera finds its robot through HostServices::robot(), which
  // the run sets before it makes the camera; made earlier (or in another order), the camera
  // binds at its first grab.
  RobotSlotHost host;
  auto params = visnav::parse_yaml_string("{width_px: 96, height_px: 64}", "camera.yaml");
  ASSERT_TRUE(params.ok()) << params.error().message;
  auto cam = vs::SimCamera::create(*params, host);
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  auto missing = (*cam)->grab(0.1);
  EXPECT_TRUE(fails_with(missing, ErrorCode::not_found));

  vs::RobotParams p;
  p.world = "straight6m";
  auto bot = vs::SimRobot::create(p);
  ASSERT_TRUE(bot.ok()) << bot.error().message;
  host.set_robot(bot->get());
  ASSERT_TRUE((*bot)->step(0.05).ok());
  auto frame = (*cam)->grab(0.1);
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  ASSERT_TRUE(frame->has_value());
  EXPECT_EQ((*frame)->image.cols, 96);
  EXPECT_NEAR((*frame)->timestamp_s, 0.05, 1e-9);

  // Two robots in one process: each camera renders its own (a registry keyed by name could not).
  p.start_pose = std::vector<double>{0.0, 0.0, 180.0};
  auto other = vs::SimRobot::create(p);
  ASSERT_TRUE(other.ok()) << other.error().message;
  vs::CameraParams c;
  c.width_px = 96;
  c.height_px = 64;
  auto other_cam = vs::SimCamera::create(c, (*other)->core());
  ASSERT_TRUE(other_cam.ok()) << other_cam.error().message;
  ASSERT_TRUE((*other)->step(0.05).ok());
  auto other_frame = (*other_cam)->grab(0.1);
  ASSERT_TRUE(other_frame.ok() && other_frame->has_value());
  EXPECT_GT(cv::norm((*frame)->image, (*other_frame)->image, cv::NORM_L1), 0.0) << "both cameras rendered one robot";
}

TEST(SimCamera, RefusesARobotThatIsNotSimulated) {
  RobotSlotHost host;
  WheelRobot real;
  host.set_robot(&real);
  auto params = visnav::parse_yaml_string("{width_px: 96, height_px: 64}", "camera.yaml");
  ASSERT_TRUE(params.ok());
  auto cam = vs::SimCamera::create(*params, host);
  EXPECT_TRUE(fails_with(cam, ErrorCode::inconsistent));
}
