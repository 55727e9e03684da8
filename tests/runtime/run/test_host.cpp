// Host services: logger levels, telemetry JSON lines, clocks, create_detector, camera_mount.
#include <csignal>
#include <cstdio>
#include <optional>
#include <thread>

#include "error_expect.hpp"
#include "run_test_util.hpp"

using namespace visnav;
using visnav::test::contains;
using visnav::test::TempDir;

TEST(Host, LoggerDropsMessagesBelowItsLevel) {
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  StderrLogger logger(LogLevel::warn, f);
  logger.info("run", "hidden");
  logger.warn("run", "shown");
  logger.set_level(LogLevel::debug);
  logger.log(LogLevel::debug, "bt", "now visible");
  std::rewind(f);
  char buf[256] = {};
  const std::size_t n = std::fread(buf, 1, sizeof buf - 1, f);
  std::fclose(f);
  const std::string text(buf, n);
  EXPECT_EQ(text, "visnav [W] run: shown\nvisnav [D] bt: now visible\n");
  EXPECT_TRUE(parse_log_level("warning"));
  EXPECT_FALSE(parse_log_level("loud"));
}

TEST(Host, TelemetryWritesOneEscapedJsonLinePerStatus) {
  TempDir dir;
  ManualClock clock(1.5);
  {
    auto t = JsonLinesTelemetry::open(dir.file("t.jsonl"), clock);
    ASSERT_TRUE(t) << t.error().message;
    NavStatus s;
    s.node_path = "Main/\"quoted\"\\path";
    s.edge = "e1";
    s.matches = 42;
    s.command = {0.25, -0.5};
    s.confidence = 0.75;
    s.blind_m = 1.25;
    s.status = "line\nbreak";
    (*t)->publish(s);
    clock.advance(0.5);
    (*t)->publish(NavStatus{});
    EXPECT_EQ((*t)->published(), 2u);
  }
  const std::string text = visnav::test::read_file(dir.file("t.jsonl"));
  EXPECT_TRUE(contains(text, "{\"t_s\":1.5000,\"node_path\":\"Main/\\\"quoted\\\"\\\\path\",\"map_node\":\"\",\"edge\":\"e1\""))
      << text;
  EXPECT_TRUE(contains(text, "\"matches\":42,")) << text;
  EXPECT_TRUE(contains(text, "\"linear_mps\":0.2500,\"angular_radps\":-0.5000,\"confidence\":0.750,\"blind_m\":1.250,"
                             "\"status\":\"line\\nbreak\"}\n")) << text;
  EXPECT_TRUE(contains(text, "{\"t_s\":2.0000,")) << text;
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 2);
}

TEST(Host, TelemetryFileThatCannotBeOpenedIsAnError) {
  ManualClock clock;
  auto t = JsonLinesTelemetry::open("/nonexistent/dir/t.jsonl", clock);
  ASSERT_FALSE(t);
  EXPECT_TRUE(visnav::test::fails_with(t, ErrorCode::io, visnav::test::At{"/nonexistent/dir/t.jsonl"}));
}

TEST(Host, CreateDetectorGoesThroughTheLoader) {
  TempDir dir;
  visnav::test::CaptureLogger log;
  auto s = visnav::test::fixture_session(dir.write("c.yaml", visnav::test::fixture_config()), &log);
  ASSERT_TRUE(s) << s.error().message;
  HostServices& host = (*s)->host();
  auto d = host.create_detector("grid_l2", ConfigNode{});
  ASSERT_TRUE(d) << d.error().message;
  EXPECT_EQ((*d)->norm(), DescriptorNorm::l2);
  auto missing = host.create_detector("sift9000", ConfigNode{});
  ASSERT_FALSE(missing);
  EXPECT_TRUE(visnav::test::fails_with(missing, ErrorCode::not_found));
}

