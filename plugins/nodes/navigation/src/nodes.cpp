// Behaviour-tree adapters of the navigation plugin. Each node is thin: it reads ports and the
// host's run services, and delegates to navigation_core / the map store.
#include "nodes.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "visnav/edge_progress.hpp"
#include "visnav_navigation/navigation_core.hpp"

namespace visnav::nav {

namespace {

using bt::NodeStatus;

constexpr const char* kDefaultReplayKinds =
    "feature_segment=ReplayFeatureEdge;feature_localmaps=ReplayFeatureEdge;path_following=FollowPathEdge;"
    "visual_memory=ReplayVisualMemoryEdge";
constexpr const char* kDefaultTeachKinds =
    "feature_segment=TeachFeatureEdge;feature_localmaps=TeachFeatureEdge;path_following=TeachPathEdge;"
    "visual_memory=TeachVisualMemoryEdge";

std::optional<double> current_heading_rad(HostServices& host) {
  FrameBus* bus = host.frame_bus();
  if (bus == nullptr) return std::nullopt;
  auto odom = bus->latest_odometry();
  if (!odom) return std::nullopt;
  return odom->pose.heading_rad;
}

void stop_robot(HostServices& host) {
  if (Robot* robot = host.robot()) (void)robot->stop();
}

/// Logs `message` for `node` and returns failure.
NodeStatus fail_node(HostServices& host, const bt::TreeNode& node, const std::string& message) {
  host.logger().error(node.path(), message);
  return NodeStatus::failure;
}

/// Sends a velocity command: running, or, when the robot refuses it, the robot stopped and the
/// node failed with the robot's reason.
NodeStatus command(HostServices& host, bt::TreeNode& node, double linear_mps, double angular_radps) {
  Robot* robot = host.robot();
  if (robot == nullptr) return NodeStatus::running;
  if (auto st = robot->send_command(Twist{linear_mps, angular_radps}); !st) {
    (void)robot->stop();
    return fail_node(host, node, "the robot refused the velocity command: " + st.error().message);
  }
  return NodeStatus::running;
}

bt::PortsList turn_ports() {
  return {bt::input_port<double>("turn_tolerance_rad", "0.02", "a turn is complete within this heading error"),
          bt::input_port<double>("turn_speed_radps", "0.6", "maximum angular speed while turning in place"),
          bt::input_port<double>("turn_gain_per_s", "1.5", "proportional gain of the turn controller")};
}

bt::PortsList arc_ports() {
  return {bt::input_port<double>("min_turning_radius_m", "0",
                                 "0: turn in place; > 0: the robot cannot turn on the spot (car-like): the turn is "
                                 "driven as a forward arc of at least this radius (|angular| <= arc_speed_mps / R), m"),
          bt::input_port<double>("arc_speed_mps", "0.3", "forward speed on such an arc turn, m/s (0, 2]")};
}

Result<ArcTurnParams> read_arc_params(const bt::TreeNode& node) {
  ArcTurnParams p;
  VISNAV_ASSIGN(p.min_turning_radius_m, node.get_input<double>("min_turning_radius_m"));
  VISNAV_ASSIGN(p.speed_mps, node.get_input<double>("arc_speed_mps"));
  VISNAV_TRY(p.validate());
  return p;
}

bool moving(const Twist& t) { return t.linear_mps != 0.0 || t.angular_radps != 0.0; }

Result<TurnParams> read_turn_params(const bt::TreeNode& node, const char* tol, const char* speed, const char* gain) {
  TurnParams p;
  VISNAV_ASSIGN(p.tolerance_rad, node.get_input<double>(tol));
  VISNAV_ASSIGN(p.max_angular_radps, node.get_input<double>(speed));
  VISNAV_ASSIGN(p.gain_per_s, node.get_input<double>(gain));
  p.min_angular_radps = std::min(p.min_angular_radps, p.max_angular_radps);
  VISNAV_TRY(p.validate());
  return p;
}

}  // namespace

// ---------------------------------------------------------------------------------- PlanRoute

PlanRoute::PlanRoute(const std::string& name, const bt::NodeConfig& config, HostServices& host)
    : bt::SyncActionNode(name, config), host_(host) {}

bt::PortsList PlanRoute::provided_ports() {
  return {bt::input_port<std::string>("start", "", "start node (id or name); ignored when start_edge is set"),
          bt::input_port<std::string>("goal", "goal node (id or name); equal to start plans a closed loop"),
          bt::input_port<std::string>("start_edge", "",
                                      "plan from the middle of this edge (e.g. {reloc_edge} from Relocalise): the "
                                      "route is the rest of it, then the cheapest route from its end node to the goal"),
          bt::input_port<std::vector<std::string>>("kind_costs", "",
                                                    "cost multipliers per edge kind, e.g. path_following=0.5"),
          bt::output_port<std::vector<std::string>>("route", "{route}", "edge ids to traverse, in order"),
          bt::output_port<double>("length_m", "{route_length_m}", "odometric length of the route")};
}

NodeStatus PlanRoute::tick() {
  MapStore* map = host_.map();
  if (map == nullptr) return fail_node(host_, *this, "PlanRoute needs a map (visnav run --map M)");
  auto start = get_input<std::string>("start");
  auto goal = get_input<std::string>("goal");
  auto costs = get_input<std::vector<std::string>>("kind_costs");
  if (!start || !goal || !costs) return fail_node(host_, *this, (!start ? start.error() : !goal ? goal.error() : costs.error()).message);
  auto cost = parse_kind_costs(*costs);
  if (!cost) return fail_node(host_, *this, "kind_costs: " + cost.error().message);
  auto start_edge = get_input<std::string>("start_edge");
  if (!start_edge) return fail_node(host_, *this, start_edge.error().message);
  auto goal_node = map->resolve_node(*goal);
  if (!goal_node) return fail_node(host_, *this, goal_node.error().message);
  Result<Route> route = Route{};
  if (!start_edge->empty()) {
    route = plan_from_edge(*map, *start_edge, (*goal_node)->id, *cost);
  } else {
    if (start->empty()) return fail_node(host_, *this, "PlanRoute needs 'start' (a node) or 'start_edge'");
    auto start_node = map->resolve_node(*start);
    if (!start_node) return fail_node(host_, *this, start_node.error().message);
    route = (*start_node)->id == (*goal_node)->id ? plan_cycle(*map, (*start_node)->id, *cost)
                                                  : plan_route(*map, (*start_node)->id, (*goal_node)->id, *cost);
  }
  if (!route) return fail_node(host_, *this, route.error().message);
  host_.logger().info(path(), "route " + (start_edge->empty() ? *start : "edge " + *start_edge) + " -> " + *goal + ": " + std::to_string(route->edge_ids.size()) +
                                  " edges, " + std::to_string(route->length_m) + " m");
  auto s1 = set_output("route", route->edge_ids);
  auto s2 = set_output("length_m", route->length_m);
  if (!s1 || !s2) return fail_node(host_, *this, (!s1 ? s1.error() : s2.error()).message);
  return NodeStatus::success;
}

// ------------------------------------------------------------------------------ TurnToAzimuth

TurnToAzimuth::TurnToAzimuth(const std::string& name, const bt::NodeConfig& config, HostServices& host)
    : bt::StatefulActionNode(name, config), host_(host) {}

bt::PortsList TurnToAzimuth::provided_ports() {
  bt::PortsList ports = {
      bt::input_port<double>("azimuth_rad", "0", "target heading (odom frame), or a turn angle when relative=true"),
      bt::input_port<std::string>("edge", "", "if set: turn to the start azimuth of this map edge instead"),
      bt::input_port<bool>("relative", "false", "azimuth_rad is relative to the heading at the start")};
  for (auto& p : turn_ports()) ports.push_back(std::move(p));
  for (auto& p : arc_ports()) ports.push_back(std::move(p));
  return ports;
}

NodeStatus TurnToAzimuth::on_start() {
  auto params = read_turn_params(*this, "turn_tolerance_rad", "turn_speed_radps", "turn_gain_per_s");
  if (!params) return fail_node(host_, *this, params.error().message);
  params_ = *params;
  auto arc = read_arc_params(*this);
  if (!arc) return fail_node(host_, *this, arc.error().message);
  arc_ = *arc;
  auto heading = current_heading_rad(host_);
  if (!heading) return fail_node(host_, *this, "no odometry");
  auto edge = get_input<std::string>("edge");
  auto azimuth = get_input<double>("azimuth_rad");
  auto relative = get_input<bool>("relative");
  if (!edge || !azimuth || !relative) return fail_node(host_, *this, "bad ports");
  if (!edge->empty()) {
    MapStore* map = host_.map();
    if (map == nullptr) return fail_node(host_, *this, "edge given but no map is loaded");
    const EdgeRecord* record = map->find_edge(*edge);
    if (record == nullptr) return fail_node(host_, *this, "unknown edge '" + *edge + "'");
    target_rad_ = record->azimuth_rad;
  } else {
    target_rad_ = *relative ? *heading + *azimuth : *azimuth;
  }
  return on_running();
}

NodeStatus TurnToAzimuth::on_running() {
  auto heading = current_heading_rad(host_);
  if (!heading) return fail_node(host_, *this, "no odometry");
  const Twist c = arc_turn_command(wrap_angle_rad(target_rad_ - *heading), params_, arc_);
  if (!moving(c)) {
    stop_robot(host_);
    return NodeStatus::success;
  }
  return command(host_, *this, c.linear_mps, c.angular_radps);
}

void TurnToAzimuth::on_halted() { stop_robot(host_); }

// ------------------------------------------------------------------------------------ AtNode

AtNode::AtNode(const std::string& name, const bt::NodeConfig& config, HostServices& host)
    : bt::ConditionNode(name, config), host_(host) {}

bt::PortsList AtNode::provided_ports() {
  return {bt::input_port<std::string>("node", "map node (id or name)"),
          bt::input_port<std::string>("current", "{current_node}", "the node the robot is at (id)")};
}

NodeStatus AtNode::tick() {
  auto node = get_input<std::string>("node");
  auto current = get_input<std::string>("current");
  if (!node || !current) return NodeStatus::failure;
  if (*node == *current) return NodeStatus::success;
  MapStore* map = host_.map();
  if (map == nullptr) return NodeStatus::failure;
  auto resolved = map->resolve_node(*node);
  return resolved && (*resolved)->id == *current ? NodeStatus::success : NodeStatus::failure;
}

// -------------------------------------------------------------------------------- FollowRoute

FollowRoute::FollowRoute(const std::string& name, const bt::NodeConfig& config, HostServices& host)
    : bt::ControlNode(name, config), host_(host) {}

bt::PortsList FollowRoute::provided_ports() {
  bt::PortsList ports = {
      bt::input_port<std::vector<std::string>>("route", "{route}", "edge ids to traverse (from PlanRoute)"),
      bt::input_port<std::vector<std::string>>("primitives", kDefaultReplayKinds,
                                                "which child node replays which edge kind (kind=NodeID;...)"),
      bt::input_port<bool>("turn_at_nodes", "true", "turn to the next edge's azimuth at each node (in place, or an arc with min_turning_radius_m > 0)"),
      bt::input_port<std::vector<std::string>>(
          "heading_holding_kinds", "feature_segment;feature_localmaps;path_following",
          "edge kinds whose primitive ends on the taught heading (the turn to the next edge is measured from "
          "the heading at the edge's end); after other kinds the turn is measured from the heading at the "
          "edge's start, which carries both runs' odometric heading drift over the whole edge "
          "(docs/navigation.md, \"The turn after a path edge\")"),
      bt::input_port<bool>("carry_overshoot", "true",
                           "start each edge as far along as the robot already is: the distance it travelled past "
                           "the previous edge's end node (last-frame overshoot plus stopping distance) minus the gap "
                           "recorded when teaching (statistic start_gap_m), projected onto the new edge's direction"),
      bt::input_port<double>("max_carry_m", "0.5", "clamp of |carried_m|, m (> 0)"),
      bt::input_port<double>("end_shift_m", edge_progress::end_shift_m,
                             "written by the replay child when it ends an edge: how much earlier in odometric "
                             "distance than the edge's length it put the end node (its visual along-track "
                             "correction); the overshoot carried into the next edge is counted from there (unset: 0)"),
      bt::inout_port<double>(
          "extra_travel_m", edge_progress::extra_travel_m,
          "written by the replay child when it ends an edge: odometric metres it drove that were not progress along "
          "the edge (ReplayAvoiding's detours, reversing, crossings); FollowRoute resets it to 0 at the edge's start and "
          "counts route distance without it (the next edge's carried distance and the distance-scale fixes), m"),
      bt::input_port<bool>("checkpoint", "false",
                           "keep a progress checkpoint (edge, distance, goal) in the map folder, progress.yaml, "
                           "written crash-safely at each edge start and every checkpoint_interval_m, removed when the "
                           "route is done: `visnav run --resume` continues from it"),
      bt::input_port<double>("checkpoint_interval_m", "1", "distance between checkpoint writes along an edge, m (> 0)"),
      bt::input_port<double>("start_distance_m", "0",
                             "distance of the route's first edge already behind the robot when the route starts "
                             "(e.g. {reloc_distance_m} from Relocalise): the first edge is driven from there, m (>= 0)"),
      bt::input_port<std::string>(
          "first_edge_turn", "none",
          "before the first edge of a mission (no previous_edge): none = no turn, the robot starts facing along "
          "the edge and the edge's own visual correction removes the rest (a replay never depends on the heading "
          "drift accumulated while teaching); absolute = turn to the edge's odometry-frame azimuth (only when the "
          "replay's odometry frame is the teach run's)"),
      bt::input_port<bool>("scale_distance", "false",
                           "estimate this replay's odometric distance scale against the teach run's from the "
                           "edges whose primitive fixed its end visually (end_shift_m != 0) and hand it to the "
                           "children (distance_scale); without such edges it stays 1"),
      bt::input_port<std::string>(
          "scale_fix_kinds", "",
          "scale_distance: only the ends of edges of these kinds (comma-separated, e.g. path_following) are "
          "fixes of the scale; empty = every kind whose primitive moved its end"),
      bt::input_port<double>("scale_min_baseline_m", "20",
                             "taught distance the visual fixes must span before the scale is used, m (> 0)"),
      bt::input_port<double>("scale_max_deviation", "0.1", "clamp of |distance_scale - 1|, (0, 0.5]"),
      bt::output_port<double>("distance_scale", edge_progress::distance_scale,
                              "odometric metres per taught metre for the edge being driven (children read it)"),
      bt::output_port<double>("carried_m", edge_progress::carried_m,
                              "distance of the edge already covered when it starts (children read it; 0 when off)"),
      bt::output_port<std::string>("edge", edge_progress::edge, "the edge being traversed (children read it)"),
      bt::output_port<std::string>("current_node", "{current_node}", "the last node reached"),
      bt::inout_port<std::string>("previous_edge", "{previous_edge}",
                                  "last edge traversed (kept across runs so patrol loops turn relatively)")};
  for (auto& p : turn_ports()) ports.push_back(std::move(p));
  for (auto& p : arc_ports()) ports.push_back(std::move(p));
  return ports;
}

Status FollowRoute::start() {
  MapStore* map = host_.map();
  if (map == nullptr) return fail("FollowRoute needs a map (visnav run --map M)");
  VISNAV_ASSIGN(route_, get_input<std::vector<std::string>>("route"));
  VISNAV_ASSIGN(auto entries, get_input<std::vector<std::string>>("primitives"));
  VISNAV_ASSIGN(kinds_, parse_kind_map(entries));
  VISNAV_ASSIGN(turn_at_nodes_, get_input<bool>("turn_at_nodes"));
  VISNAV_ASSIGN(heading_holding_kinds_, get_input<std::vector<std::string>>("heading_holding_kinds"));
  VISNAV_ASSIGN(carry_overshoot_, get_input<bool>("carry_overshoot"));
  VISNAV_ASSIGN(max_carry_m_, get_input<double>("max_carry_m"));
  if (!(max_carry_m_ > 0.0)) return fail("max_carry_m must be > 0");
  VISNAV_ASSIGN(checkpoint_, get_input<bool>("checkpoint"));
  VISNAV_ASSIGN(checkpoint_interval_m_, get_input<double>("checkpoint_interval_m"));
  if (!(checkpoint_interval_m_ > 0.0))
    return fail(ErrorCode::out_of_range, {"", 0, "checkpoint_interval_m"},
                "value " + std::to_string(checkpoint_interval_m_) + " must be > 0");
  VISNAV_ASSIGN(start_distance_m_, get_input<double>("start_distance_m"));
  if (!(start_distance_m_ >= 0.0) || !std::isfinite(start_distance_m_))
    return fail(ErrorCode::out_of_range, {"", 0, "start_distance_m"},
                "value " + std::to_string(start_distance_m_) + " is not a finite distance >= 0");
  if (!route_.empty())
    if (const EdgeRecord* first = map->find_edge(route_.front()); first != nullptr && start_distance_m_ > first->length_m)
      return fail(ErrorCode::out_of_range, {"", 0, "start_distance_m"},
                  "value " + std::to_string(start_distance_m_) + " is beyond the end of edge " + first->id + " (" +
                      std::to_string(first->length_m) + " m)");
  VISNAV_ASSIGN(const std::string first_turn, get_input<std::string>("first_edge_turn"));
  if (first_turn != "none" && first_turn != "absolute")
    return fail("port 'first_edge_turn': '" + first_turn + "' is not one of: none, absolute");
  first_turn_absolute_ = first_turn == "absolute";
  VISNAV_ASSIGN(scale_distance_, get_input<bool>("scale_distance"));
  {
    VISNAV_ASSIGN(const std::string kinds, get_input<std::string>("scale_fix_kinds"));
    scale_fix_kinds_.clear();
    std::size_t begin = 0;
    while (begin <= kinds.size()) {
      std::size_t end = kinds.find(',', begin);
      if (end == std::string::npos) end = kinds.size();
      std::string kind = kinds.substr(begin, end - begin);
      kind.erase(0, kind.find_first_not_of(" \t"));
      kind.erase(kind.find_last_not_of(" \t") + 1);
      if (!kind.empty()) scale_fix_kinds_.push_back(kind);
      begin = end + 1;
    }
  }
  DistanceScaleParams scale_params;
  VISNAV_ASSIGN(scale_params.min_baseline_m, get_input<double>("scale_min_baseline_m"));
  VISNAV_ASSIGN(scale_params.max_deviation, get_input<double>("scale_max_deviation"));
  VISNAV_TRY(scale_params.validate());
  {
    // The fixes stay valid while the robot goes on from where the last route ended (a patrol's
    // next lap); a route that starts elsewhere (relocalised, another start) starts afresh.
    auto previous = get_input<std::string>("previous_edge");
    const EdgeRecord* prev = previous ? map->find_edge(*previous) : nullptr;
    const EdgeRecord* first = route_.empty() ? nullptr : map->find_edge(route_.front());
    const bool continues = prev != nullptr && first != nullptr && prev->to == first->from && start_distance_m_ == 0.0 &&
                           previous && *previous == ended_edge_;
    if (!continues || scale_params.min_baseline_m != scale_params_.min_baseline_m ||
        scale_params.max_deviation != scale_params_.max_deviation) {
      scale_params_ = scale_params;
      scale_estimator_ = DistanceScaleEstimator(scale_params_);
      taught_total_m_ = 0.0;
    }
  }
  previous_start_heading_.reset();
  checkpointed_m_.reset();
  checkpoint_warned_ = false;
  VISNAV_ASSIGN(turn_, read_turn_params(*this, "turn_tolerance_rad", "turn_speed_radps", "turn_gain_per_s"));
  VISNAV_ASSIGN(arc_, read_arc_params(*this));
  child_for_edge_.clear();
  for (const auto& edge_id : route_) {
    const EdgeRecord* edge = map->find_edge(edge_id);
    if (edge == nullptr) return fail("route names unknown edge '" + edge_id + "'");
    const std::string* node_id = find_kind(kinds_, edge->kind);
    if (node_id == nullptr) return fail("no primitive is mapped for edge kind '" + edge->kind + "' (edge " + edge_id + ")");
    std::optional<std::size_t> child;
    for (std::size_t i = 0; i < children_.size(); ++i)
      if (children_[i]->registration_id() == *node_id) { child = i; break; }
    if (!child) return fail("edge kind '" + edge->kind + "' needs a child " + *node_id + " under FollowRoute");
    child_for_edge_.push_back(*child);
  }
  // Every payload of the route is read and decoded before the robot moves (issue 17): a damaged
  // or edited edge further on must not be found after the earlier edges have been driven.
  VISNAV_TRY(map->check_route(route_));
  index_ = 0;
  turning_ = true;
  turn_target_.reset();
  return ok();
}

NodeStatus FollowRoute::tick() {
  if (status() != NodeStatus::running) {
    if (auto st = start(); !st) return fail_node(host_, *this, st.error().message);
    if (route_.empty()) return NodeStatus::success;
  }
  MapStore& map = *host_.map();
  const EdgeRecord& edge = *map.find_edge(route_[index_]);
  if (turning_) {
    if (turn_at_nodes_) {
      auto heading = current_heading_rad(host_);
      if (!heading) return fail_node(host_, *this, "no odometry");
      if (!turn_target_) {
        auto previous = get_input<std::string>("previous_edge");
        const EdgeRecord* prev = previous ? map.find_edge(*previous) : nullptr;
        turn_target_ = turn_target_rad(prev, edge, *heading);
        arc_start_m_.reset();
        if (FrameBus* bus = host_.frame_bus())
          if (auto odom = bus->latest_odometry()) arc_start_m_ = route_odometer_m(*odom);
      }
      const Twist c = arc_turn_command(wrap_angle_rad(*turn_target_ - *heading), turn_, arc_);
      if (moving(c)) {
        return command(host_, *this, c.linear_mps, c.angular_radps);
      }
      // An arc turn ends moving: the next edge's child takes over without a stop.
      if (!arc_.arcs()) stop_robot(host_);
    }
    turning_ = false;
    turn_target_.reset();
    edge_start_heading_ = current_heading_rad(host_);
    // Where the new edge starts, in odometric distance: here, less what the robot overshot the
    // previous edge's end node by (when that edge leads straight into this one).
    const auto odom = host_.frame_bus() != nullptr ? host_.frame_bus()->latest_odometry() : std::nullopt;
    double carried_m = 0.0;
    auto previous = get_input<std::string>("previous_edge");
    if (carry_overshoot_ && odom && ended_at_m_ && previous && *previous == ended_edge_) {
      if (const EdgeRecord* prev = map.find_edge(ended_edge_)) {
        double taught_gap_m = 0.0;
        if (auto it = edge.statistics.find(kStartGapStatistic); it != edge.statistics.end()) taught_gap_m = it->second;
        if (arc_.arcs() && turn_at_nodes_ && arc_start_m_) {
          // Arc turn: the taught gap is the taught arc, which this arc drove again; only the
          // overshoot before the arc started is carried.
          carried_m = carried_distance_m(*arc_start_m_ - *ended_at_m_, 0.0, turn_between_edges_rad(*prev, edge),
                                         max_carry_m_);
        } else {
          carried_m = carried_distance_m(route_odometer_m(*odom) - *ended_at_m_, taught_gap_m,
                                         turn_between_edges_rad(*prev, edge), max_carry_m_);
        }
      }
    }
    // The first edge of a route started from the middle (a relocalised robot): the rest of it.
    if (index_ == 0 && start_distance_m_ > 0.0) carried_m = start_distance_m_;
    edge_scale_ = scale_distance_ ? scale_estimator_.scale() : 1.0;
    // carried_m is in taught metres: the odometric overshoot divided by the scale.
    carried_m /= (index_ == 0 && start_distance_m_ > 0.0) ? 1.0 : edge_scale_;
    edge_origin_m_.reset();
    if (odom) edge_origin_m_ = route_odometer_m(*odom) - edge_scale_ * carried_m;
    if (auto st = set_output("carried_m", carried_m); !st) return fail_node(host_, *this, st.error().message);
    (void)set_output("extra_travel_m", 0.0);  // never a previous edge's (a tree may bind a literal)
    if (auto st = set_output("distance_scale", edge_scale_); !st) return fail_node(host_, *this, st.error().message);
    if (auto st = set_output("edge", edge.id); !st) return fail_node(host_, *this, st.error().message);
    (void)set_output("current_node", edge.from);
    host_.logger().info(path(), "edge " + edge.id + " (" + edge.kind + ", " + std::to_string(edge.length_m) +
                                    " m, carried " + std::to_string(carried_m) + " m, distance scale " +
                                    std::to_string(edge_scale_) + ")");
    checkpointed_m_.reset();
  }
  save_progress(edge);
  const std::size_t child_index = child_for_edge_[index_];
  const NodeStatus child_status = children_[child_index]->execute_tick();
  if (child_status == NodeStatus::running) return NodeStatus::running;
  reset_children();
  if (child_status == NodeStatus::failure) return fail_node(host_, *this, "edge " + edge.id + " failed");
  (void)set_output("previous_edge", edge.id);
  (void)set_output("current_node", edge.to);
  previous_start_heading_ = edge_start_heading_;
  ended_at_m_.reset();
  if (edge_origin_m_) {
    // The end node is where the child ended the edge: a primitive that corrects its along-track
    // position visually ends it end_shift_m before the odometric length; carrying the difference
    // into the next edge would undo that correction.
    const auto shift = get_input<double>("end_shift_m");
    const double shift_m = shift && std::isfinite(*shift) ? *shift : 0.0;
    ended_at_m_ = *edge_origin_m_ + edge_scale_ * (edge.length_m - shift_m);
    // A primitive that moved its end saw where the end node is: a fix of the distance scale.
    const bool fix_kind = scale_fix_kinds_.empty() || std::find(scale_fix_kinds_.begin(), scale_fix_kinds_.end(),
                                                                 edge.kind) != scale_fix_kinds_.end();
    if (scale_distance_ && fix_kind && shift_m != 0.0) scale_estimator_.add_fix(taught_total_m_ + edge.length_m, *ended_at_m_);
  }
  // Odometry the child drove off the route (a detour's sideways legs) is no progress along it:
  // route distances from here on leave it out.
  if (const auto extra = get_input<double>("extra_travel_m"); extra && std::isfinite(*extra) && *extra > 0.0)
    extra_travel_m_ += *extra;
  taught_total_m_ += edge.length_m;
  ended_edge_ = edge.id;
  ++index_;
  if (index_ >= route_.size()) {
    // Done: nothing is left to resume.
    if (checkpoint_)
      if (auto st = clear_progress(map.dir()); !st) host_.logger().warn(path(), st.error().message);
    return NodeStatus::success;
  }
  turning_ = true;
  return NodeStatus::running;
}

double FollowRoute::turn_target_rad(const EdgeRecord* previous, const EdgeRecord& next, double heading_rad) const {
  // First edge of a mission: the odometry frame of a replay is not the teach run's (and even in
  // one process it carries the teach run's heading drift), so by default the robot starts as it
  // stands and the edge's visual correction aligns it.
  if (previous == nullptr) return first_turn_absolute_ ? next.azimuth_rad : heading_rad;
  // From the route's last edge into its first (the next lap): the turn the operator made when
  // closing the loop, not the headings measured a whole loop apart.
  if (index_ == 0 && previous->to == next.from)
    if (auto it = previous->statistics.find(kClosingTurnStatistic); it != previous->statistics.end())
      return heading_rad + it->second;
  const bool holds_heading = std::find(heading_holding_kinds_.begin(), heading_holding_kinds_.end(),
                                       previous->kind) != heading_holding_kinds_.end();
  // The previous edge's primitive ended on its taught heading: turn relative to now.
  if (holds_heading || !previous_start_heading_) return heading_rad + turn_between_edges_rad(*previous, next);
  // It followed the shape of the terrain (e.g. rounded a corner): measure from the heading the
  // robot had, aligned with the previous edge's azimuth, when that edge started.
  return *previous_start_heading_ + wrap_angle_rad(next.azimuth_rad - previous->azimuth_rad);
}

void FollowRoute::save_progress(const EdgeRecord& edge) {
  if (!checkpoint_ || !edge_origin_m_ || host_.frame_bus() == nullptr) return;
  const auto odom = host_.frame_bus()->latest_odometry();
  if (!odom) return;
  const double along_m = std::clamp((route_odometer_m(*odom) - *edge_origin_m_) / edge_scale_, 0.0, edge.length_m);
  if (checkpointed_m_ && along_m - *checkpointed_m_ < checkpoint_interval_m_) return;
  MapStore& map = *host_.map();
  const EdgeRecord* last = map.find_edge(route_.back());
  const ProgressCheckpoint progress{edge.id, along_m, last != nullptr ? last->to : edge.to};
  if (auto st = write_progress(map.dir(), progress); !st) {
    // A checkpoint that cannot be written does not stop the mission (it only limits a resume).
    if (!checkpoint_warned_) host_.logger().warn(path(), "progress checkpoint: " + st.error().message);
    checkpoint_warned_ = true;
  }
  checkpointed_m_ = along_m;
}

void FollowRoute::halt() {
  reset_children();
  stop_robot(host_);
  turning_ = true;
  turn_target_.reset();
}

// --------------------------------------------------------------------------------- TeachRoute

TeachRoute::TeachRoute(const std::string& name, const bt::NodeConfig& config, HostServices& host)
    : bt::ControlNode(name, config), host_(host) {}

bt::PortsList TeachRoute::provided_ports() {
  return {
      bt::input_port<std::string>("primitive", "{primitive}",
                                  "edge kind the operator is teaching now; empty while not teaching (turning)"),
      bt::input_port<bool>("done", "{teach_done}", "the operator finished the route"),
      bt::input_port<std::string>("start_node", "start", "name of the first node"),
      bt::input_port<bool>("close_loop", "false", "the last edge ends at the first node (closed route)"),
      bt::input_port<bool>("closing", "{teach_closing}",
                           "closed route: the operator has driven every leg and is turning to face the first edge; "
                           "the last edge ends at the first node and the turn made until {teach_done} is recorded "
                           "(statistic closing_turn_rad; unset counts as false)"),
      bt::input_port<std::vector<std::string>>("primitives", kDefaultTeachKinds,
                                                "which child node teaches which edge kind (kind=NodeID;...)"),
      bt::input_port<std::string>("taught_edge", "{taught_edge}", "edge id written by the teaching child"),
      bt::output_port<std::string>("edge_from", edge_progress::edge_from, "start node of the edge being taught"),
      bt::output_port<std::string>("edge_to", edge_progress::edge_to, "end node, set when the edge is finished"),
      bt::output_port<bool>("finish_edge", "{finish_edge}", "true: the child must store its edge and succeed"),
      bt::output_port<std::string>("current_node", "{current_node}", "the last node created"),
      bt::output_port<std::vector<std::string>>("route", "{taught_route}", "edges taught so far, in order")};
}

Result<std::string> TeachRoute::add_node(const std::string& name) {
  MapStore* map = host_.map();
  NodeRecord node;
  node.name = name;
  if (FrameBus* bus = host_.frame_bus())
    if (auto odom = bus->latest_odometry()) node.position_hint = odom->pose;
  return map->add_node(std::move(node));
}

NodeStatus TeachRoute::tick() {
  if (status() != NodeStatus::running) {
    if (host_.map() == nullptr) return fail_node(host_, *this, "TeachRoute needs a map (visnav run --map M)");
    auto entries = get_input<std::vector<std::string>>("primitives");
    if (!entries) return fail_node(host_, *this, entries.error().message);
    auto kinds = parse_kind_map(*entries);
    if (!kinds) return fail_node(host_, *this, "primitives: " + kinds.error().message);
    kinds_ = std::move(*kinds);
    auto start_name = get_input<std::string>("start_node");
    auto close = get_input<bool>("close_loop");
    if (!start_name || !close) return fail_node(host_, *this, "bad start_node/close_loop");
    close_loop_ = *close;
    auto id = add_node(*start_name);
    if (!id) return fail_node(host_, *this, id.error().message);
    start_id_ = current_id_ = *id;
    nodes_created_ = 1;
    active_child_.reset();
    taught_.clear();
    last_end_m_.reset();
    pending_gap_m_.reset();
    closing_ = false;
    closing_from_heading_rad_.reset();
    (void)set_output("current_node", current_id_);
    (void)set_output("finish_edge", false);
  }
  auto primitive = get_input<std::string>("primitive");
  auto done_input = get_input<bool>("done");
  const std::string kind = primitive ? *primitive : std::string();
  const bool done = done_input && *done_input;
  if (auto closing = get_input<bool>("closing"); closing && *closing && close_loop_) closing_ = true;

  if (active_child_) {
    const bool finishing = done || closing_ || kind != active_kind_;
    if (finishing && !edge_to_) {
      // Close the edge: create its end node first, so the edge never references a node that
      // is not on disk yet.
      if ((done || closing_) && close_loop_) {
        edge_to_ = start_id_;
      } else {
        auto id = add_node("n" + std::to_string(nodes_created_++));
        if (!id) return fail_node(host_, *this, id.error().message);
        edge_to_ = *id;
      }
      (void)set_output("edge_to", *edge_to_);
      (void)set_output("finish_edge", true);
    }
    const NodeStatus s = children_[*active_child_]->execute_tick();
    if (s == NodeStatus::failure) {
      reset_children();
      return fail_node(host_, *this, "teaching the " + active_kind_ + " edge failed");
    }
    if (s == NodeStatus::running) return NodeStatus::running;
    if (!edge_to_) return fail_node(host_, *this, "a teaching child finished before the operator ended its edge");
    // Edge stored by the child.
    if (auto edge = get_input<std::string>("taught_edge"); edge) {
      taught_.push_back(*edge);
      // How far the robot had rolled on between the previous edge's end and this edge's start
      // (FollowRoute subtracts it from the overshoot it carries into this edge).
      if (pending_gap_m_)
        if (auto st = host_.map()->set_edge_statistic(*edge, kStartGapStatistic, *pending_gap_m_); !st)
          host_.logger().warn(path(), "edge " + *edge + ": " + st.error().message);
    }
    pending_gap_m_.reset();
    last_end_m_.reset();
    if (FrameBus* bus = host_.frame_bus())
      if (auto odom = bus->latest_odometry()) {
        last_end_m_ = odom->distance_m;
        if (closing_) closing_from_heading_rad_ = odom->pose.heading_rad;
      }
    (void)set_output("route", taught_);
    current_id_ = *edge_to_;
    (void)set_output("current_node", current_id_);
    (void)set_output("finish_edge", false);
    reset_children();
    active_child_.reset();
    edge_to_.reset();
    host_.logger().info(path(), "taught edge " + (taught_.empty() ? std::string("?") : taught_.back()) + " (" +
                                    active_kind_ + ") ending at node " + current_id_);
  }
  if (done) {
    record_closing_turn();
    return NodeStatus::success;
  }
  if (kind.empty() || closing_) return NodeStatus::running;  // operator is between edges (e.g. turning)
  const std::string* node_id = find_kind(kinds_, kind);
  if (node_id == nullptr) return fail_node(host_, *this, "no teaching node is mapped for kind '" + kind + "'");
  for (std::size_t i = 0; i < children_.size(); ++i) {
    if (children_[i]->registration_id() == *node_id) {
      active_child_ = i;
      break;
    }
  }
  if (!active_child_) return fail_node(host_, *this, "kind '" + kind + "' needs a child " + *node_id + " under TeachRoute");
  active_kind_ = kind;
  pending_gap_m_.reset();
  if (last_end_m_)
    if (FrameBus* bus = host_.frame_bus())
      if (auto odom = bus->latest_odometry()) pending_gap_m_ = std::max(0.0, odom->distance_m - *last_end_m_);
  (void)set_output("edge_from", current_id_);
  (void)set_output("edge_to", std::string());
  (void)set_output("finish_edge", false);
  const NodeStatus s = children_[*active_child_]->execute_tick();
  if (s == NodeStatus::failure) {
    reset_children();
    return fail_node(host_, *this, "teaching the " + kind + " edge failed to start");
  }
  return NodeStatus::running;
}

void TeachRoute::record_closing_turn() {
  if (!closing_from_heading_rad_ || taught_.empty()) return;
  FrameBus* bus = host_.frame_bus();
  const auto odom = bus != nullptr ? bus->latest_odometry() : std::nullopt;
  if (!odom) return;
  const double turn_rad = wrap_angle_rad(odom->pose.heading_rad - *closing_from_heading_rad_);
  if (auto st = host_.map()->set_edge_statistic(taught_.back(), kClosingTurnStatistic, turn_rad); !st) {
    host_.logger().warn(path(), "edge " + taught_.back() + ": " + st.error().message);
    return;
  }
  host_.logger().info(path(), "closing turn " + std::to_string(turn_rad * 180.0 / std::numbers::pi) +
                                  " deg recorded on edge " + taught_.back());
}

void TeachRoute::halt() {
  reset_children();  // the edge being taught is dropped; completed edges are already on disk
  active_child_.reset();
  edge_to_.reset();
}

}  // namespace visnav::nav
