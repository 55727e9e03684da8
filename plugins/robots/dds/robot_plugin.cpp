// The `dds` robot: a mobile base on Cyclone DDS speaking ROS 2 types.
//   writes geometry_msgs/Twist on `cmd_vel_topic` (default rt/cmd_vel, reliable),
//   reads nav_msgs/Odometry from `odom_topic` (default rt/odom, best effort: matches both
//   reliable and best-effort publishers).
// Odometry arrives on the subscription thread, is converted (OdometryTracker) and stored in a
// latest-value slot; `latest_odometry()` (tick thread) reads the slot. Timestamps are honest:
// `timestamp: receive` (default) stamps each sample with the run clock when it arrived,
// `timestamp: header` maps the sample's header stamp onto the run clock (needs synchronised
// wall clocks), so the runtime's stale-odometry check sees the real age of the data.
// Malformed samples (non-finite values, zero quaternion) and writers of the wrong type are
// dropped, counted and reported with rate-limited warnings.
// Arbitration (issue 17): `odom_writer` pins the participant whose odometry is believed (a GUID,
// or `first`: whoever sends first), by the same rule (dds::WriterArbiter) that `visnav simd
// --cmd-vel-writer` applies to the commands it receives; odometry from anyone else is dropped,
// counted and warned about at most once per second.
#include <atomic>
#include <memory>
#include <mutex>

#include "odometry_tracker.hpp"
#include "visnav/dds.hpp"
#include "visnav/plugin.hpp"

namespace visnav::robot_dds {
namespace {

struct DdsRobotParams {
  int domain_id = 0;
  std::string partition;
  std::string cmd_vel_topic = "rt/cmd_vel";
  std::string odom_topic = "rt/odom";
  std::string cmd_vel_reliability = "reliable";
  int cmd_vel_history_depth = 1;
  std::string odom_reliability = "best_effort";
  int odom_history_depth = 5;
  double odom_deadline_s = 0.0;
  std::string timestamp = "receive";
  double connect_timeout_s = 0.0;
  std::string odom_writer;  // participant GUID allowed to publish odometry, or "first"; empty = any

  [[nodiscard]] Status validate() const {
    if (cmd_vel_topic.empty() || odom_topic.empty()) return fail("topic names must not be empty");
    if (cmd_vel_topic == odom_topic) return fail("cmd_vel_topic and odom_topic must differ");
    if (auto rule = dds::WriterArbiter::parse(odom_writer); !rule)
      return fail(ErrorCode::invalid_value, ErrorLocation{{}, 0, "odom_writer"}, rule.error().message);
    return ok();
  }
  static const ParamSchema<DdsRobotParams>& schema() {
    static const auto s = ParamSchema<DdsRobotParams>{}
        .field("domain_id", &DdsRobotParams::domain_id, "DDS domain id (ROS_DOMAIN_ID of the robot)").range(0, 232)
        .field("partition", &DdsRobotParams::partition, "DDS partition; empty = default (what ROS 2 uses)")
        .field("cmd_vel_topic", &DdsRobotParams::cmd_vel_topic, "DDS topic for geometry_msgs/Twist commands (ROS /cmd_vel = rt/cmd_vel)")
        .field("odom_topic", &DdsRobotParams::odom_topic, "DDS topic of nav_msgs/Odometry (ROS /odom = rt/odom)")
        .field("cmd_vel_reliability", &DdsRobotParams::cmd_vel_reliability, "QoS reliability of the command writer").one_of({"reliable", "best_effort"})
        .field("cmd_vel_history_depth", &DdsRobotParams::cmd_vel_history_depth, "keep-last depth of the command writer").range(1, 1000)
        .field("odom_reliability", &DdsRobotParams::odom_reliability, "QoS reliability of the odometry reader").one_of({"best_effort", "reliable"})
        .field("odom_history_depth", &DdsRobotParams::odom_history_depth, "keep-last depth of the odometry reader").range(1, 1000)
        .field("odom_deadline_s", &DdsRobotParams::odom_deadline_s, "QoS deadline of the odometry reader; 0 = none").range(0, 3600)
        .field("timestamp", &DdsRobotParams::timestamp, "odometry time: arrival on the run clock, or the header stamp mapped onto it").one_of({"receive", "header"})
        .field("connect_timeout_s", &DdsRobotParams::connect_timeout_s, "wait this long at creation for the first odometry sample; 0 = don't wait").range(0, 600)
        .field("odom_writer", &DdsRobotParams::odom_writer, "accept odometry only from this participant GUID (32 hex digits; the robot driver logs it), or `first`: from the first sender; empty = any (see docs/security.md)");
    return s;
  }
};

class DdsRobot final : public Robot {
 public:
  using Params = DdsRobotParams;

  static Result<std::unique_ptr<DdsRobot>> create(const ConfigNode& node, HostServices& host) {
    VISNAV_ASSIGN(Params params, Params::schema().parse(node));
    auto robot = std::unique_ptr<DdsRobot>(new DdsRobot(params, host));
    VISNAV_TRY(robot->connect());
    return robot;
  }

