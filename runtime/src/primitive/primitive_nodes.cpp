// The one adapter between navigation primitives (visnav/primitive.hpp) and behaviour trees:
// ReplayEdgeNode and TeachEdgeNode, generated per registered primitive type. Everything every
// primitive needs alike lives here once; the primitive classes only decode, step and encode.
#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>
#include <string_view>
#include <type_traits>
#include <utility>

#include "visnav/edge_progress.hpp"
#include "visnav/bt/node.hpp"
#include "visnav/bt/param_ports.hpp"
#include "visnav/bt/registry.hpp"
#include "visnav/primitive.hpp"

namespace visnav {
namespace {

using bt::NodeStatus;
using bt::ParamPorts;

std::string format_double(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3f", v);
  return buf;
}

ParamPorts primitive_ports(const std::shared_ptr<const PrimitiveType>& type) {
  return {type->params, [type](std::string_view key, const ConfigNode& v) { return type->check_param(key, v); }};
}

/// The lost policy (nav_health.hpp) as every replay node's ports (docs/navigation.md, "Lost
/// detection"): the defaults are LostPolicy's, the ranges checked on literals, validate() the policy's own.
struct LostPolicyPorts {
  double min_frame_confidence = LostPolicy{}.min_confidence;
  double slow_after_m = LostPolicy{}.slow_after_m;
  double max_blind_m = LostPolicy{}.max_blind_m;
  double max_frozen_m = LostPolicy{}.max_frozen_m;
  double max_saturated_m = LostPolicy{}.max_saturated_m;
  double max_heading_deviation_deg = LostPolicy{}.max_heading_deviation_rad * 180.0 / std::numbers::pi;

  [[nodiscard]] LostPolicy policy() const {
    LostPolicy p;
    p.min_confidence = min_frame_confidence;
    p.slow_after_m = slow_after_m;
    p.max_blind_m = max_blind_m;
    p.max_frozen_m = max_frozen_m;
    p.max_saturated_m = max_saturated_m;
    p.max_heading_deviation_rad = max_heading_deviation_deg * std::numbers::pi / 180.0;
    return p;
  }
  [[nodiscard]] Status validate() const {
    VISNAV_TRY(schema().check(*this));
    return policy().validate();
  }
  static const ParamSchema<LostPolicyPorts>& schema() {
    using P = LostPolicyPorts;
    static const auto s =
        ParamSchema<P>{}
            .field("min_frame_confidence", &P::min_frame_confidence,
                   "lost policy: window-mean confidence at which the robot sees the route")
            .range(0.0, 1.0)
            .field("slow_after_m", &P::slow_after_m, "lost policy: blind distance after which the speed is reduced, m")
            .range(0.0, 1e6)
            .field("max_blind_m", &P::max_blind_m,
                   "lost policy: blind distance after which the edge fails with 'lost', m")
            .range(0.0, 1e6)
            .field("max_frozen_m", &P::max_frozen_m,
                   "lost policy: travel with identical frames (or without a new frame) after which the edge fails "
                   "with 'camera frozen', m")
            .range(0.0, 1e6)
            .field("max_saturated_m", &P::max_saturated_m,
                   "lost policy: travel with a saturated correction after which the edge fails, m")
            .range(0.0, 1e6)
            .field("max_heading_deviation_deg", &P::max_heading_deviation_deg,
                   "lost policy: odometric heading vs the taught one, deg; 0 = off")
            .range(0.0, 180.0);
    return s;
  }
};

Result<LostPolicy> read_lost_policy(const bt::TreeNode& node) {
  VISNAV_ASSIGN(LostPolicyPorts p, bt::parse_param_ports(node, LostPolicyPorts::schema()));
  return p.policy();
}

/// Starts `monitor` for an edge from the node's carried inout ports (unset ones count from here).
void begin_nav_health(NavHealthMonitor& monitor, const bt::TreeNode& node, double odom_distance_m,
                      double odom_heading_rad, std::optional<TaughtHeading> taught) {
  auto carried = [&](const char* port) -> std::optional<double> {
    auto v = node.get_input<double>(port);
    if (!v) return std::nullopt;
    return *v;
  };
  monitor.begin(odom_distance_m, odom_heading_rad, carried("confident_at_m"), carried("image_changed_at_m"), taught);
}

/// The newest frame if it is new, its features (when the primitive uses a detector) and what
/// makes it unusable. Shared by both adapters.
class FrameGate {
 public:
  void reset() {
    have_frame_ = false;
    warned_ = false;
    features_.clear();
  }
  /// nullopt when there is no frame newer than the last one.
  std::optional<Frame> next(FrameBus& bus) {
    std::optional<Frame> frame = bus.latest_frame();
    if (!frame || (have_frame_ && frame->sequence <= last_sequence_)) return std::nullopt;
    have_frame_ = true;
    last_sequence_ = frame->sequence;
    return frame;
  }
  /// Checks size and runs the detector; returns the problem or nullptr. Warns once per edge.
  /// `node` names the warnings (its path is built only when one is logged, not per frame).
  const char* inspect(const Frame& frame, Detector* detector, int width_px, int height_px, Logger& logger,
                      const bt::TreeNode& node) {
    const cv::Mat& image = frame.image;
    const char* problem = nullptr;
    if (image.empty()) {
      problem = "empty frame";
    } else if (width_px > 0 && (image.cols != width_px || image.rows != height_px)) {
      problem = "frame size differs from the taught one";
    } else if (detector != nullptr) {
      if (auto st = detector->detect(image, features_); !st) {
        problem = "detector failed on the frame";
        if (!warned_) logger.warn(node.path(), "detector: " + st.error().message);
      }
    }
    if (problem != nullptr) {
      features_.clear();
      if (!warned_) logger.warn(node.path(), std::string(problem) + ": no use of this frame");
      warned_ = true;
    }
    return problem;
  }
  [[nodiscard]] const Features& features() const { return features_; }

