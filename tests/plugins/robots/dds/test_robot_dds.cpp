// The `dds` robot: cmd_vel out, odometry in, against a fake ROS 2 robot on DDS.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <mutex>
#include <thread>

#include "dds_test_util.hpp"
#include "odometry_tracker.hpp"
#include "visnav/config.hpp"
#include "visnav/dds.hpp"
#include "visnav/loader.hpp"
#include "visnav/runtime_host.hpp"
#include "error_expect.hpp"

namespace dds = visnav::dds;
using dds::testing::eventually;

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;

namespace {

// ---- core ------------------------------------------------------------------------------------

dds::msg::Odometry odom_at(double x, double y, double yaw, double v = 0.0) {
  dds::msg::Odometry o;
  o.pose.pose.position = {x, y, 0.0};
  o.pose.pose.orientation = dds::quaternion_from_yaw(yaw);
  o.twist.twist.linear.x = v;
  return o;
}

TEST(OdometryTracker, IntegratesSignedPathLength) {
  visnav::robot_dds::OdometryTracker tracker;
  auto a = tracker.update(odom_at(0, 0, 0), 1.0);
  ASSERT_TRUE(a.ok());
  EXPECT_EQ(a->distance_m, 0.0);
  EXPECT_EQ(a->timestamp_s, 1.0);
  auto b = tracker.update(odom_at(1.0, 0, 0, 0.5), 2.0);
  ASSERT_TRUE(b.ok());
  EXPECT_NEAR(b->distance_m, 1.0, 1e-12);
  EXPECT_EQ(b->twist.linear_mps, 0.5);
  // Reversing subtracts.
  auto c = tracker.update(odom_at(0.5, 0, 0, -0.5), 3.0);
  EXPECT_NEAR(c->distance_m, 0.5, 1e-12);
  // Quarter circle of radius 1 driven forward in small steps: ~pi/2.
  tracker.reset();
  for (int i = 0; i <= 100; ++i) {
    const double th = (M_PI / 2) * i / 100.0;
    ASSERT_TRUE(tracker.update(odom_at(std::sin(th), 1 - std::cos(th), th), i).ok());
  }
  EXPECT_NEAR(tracker.distance_m(), M_PI / 2, 1e-3);
}

TEST(OdometryTracker, RejectsMalformedSamplesWithoutChangingState) {
  visnav::robot_dds::OdometryTracker tracker;
  ASSERT_TRUE(tracker.update(odom_at(1, 2, 0.5), 0).ok());
  auto nan = odom_at(NAN, 0, 0);
  EXPECT_FALSE(tracker.update(nan, 1).ok());
  auto inf = odom_at(0, 0, 0);
  inf.twist.twist.angular.z = INFINITY;
  EXPECT_FALSE(tracker.update(inf, 1).ok());
  auto zero_q = odom_at(0, 0, 0);
  zero_q.pose.pose.orientation = {0, 0, 0, 0};
  auto r = tracker.update(zero_q, 1);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("quaternion"), std::string::npos);
  auto next = tracker.update(odom_at(2, 2, 0), 2);
  ASSERT_TRUE(next.ok());
  EXPECT_NEAR(next->distance_m, std::cos(0.25) * 1.0, 1e-9);  // from (1,2) heading 0.5 -> 0
}

TEST(OdometryTracker, RunClockMappingNeverGoesIntoTheFuture) {
  EXPECT_DOUBLE_EQ(visnav::robot_dds::to_run_clock(100.0, 100.25, 5.0), 4.75);
  EXPECT_DOUBLE_EQ(visnav::robot_dds::to_run_clock(101.0, 100.0, 5.0), 5.0);
  auto t = visnav::robot_dds::to_ros_twist(visnav::Twist{0.3, -0.1});
  EXPECT_EQ(t.linear.x, 0.3);
  EXPECT_EQ(t.angular.z, -0.1);
  EXPECT_EQ(t.linear.y, 0.0);
}

// ---- plugin ----------------------------------------------------------------------------------

class CapturingLogger final : public visnav::Logger {
 public:
  void log(visnav::LogLevel level, std::string_view component, std::string_view message) override {
    std::lock_guard lock(mutex_);
    if (level == visnav::LogLevel::warn) warnings_.push_back(std::string(component) + ": " + std::string(message));
  }
  std::vector<std::string> warnings() {
    std::lock_guard lock(mutex_);
    return warnings_;
  }

