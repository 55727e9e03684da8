// The simulator plugin through the real plugin loader: one descriptor carrying a robot type, a
// camera type and a command; params; lock-step step → grab; the `sim` command entry.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>

#include "visnav/config_node.hpp"
#include "visnav/devices.hpp"
#include "visnav/host.hpp"
#include "visnav/loader.hpp"
#include "visnav/plugin.hpp"
#include "error_expect.hpp"

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;

namespace {

class QuietLogger final : public visnav::Logger {
 public:
  void log(visnav::LogLevel, std::string_view, std::string_view) override {}
};
class ZeroClock final : public visnav::Clock {
 public:
  [[nodiscard]] double now_s() const override { return 0.0; }
};
class TestHost final : public visnav::HostServices {
 public:
  visnav::Logger& logger() override { return logger_; }
  const visnav::Clock& clock() override { return clock_; }
  visnav::Result<std::unique_ptr<visnav::Detector>> create_detector(std::string_view, const visnav::ConfigNode&) override {
    return visnav::fail("no detectors in this test");
  }
  visnav::Robot* robot() override { return robot_; }
  void set_robot(visnav::Robot* robot) { robot_ = robot; }

 private:
  visnav::Robot* robot_ = nullptr;
  QuietLogger logger_;
  ZeroClock clock_;
};

visnav::ConfigNode params(std::initializer_list<std::pair<const char*, const char*>> kv) {
  visnav::ConfigNode n = visnav::ConfigNode::make_map(visnav::SourceLocation{"test.yaml", 1});
  int line = 2;
  for (const auto& [k, v] : kv) n.set(k, visnav::ConfigNode::make_scalar(v, visnav::SourceLocation{"test.yaml", line++}));
  return n;
}

}  // namespace

TEST(SimPlugins, LoadCreateStepGrab) {
  visnav::PluginLoader loader({VISNAV_TEST_PLUGIN_DIR});
  TestHost host;
  auto lib = loader.load_library("simulator");
  ASSERT_TRUE(lib.ok()) << lib.error().message;
  EXPECT_EQ((*lib)->kinds, (std::vector<visnav::PluginKind>{visnav::PluginKind::robot, visnav::PluginKind::camera}));
  EXPECT_EQ((*lib)->type_names(visnav::PluginKind::robot), std::vector<std::string>{"sim"});
  EXPECT_EQ((*lib)->type_names(visnav::PluginKind::camera), std::vector<std::string>{"sim"});

  bool has_sim_command = false;
  for (const auto& c : loader.commands()) has_sim_command = has_sim_command || c.name == "sim";
  EXPECT_TRUE(has_sim_command);
  auto docs = loader.param_docs(visnav::PluginKind::robot, "sim");
  ASSERT_TRUE(docs.ok());
  EXPECT_GT(docs->size(), 15u);

  auto robot = loader.create<visnav::Robot>(
      "sim", params({{"world", "straight6m"}, {"odom_rate_hz", "10"}}), host);
  ASSERT_TRUE(robot.ok()) << robot.error().message;
  host.set_robot(robot->get());  // as the run does before it makes the camera
  auto camera = loader.create<visnav::Camera>("sim", params({{"width_px", "160"}, {"height_px", "120"}}), host);
  ASSERT_TRUE(camera.ok()) << camera.error().message;

  visnav::SimulationControl* sim = (*robot)->simulation();
  ASSERT_NE(sim, nullptr);
  cv::Mat first;
  for (int i = 0; i < 10; ++i) {
    ASSERT_TRUE((*robot)->send_command({0.5, 0.0}).ok());
    ASSERT_TRUE(sim->step(0.1).ok());
    auto frame = (*camera)->grab(0.1);
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    ASSERT_TRUE(frame->has_value());
    EXPECT_EQ((*frame)->image.size(), cv::Size(160, 120));
    EXPECT_NEAR((*frame)->timestamp_s, 0.1 * (i + 1), 1e-9);
    if (i == 0) first = (*frame)->image;
  }
  EXPECT_NEAR(sim->ground_truth_pose().x_m, 0.375, 0.01);  // 0.5 s ramp at 1 m/s^2, then 0.5 s at 0.5 m/s
  auto odo = (*robot)->latest_odometry();
  ASSERT_TRUE(odo.has_value());
  EXPECT_NEAR(odo->distance_m, sim->ground_truth_pose().x_m, 1e-6);  // published at t = 1.0 (10 Hz)
}