TEST(Host, SimulationClockFollowsTheSimulation) {
  TempDir dir;
  visnav::test::CaptureLogger log;
  auto s = visnav::test::fixture_session(dir.write("c.yaml", visnav::test::fixture_config()), &log);
  ASSERT_TRUE(s) << s.error().message;
  SimulationControl* sim = (*s)->robot().simulation();
  ASSERT_NE(sim, nullptr);
  const double before = (*s)->clock().now_s();
  ASSERT_TRUE(sim->step(0.25));
  EXPECT_DOUBLE_EQ((*s)->clock().now_s(), before + 0.25);
}

TEST(Host, StopRequestIsSeenQuicklyAtLowTickRates) {
  TempDir dir;
  visnav::test::CaptureLogger log;
  auto s = visnav::test::fixture_session(
      dir.write("c.yaml", visnav::test::fixture_config("{simulated: false}", "{frame_period_s: 0.01}",
                                                       "{tick: rate, rate_hz: 0.2, max_frame_age_s: 60, max_odometry_age_s: 60}")),
      &log);
  ASSERT_TRUE(s) << s.error().message;
  dir.write("tree.xml", visnav::test::drive_tree(100.0));
  auto tree = (*s)->load_tree(dir.file("tree.xml"));
  ASSERT_TRUE(tree) << tree.error().message;
  std::atomic<int> flag{0};
  std::thread stopper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(150));
    flag.store(SIGTERM);
  });
  RunOptions o;
  o.stop_requested = &flag;
  const RunReport r = run_tree(**s, *tree, o);
  stopper.join();
  EXPECT_EQ(r.outcome, RunOutcome::interrupted);
  EXPECT_EQ(r.exit_code, 128 + SIGTERM);
  EXPECT_EQ(r.ticks, 1u);           // the first tick happens at once, the next one is 5 s away
  EXPECT_LT(r.wall_time_s, 1.0);    // but the stop is seen within a slice
}

namespace {

/// A camera that declares `mount` (nullopt: none) and never delivers a frame.
class MountCamera final : public Camera {
 public:
  explicit MountCamera(std::optional<CameraMount> mount) : mount_(mount) {}
  [[nodiscard]] std::optional<CameraMount> mount() const override { return mount_; }
  Result<std::optional<Frame>> grab(double) override { return std::optional<Frame>{}; }
  std::optional<CameraMount> mount_;
};

CameraMount test_mount() {
  CameraMount m;
  m.hfov_deg = 72.0;
  m.height_m = 0.35;
  m.pitch_down_deg = 12.0;
  m.forward_m = 0.2;
  m.lateral_m = -0.05;
  return m;
}

class NoDevicesHost final : public HostServices {
 public:
  Logger& logger() override { return logger_; }
  const Clock& clock() override { return clock_; }
  Result<std::unique_ptr<Detector>> create_detector(std::string_view, const ConfigNode&) override {
    return fail("no detectors");
  }

 private:
  StderrLogger logger_{LogLevel::error};
  ManualClock clock_;
};

}  // namespace

TEST(HostCameraMount, HostServicesDefaultIsNotRunning) {
  NoDevicesHost host;
  auto m = host.camera_mount();
  ASSERT_FALSE(m);
  EXPECT_TRUE(visnav::test::fails_with(m, ErrorCode::missing));
  EXPECT_TRUE(contains(m.error().message, "not running")) << m.error().message;
}

TEST(HostCameraMount, WithoutACameraItIsNotRunning) {
  PluginLoader loader(std::vector<std::string>{});
  StderrLogger logger(LogLevel::error);
  ManualClock clock;
  RuntimeHost host(loader, logger, clock);
  auto m = host.camera_mount();
  ASSERT_FALSE(m);
  EXPECT_TRUE(visnav::test::fails_with(m, ErrorCode::missing));
  EXPECT_TRUE(contains(m.error().message, "no camera mount: not running")) << m.error().message;
  // A camera set and then taken away again: not running either.
  MountCamera cam(test_mount());
  host.set_camera(&cam, "camera 'x' (c.yaml:2)");
  ASSERT_TRUE(host.camera_mount());
  host.set_camera(nullptr, {});
  EXPECT_TRUE(visnav::test::fails_with(host.camera_mount(), ErrorCode::missing));
}

