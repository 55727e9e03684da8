// DDS telemetry publisher (visnav::Telemetry) and mission-control endpoints.
#include <gtest/gtest.h>

#include <mutex>

#include "dds_test_util.hpp"
#include "visnav/dds.hpp"

namespace dds = visnav::dds;
using dds::testing::eventually;

namespace {

class CapturingLogger final : public visnav::Logger {
 public:
  void log(visnav::LogLevel level, std::string_view component, std::string_view message) override {
    std::lock_guard lock(mutex_);
    lines_.push_back(std::string(level == visnav::LogLevel::warn ? "W " : "I ") + std::string(component) + ": " +
                     std::string(message));
  }
  std::vector<std::string> lines() {
    std::lock_guard lock(mutex_);
    return lines_;
  }

 private:
  std::mutex mutex_;
  std::vector<std::string> lines_;
};

dds::TelemetryParams test_params() {
  dds::testing::use_loopback();
  dds::TelemetryParams p;
  p.domain_id = dds::testing::random_domain_id();
  p.partition = dds::testing::unique_partition();
  return p;
}

TEST(DdsTelemetry, PublishesNavStatusOnTheTelemetryTopic) {
  const auto params = test_params();
  CapturingLogger logger;
  auto telemetry = dds::DdsTelemetry::create(params, logger);
  ASSERT_TRUE(telemetry.ok()) << telemetry.error().message;
  auto participant = dds::Participant::create(params.domain_id);
  ASSERT_TRUE(participant.ok());
  auto reader = dds::Reader<dds::msg::Telemetry>::create(
      *participant, dds::EndpointOptions{"rt/visnav/telemetry", dds::Qos::ros_default(), params.partition});
  ASSERT_TRUE(reader.ok());
  ASSERT_TRUE(eventually([&] { return (*telemetry)->matched_readers() == 1; }));

  visnav::NavStatus s;
  s.node_path = "Mission/Sequence/TraverseEdge";
  s.map_node = "gate";
  s.edge = "e3";
  s.distance_m = 4.25;
  s.matches = 120;
  s.inliers = 87;
  s.offset_px = -12.5;
  s.command = visnav::Twist{0.4, -0.05};
  s.status = "replaying";
  visnav::Telemetry& as_interface = **telemetry;
  as_interface.publish(s);
  s.status = "done";
  as_interface.publish(s);

  std::vector<dds::msg::Telemetry> got;
  ASSERT_TRUE(eventually([&] {
    (void)reader->take([&](dds::msg::Telemetry&& t, const dds::SampleInfo&) { got.push_back(std::move(t)); });
    return got.size() == 2;
  }));
  EXPECT_EQ(got[0].sequence_number, 1u);
  EXPECT_EQ(got[1].sequence_number, 2u);
  EXPECT_EQ(got[0].node_path, "Mission/Sequence/TraverseEdge");
  EXPECT_EQ(got[0].map_node, "gate");
  EXPECT_EQ(got[0].edge, "e3");
  EXPECT_EQ(got[0].distance_m, 4.25);
  EXPECT_EQ(got[0].matches, 120);
  EXPECT_EQ(got[0].inliers, 87);
  EXPECT_EQ(got[0].offset_px, -12.5);
  EXPECT_EQ(got[0].linear_mps, 0.4);
  EXPECT_EQ(got[0].angular_radps, -0.05);
  EXPECT_EQ(got[0].status, "replaying");
  EXPECT_EQ(got[1].status, "done");
  EXPECT_NEAR(got[0].header.stamp.seconds(), dds::epoch_now_s(), 10.0);
  EXPECT_EQ((*telemetry)->published(), 2u);
}

TEST(DdsControl, RequestsArriveInOrderAndUnknownCodesAreDropped) {
  const auto params = test_params();
  CapturingLogger logger;
  auto subscriber = dds::ControlSubscriber::create(params, logger);
  ASSERT_TRUE(subscriber.ok()) << subscriber.error().message;
  auto publisher = dds::ControlPublisher::create(params);
  ASSERT_TRUE(publisher.ok());
  ASSERT_TRUE((*publisher)->wait_for_subscribers(1, 5.0));

  ASSERT_TRUE((*publisher)->send(dds::msg::ControlCommand::pause).ok());
  ASSERT_TRUE((*publisher)->send(dds::msg::ControlCommand::swap_detector, "orb").ok());
  ASSERT_TRUE((*publisher)->send(dds::msg::ControlCommand::swap_detector).ok());  // no detector: dropped
  // A raw writer sending an unknown command code.
  auto participant = dds::Participant::create(params.domain_id);
  auto raw = dds::Writer<dds::msg::Control>::create(
      *participant, dds::EndpointOptions{params.control_topic, dds::Qos{dds::Reliability::reliable, dds::Durability::volatile_data, 32, 0.0},
                                         params.partition});
  ASSERT_TRUE(raw.ok());
  ASSERT_TRUE(raw->wait_for_readers(1, 5.0));
  dds::msg::Control bogus;
  bogus.command = 42;
  ASSERT_TRUE(raw->write(bogus).ok());
  ASSERT_TRUE((*publisher)->send(dds::msg::ControlCommand::resume).ok());
  ASSERT_TRUE((*publisher)->send(dds::msg::ControlCommand::abort).ok());

  std::vector<dds::ControlRequest> got;
  ASSERT_TRUE(eventually([&] {
    for (auto& r : (*subscriber)->take_pending()) got.push_back(std::move(r));
    return got.size() >= 4;
  }));
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  for (auto& r : (*subscriber)->take_pending()) got.push_back(std::move(r));
  ASSERT_EQ(got.size(), 4u);
  EXPECT_EQ(got[0].command, dds::msg::ControlCommand::pause);
  EXPECT_EQ(got[1].command, dds::msg::ControlCommand::swap_detector);
  EXPECT_EQ(got[1].argument, "orb");
  EXPECT_EQ(got[2].command, dds::msg::ControlCommand::resume);
  EXPECT_EQ(got[3].command, dds::msg::ControlCommand::abort);
  int warnings = 0;
  for (const auto& l : logger.lines()) warnings += l.rfind("W dds.control", 0) == 0;
  EXPECT_GE(warnings, 1);  // rate-limited: at least the first of the two drops is reported
}

TEST(DdsControl, CommandNamesRoundTrip) {
  for (auto c : {dds::msg::ControlCommand::pause, dds::msg::ControlCommand::resume, dds::msg::ControlCommand::abort,
                 dds::msg::ControlCommand::swap_detector})
    EXPECT_EQ(*dds::parse_control_command(dds::to_string(c)), c);
  EXPECT_FALSE(dds::parse_control_command("explode").ok());
}

TEST(DdsTelemetryParams, SchemaRejectsUnknownKeysAndSameTopics) {
  visnav::ConfigNode node = visnav::ConfigNode::make_map({"t.yaml", 1});
  node.set("domain_id", visnav::ConfigNode::make_scalar("7", {"t.yaml", 2}));
  auto parsed = dds::TelemetryParams::schema().parse(node);
  ASSERT_TRUE(parsed.ok());
  EXPECT_EQ(parsed->domain_id, 7);
  EXPECT_EQ(parsed->telemetry_topic, "rt/visnav/telemetry");
  node.set("bogus", visnav::ConfigNode::make_scalar("1", {"t.yaml", 3}));
  EXPECT_FALSE(dds::TelemetryParams::schema().parse(node).ok());
  dds::TelemetryParams same;
  same.control_topic = same.telemetry_topic;
  EXPECT_FALSE(same.validate().ok());
}

}  // namespace
