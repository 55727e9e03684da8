// The RAII layer over Cyclone DDS: typed round trips, QoS, partitions, subscriptions and the
// wrong-type-writer watch. Loopback only.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <mutex>

#include <opencv2/core.hpp>

#include "error_expect.hpp"
#include "dds_test_util.hpp"
#include "visnav/dds.hpp"

namespace dds = visnav::dds;
using dds::testing::eventually;

namespace {

class DdsLayer : public ::testing::Test {
 protected:
  void SetUp() override {
    dds::testing::use_loopback();
    ASSERT_TRUE(dds::available());
    domain_ = dds::testing::random_domain_id();
    partition_ = dds::testing::unique_partition();
    auto p = dds::Participant::create(domain_);
    ASSERT_TRUE(p.ok()) << p.error().message;
    participant_.emplace(*p);
  }
  dds::EndpointOptions options(const std::string& topic, dds::Qos qos = {}) const {
    return dds::EndpointOptions{topic, qos, partition_};
  }
  int domain_ = 0;
  std::string partition_;
  std::optional<dds::Participant> participant_;
};

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST_F(DdsLayer, TwistRoundTripKeepsValues) {
  auto writer = dds::Writer<dds::msg::Twist>::create(*participant_, options("rt/cmd_vel"));
  ASSERT_TRUE(writer.ok()) << writer.error().message;
  auto reader = dds::Reader<dds::msg::Twist>::create(*participant_, options("rt/cmd_vel"));
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  ASSERT_TRUE(writer->wait_for_readers(1, 5.0));
  EXPECT_EQ(reader->matched_writers(), 1);

  dds::msg::Twist sent;
  sent.linear = {0.5, -0.25, 0.125};
  sent.angular = {1.0, 2.0, -0.75};
  const double before_s = dds::epoch_now_s();
  ASSERT_TRUE(writer->write(sent).ok());
  auto ready = reader->wait(5.0);
  ASSERT_TRUE(ready.ok() && *ready);
  std::vector<dds::msg::Twist> got;
  dds::SampleInfo info;
  auto n = reader->take([&](dds::msg::Twist&& t, const dds::SampleInfo& i) { got.push_back(t); info = i; });
  ASSERT_TRUE(n.ok());
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].linear.x, 0.5);
  EXPECT_EQ(got[0].linear.y, -0.25);
  EXPECT_EQ(got[0].linear.z, 0.125);
  EXPECT_EQ(got[0].angular.x, 1.0);
  EXPECT_EQ(got[0].angular.y, 2.0);
  EXPECT_EQ(got[0].angular.z, -0.75);
  EXPECT_GE(info.source_time_s, before_s - 1e-3);
  EXPECT_GE(info.receive_time_s, info.source_time_s - 1e-3);
  EXPECT_LT(info.receive_time_s - before_s, 5.0);
  // Nothing more to take.
  auto again = reader->take([](dds::msg::Twist&&, const dds::SampleInfo&) {});
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(*again, 0u);
}

TEST_F(DdsLayer, OdometryRoundTripKeepsStringsAndCovariance) {
  auto writer = dds::Writer<dds::msg::Odometry>::create(*participant_, options("rt/odom"));
  auto reader = dds::Reader<dds::msg::Odometry>::create(*participant_, options("rt/odom"));
  ASSERT_TRUE(writer.ok() && reader.ok());
  ASSERT_TRUE(writer->wait_for_readers(1, 5.0));
  dds::msg::Odometry o;
  o.header.stamp = dds::msg::Time{1700000000, 123456789};
  o.header.frame_id = "odom";
  o.child_frame_id = "base_link";
  o.pose.pose.position = {1.5, -2.5, 0.0};
  o.pose.pose.orientation = dds::quaternion_from_yaw(0.75);
  for (int i = 0; i < 36; ++i) o.pose.covariance[static_cast<std::size_t>(i)] = i * 0.5;
  o.twist.twist.linear.x = 0.3;
  o.twist.twist.angular.z = -0.2;
  o.twist.covariance[35] = 9.0;
  ASSERT_TRUE(writer->write(o).ok());
  ASSERT_TRUE(*reader->wait(5.0));
  std::optional<dds::msg::Odometry> got;
  ASSERT_TRUE(reader->take([&](dds::msg::Odometry&& m, const dds::SampleInfo&) { got = std::move(m); }).ok());
  ASSERT_TRUE(got.has_value());
  EXPECT_EQ(got->header.stamp.sec, 1700000000);
  EXPECT_EQ(got->header.stamp.nanosec, 123456789u);
  EXPECT_EQ(got->header.frame_id, "odom");
  EXPECT_EQ(got->child_frame_id, "base_link");
  EXPECT_EQ(got->pose.pose.position.x, 1.5);
  EXPECT_EQ(got->pose.pose.position.y, -2.5);
  EXPECT_NEAR(dds::yaw_from_quaternion(got->pose.pose.orientation), 0.75, 1e-12);
  EXPECT_EQ(got->pose.covariance[35], 17.5);
  EXPECT_EQ(got->twist.twist.linear.x, 0.3);
  EXPECT_EQ(got->twist.twist.angular.z, -0.2);
  EXPECT_EQ(got->twist.covariance[35], 9.0);
}