 private:
  Features features_;
  std::uint64_t last_sequence_ = 0;
  bool have_frame_ = false;
  bool warned_ = false;
};

int statistic(const EdgeRecord& edge, const char* key) {
  auto it = edge.statistics.find(key);
  return it != edge.statistics.end() ? static_cast<int>(it->second) : 0;
}

// ---------------------------------------------------------------------------------- replay

class ReplayEdgeNode final : public bt::StatefulActionNode {
 public:
  ReplayEdgeNode(const std::string& name, const bt::NodeConfig& config, HostServices& host,
                 std::shared_ptr<const PrimitiveType> type)
      : StatefulActionNode(name, config), host_(host), type_(std::move(type)) {}

  static Result<bt::PortsList> ports(const std::shared_ptr<const PrimitiveType>& type) {
    std::string kinds;
    for (const auto& k : type->kinds) kinds += (kinds.empty() ? "" : " or ") + k;
    bt::PortsList p = {
        bt::input_port<std::string>("edge", edge_progress::edge, "map edge to traverse (kind " + kinds + ")"),
        bt::input_port<double>("carried_m", edge_progress::carried_m,
                               "distance of the edge already covered at the start (FollowRoute's overshoot carry; "
                               "unset counts as 0)"),
        bt::with_range(bt::input_port<double>("distance_scale", edge_progress::distance_scale,
                               "odometric metres per taught metre (FollowRoute's estimate of this replay's odometry "
                               "scale against the teach run's): the primitive sees the edge's distance divided by it, "
                               "so the edge ends where it ended when taught; unset counts as 1, else in [0.5, 2]"), 0.5, 2.0),
        bt::output_port<int>("lap", "{lap}", "0-based lap being driven (closed paths driven several times)"),
        bt::output_port<std::string>("failure", edge_progress::failure,
                                     "the reason of the node's last FAILURE (empty while it runs or after a success): "
                                     "for people and logs; a decorator keys on failure_code, never on this text"),
        bt::output_port<std::string>("failure_code", edge_progress::failure_code,
                                     "the kind of the node's last FAILURE, a stable code to key on (view_lost, "
                                     "route_lost, input_lost, command_failed, bad_params, ...; docs/feature_replay.md, "
                                     "\"Failure codes\"); empty while it runs or after a success"),
        bt::output_port<double>("end_shift_m", edge_progress::end_shift_m,
                                "when the edge ends: how much earlier (positive) or later in odometric distance than "
                                "its taught length the primitive ended it (a visual along-track correction; 0 for "
                                "odometry alone); FollowRoute counts the next edge's carried distance from there"),
        bt::output_port<double>("shift_m", edge_progress::shift_m,
                                "while the edge runs, every frame: the primitive's visual along-track correction so far "
                                "(its along-edge distance minus the odometric count, taught metres; 0 at the start and "
                                "for odometry alone); a decorator that halts and restarts the node mid-edge "
                                "(ReplayAvoiding) carries it into the restart"),
    };
    VISNAV_TRY(bt::append_param_ports(p, primitive_ports(type)));
    bt::append_param_ports(p, LostPolicyPorts::schema());
    p.push_back(bt::inout_port<double>("confident_at_m", edge_progress::confident_at_m,
                                       "odometric distance at which the route was last seen (carried between edges; "
                                       "unset: count from the edge start)"));
    p.push_back(bt::inout_port<double>("image_changed_at_m", edge_progress::image_changed_at_m,
                                       "odometric distance at which the image last changed (carried between edges)"));
    return p;
  }