 private:
  std::mutex mutex_;
  std::vector<std::string> warnings_;
};

/// A ROS-2-like differential-drive robot on DDS: integrates rt/cmd_vel, publishes rt/odom at 100 Hz.
class FakeRobot {
 public:
  FakeRobot(int domain, const std::string& partition) {
    auto p = dds::Participant::create(domain);
    EXPECT_TRUE(p.ok());
    participant_.emplace(*p);
    auto w = dds::Writer<dds::msg::Odometry>::create(*participant_, {"rt/odom", dds::Qos::ros_default(), partition});
    EXPECT_TRUE(w.ok());
    odom_.emplace(std::move(*w));
    auto s = dds::Subscription<dds::msg::Twist>::create(
        *participant_, {"rt/cmd_vel", dds::Qos::ros_default(), partition}, [this](dds::msg::Twist&& t, const dds::SampleInfo&) {
          std::lock_guard lock(mutex_);
          command_ = t;
          ++commands_;
        });
    EXPECT_TRUE(s.ok());
    cmd_ = std::move(*s);
    thread_ = std::thread([this] { run(); });
  }
  ~FakeRobot() {
    stop_ = true;
    thread_.join();
  }
  dds::msg::Twist command() {
    std::lock_guard lock(mutex_);
    return command_;
  }
  int commands() {
    std::lock_guard lock(mutex_);
    return commands_;
  }
  void publish_raw(const dds::msg::Odometry& o) { (void)odom_->write(o); }
  void pause(bool paused) { paused_ = paused; }

