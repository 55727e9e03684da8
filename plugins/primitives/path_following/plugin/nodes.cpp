#include "nodes.hpp"

#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "visnav/bt/nav_health_ports.hpp"
#include "visnav/bt/node.hpp"
#include "visnav/map.hpp"
#include "visnav/path_following/path_follower.hpp"
#include "visnav/path_following/path_loss_monitor.hpp"

namespace visnav::path_following {
namespace {

using bt::NodeStatus;

constexpr const char* kKind = "path_following";
constexpr std::uint32_t kPayloadMagic = 0x56504631;  // "VPF1": appearance summary, version 1

/// Appearance summary payload: the path's reference colour models.
std::vector<std::uint8_t> encode_models(const std::vector<ColourModel>& models) {
  PayloadWriter w;
  w.put<std::uint32_t>(kPayloadMagic);
  w.put<std::uint32_t>(static_cast<std::uint32_t>(models.size()));
  for (const auto& m : models) {
    for (int i = 0; i < 3; ++i) w.put<double>(m.mean[i]);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) w.put<double>(m.cov(r, c));
  }
  return w.take();
}

Result<std::vector<ColourModel>> decode_models(std::span<const std::uint8_t> bytes) {
  PayloadReader r(bytes);
  VISNAV_ASSIGN(auto magic, r.get<std::uint32_t>());
  if (magic != kPayloadMagic) return fail("not a path-following appearance summary (bad magic)");
  VISNAV_ASSIGN(auto count, r.get<std::uint32_t>());
  if (count > 64) return fail("implausible number of colour models: " + std::to_string(count));
  std::vector<ColourModel> models(count);
  for (auto& m : models) {
    for (int i = 0; i < 3; ++i) { VISNAV_ASSIGN(m.mean[i], r.get<double>()); }
    for (int rr = 0; rr < 3; ++rr)
      for (int c = 0; c < 3; ++c) { VISNAV_ASSIGN(m.cov(rr, c), r.get<double>()); }
    if (!m.mean.allFinite() || !m.cov.allFinite()) return fail("non-finite colour model");
  }
  if (!r.at_end()) return fail("trailing bytes after the colour models");
  return models;
}

/// Params of both nodes: the core's defaults with the ports' overrides.
Result<PathFollowerParams> params_from_ports(const bt::TreeNode& node) {
  PathFollowerParams p;
  VISNAV_ASSIGN(p.max_linear_mps, node.get_input<double>("max_speed_mps"));
  VISNAV_ASSIGN(p.alpha_radps, node.get_input<double>("steer_gain_radps"));
  VISNAV_ASSIGN(p.grace_s, node.get_input<double>("grace_s"));
  VISNAV_ASSIGN(p.model_blend, node.get_input<double>("model_blend"));
  VISNAV_ASSIGN(p.taught_gate_distance, node.get_input<double>("taught_gate_distance"));
  VISNAV_TRY(p.validate());
  return p;
}

bt::PortsList common_ports() {
  return {bt::input_port<double>("max_speed_mps", "0.5", "forward speed limit"),
          bt::input_port<double>("steer_gain_radps", "0.8", "alpha of control law (1): ω per unit mean offset"),
          bt::input_port<double>("grace_s", "1.0", "path may be unseen this long before FAILURE \"path lost\""),
          bt::input_port<double>("model_blend", "0.3", "weight of the previous frame's path colour models"),
          bt::input_port<double>("taught_gate_distance", "6",
                                 "replay: re-learned path models farther than this (sigma) from the taught appearance "
                                 "summary are rejected, keeping the previous/taught models; 0 = off")};
}

class FollowPathEdge final : public bt::StatefulActionNode {
 public:
  FollowPathEdge(const std::string& name, const bt::NodeConfig& config, HostServices& host)
      : StatefulActionNode(name, config), host_(host), monitor_(1.0) {}

  static bt::PortsList provided_ports() {
    bt::PortsList p = {bt::input_port<std::string>("edge", "{edge}", "map edge to traverse (kind path_following)"),
                       bt::input_port<double>("junction_clear_m", "2.0",
                                              "junction mode for this long after the start node (see path_follower.hpp)"),
                       bt::input_port<double>("carried_m", "{edge_carried_m}",
                                              "distance of the edge already covered at the start (FollowRoute's "
                                              "overshoot carry; unset counts as 0)"),
                       bt::input_port<double>("junction_approach_m", "0",
                                              "junction mode also for this long before the edge's end node (an L corner "
                                              "or junction ahead pulls the follower into cutting it); 0 = off")};
    for (auto& c : common_ports()) p.push_back(std::move(c));
    bt::append_lost_policy_ports(p);
    return p;
  }

