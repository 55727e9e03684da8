// Navigation nodes over the hybrid topological map (seed 000 Sec. 2): PlanRoute, FollowRoute,
// TurnToAzimuth, TeachRoute, AtNode. See docs/navigation.md for ports and the protocol
// between TeachRoute/FollowRoute and the primitive nodes they run as children.
//
// Thread-safety: ticked from the tick thread only. The HostServices reference outlives the tree.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "visnav/bt/node.hpp"
#include "visnav/host.hpp"
#include "visnav/map.hpp"
#include "visnav_navigation/navigation_core.hpp"

namespace visnav::nav {

/// Plans the cheapest route between two map nodes (a closed loop when start == goal).
class PlanRoute final : public bt::SyncActionNode {
 public:
  PlanRoute(const std::string& name, const bt::NodeConfig& config, HostServices& host);
  static bt::PortsList provided_ports();

 protected:
  bt::NodeStatus tick() override;

 private:
  HostServices& host_;
};

/// Turns in place (or, with min_turning_radius_m > 0, on a forward arc) to an absolute azimuth,
/// a relative angle, or a map edge's start azimuth.
class TurnToAzimuth final : public bt::StatefulActionNode {
 public:
  TurnToAzimuth(const std::string& name, const bt::NodeConfig& config, HostServices& host);
  static bt::PortsList provided_ports();
  bt::NodeStatus on_start() override;
  bt::NodeStatus on_running() override;
  void on_halted() override;

 private:
  HostServices& host_;
  TurnParams params_;
  ArcTurnParams arc_;
  double target_rad_ = 0.0;
};

/// Succeeds when the robot is at the given map node (as tracked by FollowRoute/TeachRoute).
class AtNode final : public bt::ConditionNode {
 public:
  AtNode(const std::string& name, const bt::NodeConfig& config, HostServices& host);
  static bt::PortsList provided_ports();

 protected:
  bt::NodeStatus tick() override;

 private:
  HostServices& host_;
};

/// Traverses a route edge by edge: turns to the edge's azimuth at each node, publishes the edge
/// id on {edge} and ticks the child registered for the edge's kind until it succeeds. With
/// carry_overshoot, {edge_carried_m} tells the child how far along the new edge the robot already
/// is (the previous edge's overshoot past its end node, see carried_distance_m).
class FollowRoute final : public bt::ControlNode {
 public:
  FollowRoute(const std::string& name, const bt::NodeConfig& config, HostServices& host);
  static bt::PortsList provided_ports();

 protected:
  bt::NodeStatus tick() override;
  void halt() override;

 private:
  Status start();
  /// With checkpoint: writes the progress checkpoint at the edge start and every checkpoint_interval_m.
  void save_progress(const EdgeRecord& edge);
  [[nodiscard]] double turn_target_rad(const EdgeRecord* previous, const EdgeRecord& next, double heading_rad) const;

  HostServices& host_;
  std::vector<std::string> route_;
  std::vector<std::string> heading_holding_kinds_;
  std::optional<double> edge_start_heading_;      ///< odom heading when the current edge started
  std::optional<double> previous_start_heading_;  ///< same for the previous edge of this run
  KindMap kinds_;
  std::vector<std::size_t> child_for_edge_;
  TurnParams turn_;
  ArcTurnParams arc_;                      ///< min_turning_radius_m > 0: turns are driven as arcs
  std::optional<double> arc_start_m_;      ///< odometric distance when the current node's turn began
  bool turn_at_nodes_ = true;
  bool carry_overshoot_ = true;
  double max_carry_m_ = 0.5;
  double start_distance_m_ = 0.0;  ///< of the route's first edge, already behind the robot at the start
  bool checkpoint_ = false;
  double checkpoint_interval_m_ = 1.0;
  std::optional<double> checkpointed_m_;  ///< along the current edge at the last checkpoint write
  bool checkpoint_warned_ = false;
  bool first_turn_absolute_ = false;
  std::optional<double> edge_origin_m_;  ///< odometric distance at which the current edge counts as started
  std::optional<double> ended_at_m_;     ///< route distance (route_odometer_m) of the last finished edge's end node
  /// Odometric metres the children drove off the route (their extra_travel_m), summed; never reset,
  /// so every stored route distance stays in one frame.
  double extra_travel_m_ = 0.0;
  /// The odometer less the travel off the route: what the edge origins, the carried overshoot and
  /// the distance-scale fixes count in.
  [[nodiscard]] double route_odometer_m(const Odometry& odom) const { return odom.distance_m - extra_travel_m_; }
  std::string ended_edge_;               ///< that edge's id
  std::size_t index_ = 0;
  bool turning_ = true;
  std::optional<double> turn_target_;
  bool scale_distance_ = false;
  std::vector<std::string> scale_fix_kinds_;  ///< kinds whose edge ends are scale fixes; empty = all
  DistanceScaleParams scale_params_;
  DistanceScaleEstimator scale_estimator_;  ///< kept across laps (the node persists in a patrol)
  double taught_total_m_ = 0.0;  ///< taught length of the edges driven since the estimator's reset
  double edge_scale_ = 1.0;      ///< distance_scale given to the current edge
};

/// Operator-driven teaching (seed 000 Sec. 2.1): creates a node and closes the current edge
/// whenever the operator switches primitive ({primitive}), pauses between edges while the
/// primitive is empty, and ends when {teach_done} is true. On a closed route, an operator that
/// signals {teach_closing} (every leg driven, turning to face the first edge) closes the last
/// edge at the start node at once and the turn it then makes is stored on that edge
/// (kClosingTurnStatistic) for FollowRoute's lap-to-lap turn.
class TeachRoute final : public bt::ControlNode {
 public:
  TeachRoute(const std::string& name, const bt::NodeConfig& config, HostServices& host);
  static bt::PortsList provided_ports();

 protected:
  bt::NodeStatus tick() override;
  void halt() override;

 private:
  Result<std::string> add_node(const std::string& name);
  void record_closing_turn();

  HostServices& host_;
  KindMap kinds_;
  bool close_loop_ = false;
  std::string start_id_;
  std::string current_id_;
  int nodes_created_ = 0;
  std::optional<std::size_t> active_child_;
  std::string active_kind_;
  std::optional<std::string> edge_to_;
  std::vector<std::string> taught_;
  std::optional<double> last_end_m_;     ///< odometric distance when the last edge was stored
  std::optional<double> pending_gap_m_;  ///< distance between that and the start of the edge being taught
  bool closing_ = false;                 ///< closed route: the operator is making the closing turn
  std::optional<double> closing_from_heading_rad_;  ///< odometric heading when the last edge was stored
};

}  // namespace visnav::nav
