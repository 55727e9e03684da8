// Entry point of the `navigation` nodes plugin.
#include "nodes.hpp"
#include "visnav/bt/registry.hpp"
#include "visnav/plugin.hpp"

namespace {

visnav::Status register_navigation_nodes(visnav::bt::NodeRegistry& registry, visnav::HostServices& host) {
  using namespace visnav::nav;
  auto with_host = [&host]<typename T>(T*) {
    return [&host](const std::string& name, const visnav::bt::NodeConfig& config) {
      return std::make_unique<T>(name, config, host);
    };
  };
  VISNAV_TRY(registry.register_node<PlanRoute>(
      "PlanRoute", "Plans the cheapest route between two map nodes (a closed loop when start == goal)",
      with_host(static_cast<PlanRoute*>(nullptr))));
  VISNAV_TRY(registry.register_node<FollowRoute>(
      "FollowRoute", "Traverses a route: turns to each edge's azimuth, then runs the child for the edge's kind",
      with_host(static_cast<FollowRoute*>(nullptr))));
  VISNAV_TRY(registry.register_node<TurnToAzimuth>(
      "TurnToAzimuth", "Turns in place to an azimuth (absolute, relative, or a map edge's)",
      with_host(static_cast<TurnToAzimuth*>(nullptr))));
  VISNAV_TRY(registry.register_node<TeachRoute>(
      "TeachRoute", "Operator-driven teaching: a new node and edge whenever the operator switches primitive",
      with_host(static_cast<TeachRoute*>(nullptr))));
  VISNAV_TRY(registry.register_node<AtNode>("AtNode", "True when the robot is at the given map node",
                                            with_host(static_cast<AtNode*>(nullptr))));
  return visnav::ok();
}

}  // namespace

VISNAV_PLUGIN({.name = "navigation",
               .version = "0.1.0",
               .description = "Route nodes over the hybrid topological map: PlanRoute, FollowRoute, "
                              "TurnToAzimuth, TeachRoute, AtNode",
               .register_nodes = &register_navigation_nodes})