  NodeStatus on_start() override {
    replayer_.reset();
    (void)set_output("end_shift_m", 0.0);  // never a previous edge's
    (void)set_output("shift_m", 0.0);
    (void)set_output("failure", std::string());
    (void)set_output("failure_code", std::string());
    std::string_view code = replay_failure::bad_params;  // start() names the kind of what it refuses
    if (auto st = start(code); !st) return failed(code, st.error().message);
    return on_running();
  }

  NodeStatus on_running() override {
    Robot& robot = *host_.robot();
    std::optional<Odometry> odom = host_.frame_bus()->latest_odometry();
    std::optional<Frame> frame = odom ? frames_.next(*host_.frame_bus()) : std::nullopt;
    if (!odom || !frame) return without_new_frame(robot, odom);
    last_frame_odom_m_ = odom->distance_m;

    const char* problem = frames_.inspect(*frame, type_->uses_detector ? host_.active_detector() : nullptr,
                                          expected_width_px_, expected_height_px_, host_.logger(), *this);
    // The primitive sees distance in the teach run's odometric metres (distance_scale).
    const Odometry taught_odom = in_taught_units(*odom);
    const ReplayInput input{taught_odom, taught_odom.distance_m - origin_m_, *frame,
                            type_->uses_detector ? &frames_.features() : nullptr, problem};
    ReplayStep step = replayer_->step(input);
    if (problem != nullptr) step.confidence = 0.0;
    // The primitive's along-edge distance against odometry's: published before any failure, so a
    // decorator that takes over mid-edge keeps the correction (lap 0 only: a closed path's
    // distance restarts every lap).
    if (step.lap == 0) {
      const double shift_m = step.distance_m - input.edge_distance_m;
      (void)set_output("shift_m", std::isfinite(shift_m) ? shift_m : 0.0);
    }
    if (step.lap != lap_) {
      lap_ = step.lap;
      (void)set_output("lap", lap_);
    }
    if (!step.failure.empty()) {
      publish(step, Twist{}, problem, nullptr);
      return failed(step.failure_code.empty() ? replay_failure::primitive : std::string_view(step.failure_code),
                    step.failure);
    }
    if (step.orienting) {
      publish(step, step.command, problem, nullptr);
      return send(robot, step.command);
    }
    const NavHealthVerdict& health = health_.update(odom->distance_m, odom->pose.heading_rad, step.distance_m,
                                                    frame->image, step.confidence, step.saturated, step.informative);
    // The carried distances (errors ignored: a tree that does not carry them may bind literals).
    (void)set_output("confident_at_m", health_.confident_at_m());
    (void)set_output("image_changed_at_m", health_.changed_at_m());
    // A robot that is not sure where the route is slows down (the curvature is kept).
    Twist command{step.command.linear_mps * health.speed_factor, step.command.angular_radps * health.speed_factor};
    publish(step, health.must_stop() ? Twist{} : command, problem, &health);
    if (health.must_stop()) {
      const std::string_view code =
          health.state == NavHealthState::frozen ? replay_failure::input_lost : replay_failure::route_lost;
      return failed(code, health.reason + " on edge " + edge_id_ + " (" + edge_kind_ + ", " +
                              std::to_string(step.inliers) + " inliers, window confidence " +
                              format_double(health.window_confidence) + ")");
    }
    if (step.finished) {
      // Where the primitive put the edge's end: its own along-edge distance against odometry's.
      const double shift_m = step.distance_m - (taught_odom.distance_m - origin_m_);
      (void)set_output("end_shift_m", std::isfinite(shift_m) ? shift_m : 0.0);
      (void)robot.stop();
      last_command_ = Twist{};
      if (auto st = replayer_->succeeded(); !st) host_.logger().warn(path(), "edge " + edge_id_ + ": " + st.error().message);
      replayer_.reset();
      return NodeStatus::success;
    }
    return send(robot, command);
  }