TEST(HostCameraMount, CameraWithoutAMountNamesTheCameraAndTheKeysToAdd) {
  PluginLoader loader(std::vector<std::string>{});
  StderrLogger logger(LogLevel::error);
  ManualClock clock;
  RuntimeHost host(loader, logger, clock);
  MountCamera cam(std::nullopt);
  host.set_camera(&cam, "camera 'v4l2' (config.yaml:12)");
  auto m = host.camera_mount();
  ASSERT_FALSE(m);
  EXPECT_TRUE(visnav::test::fails_with(m, ErrorCode::missing, visnav::test::key_only("camera.params")));
  const std::string& text = m.error().message;
  EXPECT_TRUE(contains(text, "camera 'v4l2' (config.yaml:12) declares no mount")) << text;
  EXPECT_TRUE(contains(text, "hfov_deg, mount_height_m, mount_pitch_down_deg")) << text;
  EXPECT_TRUE(contains(text, "camera.params")) << text;
}

TEST(HostCameraMount, CameraWithAMountReportsItsValues) {
  PluginLoader loader(std::vector<std::string>{});
  StderrLogger logger(LogLevel::error);
  ManualClock clock;
  RuntimeHost host(loader, logger, clock);
  MountCamera cam(test_mount());
  host.set_camera(&cam, "camera 'image_folder' (c.yaml:2)");
  auto m = host.camera_mount();
  ASSERT_TRUE(m) << m.error().message;
  EXPECT_DOUBLE_EQ(m->hfov_deg, 72.0);
  EXPECT_DOUBLE_EQ(m->height_m, 0.35);
  EXPECT_DOUBLE_EQ(m->pitch_down_deg, 12.0);
  EXPECT_DOUBLE_EQ(m->forward_m, 0.2);
  EXPECT_DOUBLE_EQ(m->lateral_m, -0.05);
  // Asked again after the camera's mount changed (a live reload): the new values.
  cam.mount_->hfov_deg = 90.0;
  auto again = host.camera_mount();
  ASSERT_TRUE(again) << again.error().message;
  EXPECT_DOUBLE_EQ(again->hfov_deg, 90.0);
  // A camera that breaks its contract (an invalid mount) is named, not passed on.
  cam.mount_->hfov_deg = 0.0;
  auto bad = host.camera_mount();
  ASSERT_FALSE(bad);
  EXPECT_TRUE(visnav::test::fails_with(bad, ErrorCode::out_of_range, visnav::test::key_only("hfov_deg")));
  EXPECT_TRUE(contains(bad.error().message, "camera 'image_folder' (c.yaml:2)")) << bad.error().message;
}

// The session hands its camera to the host with the config's type and location; the fixture
// camera declares no mount.
TEST(HostCameraMount, SessionNamesItsConfiguredCamera) {
  TempDir dir;
  visnav::test::CaptureLogger log;
  const std::string config = dir.write("c.yaml", visnav::test::fixture_config());
  auto s = visnav::test::fixture_session(config, &log);
  ASSERT_TRUE(s) << s.error().message;
  auto m = (*s)->host().camera_mount();
  ASSERT_FALSE(m);
  EXPECT_TRUE(visnav::test::fails_with(m, ErrorCode::missing));
  EXPECT_TRUE(contains(m.error().message, "camera 'fixture' (")) << m.error().message;
  EXPECT_TRUE(contains(m.error().message, "c.yaml:2) declares no mount")) << m.error().message;
  EXPECT_FALSE(contains(m.error().message, "not running")) << m.error().message;
}