TEST_F(DdsLayer, VgaImageRoundTripIsBitExact) {
  auto writer = dds::Writer<dds::msg::Image>::create(*participant_, options("rt/camera/image_raw"));
  auto reader = dds::Reader<dds::msg::Image>::create(*participant_, options("rt/camera/image_raw"));
  ASSERT_TRUE(writer.ok() && reader.ok());
  ASSERT_TRUE(writer->wait_for_readers(1, 5.0));
  cv::Mat image(480, 640, CV_8UC3);
  cv::randu(image, 0, 255);
  dds::msg::Image m;
  ASSERT_TRUE(dds::fill_image_message(image, m).ok());
  EXPECT_EQ(m.step, 640u * 3u);
  EXPECT_EQ(m.encoding, "bgr8");
  ASSERT_TRUE(writer->write(m).ok());
  ASSERT_TRUE(*reader->wait(5.0));
  std::optional<dds::msg::Image> got;
  ASSERT_TRUE(reader->take([&](dds::msg::Image&& i, const dds::SampleInfo&) { got = std::move(i); }).ok());
  ASSERT_TRUE(got.has_value());
  EXPECT_EQ(got->width, 640u);
  EXPECT_EQ(got->height, 480u);
  EXPECT_EQ(got->encoding, "bgr8");
  EXPECT_EQ(got->step, 1920u);
  EXPECT_EQ(got->data, m.data);
}

TEST_F(DdsLayer, FillImageMessageRejectsUnsupportedTypes) {
  dds::msg::Image m;
  EXPECT_FALSE(dds::fill_image_message(cv::Mat(), m).ok());
  EXPECT_FALSE(dds::fill_image_message(cv::Mat(4, 4, CV_32FC1), m).ok());
  ASSERT_TRUE(dds::fill_image_message(cv::Mat(3, 5, CV_8UC1, cv::Scalar(7)), m).ok());
  EXPECT_EQ(m.encoding, "mono8");
  EXPECT_EQ(m.data.size(), 15u);
}

TEST_F(DdsLayer, SubscriptionThreadDeliversIntoLatestSlot) {
  dds::LatestSlot<double> slot;
  auto sub = dds::Subscription<dds::msg::Twist>::create(
      *participant_, options("rt/cmd_vel", dds::Qos::ros_default()),  // keep-last 10: all 5 samples are seen
      [&](dds::msg::Twist&& t, const dds::SampleInfo&) { slot.put(t.linear.x); });
  ASSERT_TRUE(sub.ok()) << sub.error().message;
  auto writer = dds::Writer<dds::msg::Twist>::create(*participant_, options("rt/cmd_vel", dds::Qos::ros_default()));
  ASSERT_TRUE(writer.ok());
  ASSERT_TRUE(writer->wait_for_readers(1, 5.0));
  for (int i = 1; i <= 5; ++i) {
    dds::msg::Twist t;
    t.linear.x = i;
    ASSERT_TRUE(writer->write(t).ok());
  }
  auto last = slot.wait_newer(0, 5.0);
  ASSERT_TRUE(last.has_value());
  ASSERT_TRUE(eventually([&] { return slot.get() == 5.0; }));
  EXPECT_TRUE(eventually([&] { return (*sub)->stats().samples == 5; }));
  EXPECT_EQ((*sub)->stats().matched_writers, 1);
  EXPECT_EQ((*sub)->stats().wrong_type_writers, 0u);
  sub->reset();  // joins the thread; no handler runs afterwards
  dds::msg::Twist t;
  t.linear.x = 99;
  (void)writer->write(t);
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_EQ(slot.get(), 5.0);
}