  void on_halted() override {
    if (Robot* robot = host_.robot()) (void)robot->stop();
    replayer_.reset();
  }

 private:
  /// Prepares the edge; `code` is set to the replay_failure kind of each check before it runs.
  Status start(std::string_view& code) {
    const std::string& id = type_->node_id;
    MapStore* map = host_.map();
    code = replay_failure::no_map;
    if (map == nullptr) return fail(id + " needs a map (visnav run --map M)");
    code = replay_failure::input_lost;
    if (host_.frame_bus() == nullptr || host_.robot() == nullptr) return fail(id + " needs a running session");
    code = replay_failure::no_detector;
    if (type_->uses_detector && host_.active_detector() == nullptr)
      return fail(id + " needs a detector (config section 'detector')");
    code = replay_failure::bad_params;
    VISNAV_ASSIGN(edge_id_, get_input<std::string>("edge"));
    code = replay_failure::bad_edge;
    const EdgeRecord* edge = map->find_edge(edge_id_);
    if (edge == nullptr) return fail("unknown edge '" + edge_id_ + "'");
    bool known_kind = false;
    std::string kinds;
    for (const auto& k : type_->kinds) {
      known_kind = known_kind || k == edge->kind;
      kinds += (kinds.empty() ? "" : " and ") + k;
    }
    if (!known_kind) return fail("edge " + edge_id_ + " has kind '" + edge->kind + "'; " + id + " replays only " + kinds);
    edge_kind_ = edge->kind;
    expected_width_px_ = statistic(*edge, "image_width_px");
    expected_height_px_ = statistic(*edge, "image_height_px");

    code = replay_failure::bad_params;
    VISNAV_ASSIGN(LostPolicy policy, read_lost_policy(*this));
    health_ = NavHealthMonitor(policy);
    VISNAV_ASSIGN(ConfigNode params, bt::read_param_ports(*this, type_->params));
    VISNAV_ASSIGN(replayer_, type_->make_replayer(params));
    // The payload is read and verified once, here, before the robot moves (never per frame).
    code = replay_failure::bad_payload;
    auto body = map->read_payload(edge_id_);
    if (!body) return fail("edge " + edge_id_ + " payload: " + body.error().message);
    // The primitive's own body check (length against the graph and against the body's evidence,
    // loops), as `visnav map validate` runs it: a single-edge mission is not route-checked.
    if (auto checked = map->check_payload(edge_id_); !checked)
      return fail(checked.error().code, "edge " + edge_id_ + " payload: " + checked.error().message);
    code = replay_failure::input_lost;
    std::optional<Odometry> odom = host_.frame_bus()->latest_odometry();
    if (!odom) return fail("no odometry yet");
    // The edge counts as started `carried_m` before here (FollowRoute; an unset entry counts as 0).
    const auto carried = get_input<double>("carried_m");
    scale_ = 1.0;
    code = replay_failure::bad_params;
    if (const auto scale = get_input<double>("distance_scale"); scale) {
      if (!(*scale >= 0.5 && *scale <= 2.0))
        return fail(ErrorCode::out_of_range, {"", 0, "distance_scale"},
                    "port 'distance_scale': value " + format_double(*scale) + " is not in [0.5, 2]");
      scale_ = *scale;
    }
    origin_m_ = odom->distance_m - scale_ * (carried && std::isfinite(*carried) ? *carried : 0.0);
    // ReplayStart holds a view of the node path: keep the string alive past begin().
    const std::string node_path = path();
    const Odometry taught_odom = in_taught_units(*odom);
    const ReplayStart start{*edge, *body, taught_odom, origin_m_, health_.policy(), host_.logger(), node_path};
    code = replay_failure::bad_payload;
    if (auto st = replayer_->begin(start); !st) return fail("edge " + edge_id_ + " payload: " + st.error().message);

    std::optional<TaughtHeading> taught;
    if (replayer_->heading_check()) {
      taught = TaughtHeading{edge->length_m, 0.0};
      if (auto it = edge->statistics.find("end_heading_rad"); it != edge->statistics.end())
        taught->end_turn_rad = wrap_angle_rad(it->second - edge->azimuth_rad);
    }
    begin_nav_health(health_, *this, odom->distance_m, odom->pose.heading_rad, taught);
    frames_.reset();
    last_frame_odom_m_ = odom->distance_m;
    last_command_ = Twist{};
    lap_ = 0;
    (void)set_output("lap", 0);
    status_ = NavStatus{};
    status_.node_path = path();
    status_.map_node = edge->from;
    status_.edge = edge_id_;
    return ok();
  }