 private:
  void run() {
    const double dt = 0.01;
    while (!stop_) {
      if (!paused_) {
        dds::msg::Twist c = command();
        x_ += c.linear.x * std::cos(yaw_) * dt;
        y_ += c.linear.x * std::sin(yaw_) * dt;
        yaw_ += c.angular.z * dt;
        auto o = odom_at(x_, y_, yaw_, c.linear.x);
        o.twist.twist.angular.z = c.angular.z;
        o.header.stamp = dds::msg::Time::from_seconds(dds::epoch_now_s());
        o.header.frame_id = "odom";
        (void)odom_->write(o);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  std::optional<dds::Participant> participant_;
  std::optional<dds::Writer<dds::msg::Odometry>> odom_;
  std::unique_ptr<dds::Subscription<dds::msg::Twist>> cmd_;
  std::mutex mutex_;
  dds::msg::Twist command_;
  int commands_ = 0;
  double x_ = 0, y_ = 0, yaw_ = 0;
  std::atomic<bool> stop_{false};
  std::atomic<bool> paused_{false};
  std::thread thread_;
};

class RobotDdsPlugin : public ::testing::Test {
 protected:
  void SetUp() override {
    dds::testing::use_loopback();
    domain_ = dds::testing::random_domain_id();
    partition_ = dds::testing::unique_partition();
    loader_ = std::make_unique<visnav::PluginLoader>(std::vector<std::string>{VISNAV_TEST_PLUGIN_DIR});
    ASSERT_TRUE(loader_->load_library("robot_dds").ok());
    host_ = std::make_unique<visnav::RuntimeHost>(*loader_, logger_, clock_);
  }
  visnav::Result<visnav::PluginPtr<visnav::Robot>> make_robot(const std::string& extra = "") {
    auto params = visnav::parse_yaml_string("domain_id: " + std::to_string(domain_) + "\npartition: " + partition_ + "\n" + extra,
                                            "robot.yaml");
    EXPECT_TRUE(params.ok());
    return loader_->create<visnav::Robot>("dds", *params, *host_);
  }
  int domain_ = 0;
  std::string partition_;
  CapturingLogger logger_;
  visnav::WallClock clock_;
  std::unique_ptr<visnav::PluginLoader> loader_;
  std::unique_ptr<visnav::RuntimeHost> host_;
};

TEST_F(RobotDdsPlugin, DrivesAFakeRobotAndReportsItsOdometry) {
  FakeRobot fake(domain_, partition_);
  auto robot = make_robot("connect_timeout_s: 5\n");
  ASSERT_TRUE(robot.ok()) << robot.error().message;
  ASSERT_TRUE((*robot)->latest_odometry().has_value());
  EXPECT_EQ((*robot)->simulation(), nullptr);

  // Keep commanding (like a tick loop) until the fake robot has moved 0.1 m forward.
  std::optional<visnav::Odometry> odom;
  ASSERT_TRUE(eventually([&] {
    EXPECT_TRUE((*robot)->send_command(visnav::Twist{0.5, 0.2}).ok());
    odom = (*robot)->latest_odometry();
    return odom && odom->distance_m > 0.1;
  }));
  EXPECT_NEAR(fake.command().linear.x, 0.5, 1e-12);
  EXPECT_NEAR(fake.command().angular.z, 0.2, 1e-12);
  EXPECT_GT(odom->pose.x_m, 0.05);
  EXPECT_GT(odom->pose.heading_rad, 0.0);
  EXPECT_NEAR(odom->twist.linear_mps, 0.5, 1e-12);
  EXPECT_NEAR(odom->twist.angular_radps, 0.2, 1e-12);
  // Honest timestamps: the newest reading is at most a few tens of ms old on the run clock.
  EXPECT_LE(odom->timestamp_s, clock_.now_s());
  EXPECT_GT(odom->timestamp_s, clock_.now_s() - 0.1);

  ASSERT_TRUE((*robot)->stop().ok());
  ASSERT_TRUE(eventually([&] { return fake.command().linear.x == 0.0 && fake.command().angular.z == 0.0; }));

  // When odometry stops, its timestamp ages (the runtime's staleness check relies on this).
  fake.pause(true);
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const double stamp = (*robot)->latest_odometry()->timestamp_s;
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ((*robot)->latest_odometry()->timestamp_s, stamp);
  EXPECT_GT(clock_.now_s() - stamp, 0.2);
}

TEST_F(RobotDdsPlugin, HeaderTimestampsAreMappedOntoTheRunClock) {
  FakeRobot fake(domain_, partition_);
  fake.pause(true);
  auto robot = make_robot("timestamp: header\n");
  ASSERT_TRUE(robot.ok()) << robot.error().message;
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // discovery
  auto o = odom_at(1, 0, 0);
  o.header.stamp = dds::msg::Time::from_seconds(dds::epoch_now_s() - 2.0);  // 2 s old
  fake.publish_raw(o);
  ASSERT_TRUE(eventually([&] { return (*robot)->latest_odometry().has_value(); }));
  const double age = clock_.now_s() - (*robot)->latest_odometry()->timestamp_s;
  EXPECT_NEAR(age, 2.0, 0.1);
}

TEST_F(RobotDdsPlugin, MalformedOdometryIsDroppedWithAWarning) {
  FakeRobot fake(domain_, partition_);
  fake.pause(true);
  auto robot = make_robot();
  ASSERT_TRUE(robot.ok()) << robot.error().message;
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // discovery
  fake.publish_raw(odom_at(NAN, 0, 0));
  auto zero_q = odom_at(1, 1, 0);
  zero_q.pose.pose.orientation = {0, 0, 0, 0};
  fake.publish_raw(zero_q);
  ASSERT_TRUE(eventually([&] { return !logger_.warnings().empty(); }));
  EXPECT_FALSE((*robot)->latest_odometry().has_value());
  EXPECT_NE(logger_.warnings()[0].find("malformed odometry"), std::string::npos) << logger_.warnings()[0];
  fake.publish_raw(odom_at(3, 4, 0));
  ASSERT_TRUE(eventually([&] { return (*robot)->latest_odometry().has_value(); }));
  EXPECT_EQ((*robot)->latest_odometry()->pose.x_m, 3.0);
}

TEST_F(RobotDdsPlugin, WrongTypeOnOdomTopicIsReportedNotFatal) {
  auto robot = make_robot();
  ASSERT_TRUE(robot.ok());
  auto p = dds::Participant::create(domain_);
  auto wrong = dds::Writer<dds::msg::Twist>::create(*p, {"rt/odom", {}, partition_});
  ASSERT_TRUE(wrong.ok());
  ASSERT_TRUE(eventually([&] {
    for (const auto& w : logger_.warnings())
      if (w.find("ignoring a writer with type 'geometry_msgs::msg::dds_::Twist_'") != std::string::npos) return true;
    return false;
  }));
  (void)wrong->write(dds::msg::Twist{});
  EXPECT_FALSE((*robot)->latest_odometry().has_value());
}

// Arbitration (issue 17): with `odom_writer` only one participant's odometry is believed, by the
// rule visnav simd applies to cmd_vel (dds::WriterArbiter). A spoofer's 30 m jump is dropped.
TEST_F(RobotDdsPlugin, OdomWriterFirstLocksOntoTheFirstSenderAndDropsOthers) {
  FakeRobot fake(domain_, partition_);
  fake.pause(true);
  auto robot = make_robot("odom_writer: first\n");
  ASSERT_TRUE(robot.ok()) << robot.error().message;
  auto spoofer = dds::Participant::create(domain_);
  ASSERT_TRUE(spoofer.ok());
  auto spoofed = dds::Writer<dds::msg::Odometry>::create(*spoofer, {"rt/odom", dds::Qos::ros_default(), partition_});
  ASSERT_TRUE(spoofed.ok());
  // The robot's odometry arrives first and takes the lock.
  ASSERT_TRUE(eventually([&] {
    fake.publish_raw(odom_at(1, 0, 0));
    return (*robot)->latest_odometry().has_value();
  }));
  EXPECT_EQ((*robot)->latest_odometry()->pose.x_m, 1.0);
  ASSERT_TRUE(eventually([&] {
    (void)spoofed->write(odom_at(31, 0, 0));
    for (const auto& w : logger_.warnings())
      if (w.find("dropped odometry from participant '" + spoofer->guid() + "'") != std::string::npos) return true;
    return false;
  }));
  EXPECT_EQ((*robot)->latest_odometry()->pose.x_m, 1.0);
  fake.publish_raw(odom_at(1.5, 0, 0));  // the locked writer still reports
  ASSERT_TRUE(eventually([&] { return (*robot)->latest_odometry()->pose.x_m == 1.5; }));
}

TEST_F(RobotDdsPlugin, OdomWriterGuidAcceptsOnlyThatParticipant) {
  FakeRobot other(domain_, partition_);
  other.pause(true);
  auto driver = dds::Participant::create(domain_);
  ASSERT_TRUE(driver.ok());
  auto odom = dds::Writer<dds::msg::Odometry>::create(*driver, {"rt/odom", dds::Qos::ros_default(), partition_});
  ASSERT_TRUE(odom.ok());
  auto robot = make_robot("odom_writer: " + driver->guid() + "\n");
  ASSERT_TRUE(robot.ok()) << robot.error().message;
  ASSERT_TRUE(eventually([&] {
    other.publish_raw(odom_at(30, 0, 0));
    for (const auto& w : logger_.warnings())
      if (w.find("dropped odometry from participant") != std::string::npos) return true;
    return false;
  }));
  EXPECT_FALSE((*robot)->latest_odometry().has_value());
  ASSERT_TRUE(eventually([&] {
    (void)odom->write(odom_at(2, 0, 0));
    return (*robot)->latest_odometry().has_value();
  }));
  EXPECT_EQ((*robot)->latest_odometry()->pose.x_m, 2.0);
}

TEST_F(RobotDdsPlugin, ParamsAreValidated) {
  auto unknown = make_robot("odom_topic_typo: rt/odom\n");
  EXPECT_TRUE(fails_with(unknown, ErrorCode::unknown_key, visnav::test::key_only("odom_topic_typo")));
  auto bad_qos = make_robot("odom_reliability: sometimes\n");
  EXPECT_TRUE(fails_with(bad_qos, ErrorCode::out_of_range, visnav::test::key_only("odom_reliability")));
  auto writer = make_robot("odom_writer: 0123ABCD\n");
  EXPECT_TRUE(fails_with(writer, ErrorCode::invalid_value, visnav::test::key_only("odom_writer")));
  auto same = make_robot("odom_topic: rt/cmd_vel\n");
  EXPECT_FALSE(same.ok());
  auto timeout = make_robot("connect_timeout_s: 0.2\n");  // nobody publishes odometry
  ASSERT_FALSE(timeout.ok());
  EXPECT_NE(timeout.error().message.find("no odometry"), std::string::npos);
}

}  // namespace