TEST_F(DdsLayer, PartitionsIsolateTraffic) {
  auto writer = dds::Writer<dds::msg::Twist>::create(*participant_, options("rt/cmd_vel"));
  auto other = dds::Reader<dds::msg::Twist>::create(
      *participant_, dds::EndpointOptions{"rt/cmd_vel", {}, partition_ + "_other"});
  auto same = dds::Reader<dds::msg::Twist>::create(*participant_, options("rt/cmd_vel"));
  ASSERT_TRUE(writer.ok() && other.ok() && same.ok());
  ASSERT_TRUE(same->wait_for_writers(1, 5.0));
  ASSERT_TRUE(writer->write(dds::msg::Twist{}).ok());
  ASSERT_TRUE(*same->wait(5.0));
  EXPECT_EQ(other->matched_writers(), 0);
  EXPECT_EQ(*other->take([](dds::msg::Twist&&, const dds::SampleInfo&) {}), 0u);
}

TEST_F(DdsLayer, ReliableReaderDoesNotMatchBestEffortWriter) {
  auto writer = dds::Writer<dds::msg::Twist>::create(*participant_, options("rt/q", dds::Qos::sensor_data()));
  auto reliable = dds::Reader<dds::msg::Twist>::create(*participant_, options("rt/q", dds::Qos::ros_default()));
  auto best_effort = dds::Reader<dds::msg::Twist>::create(*participant_, options("rt/q", dds::Qos::sensor_data()));
  ASSERT_TRUE(writer.ok() && reliable.ok() && best_effort.ok());
  ASSERT_TRUE(best_effort->wait_for_writers(1, 5.0));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(reliable->matched_writers(), 0);
  EXPECT_EQ(writer->matched_readers(), 1);
}

TEST_F(DdsLayer, TransientLocalDeliversLastSampleToLateReader) {
  dds::Qos latched{dds::Reliability::reliable, dds::Durability::transient_local, 1, 0.0};
  auto writer = dds::Writer<dds::msg::Twist>::create(*participant_, options("rt/latched", latched));
  ASSERT_TRUE(writer.ok());
  dds::msg::Twist t;
  t.angular.z = 0.5;
  ASSERT_TRUE(writer->write(t).ok());
  t.angular.z = 0.75;
  ASSERT_TRUE(writer->write(t).ok());
  auto reader = dds::Reader<dds::msg::Twist>::create(*participant_, options("rt/latched", latched));
  ASSERT_TRUE(reader.ok());
  std::vector<double> got;
  ASSERT_TRUE(eventually([&] {
    (void)reader->take([&](dds::msg::Twist&& m, const dds::SampleInfo&) { got.push_back(m.angular.z); });
    return !got.empty();
  }));
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0], 0.75);
}

TEST_F(DdsLayer, DeadlineMissesAreCounted) {
  dds::Qos qos = dds::Qos::ros_default();
  qos.deadline_s = 0.02;
  auto sub = dds::Subscription<dds::msg::Twist>::create(*participant_, options("rt/deadline", qos),
                                                        [](dds::msg::Twist&&, const dds::SampleInfo&) {});
  auto writer = dds::Writer<dds::msg::Twist>::create(*participant_, options("rt/deadline", qos));
  ASSERT_TRUE(sub.ok() && writer.ok());
  ASSERT_TRUE(writer->wait_for_readers(1, 5.0));
  ASSERT_TRUE(writer->write(dds::msg::Twist{}).ok());
  EXPECT_TRUE(eventually([&] { return (*sub)->stats().deadline_missed >= 2; }, 5.0));
}