  /// The no-new-frame policy (primitive.hpp): keep the last command alive within max_frozen_m.
  NodeStatus without_new_frame(Robot& robot, const std::optional<Odometry>& odom) {
    const double limit_m = health_.policy().max_frozen_m;
    if (odom && std::abs(odom->distance_m - last_frame_odom_m_) > limit_m) {
      return failed(replay_failure::input_lost,
                    "camera frozen: no new frame over " + format_double(odom->distance_m - last_frame_odom_m_) +
                        " m on edge " + edge_id_ + " (max_frozen_m " + format_double(limit_m) + ")");
    }
    // Without odometry the runtime's stale-data check stops the run.
    return send(robot, last_command_);
  }

  /// The send-failure policy (primitive.hpp): a command that cannot be sent fails the node.
  NodeStatus send(Robot& robot, const Twist& command) {
    last_command_ = command;
    if (auto st = robot.send_command(command); !st)
      return failed(replay_failure::command_failed, "sending the command: " + st.error().message);
    return NodeStatus::running;
  }

  void publish(const ReplayStep& step, const Twist& command, const char* problem, const NavHealthVerdict* health) {
    Telemetry* telemetry = host_.telemetry();
    if (telemetry == nullptr) return;
    status_.distance_m = step.distance_m;
    status_.matches = step.matches;
    status_.inliers = step.inliers;
    status_.offset_px = step.offset_px;
    status_.command = command;
    status_.confidence = health != nullptr ? health->window_confidence : step.confidence;
    status_.blind_m = health != nullptr ? health->blind_m : status_.blind_m;
    status_.status = problem != nullptr ? "bad frame" : step.status;
    if (health != nullptr && (health->state == NavHealthState::slowing || health->must_stop()))
      status_.status += std::string(" | ") + to_string(health->state);
    status_.overlay = problem != nullptr ? nullptr : step.overlay;  // valid during publish() only
    telemetry->publish(status_);
    status_.overlay = nullptr;
  }

