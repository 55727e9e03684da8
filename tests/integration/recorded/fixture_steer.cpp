// Fixture nodes plugin for the recorded-run tests.
//  * RecSteer (stateful action): drives at speed_mps and steers by the image: omega =
//    -gain_radps · (x-centroid of the brightness − image centre) / half width, plus a term in the
//    odometric distance; succeeds after distance_m. Every command depends on that tick's frame
//    pixels and odometry, so any difference between a live run and its playback shows up in the
//    commands. Publishes one NavStatus per tick (offset_px = centroid offset).
#include <cmath>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/imgproc.hpp>

#include "visnav/bt/registry.hpp"
#include "visnav/plugin.hpp"

namespace {

using visnav::bt::NodeStatus;

class RecSteer final : public visnav::bt::StatefulActionNode {
 public:
  RecSteer(const std::string& name, const visnav::bt::NodeConfig& config, visnav::HostServices& host)
      : StatefulActionNode(name, config), host_(host) {}

  static visnav::bt::PortsList provided_ports() {
    return {visnav::bt::input_port<double>("distance_m", "distance to drive"),
            visnav::bt::input_port<double>("speed_mps", "0.5", "forward speed"),
            visnav::bt::input_port<double>("gain_radps", "0.4", "steering gain")};
  }

  NodeStatus on_start() override {
    auto d = get_input<double>("distance_m");
    auto v = get_input<double>("speed_mps");
    auto g = get_input<double>("gain_radps");
    if (!d || !v || !g || host_.frame_bus() == nullptr || host_.robot() == nullptr) return NodeStatus::failure;
    distance_m_ = *d;
    speed_mps_ = *v;
    gain_ = *g;
    auto odo = host_.frame_bus()->latest_odometry();
    if (!odo) return NodeStatus::failure;
    start_m_ = odo->distance_m;
    return on_running();
  }

  NodeStatus on_running() override {
    auto odo = host_.frame_bus()->latest_odometry();
    auto frame = host_.frame_bus()->latest_frame();
    if (!odo || !frame) return NodeStatus::failure;
    const double travelled = odo->distance_m - start_m_;
    if (travelled >= distance_m_) {
      (void)host_.robot()->send_command(visnav::Twist{});
      return NodeStatus::success;
    }
    if (frame->image.channels() == 3)
      cv::cvtColor(frame->image, grey_, cv::COLOR_BGR2GRAY);
    else
      grey_ = frame->image;
    const cv::Moments m = cv::moments(grey_, false);
    const double half = grey_.cols / 2.0;
    const double offset_px = m.m00 > 0.0 ? m.m10 / m.m00 - half : 0.0;
    visnav::Twist cmd{speed_mps_, -gain_ * offset_px / half + 0.05 * std::sin(3.0 * travelled) + 0.1 * odo->pose.heading_rad};
    if (!host_.robot()->send_command(cmd)) return NodeStatus::failure;
    if (visnav::Telemetry* t = host_.telemetry()) {
      visnav::NavStatus s;
      s.node_path = path();
      s.distance_m = travelled;
      s.offset_px = offset_px;
      s.command = cmd;
      s.status = "steering";
      t->publish(s);
    }
    return NodeStatus::running;
  }

  void on_halted() override {
    if (host_.robot() != nullptr) (void)host_.robot()->send_command(visnav::Twist{});
  }

 private:
  visnav::HostServices& host_;
  cv::Mat grey_;
  double distance_m_ = 0.0;
  double speed_mps_ = 0.0;
  double gain_ = 0.0;
  double start_m_ = 0.0;
};

visnav::Status register_nodes(visnav::bt::NodeRegistry& registry, visnav::HostServices& host) {
  return registry.register_node<RecSteer>("RecSteer", "steer by the image's brightness centroid (tests)",
                                          [&host](const std::string& name, const visnav::bt::NodeConfig& config) {
                                            return std::make_unique<RecSteer>(name, config, host);
                                          });
}

}  // namespace

VISNAV_PLUGIN({.name = "fixture_recorded_nodes",
               .version = "1.0",
               .description = "recorded-run test nodes",
               .register_nodes = &register_nodes})
