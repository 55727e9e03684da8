// Example out-of-tree nodes plugin: `ExampleTurn` turns the robot in place by `angle_rad`
// (odometry heading), then stops. A primitive is this small: ports, start/running/halted.
#include <cmath>
#include <memory>
#include <string>

#include <visnav/bt/registry.hpp>
#include <visnav/plugin.hpp>

namespace {

using visnav::bt::NodeStatus;

class ExampleTurn final : public visnav::bt::StatefulActionNode {
 public:
  ExampleTurn(const std::string& name, const visnav::bt::NodeConfig& config, visnav::HostServices& host)
      : StatefulActionNode(name, config), host_(host) {}

  static visnav::bt::PortsList provided_ports() {
    return {visnav::bt::input_port<double>("angle_rad", "angle to turn, counter-clockwise positive"),
            visnav::bt::input_port<double>("rate_radps", "0.5", "turn rate (magnitude)")};
  }

  NodeStatus on_start() override {
    auto angle = get_input<double>("angle_rad");
    auto rate = get_input<double>("rate_radps");
    if (!angle || !rate || *rate <= 0.0 || host_.robot() == nullptr || host_.frame_bus() == nullptr) {
      host_.logger().error("ExampleTurn", path() + ": needs angle_rad, a positive rate_radps and a running robot");
      return NodeStatus::failure;
    }
    auto odo = host_.frame_bus()->latest_odometry();
    if (!odo) return NodeStatus::failure;
    target_rad_ = odo->pose.heading_rad + *angle;
    rate_radps_ = std::copysign(*rate, *angle);
    return on_running();
  }

  NodeStatus on_running() override {
    auto odo = host_.frame_bus()->latest_odometry();
    if (!odo) return NodeStatus::failure;
    const double remaining_rad = target_rad_ - odo->pose.heading_rad;
    if (remaining_rad * rate_radps_ <= 0.0) {  // reached or passed the target heading
      (void)host_.robot()->stop();
      return NodeStatus::success;
    }
    if (!host_.robot()->send_command(visnav::Twist{0.0, rate_radps_})) return NodeStatus::failure;
    return NodeStatus::running;
  }

  void on_halted() override { (void)host_.robot()->stop(); }

 private:
  visnav::HostServices& host_;
  double target_rad_ = 0.0;
  double rate_radps_ = 0.0;
};

visnav::Status register_nodes(visnav::bt::NodeRegistry& registry, visnav::HostServices& host) {
  return registry.register_node<ExampleTurn>(
      "ExampleTurn", "turn in place by angle_rad (example out-of-tree plugin)",
      [&host](const std::string& name, const visnav::bt::NodeConfig& config) {
        return std::make_unique<ExampleTurn>(name, config, host);
      });
}

}  // namespace

VISNAV_PLUGIN({.name = "example_nodes",
               .version = "1.0",
               .description = "example out-of-tree nodes plugin",
               .register_nodes = &register_nodes})