  /// Fails the node: `code` (replay_failure) to `failure_code`, `message` logged and to `failure`.
  NodeStatus failed(std::string_view code, const std::string& message) {
    host_.logger().error(path(), message);
    (void)set_output("failure", message);
    (void)set_output("failure_code", std::string(code));
    if (Robot* robot = host_.robot()) (void)robot->stop();
    replayer_.reset();
    return NodeStatus::failure;
  }

  HostServices& host_;
  std::shared_ptr<const PrimitiveType> type_;
  std::unique_ptr<EdgeReplayer> replayer_;
  FrameGate frames_;
  NavHealthMonitor health_;
  NavStatus status_;
  Twist last_command_;
  std::string edge_id_;
  std::string edge_kind_;
  /// Odometry as the primitive sees it: distance since the edge's origin divided by scale_.
  [[nodiscard]] Odometry in_taught_units(const Odometry& odom) const {
    Odometry o = odom;
    o.distance_m = origin_m_ + (odom.distance_m - origin_m_) / scale_;
    return o;
  }

  double origin_m_ = 0.0;
  double scale_ = 1.0;  ///< distance_scale of this edge
  double last_frame_odom_m_ = 0.0;
  int expected_width_px_ = 0;  ///< from the edge statistics (0 = unknown)
  int expected_height_px_ = 0;
  int lap_ = 0;
};

// ----------------------------------------------------------------------------------- teach

class TeachEdgeNode final : public bt::StatefulActionNode {
 public:
  TeachEdgeNode(const std::string& name, const bt::NodeConfig& config, HostServices& host,
                std::shared_ptr<const PrimitiveType> type)
      : StatefulActionNode(name, config), host_(host), type_(std::move(type)) {}

  static Result<bt::PortsList> ports(const std::shared_ptr<const PrimitiveType>& type) {
    bt::PortsList p = {
        bt::input_port<std::string>("edge_from", edge_progress::edge_from, "start node (id or name); empty: a new node 'start'"),
        bt::input_port<std::string>("edge_to", edge_progress::edge_to, "end node (id or name), read at finish; empty: a new node 'end'"),
        bt::input_port<bool>("finish", "{finish_edge}", "true: store the edge and succeed (unset counts as false)"),
        bt::output_port<std::string>("edge", "{taught_edge}", "id of the stored edge"),
    };
    VISNAV_TRY(bt::append_param_ports(p, primitive_ports(type)));
    return p;
  }

  NodeStatus on_start() override {
    const std::string& id = type_->node_id;
    if (host_.map() == nullptr) return failed(id + " needs a map (visnav run --map M)");
    if (host_.frame_bus() == nullptr) return failed(id + " needs a running session (no frame bus)");
    if (type_->uses_detector && host_.active_detector() == nullptr)
      return failed(id + " needs a detector (config section 'detector')");
    auto odom = host_.frame_bus()->latest_odometry();
    if (!odom) return failed("no odometry yet");
    auto params = bt::read_param_ports(*this, type_->params);
    if (!params) return failed(params.error().message);
    auto made = type_->make_teacher(*params);
    if (!made) return failed(made.error().message);
    teacher_ = std::move(*made);
    if (auto st = teacher_->begin(TeachStart{*odom, host_.logger(), path()}); !st) return failed(st.error().message);
    start_distance_m_ = odom->distance_m;
    start_pose_ = odom->pose;
    frames_.reset();
    last_frame_.reset();
    frame_count_ = skipped_ = 0;
    width_px_ = height_px_ = 0;
    return on_running();
  }

