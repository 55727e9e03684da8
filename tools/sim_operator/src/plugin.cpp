// `sim_operator` nodes plugin: ScriptedOperator, the unattended "person" who teaches a route
// in the simulator (see operator_core.hpp).
#include <algorithm>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "convergence.hpp"
#include "benchmark.hpp"
#include "experiment.hpp"
#include "operator_core.hpp"
#include "visnav/bt/node.hpp"
#include "visnav/bt/registry.hpp"
#include "visnav/plugin.hpp"
#include "visnav_navigation/navigation_core.hpp"
#include "visnav_sim/route.hpp"

namespace visnav::simop {
namespace {

using bt::NodeStatus;

/// The route a ScriptedOperator drives: the port's literal check (so `visnav validate` and the
/// check before `visnav run` open and parse a route_file written in the tree) and the node's
/// start both read it through this.
Result<sim::Route> read_waypoint_route(const std::string& file) {
  auto route = sim::load_route(file);  // refuses a missing file, a device or an oversized file first
  if (!route) return route.error().with_default_code(ErrorCode::parse_error);
  if (route->waypoints.empty())
    return Error{file + ": ScriptedOperator needs a waypoint route", ErrorCode::invalid_value};
  return route;
}

bt::PortInfo route_file_port() {
  bt::PortInfo port = bt::input_port<std::string>("route_file", "route script (config/routes/*.yaml) with waypoints");
  port.constraint = "a waypoint route file";
  port.check = [](std::string_view text) -> Status {
    VISNAV_TRY(read_waypoint_route(std::string(text)));
    return ok();
  };
  return port;
}

class ScriptedOperator final : public bt::StatefulActionNode {
 public:
  ScriptedOperator(const std::string& name, const bt::NodeConfig& config, HostServices& host)
      : StatefulActionNode(name, config), host_(host) {}

  static bt::PortsList provided_ports() {
    return {route_file_port(),
            bt::input_port<std::vector<std::string>>("kinds", "feature=feature_segment;path=path_following;memory=visual_memory",
                                                      "route leg kind -> map edge kind"),
            bt::input_port<std::string>("force_kind", "", "teach every leg with this edge kind (e.g. a feature-only map)"),
            bt::input_port<double>("speed_mps", "0.5", "driving speed"),
            bt::input_port<double>("min_turning_radius_m", "0",
                                   "0: turn in place at each waypoint; > 0: the robot cannot turn tighter (car-like), "
                                   "each corner is driven as an arc of this radius that starts R*tan(turn/2) before "
                                   "the waypoint, not taught (the node is where the arc starts), m"),
            bt::input_port<double>("arc_speed_mps", "0.3", "forward speed on a corner arc (<= speed_mps)"),
            bt::output_port<std::string>("primitive", "{primitive}", "edge kind being taught; empty while turning"),
            bt::output_port<bool>("closing", "{teach_closing}",
                                  "closed route: true once every leg is driven, while the operator turns to face "
                                  "the first leg again (TeachRoute records that turn)"),
            bt::output_port<bool>("done", "{teach_done}", "true once the route is driven")};
  }

  NodeStatus on_start() override {
    Robot* robot = host_.robot();
    sim_ = robot != nullptr ? robot->simulation() : nullptr;
    if (sim_ == nullptr) return failed("ScriptedOperator needs the simulated robot (robot type sim)");
    auto file = get_input<std::string>("route_file");
    auto kinds = get_input<std::vector<std::string>>("kinds");
    auto force = get_input<std::string>("force_kind");
    auto speed = get_input<double>("speed_mps");
    auto radius = get_input<double>("min_turning_radius_m");
    auto arc_speed = get_input<double>("arc_speed_mps");
    if (!file || !kinds || !force || !speed || !radius || !arc_speed) return failed("bad ports");
    auto route = read_waypoint_route(*file);
    if (!route) return failed(route.error().message);
    auto kind_map = nav::parse_kind_map(*kinds);
    if (!kind_map) return failed("kinds: " + kind_map.error().message);
    std::vector<cv::Point2d> points;
    std::vector<std::string> point_kinds;
    for (const auto& w : route->waypoints) {
      points.push_back(w.position_m);
      point_kinds.push_back(w.kind);
    }
    auto legs = make_legs(points, point_kinds, route->closed, *kind_map, *force);
    if (!legs) return failed(*file + ": " + legs.error().message);
    OperatorParams params;
    params.speed_mps = *speed;
    params.min_turning_radius_m = *radius;
    params.arc_speed_mps = std::min(*arc_speed, *speed);
    if (auto st = params.validate(); !st) return failed(st.error().message);
    if (auto arcs = leg_arcs(*legs, route->closed, params.min_turning_radius_m); !arcs)
      return failed(*file + ": " + arcs.error().message);
    core_.emplace(std::move(*legs), params, route->closed);
    (void)set_output("done", false);
    (void)set_output("closing", false);
    closing_ = false;
    (void)set_output("primitive", std::string());
    return on_running();
  }

  NodeStatus on_running() override {
    const OperatorAction a = core_->update(sim_->ground_truth_pose());
    if (a.primitive != last_primitive_) {
      (void)set_output("primitive", a.primitive);
      last_primitive_ = a.primitive;
    }
    if (a.closing != closing_) {
      (void)set_output("closing", a.closing);
      closing_ = a.closing;
    }
    if (a.done) {
      (void)host_.robot()->stop();
      (void)set_output("done", true);
      return NodeStatus::success;
    }
    if (auto st = host_.robot()->send_command(a.command); !st) {
      (void)host_.robot()->stop();
      return failed("the robot refused the velocity command: " + st.error().message);
    }
    return NodeStatus::running;
  }

  void on_halted() override {
    if (Robot* robot = host_.robot()) (void)robot->stop();
  }

 private:
  NodeStatus failed(const std::string& message) {
    host_.logger().error(path(), message);
    return NodeStatus::failure;
  }

  HostServices& host_;
  SimulationControl* sim_ = nullptr;
  std::optional<ScriptedOperatorCore> core_;
  std::string last_primitive_ = "?";
  bool closing_ = false;
};

Status register_sim_operator_nodes(bt::NodeRegistry& registry, HostServices& host) {
  return registry.register_node<ScriptedOperator>(
      "ScriptedOperator",
      "Simulated operator: drives a waypoint route leg by leg (turn in place, or an arc for a car-like robot; "
      "drive straight) on the sim robot and publishes the primitive being taught",
      [&host](const std::string& name, const bt::NodeConfig& config) {
        return std::make_unique<ScriptedOperator>(name, config, host);
      });
}

const CommandEntry kCommands[] = {
    {"experiment", "teach a route in the simulator, displace, replay N loops, report accuracy (seed 000 eq. 18)",
     &guarded_command<&experiment_command>},
    {"benchmark", "teach + replay loops on generated worlds (held-out seeds), every error model on: the results table",
     &guarded_command<&benchmark_command>},
    {"convergence", "straight segment from 0.5 m off: fit y = a*exp(-kx) per primitive (seed 000 Fig. 3)",
     &guarded_command<&convergence_command>}};

}  // namespace
}  // namespace visnav::simop

VISNAV_PLUGIN({.name = "sim_operator",
               .version = "0.1.0",
               .description = "Scripted teaching operator and the `experiment` and `convergence` commands for the simulator",
               .register_nodes = &visnav::simop::register_sim_operator_nodes,
               .commands = visnav::simop::kCommands})