TEST(SimPlugins, BadParamsAreRejectedWithLocation) {
  visnav::PluginLoader loader({VISNAV_TEST_PLUGIN_DIR});
  TestHost host;
  auto robot = loader.create<visnav::Robot>("sim", params({{"max_linear_mps", "fast"}}), host, "simulator");
  EXPECT_TRUE(fails_with(robot, ErrorCode::invalid_value, At{"test.yaml", 2, "max_linear_mps"}));
  auto robot2 = loader.create<visnav::Robot>("sim", params({{"kinematics", "hovercraft"}}), host, "simulator");
  EXPECT_TRUE(fails_with(robot2, ErrorCode::out_of_range, At{"test.yaml", 2, "kinematics"}));
}

// The sim camera always declares its mount: the one it renders from (hfov_deg, mount_* keys),
// the defaults when none are given, and the new values after a reconfigure (live reload).
TEST(SimPlugins, CameraReportsTheMountItRendersFrom) {
  visnav::PluginLoader loader({VISNAV_TEST_PLUGIN_DIR});
  TestHost host;
  auto robot = loader.create<visnav::Robot>("sim", params({{"world", "straight6m"}}), host, "simulator");
  ASSERT_TRUE(robot.ok()) << robot.error().message;
  host.set_robot(robot->get());

  auto defaults = loader.create<visnav::Camera>("sim", params({{"width_px", "160"}, {"height_px", "120"}}), host, "simulator");
  ASSERT_TRUE(defaults.ok()) << defaults.error().message;
  const std::optional<visnav::CameraMount> d = (*defaults)->mount();
  ASSERT_TRUE(d.has_value());
  EXPECT_DOUBLE_EQ(d->hfov_deg, 60.0);
  EXPECT_DOUBLE_EQ(d->height_m, 0.5);
  EXPECT_DOUBLE_EQ(d->pitch_down_deg, 5.0);
  EXPECT_DOUBLE_EQ(d->forward_m, 0.0);
  EXPECT_DOUBLE_EQ(d->lateral_m, 0.0);
  EXPECT_TRUE(d->validate().ok());

  auto camera = loader.create<visnav::Camera>(
      "sim",
      params({{"width_px", "160"}, {"height_px", "120"}, {"hfov_deg", "75"}, {"mount_height_m", "0.8"},
              {"mount_pitch_down_deg", "12"}, {"mount_forward_m", "0.3"}, {"mount_lateral_m", "-0.1"}}),
      host, "simulator");
  ASSERT_TRUE(camera.ok()) << camera.error().message;
  const std::optional<visnav::CameraMount> m = (*camera)->mount();
  ASSERT_TRUE(m.has_value());
  EXPECT_DOUBLE_EQ(m->hfov_deg, 75.0);
  EXPECT_DOUBLE_EQ(m->height_m, 0.8);
  EXPECT_DOUBLE_EQ(m->pitch_down_deg, 12.0);
  EXPECT_DOUBLE_EQ(m->forward_m, 0.3);
  EXPECT_DOUBLE_EQ(m->lateral_m, -0.1);

  ASSERT_TRUE((*camera)->reconfigure(params({{"width_px", "160"}, {"height_px", "120"}, {"hfov_deg", "90"}})).ok());
  const std::optional<visnav::CameraMount> r = (*camera)->mount();
  ASSERT_TRUE(r.has_value());
  EXPECT_DOUBLE_EQ(r->hfov_deg, 90.0);
  EXPECT_DOUBLE_EQ(r->height_m, 0.5);  // keys left out of the new params are back at their defaults

  auto bad = loader.create<visnav::Camera>("sim", params({{"hfov_deg", "0"}}), host, "simulator");
  EXPECT_TRUE(fails_with(bad, ErrorCode::out_of_range, At{"test.yaml", 2, "hfov_deg"}));
}

TEST(SimPlugins, CliDispatchesTheSimCommand) {
  const std::string cli = VISNAV_TEST_CLI;
  if (!std::filesystem::exists(cli)) GTEST_SKIP() << "visnav CLI not built: " << cli;
  const std::string cmd = "VISNAV_PLUGIN_PATH= '" + cli + "' sim snapshot --help > /dev/null 2>&1";
  EXPECT_EQ(std::system(cmd.c_str()), 0);
  const std::string bad = "'" + cli + "' sim snapshot --world no_such_world --pose 0,0,0 -o /dev/null > /dev/null 2>&1";
  EXPECT_NE(std::system(bad.c_str()), 0);
}