TEST_F(DdsLayer, WriterWithWrongTypeIsCountedAndNeverDelivered) {
  std::mutex mutex;
  std::vector<std::string> warnings;
  std::atomic<int> samples{0};
  auto sub = dds::Subscription<dds::msg::Image>::create(
      *participant_, options("rt/camera/image_raw"), [&](dds::msg::Image&&, const dds::SampleInfo&) { ++samples; },
      [&](const std::string& w) {
        std::lock_guard lock(mutex);
        warnings.push_back(w);
      });
  ASSERT_TRUE(sub.ok());
  // Another participant (as a foreign process would) publishes Twist on the image topic.
  auto foreign = dds::Participant::create(domain_);
  ASSERT_TRUE(foreign.ok());
  auto wrong = dds::Writer<dds::msg::Twist>::create(*foreign, options("rt/camera/image_raw"));
  ASSERT_TRUE(wrong.ok()) << wrong.error().message;
  ASSERT_TRUE(eventually([&] { return (*sub)->stats().wrong_type_writers == 1; }));
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(wrong->write(dds::msg::Twist{}).ok());
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(samples.load(), 0);
  EXPECT_EQ((*sub)->stats().matched_writers, 0);
  EXPECT_EQ((*sub)->stats().wrong_type_writers, 1u);  // counted once per writer
  std::lock_guard lock(mutex);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("geometry_msgs::msg::dds_::Twist_"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("sensor_msgs::msg::dds_::Image_"), std::string::npos) << warnings[0];
}

TEST_F(DdsLayer, BadArgumentsAreErrors) {
  EXPECT_FALSE(dds::Participant::create(-1).ok());
  EXPECT_FALSE(dds::Participant::create(233).ok());
  auto empty = dds::Writer<dds::msg::Twist>::create(*participant_, options(""));
  EXPECT_TRUE(fails_with(empty, ErrorCode::invalid_value, key_only("topic")));
  dds::Qos bad;
  bad.history_depth = -3;
  EXPECT_FALSE(dds::Reader<dds::msg::Twist>::create(*participant_, options("rt/x", bad)).ok());
  auto no_handler = dds::Subscription<dds::msg::Twist>::create(*participant_, options("rt/x"), {});
  EXPECT_FALSE(no_handler.ok());
  auto bad_name = dds::Writer<dds::msg::Twist>::create(*participant_, options("bad topic name with spaces"));
  EXPECT_FALSE(bad_name.ok());
}

TEST(DdsNames, RosTopicsAndTypes) {
  EXPECT_EQ(dds::ros_topic("/cmd_vel"), "rt/cmd_vel");
  EXPECT_EQ(dds::ros_topic("cmd_vel"), "rt/cmd_vel");
  EXPECT_EQ(dds::ros_topic("rt/odom"), "rt/odom");
  EXPECT_EQ(dds::ros_topic("/camera/image_raw/compressed"), "rt/camera/image_raw/compressed");
  EXPECT_STREQ(dds::MessageTraits<dds::msg::Twist>::type_name, "geometry_msgs::msg::dds_::Twist_");
  EXPECT_STREQ(dds::MessageTraits<dds::msg::Odometry>::type_name, "nav_msgs::msg::dds_::Odometry_");
  EXPECT_STREQ(dds::MessageTraits<dds::msg::Image>::type_name, "sensor_msgs::msg::dds_::Image_");
  EXPECT_STREQ(dds::MessageTraits<dds::msg::CompressedImage>::type_name, "sensor_msgs::msg::dds_::CompressedImage_");
}