  NodeStatus on_running() override {
    auto odom = host_.frame_bus()->latest_odometry();
    if (!odom) return NodeStatus::running;  // the runtime stops the run on stale odometry
    record(*odom);
    auto finish = get_input<bool>("finish");
    if (finish && *finish) return store(*odom);
    return NodeStatus::running;
  }

  void on_halted() override { teacher_.reset(); }  // the edge being taught is dropped

 private:
  void record(const Odometry& odom) {
    const double d = std::max(0.0, odom.distance_m - start_distance_m_);
    std::optional<Frame> frame = frames_.next(*host_.frame_bus());
    const char* problem = nullptr;
    if (frame) {
      problem = frames_.inspect(*frame, type_->uses_detector ? host_.active_detector() : nullptr, width_px_, height_px_,
                                host_.logger(), *this);
    }
    const TeachInput input{odom, d, frame ? &*frame : nullptr, type_->uses_detector ? &frames_.features() : nullptr,
                           problem};
    if (auto st = teacher_->step(input); !st) {
      if (skipped_++ == 0) host_.logger().warn(path(), "frame skipped: " + st.error().message);
      return;
    }
    if (frame && problem == nullptr) {
      if (width_px_ == 0) {
        width_px_ = frame->image.cols;
        height_px_ = frame->image.rows;
      }
      last_frame_ = std::move(frame);
      ++frame_count_;
    }
  }

  Result<std::string> node_id(const std::string& id_or_name, const char* default_name, const Pose2D& hint) {
    MapStore& map = *host_.map();
    if (!id_or_name.empty()) {
      VISNAV_ASSIGN(const NodeRecord* node, map.resolve_node(id_or_name));
      return node->id;
    }
    NodeRecord node;
    node.name = default_name;
    node.position_hint = hint;
    return map.add_node(std::move(node));
  }

  NodeStatus store(const Odometry& odom) {
    const double length_m = std::max(0.0, odom.distance_m - start_distance_m_);
    const TeachInput last{odom, length_m, last_frame_ ? &*last_frame_ : nullptr,
                          type_->uses_detector ? &frames_.features() : nullptr, nullptr};
    auto taught = teacher_->finish(last);
    teacher_.reset();
    if (!taught) return failed(taught.error().message);
    auto from = get_input<std::string>("edge_from");
    auto to = get_input<std::string>("edge_to");
    auto from_id = node_id(from ? *from : std::string(), "start", start_pose_);
    if (!from_id) return failed("edge_from: " + from_id.error().message);
    auto to_id = node_id(to ? *to : std::string(), "end", odom.pose);
    if (!to_id) return failed("edge_to: " + to_id.error().message);

    EdgeRecord edge;
    edge.from = *from_id;
    edge.to = *to_id;
    edge.kind = taught->kind;
    edge.length_m = length_m;
    edge.azimuth_rad = wrap_angle_rad(start_pose_.heading_rad);
    edge.statistics = std::move(taught->statistics);
    edge.statistics["end_heading_rad"] = wrap_angle_rad(odom.pose.heading_rad);
    edge.statistics["bytes"] = static_cast<double>(taught->payload.size());
    edge.statistics["frames"] = static_cast<double>(frame_count_);
    edge.statistics["image_width_px"] = width_px_;
    edge.statistics["image_height_px"] = height_px_;
    auto id = host_.map()->add_edge(std::move(edge), taught->payload);
    if (!id) return failed("storing the edge: " + id.error().message);
    if (auto st = set_output("edge", *id); !st) return failed(st.error().message);
    host_.logger().info(path(), "taught " + taught->kind + " edge " + *id + ": " + format_double(length_m) + " m, " +
                                    std::to_string(frame_count_) + " frames, " +
                                    std::to_string(taught->payload.size()) + " bytes");
    return NodeStatus::success;
  }