  NodeStatus on_start() override {
    MapStore* map = host_.map();
    if (map == nullptr || host_.frame_bus() == nullptr || host_.robot() == nullptr)
      return failed("FollowPathEdge needs a running session with a map");
    auto edge_id = get_input<std::string>("edge");
    if (!edge_id) return failed(edge_id.error().message);
    const EdgeRecord* edge = map->find_edge(*edge_id);
    if (edge == nullptr) return failed("unknown edge '" + *edge_id + "'");
    if (edge->kind != kKind) return failed("edge " + edge->id + " is of kind '" + edge->kind + "', not " + kKind);
    auto payload = map->read_payload(edge->id);
    if (!payload) return failed(payload.error().message);
    auto models = decode_models(*payload);
    if (!models) return failed(map->payload_path(edge->id) + ": " + models.error().message);
    auto params = params_from_ports(*this);
    if (!params) return failed(params.error().message);
    if (!follower_ || !(params_ == std::optional<ParamsKey>(key(*params)))) {
      auto made = PathFollower::create(*params);
      if (!made) return failed(made.error().message);
      follower_.emplace(std::move(*made));
      params_ = key(*params);
    }
    follower_->reset();
    follower_->set_taught_models(*models);  // the gate (inactive when taught_gate_distance = 0)
    if (params->model_blend > 0.0) follower_->set_prior_models(*models);
    monitor_ = PathLossMonitor(params->grace_s);
    auto odom = host_.frame_bus()->latest_odometry();
    if (!odom) return failed("no odometry");
    const auto carried = get_input<double>("carried_m");  // unset (no FollowRoute) counts as 0
    start_distance_m_ = odom->distance_m - (carried && std::isfinite(*carried) ? *carried : 0.0);
    length_m_ = edge->length_m;
    edge_id_ = edge->id;
    auto junction = get_input<double>("junction_clear_m");
    if (!junction) return failed(junction.error().message);
    junction_clear_m_ = *junction;
    auto approach = get_input<double>("junction_approach_m");
    if (!approach) return failed(approach.error().message);
    if (!(*approach >= 0.0)) return failed("junction_approach_m must be >= 0");
    junction_approach_m_ = *approach;
    auto policy = bt::read_lost_policy(*this);
    if (!policy) return failed(policy.error().message);
    health_ = NavHealthMonitor(*policy);
    TaughtHeading taught{length_m_, 0.0};
    if (auto it = edge->statistics.find("end_heading_rad"); it != edge->statistics.end())
      taught.end_turn_rad = std::remainder(it->second - edge->azimuth_rad, 2.0 * std::numbers::pi);
    bt::begin_nav_health(health_, *this, odom->distance_m, odom->pose.heading_rad, taught);
    last_sequence_.reset();
    return on_running();
  }

  NodeStatus on_running() override {
    auto odom = host_.frame_bus()->latest_odometry();
    if (!odom) return failed("no odometry");
    const double travelled_m = odom->distance_m - start_distance_m_;
    if (travelled_m >= length_m_) {
      (void)host_.robot()->stop();
      publish(travelled_m, Twist{}, "edge done");
      return NodeStatus::success;
    }
    auto frame = host_.frame_bus()->latest_frame();
    if (!frame || (last_sequence_ && frame->sequence == *last_sequence_)) return NodeStatus::running;
    last_sequence_ = frame->sequence;
    Twist command;
    std::string status;
    double confidence = 0.0;
    follower_->set_junction_mode(travelled_m < junction_clear_m_ || length_m_ - travelled_m < junction_approach_m_);
    if (auto st = follower_->process(frame->image, estimate_); !st) {
      // An unusable frame counts as not seeing the path.
      status = "bad frame: " + st.error().message;
      verdict_ = monitor_.update(frame->timestamp_s, PathStatus::no_reference);
    } else {
      confidence = estimate_.status == PathStatus::ok ? 1.0 : 0.0;
      status = std::string(to_string(estimate_.status));
      if (estimate_.reference_source != ReferenceSource::learned)
        status += " (path models drifted from the taught appearance: " +
                  std::string(to_string(estimate_.reference_source)) + " models kept)";
      verdict_ = monitor_.update(frame->timestamp_s, estimate_.status);
      command = estimate_.command;  // zero unless the path is seen
      offset_px_ = estimate_.mean_offset * frame->image.cols / 2.0;
    }
    if (verdict_ == PathLossMonitor::Verdict::lost) {
      (void)host_.robot()->stop();
      publish(travelled_m, Twist{}, "path lost");
      const auto reason = monitor_.last_bad_status();
      return failed("path lost on edge " + edge_id_ + " (" +
                    std::string(reason ? to_string(*reason) : std::string_view("unknown")) + " for more than " +
                    std::to_string(monitor_.grace_s()) + " s)");
    }
    const NavHealthVerdict& health = health_.update(odom->distance_m, odom->pose.heading_rad, travelled_m,
                                                    frame->image, confidence, /*saturated=*/false);
    bt::store_nav_health(health_, *this);
    if (health.must_stop()) {
      (void)host_.robot()->stop();
      publish(travelled_m, Twist{}, to_string(health.state));
      return failed(health.reason + " on edge " + edge_id_ + " (path_following)");
    }
    command.linear_mps *= health.speed_factor;
    command.angular_radps *= health.speed_factor;
    if (health.state == NavHealthState::slowing) status += std::string(" | ") + to_string(health.state);
    (void)host_.robot()->send_command(command);
    publish(travelled_m, command, status);
    return NodeStatus::running;
  }

