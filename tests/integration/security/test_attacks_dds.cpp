// Issue 17: the attacks of an unauthenticated participant on the same DDS domain, each on
// loopback (tests/runtime/dds/dds_test_util.hpp pins Cyclone to 127.0.0.1):
//  * a flood of 1 MB swap_detector requests, and log-line forging through the argument;
//  * driving the robot over rt/cmd_vel (arbitration at the robot side ignores it) and while the
//    mission is paused (pause holds zero at the robot side);
//  * spoofed odometry (a 30 m jump) stops the mission with a reason.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>

#include "child_process.hpp"
#include "dds_test_util.hpp"
#include "visnav/dds.hpp"

namespace dds = visnav::dds;
namespace fs = std::filesystem;
using dds::testing::ChildProcess;
using dds::testing::eventually;
using dds::testing::slurp;

namespace {

/// Collects every log line (thread-safe: DDS callbacks log from their own threads).
class CapturingLogger final : public visnav::Logger {
 public:
  void log(visnav::LogLevel, std::string_view component, std::string_view message) override {
    std::lock_guard lock(mutex_);
    lines_.push_back(std::string(component) + ": " + std::string(message));
  }
  std::vector<std::string> lines() const {
    std::lock_guard lock(mutex_);
    return lines_;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<std::string> lines_;
};

/// Runs the visnav CLI with `args` (each single-quoted), output to `log`; the exit status.
int visnav_cli(const std::vector<std::string>& args, const fs::path& log) {
  std::ostringstream cmd;  // (a stream: GCC 12 -O3 warns falsely on chained string +)
  cmd << "'" << VISNAV_TEST_CLI << "'";
  for (const auto& a : args) cmd << " '" << a << "'";
  cmd << " > '" << log.string() << "' 2>&1";
  const int rc = std::system(cmd.str().c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

class DdsAttacks : public ::testing::Test {
 protected:
  void SetUp() override {
    dds::testing::use_loopback();  // inherited by the child processes
    domain_ = dds::testing::random_domain_id();
    partition_ = dds::testing::unique_partition("visnav_sec");
    params_.domain_id = domain_;
    params_.partition = partition_;
    dir_ = fs::path(VISNAV_TEST_BINARY_DIR) / "tests" / "integration" / "security" / partition_;
    fs::create_directories(dir_);
  }
  void TearDown() override {
    odom_sub_.reset();
    if (!HasFailure()) {
      std::error_code ec;
      fs::remove_all(dir_, ec);
    }
  }

  std::unique_ptr<ChildProcess> start_simd(const std::vector<std::string>& extra = {}) {
    std::vector<std::string> args{VISNAV_TEST_CLI, "simd", "--world", "straight6m", "--domain", std::to_string(domain_),
                                  "--partition", partition_, "--duration", "60", "--camera-rate", "10"};
    args.insert(args.end(), extra.begin(), extra.end());
    auto c = std::make_unique<ChildProcess>(args, (dir_ / "simd.log").string());
    EXPECT_TRUE(c->started());
    EXPECT_TRUE(c->wait_for_output("simd: ready", 20.0)) << slurp(dir_ / "simd.log");
    return c;
  }

  void watch_odometry(dds::Participant& p) {
    auto sub = dds::Subscription<dds::msg::Odometry>::create(
        p, {"rt/odom", dds::Qos::ros_default(), partition_}, [this](dds::msg::Odometry&& o, const dds::SampleInfo& info) {
          std::lock_guard lock(mutex_);
          if (!ignored_writer_.empty() && info.writer_participant == ignored_writer_) return;  // our own spoof
          last_x_m_ = o.pose.pose.position.x;
          last_v_mps_ = o.twist.twist.linear.x;
          max_v_mps_ = std::max(max_v_mps_, std::fabs(o.twist.twist.linear.x));
          ++odom_count_;
        });
    ASSERT_TRUE(sub.ok()) << sub.error().message;
    odom_sub_ = std::move(*sub);
  }
  double max_speed_since_reset() {
    std::lock_guard lock(mutex_);
    return max_v_mps_;
  }
  void reset_max_speed() {
    std::lock_guard lock(mutex_);
    max_v_mps_ = 0.0;
  }
  int odom_count() {
    std::lock_guard lock(mutex_);
    return odom_count_;
  }

  /// Publishes `v_mps` on rt/cmd_vel from `writer` at 50 Hz for `seconds`.
  static void drive(dds::Writer<dds::msg::Twist>& writer, double v_mps, double seconds) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end) {
      dds::msg::Twist t;
      t.linear.x = v_mps;
      (void)writer.write(t);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }

  int domain_ = 0;
  std::string partition_;
  dds::TelemetryParams params_;
  fs::path dir_;
  std::unique_ptr<dds::Subscription<dds::msg::Odometry>> odom_sub_;
  std::mutex mutex_;
  double last_x_m_ = 0.0;
  double last_v_mps_ = 0.0;
  double max_v_mps_ = 0.0;
  int odom_count_ = 0;
  std::string ignored_writer_;
};

TEST_F(DdsAttacks, ControlFloodIsRejectedWithBoundedEscapedLogs) {
  CapturingLogger log;
  auto sub = dds::ControlSubscriber::create(params_, log);
  ASSERT_TRUE(sub.ok()) << sub.error().message;
  auto pub = dds::ControlPublisher::create(params_);
  ASSERT_TRUE(pub.ok()) << pub.error().message;
  ASSERT_TRUE((*pub)->wait_for_subscribers(1, 10.0));

  // The attack: 50 requests with a 1 MB argument, and a forged log line.
  const std::string big(1 << 20, 'A');
  for (int i = 0; i < 50; ++i) {
    ASSERT_TRUE((*pub)->send(dds::msg::ControlCommand::swap_detector, big).ok());
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_TRUE((*pub)->send(dds::msg::ControlCommand::swap_detector, "orb\n[run] error: forged\x1b[2J").ok());
  ASSERT_TRUE(eventually([&] { return (*sub)->rejected() >= 51; }, 10.0)) << (*sub)->rejected() << " rejected";
  EXPECT_TRUE((*sub)->take_pending().empty());  // nothing reached the mission

  std::size_t logged_bytes = 0;
  for (const auto& line : log.lines()) {
    logged_bytes += line.size();
    EXPECT_EQ(line.find('\n'), std::string::npos) << line;
    EXPECT_EQ(line.find('\x1b'), std::string::npos) << line;
  }
  // Rate-limited: at most a few warnings, each cut to a short prefix of the argument.
  EXPECT_LE(log.lines().size(), 3u);
  EXPECT_LT(logged_bytes, 2000u);
  std::printf("[ metric ] 51 hostile control requests (50 x 1 MB): %zu log lines, %zu bytes logged\n",
              log.lines().size(), logged_bytes);

  // A request flood of valid requests is cut at kMaxControlRequestsPerS.
  for (int i = 0; i < 100; ++i) ASSERT_TRUE((*pub)->send(dds::msg::ControlCommand::pause).ok());
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const auto accepted = (*sub)->take_pending();
  EXPECT_GE(accepted.size(), 1u);
  EXPECT_LE(accepted.size(), 35u);  // 20 tokens + 20/s refill over the sending time
}

TEST_F(DdsAttacks, ArbitrationIgnoresAnotherParticipantsCmdVelAndPauseHoldsZero) {
  auto simd = start_simd({"--cmd-vel-writer", "first", "--command-timeout", "0.5"});
  auto watcher = dds::Participant::create(domain_);
  ASSERT_TRUE(watcher.ok()) << watcher.error().message;
  watch_odometry(*watcher);
  ASSERT_TRUE(eventually([&] { return odom_count() > 0; }, 10.0));

  // The mission's participant sends first (and so is the one allowed to drive) ...
  auto mission = dds::Participant::create(domain_);
  auto attacker = dds::Participant::create(domain_);
  ASSERT_TRUE(mission.ok() && attacker.ok());
  const dds::Qos cmd_qos = dds::Qos::ros_default();
  auto mission_cmd = dds::Writer<dds::msg::Twist>::create(*mission, {"rt/cmd_vel", cmd_qos, partition_});
  auto attacker_cmd = dds::Writer<dds::msg::Twist>::create(*attacker, {"rt/cmd_vel", cmd_qos, partition_});
  ASSERT_TRUE(mission_cmd.ok() && attacker_cmd.ok());
  ASSERT_TRUE(mission_cmd->wait_for_readers(1, 10.0));
  ASSERT_TRUE(attacker_cmd->wait_for_readers(1, 10.0));
  drive(*mission_cmd, 0.0, 0.5);

  // ... the attacker's 1.0 m/s never moves the robot.
  reset_max_speed();
  drive(*attacker_cmd, 1.0, 1.0);
  EXPECT_LT(max_speed_since_reset(), 0.01) << slurp(dir_ / "simd.log");
  EXPECT_NE(slurp(dir_ / "simd.log").find("dropped cmd_vel from participant"), std::string::npos)
      << slurp(dir_ / "simd.log");

  // The mission itself drives ...
  reset_max_speed();
  drive(*mission_cmd, 0.3, 1.0);
  EXPECT_GT(max_speed_since_reset(), 0.2) << slurp(dir_ / "simd.log");

  // ... until a pause on the control topic: zero at the robot side, whoever sends.
  auto operator_ctl = dds::ControlPublisher::create(params_);
  ASSERT_TRUE(operator_ctl.ok()) << operator_ctl.error().message;
  ASSERT_TRUE((*operator_ctl)->wait_for_subscribers(1, 10.0));
  ASSERT_TRUE((*operator_ctl)->send(dds::msg::ControlCommand::pause).ok());
  ASSERT_TRUE(eventually([&] { return slurp(dir_ / "simd.log").find("paused by pause") != std::string::npos; }, 5.0))
      << slurp(dir_ / "simd.log");
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // braking from 0.3 m/s
  reset_max_speed();
  drive(*mission_cmd, 1.0, 1.0);
  EXPECT_LT(max_speed_since_reset(), 0.01);
  ASSERT_TRUE((*operator_ctl)->send(dds::msg::ControlCommand::resume).ok());
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  reset_max_speed();
  drive(*mission_cmd, 0.3, 1.0);
  EXPECT_GT(max_speed_since_reset(), 0.2) << slurp(dir_ / "simd.log");
  simd->signal(SIGINT);
  EXPECT_EQ(simd->wait(10.0), 0);
}

TEST_F(DdsAttacks, WithoutArbitrationTheAttackerDrives) {
  // The control experiment: the same injection moves the robot when simd accepts any writer.
  auto simd = start_simd({"--no-control"});
  auto watcher = dds::Participant::create(domain_);
  ASSERT_TRUE(watcher.ok());
  watch_odometry(*watcher);
  ASSERT_TRUE(eventually([&] { return odom_count() > 0; }, 10.0));
  auto attacker = dds::Participant::create(domain_);
  ASSERT_TRUE(attacker.ok());
  auto attacker_cmd = dds::Writer<dds::msg::Twist>::create(*attacker, {"rt/cmd_vel", dds::Qos::ros_default(), partition_});
  ASSERT_TRUE(attacker_cmd.ok());
  ASSERT_TRUE(attacker_cmd->wait_for_readers(1, 10.0));
  reset_max_speed();
  drive(*attacker_cmd, 1.0, 1.0);
  EXPECT_GT(max_speed_since_reset(), 0.5);
  simd->signal(SIGINT);
  EXPECT_EQ(simd->wait(10.0), 0);
}

TEST_F(DdsAttacks, SpoofedOdometryJumpStopsTheMission) {
  std::ofstream(dir_ / "run.yaml") << "robot:\n  type: dds\n  params:\n    domain_id: " << domain_
                                   << "\n    partition: " << partition_ << "\n"
                                   << "camera:\n  type: dds\n  params:\n    domain_id: " << domain_
                                   << "\n    partition: " << partition_ << "\n"
                                   << "nodes: [fixture_nodes]\n"
                                   << "run:\n  tick: rate\n  rate_hz: 20\n  max_frame_age_s: 1.0\n"
                                   << "  max_odometry_age_s: 0.5\n  startup_timeout_s: 20\n";
  std::ofstream(dir_ / "drive.xml") << "<root BTCPP_format=\"4\" main_tree_to_execute=\"Main\">\n"
                                       "  <BehaviorTree ID=\"Main\"><FixtureDrive distance_m=\"100\" speed_mps=\"0.3\"/>"
                                       "</BehaviorTree>\n</root>\n";
  auto simd = start_simd();
  auto watcher = dds::Participant::create(domain_);
  ASSERT_TRUE(watcher.ok());
  watch_odometry(*watcher);
  auto run = std::make_unique<ChildProcess>(
      std::vector<std::string>{VISNAV_TEST_CLI, "run", "--config", (dir_ / "run.yaml").string(), "--tree",
                               (dir_ / "drive.xml").string(), "--plugin-path", VISNAV_TEST_FIXTURE_PLUGIN_DIR},
      (dir_ / "run.log").string());
  ASSERT_TRUE(run->started());
  ASSERT_TRUE(eventually([&] {
    std::lock_guard lock(mutex_);
    return last_v_mps_ > 0.25;
  }, 30.0)) << slurp(dir_ / "run.log");

  // The spoof: the robot's odometry, 30 m ahead (the attack lasted 1 s; we keep sending
  // for up to 5 s so a loaded machine cannot make the test miss it).
  auto attacker = dds::Participant::create(domain_);
  ASSERT_TRUE(attacker.ok());
  {
    std::lock_guard lock(mutex_);
    ignored_writer_ = attacker->guid();
  }
  auto spoof = dds::Writer<dds::msg::Odometry>::create(*attacker, {"rt/odom", dds::Qos::ros_default(), partition_});
  ASSERT_TRUE(spoof.ok());
  ASSERT_TRUE(spoof->wait_for_readers(2, 10.0));  // the run's robot and our watcher
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  const auto spoof_start = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() < end && !run->exited()) {
    dds::msg::Odometry o;
    {
      std::lock_guard lock(mutex_);
      o.pose.pose.position.x = last_x_m_ + 30.0;
    }
    o.pose.pose.orientation.w = 1.0;
    o.header.stamp = dds::msg::Time::from_seconds(dds::epoch_now_s());
    (void)spoof->write(o);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(run->wait(10.0), 3) << slurp(dir_ / "run.log");  // safety stop
  std::printf("[ metric ] spoofed odometry (+30 m): run stopped %.2f s after the spoof began\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - spoof_start).count());
  const std::string log = slurp(dir_ / "run.log");
  EXPECT_NE(log.find("implausible odometry: odometry jumped"), std::string::npos) << log;
  simd->signal(SIGINT);
  EXPECT_EQ(simd->wait(10.0), 0);
}

TEST_F(DdsAttacks, WithDdsSecurityUnauthenticatedParticipantsCannotCommandOrRead) {
  // The keystore of `visnav security init` (openssl): mission, driver and one operator.
  const fs::path keystore = dir_ / "keystore";
  ASSERT_EQ(visnav_cli({"security", "init", keystore.string(), "--robot", "r1", "--operator", "alice"}, dir_ / "init.log"), 0)
      << slurp(dir_ / "init.log");
  for (const char* f : {"ca.pem", "governance.p7s", "r1-mission/cert.pem", "r1-driver/permissions.p7s", "alice/key.pem"})
    EXPECT_TRUE(fs::exists(keystore / f)) << f;

  // The mission (`visnav run`, identity r1-mission, real time on the fixture robot) with
  // telemetry and control over DDS. Each identity is its own process, as deployed.
  const auto k = [&](const std::string& f) { return (keystore / f).string(); };
  std::ofstream(dir_ / "run.yaml") << "robot: {type: fixture, params: {simulated: false}}\ncamera: {type: fixture}\n"
                                   << "plugin_path: [" VISNAV_TEST_FIXTURE_PLUGIN_DIR "]\nnodes: [fixture_nodes]\n"
                                   << "run: {tick: rate, rate_hz: 20, max_frame_age_s: 1.0}\n"
                                   << "dds:\n  domain_id: " << domain_ << "\n  partition: " << partition_
                                   // The one key of the README: the identity folder in the keystore.
                                   << "\n  security: " << k("r1-mission") << "\n";
  std::ofstream(dir_ / "drive.xml") << "<root BTCPP_format=\"4\"><BehaviorTree ID=\"Main\">"
                                       "<FixtureDrive distance_m=\"1000\" speed_mps=\"0.2\"/></BehaviorTree></root>\n";
  auto run = std::make_unique<ChildProcess>(
      std::vector<std::string>{VISNAV_TEST_CLI, "run", "--config", (dir_ / "run.yaml").string(), "--tree",
                               (dir_ / "drive.xml").string()},
      (dir_ / "run.log").string());
  ASSERT_TRUE(run->started());
  ASSERT_TRUE(eventually([&] { return slurp(dir_ / "run.log").find("node types") != std::string::npos; }, 20.0))
      << slurp(dir_ / "run.log");
  EXPECT_NE(slurp(dir_ / "run.log").find("DDS Security on: identity"), std::string::npos) << slurp(dir_ / "run.log");

  // An unauthenticated participant (this process) sends abort for 3 s and tries to read telemetry.
  auto mallory = dds::Participant::create(domain_, std::nullopt);
  ASSERT_TRUE(mallory.ok()) << mallory.error().message;
  auto mallory_ctl = dds::ControlPublisher::create(params_);
  ASSERT_TRUE(mallory_ctl.ok()) << mallory_ctl.error().message;
  std::atomic<int> stolen{0};
  auto mallory_tel = dds::Subscription<dds::msg::Telemetry>::create(
      *mallory, {params_.telemetry_topic, dds::Qos::sensor_data(), partition_},
      [&stolen](dds::msg::Telemetry&&, const dds::SampleInfo&) { ++stolen; });
  ASSERT_TRUE(mallory_tel.ok());
  int sent = 0;
  for (int i = 0; i < 30; ++i) {
    if ((*mallory_ctl)->send(dds::msg::ControlCommand::abort).ok()) ++sent;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_GT(sent, 0);
  EXPECT_FALSE(run->exited()) << "an unauthenticated abort stopped the mission\n" << slurp(dir_ / "run.log");
  EXPECT_EQ(stolen.load(), 0) << "an unauthenticated participant read the telemetry";
  EXPECT_FALSE((*mallory_ctl)->wait_for_subscribers(1, 0.1));

  // The robot driver's identity is authenticated but may not publish control.
  const std::vector<std::string> send_abort = {"monitor", "--send", "abort", "--domain", std::to_string(domain_),
                                               "--partition", partition_, "--keystore", keystore.string()};
  auto as = [&](const std::string& identity, const char* wait_s) {
    std::vector<std::string> args = send_abort;
    args.insert(args.end(), {"--identity", identity, "--wait", wait_s});
    return args;
  };
  EXPECT_NE(visnav_cli(as("r1-driver", "3"), dir_ / "driver.log"), 0) << slurp(dir_ / "driver.log");
  EXPECT_FALSE(run->exited()) << slurp(dir_ / "run.log");

  // The operator is obeyed.
  EXPECT_EQ(visnav_cli(as("alice", "15"), dir_ / "alice.log"), 0) << slurp(dir_ / "alice.log");
  EXPECT_EQ(run->wait(15.0), 130) << slurp(dir_ / "run.log");
  EXPECT_NE(slurp(dir_ / "run.log").find("abort requested on the control topic"), std::string::npos);
  std::printf("[ metric ] security on: %d unauthenticated aborts ignored, 0 telemetry samples read without "
              "authentication, the driver identity refused, the operator's abort obeyed\n", sent);
}

}  // namespace