  NodeStatus failed(const std::string& message) {
    host_.logger().error(path(), message);
    teacher_.reset();
    return NodeStatus::failure;
  }

  HostServices& host_;
  std::shared_ptr<const PrimitiveType> type_;
  std::unique_ptr<EdgeTeacher> teacher_;
  FrameGate frames_;
  std::optional<Frame> last_frame_;  ///< the last usable frame (finish() may store it)
  double start_distance_m_ = 0.0;
  Pose2D start_pose_;
  std::uint64_t frame_count_ = 0;
  std::uint64_t skipped_ = 0;
  int width_px_ = 0;  ///< of the first usable frame; later frames must match
  int height_px_ = 0;
};

/// The literal values of `docs`' ports as the params map the schema parses; nullopt when one of
/// them is bound to the blackboard (its value is known only when the node runs).
std::optional<ConfigNode> literal_params(const bt::LiteralPorts& literal, const std::vector<ParamDoc>& docs) {
  ConfigNode map = ConfigNode::make_map();
  for (const ParamDoc& d : docs) {
    if (literal.is_bound(d.name)) return std::nullopt;
    auto it = literal.values.find(d.name);
    if (it == literal.values.end()) return std::nullopt;
    map.set(d.name, ConfigNode::make_scalar(it->second));
  }
  return map;
}

/// The checks a node's start makes on its params and lost policy (schema, ranges, validate()),
/// run on a tree's literal ports: `visnav validate` refuses what `run` would refuse when the node
/// starts (slow_after_m above max_blind_m, a primitive's cross-field rules).
Status check_literal_params(const PrimitiveType& type, bool replayer, const bt::LiteralPorts& literal) {
  if (type.check_params)
    if (auto params = literal_params(literal, type.params))
      if (auto st = type.check_params(*params); !st) return st.error().with_default_code(ErrorCode::inconsistent);
  if (replayer)
    if (auto lost = literal_params(literal, LostPolicyPorts::schema().docs())) {
      auto parsed = LostPolicyPorts::schema().parse(*lost);
      if (!parsed) return parsed.error().with_default_code(ErrorCode::inconsistent);
    }
  return ok();
}

template <typename Node>
Status register_type(bt::NodeRegistry& registry, HostServices& host, PrimitiveType type) {
  auto shared = std::make_shared<const PrimitiveType>(std::move(type));
  bt::NodeManifest m;
  m.id = shared->node_id;
  m.kind = bt::NodeKind::action;
  VISNAV_ASSIGN(m.ports, Node::ports(shared));
  m.check_literals = [shared](const bt::LiteralPorts& literal) {
    return check_literal_params(*shared, std::is_same_v<Node, ReplayEdgeNode>, literal);
  };
  m.description = shared->description;
  m.min_children = 0;
  m.max_children = 0;
  return registry.register_manifest(
      std::move(m),
      [&host, shared](const std::string& name, const bt::NodeConfig& config) noexcept
          -> Result<std::unique_ptr<bt::TreeNode>> {
        try {
          return std::unique_ptr<bt::TreeNode>(std::make_unique<Node>(name, config, host, shared));
        } catch (const std::exception& e) {
          return fail(std::string("node factory threw an exception: ") + e.what());
        }
      });
}

}  // namespace

Status register_replayer_type(bt::NodeRegistry& registry, HostServices& host, PrimitiveType type) {
  if (!type.make_replayer) return fail("primitive '" + type.node_id + "' has no replayer");
  return register_type<ReplayEdgeNode>(registry, host, std::move(type));
}

Status register_teacher_type(bt::NodeRegistry& registry, HostServices& host, PrimitiveType type) {
  if (!type.make_teacher) return fail("primitive '" + type.node_id + "' has no teacher");
  return register_type<TeachEdgeNode>(registry, host, std::move(type));
}

}  // namespace visnav