  void on_halted() override {
    if (Robot* r = host_.robot()) (void)r->stop();
  }

 private:
  struct ParamsKey {
    double speed, gain, grace, blend, gate;
    bool operator==(const ParamsKey&) const = default;
  };
  static ParamsKey key(const PathFollowerParams& p) {
    return {p.max_linear_mps, p.alpha_radps, p.grace_s, p.model_blend, p.taught_gate_distance};
  }

  void publish(double distance_m, const Twist& command, const std::string& status) {
    Telemetry* t = host_.telemetry();
    if (t == nullptr) return;
    status_.node_path = path();
    status_.edge = edge_id_;
    status_.distance_m = distance_m;
    status_.matches = 0;
    status_.inliers = 0;
    status_.offset_px = offset_px_;
    status_.command = command;
    status_.status = status;
    status_.confidence = health_.verdict().window_confidence;
    status_.blind_m = health_.verdict().blind_m;
    t->publish(status_);
  }
  NodeStatus failed(const std::string& message) {
    host_.logger().error(path(), message);
    return NodeStatus::failure;
  }

  HostServices& host_;
  std::optional<PathFollower> follower_;
  std::optional<ParamsKey> params_;
  PathEstimate estimate_;
  PathLossMonitor monitor_;
  PathLossMonitor::Verdict verdict_ = PathLossMonitor::Verdict::ok;
  NavHealthMonitor health_;
  NavStatus status_;
  double offset_px_ = 0.0;
  double junction_clear_m_ = 2.0;  ///< mean path-centre offset from the image centre, px (+ = right)
  double junction_approach_m_ = 0.0;
  double start_distance_m_ = 0.0;
  double length_m_ = 0.0;
  std::string edge_id_;
  std::optional<std::uint64_t> last_sequence_;
};

class TeachPathEdge final : public bt::StatefulActionNode {
 public:
  TeachPathEdge(const std::string& name, const bt::NodeConfig& config, HostServices& host)
      : StatefulActionNode(name, config), host_(host) {}

  static bt::PortsList provided_ports() {
    bt::PortsList p = {bt::input_port<std::string>("edge_from", "{edge_from}", "start node (empty: create 'start')"),
                       bt::input_port<std::string>("edge_to", "{edge_to}", "end node, set at finish (empty: create 'end')"),
                       bt::input_port<bool>("finish", "{finish_edge}", "true: store the edge and succeed"),
                       bt::input_port<int>("learn_every", "5", "learn the path appearance every N frames"),
                       bt::output_port<std::string>("edge", "{taught_edge}", "id of the stored edge")};
    for (auto& c : common_ports()) p.push_back(std::move(c));
    return p;
  }

  NodeStatus on_start() override {
    if (host_.map() == nullptr || host_.frame_bus() == nullptr) return failed("TeachPathEdge needs a map");
    auto odom = host_.frame_bus()->latest_odometry();
    if (!odom) return failed("no odometry");
    auto params = params_from_ports(*this);
    if (!params) return failed(params.error().message);
    if (!follower_) {
      auto made = PathFollower::create(*params);
      if (!made) return failed(made.error().message);
      follower_.emplace(std::move(*made));
    }
    follower_->reset();
    summary_.emplace(*params);
    frames_ = 0;
    seen_ok_ = 0;
    start_distance_m_ = odom->distance_m;
    azimuth_rad_ = odom->pose.heading_rad;
    last_sequence_.reset();
    return on_running();
  }

