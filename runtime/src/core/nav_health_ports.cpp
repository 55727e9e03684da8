// The lost-policy ports, declared once for every primitive (see nav_health_ports.hpp).
#include "visnav/bt/nav_health_ports.hpp"

#include <cmath>
#include <numbers>

namespace visnav::bt {

void append_lost_policy_ports(PortsList& ports) {
  const LostPolicy d;
  auto text = [](double v) {
    std::string s = std::to_string(v);
    s.erase(s.find_last_not_of('0') + 1);
    if (!s.empty() && s.back() == '.') s.pop_back();
    return s;
  };
  ports.push_back(input_port<double>("min_frame_confidence", text(d.min_confidence),
                                     "lost policy: window-mean confidence at which the robot sees the route, [0, 1]"));
  ports.push_back(input_port<double>("slow_after_m", text(d.slow_after_m),
                                     "lost policy: blind distance after which the speed is reduced, m"));
  ports.push_back(input_port<double>("max_blind_m", text(d.max_blind_m),
                                     "lost policy: blind distance after which the edge fails with 'lost', m"));
  ports.push_back(input_port<double>("max_frozen_m", text(d.max_frozen_m),
                                     "lost policy: travel with identical frames after which the edge fails "
                                     "with 'camera frozen', m"));
  ports.push_back(input_port<double>("max_saturated_m", text(d.max_saturated_m),
                                     "lost policy: travel with a saturated correction after which the edge fails, m"));
  ports.push_back(input_port<double>("max_heading_deviation_deg",
                                     text(d.max_heading_deviation_rad * 180.0 / std::numbers::pi),
                                     "lost policy: odometric heading vs the taught one, deg; 0 = off"));
  ports.push_back(inout_port<double>("confident_at_m", "{nav_confident_at_m}",
                                     "odometric distance at which the route was last seen (carried between edges; "
                                     "unset: count from the edge start)"));
  ports.push_back(inout_port<double>("image_changed_at_m", "{nav_image_changed_at_m}",
                                     "odometric distance at which the image last changed (carried between edges)"));
}

Result<LostPolicy> read_lost_policy(const TreeNode& node) {
  LostPolicy p;
  VISNAV_ASSIGN(p.min_confidence, node.get_input<double>("min_frame_confidence"));
  VISNAV_ASSIGN(p.slow_after_m, node.get_input<double>("slow_after_m"));
  VISNAV_ASSIGN(p.max_blind_m, node.get_input<double>("max_blind_m"));
  VISNAV_ASSIGN(p.max_frozen_m, node.get_input<double>("max_frozen_m"));
  VISNAV_ASSIGN(p.max_saturated_m, node.get_input<double>("max_saturated_m"));
  VISNAV_ASSIGN(double deviation_deg, node.get_input<double>("max_heading_deviation_deg"));
  p.max_heading_deviation_rad = deviation_deg * std::numbers::pi / 180.0;
  VISNAV_TRY(p.validate());
  return p;
}

void begin_nav_health(NavHealthMonitor& monitor, const TreeNode& node, double odom_distance_m, double odom_heading_rad,
                      std::optional<TaughtHeading> taught) {
  auto carried = [&](const char* port) -> std::optional<double> {
    auto v = node.get_input<double>(port);
    if (!v) return std::nullopt;
    return *v;
  };
  monitor.begin(odom_distance_m, odom_heading_rad, carried("confident_at_m"), carried("image_changed_at_m"), taught);
}

void store_nav_health(const NavHealthMonitor& monitor, TreeNode& node) {
  (void)node.set_output("confident_at_m", monitor.confident_at_m());
  (void)node.set_output("image_changed_at_m", monitor.changed_at_m());
}

}  // namespace visnav::bt