  ~DdsRobot() override {
    if (writer_) (void)writer_->write(to_ros_twist(Twist{}));  // leave the robot stopped
    subscription_.reset();
  }

  Status send_command(const Twist& command) override {
    auto st = writer_->write(to_ros_twist(command));
    if (!st) return st.error().with_context("dds robot");
    return ok();
  }

  std::optional<Odometry> latest_odometry() override { return odometry_.get(); }

  Status stop() override { return send_command(Twist{}); }

 private:
  DdsRobot(Params params, HostServices& host) : params_(std::move(params)), host_(&host) {}

  Status connect() {
    VISNAV_ASSIGN(odom_writers_, dds::WriterArbiter::parse(params_.odom_writer));
    VISNAV_ASSIGN(auto participant, dds::Participant::create(params_.domain_id));
    VISNAV_ASSIGN(auto cmd_reliability, dds::parse_reliability(params_.cmd_vel_reliability));
    VISNAV_ASSIGN(auto odom_reliability, dds::parse_reliability(params_.odom_reliability));
    dds::Qos cmd_qos{cmd_reliability, dds::Durability::volatile_data, params_.cmd_vel_history_depth, 0.0};
    dds::Qos odom_qos{odom_reliability, dds::Durability::volatile_data, params_.odom_history_depth, params_.odom_deadline_s};
    VISNAV_ASSIGN(auto writer, dds::Writer<dds::msg::Twist>::create(
                                   participant, dds::EndpointOptions{params_.cmd_vel_topic, cmd_qos, params_.partition}));
    writer_.emplace(std::move(writer));
    const bool use_header = params_.timestamp == "header";
    auto on_odometry = [this, use_header](dds::msg::Odometry&& sample, const dds::SampleInfo& info) {
      const auto verdict = odom_writers_.admit(info.writer_participant);
      if (verdict.locked)
        host_->logger().info("dds.robot", "topic '" + params_.odom_topic + "': odometry locked to the first sender, participant " +
                                              odom_writers_.allowed());
      if (!verdict.accepted) {  // arbitration (issue 17): another participant's odometry
        if (limiter_.allow(info.receive_time_s))
          host_->logger().warn("dds.robot", "topic '" + params_.odom_topic + "': dropped odometry from participant '" +
                                                dds::log_safe(info.writer_participant) + "' (odom_writer: " +
                                                odom_writers_.describe() + "); " + std::to_string(odom_writers_.refused()) +
                                                " dropped so far");
        return;
      }
      const double run_now_s = host_->clock().now_s();
      const double stamp_s =
          use_header ? to_run_clock(sample.header.stamp.seconds(), info.receive_time_s, run_now_s) : run_now_s;
      auto converted = tracker_.update(sample, stamp_s);
      if (!converted) {
        const auto dropped = ++dropped_;
        if (limiter_.allow(info.receive_time_s))
          host_->logger().warn("dds.robot", "topic '" + params_.odom_topic + "': dropped a malformed odometry sample (" +
                                                converted.error().message + "); " + std::to_string(dropped) +
                                                " dropped so far");
        return;
      }
      odometry_.put(*converted);
    };
    auto on_warning = [this](const std::string& message) { host_->logger().warn("dds.robot", message); };
    VISNAV_ASSIGN(subscription_, dds::Subscription<dds::msg::Odometry>::create(
                                     participant, dds::EndpointOptions{params_.odom_topic, odom_qos, params_.partition},
                                     on_odometry, on_warning));
    host_->logger().info("dds.robot", "domain " + std::to_string(params_.domain_id) + ": commands on '" +
                                          params_.cmd_vel_topic + "' from participant " + participant.guid() +
                                          ", odometry from '" + params_.odom_topic + "'" +
                                          " (" + odom_writers_.describe() + ")");
    if (params_.connect_timeout_s > 0.0 && !odometry_.wait_newer(0, params_.connect_timeout_s))
      return fail("dds robot: no odometry on '" + params_.odom_topic + "' (domain " + std::to_string(params_.domain_id) +
                  ") within connect_timeout_s = " + std::to_string(params_.connect_timeout_s) + " s");
    return ok();
  }

  Params params_;
  HostServices* host_;
  std::optional<dds::Writer<dds::msg::Twist>> writer_;
  OdometryTracker tracker_;  // subscription thread only
  dds::LatestSlot<Odometry> odometry_;
  std::atomic<std::uint64_t> dropped_{0};
  dds::WriterArbiter odom_writers_;  // odom_writer: whose odometry is believed
  dds::WarningLimiter limiter_{1.0};
  std::unique_ptr<dds::Subscription<dds::msg::Odometry>> subscription_;  // last: stopped first
};

const TypeEntry kTypes[] = {
    make_type<DdsRobot>("dds", "Robot over Cyclone DDS with ROS 2 types: Twist on cmd_vel, Odometry from odom")};

}  // namespace
}  // namespace visnav::robot_dds

VISNAV_PLUGIN({.name = "robot_dds",
               .version = "1.0",
               .description = "Cyclone DDS robot (ROS 2 cmd_vel/odom)",
               .types = ::visnav::robot_dds::kTypes})