  NodeStatus on_running() override {
    auto odom = host_.frame_bus()->latest_odometry();
    if (!odom) return failed("no odometry");
    auto finish = get_input<bool>("finish");
    if (finish && *finish) return store(*odom);
    auto frame = host_.frame_bus()->latest_frame();
    auto every = get_input<int>("learn_every");
    if (frame && (!last_sequence_ || frame->sequence != *last_sequence_)) {
      last_sequence_ = frame->sequence;
      if (frames_++ % std::max(1, every ? *every : 5) == 0) {
        if (follower_->process(frame->image, estimate_).ok() && estimate_.status == PathStatus::ok) {
          summary_->add_frame(follower_->reference_models());
          ++seen_ok_;
        }
      }
    }
    return NodeStatus::running;
  }

  void on_halted() override {}  // the edge being taught is dropped

 private:
  NodeStatus store(const Odometry& odom) {
    MapStore& map = *host_.map();
    auto from = get_input<std::string>("edge_from");
    auto to = get_input<std::string>("edge_to");
    std::string from_id = from ? *from : std::string();
    std::string to_id = to ? *to : std::string();
    if (from_id.empty()) {
      NodeRecord n;
      n.name = "start";
      auto id = map.add_node(n);
      if (!id) return failed(id.error().message);
      from_id = *id;
    }
    if (to_id.empty()) {
      NodeRecord n;
      n.name = "end";
      n.position_hint = odom.pose;
      auto id = map.add_node(n);
      if (!id) return failed(id.error().message);
      to_id = *id;
    }
    if (seen_ok_ == 0)
      host_.logger().warn(path(), "the path was never recognised while teaching; the edge keeps no appearance summary");
    EdgeRecord e;
    e.from = from_id;
    e.to = to_id;
    e.kind = kKind;
    e.length_m = std::max(0.0, odom.distance_m - start_distance_m_);
    e.azimuth_rad = azimuth_rad_;
    e.statistics["end_heading_rad"] = odom.pose.heading_rad;
    const std::vector<ColourModel> models = summary_ ? summary_->summary() : std::vector<ColourModel>{};
    e.statistics["colour_models"] = static_cast<double>(models.size());
    e.statistics["frames_path_seen"] = static_cast<double>(seen_ok_);
    auto id = map.add_edge(e, encode_models(models));
    if (!id) return failed(id.error().message);
    (void)set_output("edge", *id);
    return NodeStatus::success;
  }
  NodeStatus failed(const std::string& message) {
    host_.logger().error(path(), message);
    return NodeStatus::failure;
  }

  HostServices& host_;
  std::optional<PathFollower> follower_;
  PathEstimate estimate_;
  std::optional<AppearanceSummary> summary_;  ///< the path's appearance over the edge (see path_follower.hpp)
  int frames_ = 0;
  int seen_ok_ = 0;
  double start_distance_m_ = 0.0;
  double azimuth_rad_ = 0.0;
  std::optional<std::uint64_t> last_sequence_;
};

}  // namespace

Status register_path_nodes(bt::NodeRegistry& registry, HostServices& host) {
  VISNAV_TRY(registry.register_node<FollowPathEdge>(
      "FollowPathEdge", "Follows the visible path (segmentation, seed 000 Sec. 4) along a path_following edge",
      [&host](const std::string& name, const bt::NodeConfig& config) {
        return std::make_unique<FollowPathEdge>(name, config, host);
      }));
  return registry.register_node<TeachPathEdge>(
      "TeachPathEdge", "Teaches a path_following edge: its odometric length and the path's appearance",
      [&host](const std::string& name, const bt::NodeConfig& config) {
        return std::make_unique<TeachPathEdge>(name, config, host);
      });
}

Status check_path_payload(std::span<const std::uint8_t> body, const EdgeRecord& /*edge*/) noexcept {
  try {
    auto models = decode_models(body);
    if (!models) return std::move(models).error();
    return ok();
  } catch (...) {  // decode_models allocates; an allocation failure must not cross the ABI
    return fail("path-following payload reader threw an exception");
  }
}

}  // namespace visnav::path_following