TEST(DdsHelpers, TimeYawAndParsing) {
  auto t = dds::msg::Time::from_seconds(12.25);
  EXPECT_EQ(t.sec, 12);
  EXPECT_EQ(t.nanosec, 250000000u);
  EXPECT_DOUBLE_EQ(t.seconds(), 12.25);
  auto n = dds::msg::Time::from_seconds(-0.5);
  EXPECT_EQ(n.sec, -1);
  EXPECT_EQ(n.nanosec, 500000000u);
  for (double yaw : {-3.0, -1.0, 0.0, 0.5, 2.5})
    EXPECT_NEAR(dds::yaw_from_quaternion(dds::quaternion_from_yaw(yaw)), yaw, 1e-12);
  EXPECT_EQ(*dds::parse_reliability("best_effort"), dds::Reliability::best_effort);
  EXPECT_FALSE(dds::parse_reliability("sometimes").ok());
  EXPECT_EQ(*dds::parse_durability("transient_local"), dds::Durability::transient_local);
  EXPECT_FALSE(dds::parse_durability("forever").ok());
}

TEST(DdsHelpers, WarningLimiterAllowsOncePerInterval) {
  dds::WarningLimiter limiter(1.0);
  EXPECT_TRUE(limiter.allow(10.0));
  EXPECT_FALSE(limiter.allow(10.2));
  EXPECT_FALSE(limiter.allow(10.9));
  EXPECT_TRUE(limiter.allow(11.0));
  EXPECT_EQ(limiter.suppressed_before_last(), 2u);
}

TEST(DdsHelpers, LatestSlotWaitsForNewerValues) {
  dds::LatestSlot<int> slot;
  EXPECT_FALSE(slot.wait_newer(0, 0.01).has_value());
  std::thread producer([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    slot.put(7);
  });
  auto got = slot.wait_newer(0, 2.0);
  producer.join();
  ASSERT_TRUE(got.has_value());
  EXPECT_EQ(got->first, 7);
  EXPECT_EQ(got->second, 1u);
  EXPECT_FALSE(slot.wait_newer(1, 0.01).has_value());
}

}  // namespace

// Command arbitration (issue 17), the rule `visnav simd --cmd-vel-writer` and the dds robot's
// `odom_writer` share.
TEST(WriterArbiter, OpenPinnedAndFirstSenderRules) {
  const std::string a(32, 'a'), b(32, 'b');
  EXPECT_TRUE(dds::is_participant_guid(a));
  EXPECT_FALSE(dds::is_participant_guid(std::string(32, 'A')));  // GUIDs are logged lower case
  EXPECT_FALSE(dds::is_participant_guid(std::string(31, 'a')));

  dds::WriterArbiter open;  // no rule: everyone, nothing counted
  EXPECT_TRUE(open.open());
  EXPECT_TRUE(open.admit(a).accepted);
  EXPECT_TRUE(open.admit("").accepted);
  EXPECT_EQ(open.refused(), 0u);

  auto pinned = dds::WriterArbiter::parse(a);
  ASSERT_TRUE(pinned.ok());
  EXPECT_TRUE(pinned->admit(a).accepted);
  EXPECT_FALSE(pinned->admit(a).locked);
  EXPECT_FALSE(pinned->admit(b).accepted);
  EXPECT_FALSE(pinned->admit("").accepted);  // unknown sender: refused, never trusted
  EXPECT_EQ(pinned->refused(), 2u);
  EXPECT_EQ(pinned->allowed(), a);

  auto first = dds::WriterArbiter::parse("first");
  ASSERT_TRUE(first.ok());
  EXPECT_EQ(first->allowed(), "");
  EXPECT_FALSE(first->admit("").accepted);  // an unknown sender does not take the lock
  const auto locked = first->admit(b);
  EXPECT_TRUE(locked.accepted);
  EXPECT_TRUE(locked.locked);
  EXPECT_EQ(first->allowed(), b);
  EXPECT_FALSE(first->admit(a).accepted);  // later senders are refused, the locked one is not
  EXPECT_TRUE(first->admit(b).accepted);
  EXPECT_FALSE(first->admit(b).locked);
  EXPECT_EQ(first->refused(), 2u);
  EXPECT_NE(first->describe().find(b), std::string::npos);

  for (const char* bad : {"FIRST", "0123", "zzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzz", "\x1b[31m"}) {
    auto r = dds::WriterArbiter::parse(bad);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_EQ(r.error().code, visnav::ErrorCode::invalid_value) << bad;
    EXPECT_EQ(r.error().message.find('\x1b'), std::string::npos);  // shown escaped (log_safe)
  }
}
