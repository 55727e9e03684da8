// Two processes on loopback: `visnav simd` (simulated robot + camera on DDS) and `visnav run`
// (dds robot + dds camera + a driving tree). Measures how long the robot keeps moving after the
// runtime is SIGKILLed, with an odometry subscriber in this test process.
#include <gtest/gtest.h>

#include <signal.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>

#include "child_process.hpp"
#include "dds_test_util.hpp"
#include "visnav/dds.hpp"

namespace dds = visnav::dds;
namespace fs = std::filesystem;
using dds::testing::ChildProcess;
using dds::testing::eventually;
using dds::testing::slurp;
using Clock = std::chrono::steady_clock;

namespace {

struct OdomSample {
  Clock::time_point received;
  double linear_mps;
  double angular_radps;
  double x_m;
  double y_m;
};

class TwoProcess : public ::testing::Test {
 protected:
  void SetUp() override {
    dds::testing::use_loopback();  // inherited by both children
    domain_ = dds::testing::random_domain_id();
    partition_ = dds::testing::unique_partition("visnav_it");
    dir_ = fs::path(VISNAV_TEST_BINARY_DIR) / "tests" / "integration" / "dds" / partition_;
    fs::create_directories(dir_);
    std::ofstream(dir_ / "run.yaml") << "robot:\n  type: dds\n  params:\n    domain_id: " << domain_
                                     << "\n    partition: " << partition_ << "\n"
                                     << "camera:\n  type: dds\n  params:\n    domain_id: " << domain_
                                     << "\n    partition: " << partition_ << "\n"
                                     << "nodes: [fixture_nodes]\n"
                                     << "run:\n  tick: rate\n  rate_hz: 20\n  max_frame_age_s: 1.0\n"
                                     << "  max_odometry_age_s: 0.5\n  startup_timeout_s: 20\n";
    std::ofstream(dir_ / "drive.xml")
        << "<root BTCPP_format=\"4\" main_tree_to_execute=\"Main\">\n"
           "  <BehaviorTree ID=\"Main\">\n"
           "    <FixtureDrive distance_m=\"100\" speed_mps=\"0.3\"/>\n"
           "  </BehaviorTree>\n"
           "</root>\n";
    auto p = dds::Participant::create(domain_);
    ASSERT_TRUE(p.ok()) << p.error().message;
    participant_.emplace(*p);
    auto sub = dds::Subscription<dds::msg::Odometry>::create(
        *participant_, {"rt/odom", dds::Qos::ros_default(), partition_},
        [this](dds::msg::Odometry&& o, const dds::SampleInfo&) {
          std::lock_guard lock(mutex_);
          odom_.push_back(OdomSample{Clock::now(), o.twist.twist.linear.x, o.twist.twist.angular.z,
                                     o.pose.pose.position.x, o.pose.pose.position.y});
        });
    ASSERT_TRUE(sub.ok()) << sub.error().message;
    odom_sub_ = std::move(*sub);
  }

  void TearDown() override {
    odom_sub_.reset();
    if (!HasFailure()) {  // keep the logs of failed runs
      std::error_code ec;
      fs::remove_all(dir_, ec);
    }
  }

  std::unique_ptr<ChildProcess> start_simd() {
    auto c = std::make_unique<ChildProcess>(
        std::vector<std::string>{VISNAV_TEST_CLI, "simd", "--world", "straight6m", "--domain", std::to_string(domain_),
                                 "--partition", partition_, "--duration", "60", "--camera-rate", "10"},
        (dir_ / "simd.log").string());
    EXPECT_TRUE(c->started());
    EXPECT_TRUE(c->wait_for_output("simd: ready", 20.0)) << slurp(dir_ / "simd.log");
    return c;
  }
  std::unique_ptr<ChildProcess> start_run() {
    auto c = std::make_unique<ChildProcess>(
        std::vector<std::string>{VISNAV_TEST_CLI, "run", "--config", (dir_ / "run.yaml").string(), "--tree",
                                 (dir_ / "drive.xml").string(), "--plugin-path", VISNAV_TEST_FIXTURE_PLUGIN_DIR},
        (dir_ / "run.log").string());
    EXPECT_TRUE(c->started());
    return c;
  }
  std::optional<OdomSample> last_odom() {
    std::lock_guard lock(mutex_);
    if (odom_.empty()) return std::nullopt;
    return odom_.back();
  }
  std::vector<OdomSample> odom_since(Clock::time_point t) {
    std::lock_guard lock(mutex_);
    std::vector<OdomSample> out;
    for (const auto& s : odom_)
      if (s.received >= t) out.push_back(s);
    return out;
  }

  int domain_ = 0;
  std::string partition_;
  fs::path dir_;
  std::optional<dds::Participant> participant_;
  std::unique_ptr<dds::Subscription<dds::msg::Odometry>> odom_sub_;
  std::mutex mutex_;
  std::vector<OdomSample> odom_;
};

TEST_F(TwoProcess, RobotStopsWithin300msAfterTheRuntimeIsKilled) {
  auto simd = start_simd();
  ASSERT_TRUE(eventually([&] { return last_odom().has_value(); }, 10.0)) << "no odometry from simd";
  auto run = start_run();
  // The runtime drives the simulated robot over DDS: wait until it moves at the commanded speed.
  const bool moving = eventually([&] {
    auto o = last_odom();
    return o && o->linear_mps > 0.29;
  }, 30.0);
  ASSERT_TRUE(moving) << "the robot never reached 0.3 m/s\n--- run.log\n" << slurp(dir_ / "run.log")
                      << "--- simd.log\n" << slurp(dir_ / "simd.log");
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // steady state
  ASSERT_FALSE(run->exited()) << slurp(dir_ / "run.log");

  run->signal(SIGKILL);
  const auto killed = Clock::now();
  ASSERT_EQ(run->wait(5.0), 128 + SIGKILL);

  std::optional<double> stop_ms;
  ASSERT_TRUE(eventually([&] {
    for (const auto& s : odom_since(killed))
      if (std::fabs(s.linear_mps) < 1e-3 && std::fabs(s.angular_radps) < 1e-3) {
        stop_ms = std::chrono::duration<double, std::milli>(s.received - killed).count();
        return true;
      }
    return false;
  }, 5.0)) << "the robot did not stop after the runtime was killed\n" << slurp(dir_ / "simd.log");
  // Stays stopped.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  auto after = last_odom();
  ASSERT_TRUE(after.has_value());
  EXPECT_LT(std::fabs(after->linear_mps), 1e-3);

  std::printf("[ measured ] robot stopped %.0f ms after SIGKILL of visnav run (limit 300 ms)\n", *stop_ms);
  RecordProperty("stop_after_kill_ms", static_cast<int>(std::lround(*stop_ms)));
  EXPECT_LT(*stop_ms, 300.0);
  EXPECT_NE(slurp(dir_ / "simd.log").find("watchdog: no cmd_vel"), std::string::npos);

  simd->signal(SIGTERM);
  EXPECT_EQ(simd->wait(10.0), 0) << slurp(dir_ / "simd.log");
}

TEST_F(TwoProcess, RuntimeStopsOnStaleOdometryWhenSimdDies) {
  auto simd = start_simd();
  auto run = start_run();
  ASSERT_TRUE(eventually([&] {
    auto o = last_odom();
    return o && o->linear_mps > 0.29;
  }, 30.0)) << slurp(dir_ / "run.log");
  simd->signal(SIGKILL);
  const auto killed = Clock::now();
  // The runtime notices stale odometry (max_odometry_age_s = 0.5) and ends with a safety stop.
  const int code = run->wait(10.0);
  const double exit_s = std::chrono::duration<double>(Clock::now() - killed).count();
  const std::string log = slurp(dir_ / "run.log");
  EXPECT_EQ(code, 3) << log;
  EXPECT_TRUE(log.find("stale odometry") != std::string::npos || log.find("stale camera") != std::string::npos) << log;
  std::printf("[ measured ] visnav run safety-stopped %.0f ms after SIGKILL of simd\n", exit_s * 1000.0);
  EXPECT_LT(exit_s, 2.0);
}

}  // namespace

namespace {

class NullLogger final : public visnav::Logger {
 public:
  void log(visnav::LogLevel, std::string_view, std::string_view) override {}
};

TEST_F(TwoProcess, MonitorPrintsTelemetryAndSendsControlRequests) {
  dds::TelemetryParams params;
  params.domain_id = domain_;
  params.partition = partition_;
  NullLogger logger;
  auto telemetry = dds::DdsTelemetry::create(params, logger);
  ASSERT_TRUE(telemetry.ok()) << telemetry.error().message;
  auto control = dds::ControlSubscriber::create(params, logger);
  ASSERT_TRUE(control.ok()) << control.error().message;

  ChildProcess monitor({VISNAV_TEST_CLI, "monitor", "--domain", std::to_string(domain_), "--partition", partition_, "--count",
                 "2", "--duration", "20"},
                (dir_ / "monitor.log").string());
  ASSERT_TRUE(monitor.started());
  ASSERT_TRUE(eventually([&] { return (*telemetry)->matched_readers() == 1; }, 10.0)) << slurp(dir_ / "monitor.log");
  visnav::NavStatus s;
  s.node_path = "Main/Replay";
  s.map_node = "gate";
  s.edge = "e7";
  s.distance_m = 2.5;
  s.matches = 90;
  s.inliers = 61;
  s.offset_px = -4.0;
  s.command = visnav::Twist{0.35, -0.1};
  s.status = "replaying";
  (*telemetry)->publish(s);
  s.status = "arrived";
  (*telemetry)->publish(s);
  ASSERT_TRUE(monitor.wait_for_output("arrived", 10.0)) << slurp(dir_ / "monitor.log");
  EXPECT_EQ(monitor.wait(5.0), 0);
  EXPECT_TRUE(monitor.wait_for_output("replaying", 0.1));  // output so far is kept by ChildProcess
  EXPECT_TRUE(monitor.wait_for_output("Main/Replay", 0.1));
  EXPECT_TRUE(monitor.wait_for_output("inl   61/90", 0.1));

  ChildProcess send({VISNAV_TEST_CLI, "monitor", "--send", "swap_detector", "--arg", "orb", "--domain", std::to_string(domain_),
              "--partition", partition_, "--wait", "10"},
             (dir_ / "send.log").string());
  ASSERT_TRUE(send.started());
  EXPECT_EQ(send.wait(15.0), 0) << slurp(dir_ / "send.log");
  std::vector<dds::ControlRequest> got;
  ASSERT_TRUE(eventually([&] {
    for (auto& r : (*control)->take_pending()) got.push_back(r);
    return !got.empty();
  }));
  EXPECT_EQ(got[0].command, dds::msg::ControlCommand::swap_detector);
  EXPECT_EQ(got[0].argument, "orb");
}

}  // namespace
