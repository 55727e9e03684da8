// TeachFeatureEdge / ReplayFeatureEdge: thin adapters over the feature_replay core (see nodes.hpp).
#include "nodes.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <span>
#include <utility>
#include <vector>

#include "visnav/bt/nav_health_ports.hpp"
#include "visnav/map.hpp"

namespace visnav::feature_replay {
namespace {

// The one rule for ReplayFeatureEdge's speed_mps: the port's literal check (so `visnav
// validate` and the tree loader reject speed_mps="9" before the first tick) and the node's
// start both call it.
Status check_replay_speed(double speed_mps) {
  if (!(speed_mps > 0.0 && speed_mps <= 3.0))
    return Error{"speed_mps must be in (0, 3], is " + std::to_string(speed_mps), ErrorCode::out_of_range};
  return ok();
}

bt::PortInfo replay_speed_port() {
  bt::PortInfo port = bt::input_port<double>("speed_mps", "0.3",
                                             "style A: constant forward speed (style B replays the recorded speed)");
  port.constraint = "(0, 3]";
  port.check = [](std::string_view text) -> Status {
    VISNAV_ASSIGN(double v, bt::convert_from_string<double>(text));
    return check_replay_speed(v);
  };
  return port;
}

using bt::NodeStatus;

double wrap_angle_rad(double a) {
  a = std::remainder(a, 2.0 * std::numbers::pi);
  return a <= -std::numbers::pi ? a + 2.0 * std::numbers::pi : a;
}

std::string format_double(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3f", v);
  return buf;
}

/// Reads an optional bool port: an unset blackboard entry counts as false (nobody asked to finish yet).
bool read_flag(const bt::TreeNode& node, std::string_view port) {
  auto v = node.get_input<bool>(port);
  return v && *v;
}

}  // namespace

// ------------------------------------------------------------------------------ TeachFeatureEdge

TeachFeatureEdge::TeachFeatureEdge(const std::string& name, const bt::NodeConfig& config, HostServices& host)
    : StatefulActionNode(name, config), host_(host) {}

bt::PortsList TeachFeatureEdge::provided_ports() {
  return {
      bt::input_port<std::string>("style", "segment",
                                  "map style: segment (A, seed 000: kind feature_segment) or localmaps (B, seed 002: "
                                  "kind feature_localmaps)"),
      bt::input_port<std::string>("edge_from", "{edge_from}", "start node (id or name); empty: a new node 'start'"),
      bt::input_port<std::string>("edge_to", "{edge_to}", "end node (id or name), read at finish; empty: a new node 'end'"),
      bt::input_port<bool>("finish", "{finish_edge}", "true: store the edge and succeed (unset counts as false)"),
      bt::output_port<std::string>("edge", "{taught_edge}", "id of the stored edge"),
      // style A (SegmentTeachParams)
      bt::input_port<double>("max_landmarks_per_m", "250", "style A: landmark density cap (50 B each)"),
      bt::input_port<int>("min_observations", "3", "style A: frames a landmark must be seen in"),
      bt::input_port<double>("max_track_step_px", "40", "style A: max landmark image motion between frames"),
      // style B (LocalMapTeachParams)
      bt::input_port<double>("map_spacing_m", "0.2", "style B: distance between local maps"),
      bt::input_port<int>("max_features_per_map", "0", "style B: keep the strongest N features per map (0 = all)"),
      bt::input_port<bool>("store_image", "false", "style B: also store a JPEG per local map"),
      bt::input_port<double>("command_tolerance", "0.01",
                             "style B: record the odometry twist when v (m/s) or omega (rad/s) changed by more"),
      bt::input_port<double>("min_record_speed_mps", "0.02",
                             "style B: twists slower than this are not recorded (replay is indexed by distance, so "
                             "a recorded stop or turn on the spot would halt the replay there)"),
  };
}

NodeStatus TeachFeatureEdge::failed(const std::string& message) {
  host_.logger().error(path(), message);
  segment_.reset();
  localmaps_.reset();
  return NodeStatus::failure;
}

NodeStatus TeachFeatureEdge::on_start() {
  if (host_.map() == nullptr) return failed("TeachFeatureEdge needs a map (visnav run --map M)");
  if (host_.frame_bus() == nullptr) return failed("TeachFeatureEdge needs a running session (no frame bus)");
  if (host_.active_detector() == nullptr) return failed("TeachFeatureEdge needs a detector (config section 'detector')");
  auto style = get_input<std::string>("style");
  if (!style) return failed(style.error().message);
  if (*style == "segment") {
    style_ = Style::segment;
  } else if (*style == "localmaps") {
    style_ = Style::localmaps;
  } else {
    return failed("port 'style': '" + *style + "' is not one of: segment, localmaps");
  }
  auto odom = host_.frame_bus()->latest_odometry();
  if (!odom) return failed("no odometry yet");

  segment_.reset();
  localmaps_.reset();
  if (style_ == Style::segment) {
    SegmentTeachParams p;
    auto density = get_input<double>("max_landmarks_per_m");
    auto min_obs = get_input<int>("min_observations");
    auto step = get_input<double>("max_track_step_px");
    if (!density || !min_obs || !step) return failed("bad style A ports");
    if (!(*density > 0.0) || *min_obs < 1 || !(*step > 0.0))
      return failed("max_landmarks_per_m and max_track_step_px must be > 0, min_observations >= 1");
    p.max_landmarks_per_m = *density;
    p.min_observations = *min_obs;
    p.max_track_step_px = *step;
    segment_.emplace(p);
    segment_->begin(wrap_angle_rad(odom->pose.heading_rad));
  } else {
    LocalMapTeachParams p;
    auto spacing = get_input<double>("map_spacing_m");
    auto max_features = get_input<int>("max_features_per_map");
    auto image = get_input<bool>("store_image");
    auto tolerance = get_input<double>("command_tolerance");
    auto min_speed = get_input<double>("min_record_speed_mps");
    if (!spacing || !max_features || !image || !tolerance || !min_speed) return failed("bad style B ports");
    if (!(*min_speed > 0.0)) return failed("min_record_speed_mps must be > 0");
    min_record_speed_mps_ = *min_speed;
    if (!(*spacing > 0.0) || *max_features < 0 || !(*tolerance >= 0.0))
      return failed("map_spacing_m must be > 0, max_features_per_map >= 0, command_tolerance >= 0");
    p.map_interval_m = *spacing;
    p.max_features_per_map = *max_features;
    p.store_image = *image;
    p.command_tolerance = *tolerance;
    localmaps_.emplace(p);
    localmaps_->begin();
  }
  start_distance_m_ = odom->distance_m;
  start_pose_ = odom->pose;
  have_frame_ = false;
  last_image_.release();
  features_.clear();
  frames_ = bad_frames_ = 0;
  image_width_px_ = image_height_px_ = 0;
  if (auto st = record(*odom); !st) return failed(st.error().message);
  if (read_flag(*this, "finish")) return finish(*odom);
  return NodeStatus::running;
}

NodeStatus TeachFeatureEdge::on_running() {
  auto odom = host_.frame_bus()->latest_odometry();
  if (!odom) return NodeStatus::running;  // the runtime stops the run on stale odometry
  if (auto st = record(*odom); !st) return failed(st.error().message);
  if (read_flag(*this, "finish")) return finish(*odom);
  return NodeStatus::running;
}

void TeachFeatureEdge::on_halted() {
  // The edge being taught is dropped; completed edges are already on disk.
  segment_.reset();
  localmaps_.reset();
}

Status TeachFeatureEdge::record(const Odometry& odom) {
  const double d = std::max(0.0, odom.distance_m - start_distance_m_);
  // Standing still or turning on the spot is not recorded: the replay is indexed by distance and
  // would stop there for ever (finish() records the final stop).
  if (localmaps_ && std::abs(odom.twist.linear_mps) >= min_record_speed_mps_) localmaps_->record_command(d, odom.twist);

  std::optional<Frame> frame = host_.frame_bus()->latest_frame();
  if (!frame || (have_frame_ && frame->sequence <= last_sequence_)) return ok();
  have_frame_ = true;
  last_sequence_ = frame->sequence;
  const cv::Mat& image = frame->image;
  const bool size_ok = !image.empty() && (image_width_px_ == 0 || (image.cols == image_width_px_ && image.rows == image_height_px_));
  Status detected = size_ok ? host_.active_detector()->detect(image, features_)
                            : Status(fail(image.empty() ? "empty frame" : "frame size changed during the edge"));
  if (!detected) {
    features_.clear();
    if (bad_frames_++ == 0) host_.logger().warn(path(), "frame skipped: " + detected.error().message);
    return ok();
  }
  if (image_width_px_ == 0) {
    image_width_px_ = image.cols;
    image_height_px_ = image.rows;
  }
  Status added = segment_ ? segment_->add_frame(d, features_) : localmaps_->add_frame(d, features_, image);
  if (!added) {
    // E.g. the detector was switched mid-edge (descriptor type changed): skip, keep teaching.
    features_.clear();
    if (bad_frames_++ == 0) host_.logger().warn(path(), "frame skipped: " + added.error().message);
    return ok();
  }
  last_image_ = image;
  ++frames_;
  return ok();
}

Result<std::string> TeachFeatureEdge::resolve_or_create_node(const std::string& id_or_name, const char* default_name,
                                                             const Pose2D& hint) {
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

NodeStatus TeachFeatureEdge::finish(const Odometry& odom) {
  const double length_m = std::max(0.0, odom.distance_m - start_distance_m_);
  EdgeRecord edge;
  std::vector<std::uint8_t> body;
  if (segment_) {
    auto map = segment_->finish(length_m);
    if (!map) return failed("style A map: " + map.error().message);
    body = map->serialize();
    edge.kind = kSegmentKind;
    edge.statistics["landmarks"] = static_cast<double>(map->landmarks.size());
  } else {
    auto path_map = localmaps_->finish(length_m, features_, last_image_);
    if (!path_map) return failed("style B map: " + path_map.error().message);
    body = path_map->serialize();
    std::size_t features = 0;
    for (const auto& m : path_map->maps) features += m.positions_px.size();
    edge.kind = kLocalMapsKind;
    edge.statistics["local_maps"] = static_cast<double>(path_map->maps.size());
    edge.statistics["features"] = static_cast<double>(features);
    edge.statistics["commands"] = static_cast<double>(path_map->commands.size());
  }
  segment_.reset();
  localmaps_.reset();

  auto from = get_input<std::string>("edge_from");
  auto to = get_input<std::string>("edge_to");
  auto from_id = resolve_or_create_node(from ? *from : std::string(), "start", start_pose_);
  if (!from_id) return failed("edge_from: " + from_id.error().message);
  auto to_id = resolve_or_create_node(to ? *to : std::string(), "end", odom.pose);
  if (!to_id) return failed("edge_to: " + to_id.error().message);

  edge.from = *from_id;
  edge.to = *to_id;
  edge.length_m = length_m;
  edge.azimuth_rad = wrap_angle_rad(start_pose_.heading_rad);
  edge.statistics["end_heading_rad"] = wrap_angle_rad(odom.pose.heading_rad);
  edge.statistics["bytes"] = static_cast<double>(body.size());
  edge.statistics["frames"] = static_cast<double>(frames_);
  edge.statistics["image_width_px"] = image_width_px_;
  edge.statistics["image_height_px"] = image_height_px_;
  const std::string kind = edge.kind;
  auto id = host_.map()->add_edge(std::move(edge), body);
  if (!id) return failed("storing the edge: " + id.error().message);
  if (auto st = set_output("edge", *id); !st) return failed(st.error().message);
  host_.logger().info(path(), "taught " + kind + " edge " + *id + ": " + format_double(length_m) + " m, " +
                                  std::to_string(frames_) + " frames, " + std::to_string(body.size()) + " bytes");
  return NodeStatus::success;
}

// ----------------------------------------------------------------------------- ReplayFeatureEdge

ReplayFeatureEdge::ReplayFeatureEdge(const std::string& name, const bt::NodeConfig& config, HostServices& host)
    : StatefulActionNode(name, config), host_(host) {}

bt::PortsList ReplayFeatureEdge::provided_ports() {
  bt::PortsList ports = {
      bt::input_port<std::string>("edge", "{edge}", "map edge to traverse (kind feature_segment or feature_localmaps)"),
      replay_speed_port(),
      bt::input_port<double>("gain_radps_per_px", "0.01",
                             "style A steering gain: omega = -gain * offset_px (tuned in the simulator)"),
      bt::input_port<double>("correction_gain_radps_per_px", "0.003",
                             "style B correction gain: omega = recorded omega - gain * offset_px (tuned in the simulator)"),
      bt::input_port<double>("max_angular_radps", "0.5", "style A: |omega| clamp"),
      bt::input_port<double>("max_correction_radps", "0.3", "style B: |correction| clamp"),
      bt::input_port<int>("laps", "1", "style B: traversals of a closed path (distance overshoot carried over)"),
      bt::input_port<double>("distance_margin_m", "0", "style A: widen each landmark's visibility window"),
      bt::input_port<double>("ratio", "0.8", "matching: Lowe ratio test (issue 13: 0.8 chosen on appearance-change pairs)"),
      bt::input_port<double>("min_confidence", "0.25", "histogram confidence below which no correction is applied"),
      bt::input_port<double>("scan_deg", "75",
                             "start-view search: when an edge's first frames do not see its taught start view, "
                             "turn in place up to this far left and right to find it (0 = off)"),
      bt::input_port<double>("scan_speed_radps", "0.4", "start-view search: turn rate"),
      bt::input_port<int>("min_expected_features", "15",
                          "lost policy: where the map holds fewer landmarks/features than this at the current "
                          "distance, a frame without a match does not count as blind (nothing was seen there "
                          "when teaching either)"),
      bt::input_port<double>("carried_m", "{edge_carried_m}",
                             "distance of the edge already covered at the start (FollowRoute's overshoot carry; "
                             "unset counts as 0)"),
      bt::output_port<int>("lap", "{lap}", "style B: 0-based lap being driven"),
  };
  bt::append_lost_policy_ports(ports);
  return ports;
}

NodeStatus ReplayFeatureEdge::failed(const std::string& message) {
  host_.logger().error(path(), message);
  segment_.reset();
  localmaps_.reset();
  if (Robot* robot = host_.robot()) (void)robot->stop();
  return NodeStatus::failure;
}

Status ReplayFeatureEdge::load_edge() {
  MapStore* map = host_.map();
  if (map == nullptr) return fail("ReplayFeatureEdge needs a map (visnav run --map M)");
  if (host_.frame_bus() == nullptr || host_.robot() == nullptr) return fail("ReplayFeatureEdge needs a running session");
  if (host_.active_detector() == nullptr) return fail("ReplayFeatureEdge needs a detector (config section 'detector')");
  VISNAV_ASSIGN(edge_id_, get_input<std::string>("edge"));
  const EdgeRecord* edge = map->find_edge(edge_id_);
  if (edge == nullptr) return fail("unknown edge '" + edge_id_ + "'");
  if (edge->kind != kSegmentKind && edge->kind != kLocalMapsKind)
    return fail("edge " + edge_id_ + " has kind '" + edge->kind + "'; ReplayFeatureEdge replays only " + kSegmentKind +
                " and " + kLocalMapsKind);
  from_node_ = edge->from;
  auto stat = [&](const char* key) {
    auto it = edge->statistics.find(key);
    return it != edge->statistics.end() ? static_cast<int>(it->second) : 0;
  };
  expected_width_px_ = stat("image_width_px");
  expected_height_px_ = stat("image_height_px");

  VISNAV_ASSIGN(double speed, get_input<double>("speed_mps"));
  VISNAV_ASSIGN(double gain, get_input<double>("gain_radps_per_px"));
  VISNAV_ASSIGN(double correction_gain, get_input<double>("correction_gain_radps_per_px"));
  VISNAV_ASSIGN(double max_w, get_input<double>("max_angular_radps"));
  VISNAV_ASSIGN(double max_corr, get_input<double>("max_correction_radps"));
  VISNAV_ASSIGN(int laps, get_input<int>("laps"));
  VISNAV_ASSIGN(double margin, get_input<double>("distance_margin_m"));
  VISNAV_ASSIGN(double ratio, get_input<double>("ratio"));
  VISNAV_ASSIGN(double min_conf, get_input<double>("min_confidence"));
  VISNAV_TRY(check_replay_speed(speed));
  if (!(gain >= 0.0) || !(correction_gain >= 0.0) || !(max_w > 0.0) || !(max_corr >= 0.0) || !(margin >= 0.0))
    return fail("the gains, max_correction_radps and distance_margin_m must be >= 0 and max_angular_radps > 0");
  if (laps < 1) return fail("laps must be >= 1");
  VISNAV_ASSIGN(LostPolicy policy, bt::read_lost_policy(*this));
  VISNAV_ASSIGN(min_expected_features_, get_input<int>("min_expected_features"));
  VISNAV_ASSIGN(double scan_deg, get_input<double>("scan_deg"));
  VISNAV_ASSIGN(scan_speed_radps_, get_input<double>("scan_speed_radps"));
  if (!(scan_deg >= 0.0 && scan_deg <= 180.0)) return fail("scan_deg must be in [0, 180]");
  if (!(scan_speed_radps_ > 0.0 && scan_speed_radps_ <= 3.0)) return fail("scan_speed_radps must be in (0, 3]");
  scan_rad_ = scan_deg * std::numbers::pi / 180.0;
  if (min_expected_features_ < 0) return fail("min_expected_features must be >= 0");
  health_ = NavHealthMonitor(policy);
  edge_kind_ = edge->kind;
  max_angular_radps_ = max_w;
  max_correction_radps_ = max_corr;
  laps_ = laps;
  taught_heading_ = TaughtHeading{edge->length_m, 0.0};
  if (auto it = edge->statistics.find("end_heading_rad"); it != edge->statistics.end())
    taught_heading_.end_turn_rad = wrap_angle_rad(it->second - edge->azimuth_rad);
  HeadingParams heading;
  heading.ratio = ratio;
  heading.min_confidence = min_conf;
  VISNAV_TRY(heading.validate());

  // The payload is read once, here (never per frame).
  VISNAV_ASSIGN(std::vector<std::uint8_t> body, map->read_payload(edge_id_));
  if (edge->kind == kSegmentKind) {
    auto parsed = SegmentMap::deserialize(body);
    if (!parsed) return fail("edge " + edge_id_ + " payload: " + parsed.error().message);
    SegmentReplayParams p;
    p.speed_mps = speed;
    p.gain_radps_per_px = gain;
    p.max_angular_radps = max_w;
    p.distance_margin_m = margin;
    segment_.emplace(std::make_shared<const SegmentMap>(std::move(*parsed)), p, heading);
    if (!segment_->map_valid()) return fail("edge " + edge_id_ + " payload: invalid segment map");
  } else {
    auto parsed = LocalMapPath::deserialize(body);
    if (!parsed) return fail("edge " + edge_id_ + " payload: " + parsed.error().message);
    LocalMapReplayParams p;
    p.gain_radps_per_px = correction_gain;
    p.max_correction_radps = max_corr;
    p.laps = laps;
    localmaps_.emplace(std::make_shared<const LocalMapPath>(std::move(*parsed)), p, heading);
    if (!localmaps_->path_valid()) return fail("edge " + edge_id_ + " payload: invalid local-map path");
  }
  return ok();
}

NodeStatus ReplayFeatureEdge::on_start() {
  segment_.reset();
  localmaps_.reset();
  if (auto st = load_edge(); !st) return failed(st.error().message);
  auto odom = host_.frame_bus()->latest_odometry();
  if (!odom) return failed("no odometry yet");
  // The edge counts as started `carried_m` before here (FollowRoute; an unset entry counts as 0).
  const auto carried = get_input<double>("carried_m");
  const double origin_m = odom->distance_m - (carried && std::isfinite(*carried) ? *carried : 0.0);
  if (segment_) segment_->begin(origin_m);
  if (localmaps_) localmaps_->begin(origin_m);
  // A closed multi-lap path has no single taught heading profile: no heading check there.
  std::optional<TaughtHeading> taught;
  if (segment_ || laps_ == 1) taught = taught_heading_;
  bt::begin_nav_health(health_, *this, odom->distance_m, odom->pose.heading_rad, taught);
  // Only an edge started at its beginning searches its start view.
  phase_ = scan_rad_ > 0.0 && odom->distance_m - origin_m < 0.3 ? StartPhase::probe : StartPhase::driving;
  probe_frames_ = 0;
  probe_confidence_sum_ = 0.0;
  best_confidence_ = -1.0;
  have_frame_ = false;
  last_command_ = Twist{};
  last_state_ = ReplayState::steering;
  warned_bad_frame_ = false;
  status_ = NavStatus{};
  status_.node_path = path();
  status_.map_node = from_node_;
  status_.edge = edge_id_;
  (void)set_output("lap", 0);
  return on_running();
}

NodeStatus ReplayFeatureEdge::on_running() {
  Robot* robot = host_.robot();
  auto odom = host_.frame_bus()->latest_odometry();
  std::optional<Frame> frame = host_.frame_bus()->latest_frame();
  if (!odom || !frame || (have_frame_ && frame->sequence <= last_sequence_)) {
    // No new data: keep the last command alive (the runtime stops the run on stale data).
    (void)robot->send_command(last_command_);
    return NodeStatus::running;
  }
  have_frame_ = true;
  last_sequence_ = frame->sequence;

  const cv::Mat& image = frame->image;
  const char* bad_frame = nullptr;
  if (image.empty()) {
    bad_frame = "empty frame";
  } else if (expected_width_px_ > 0 && (image.cols != expected_width_px_ || image.rows != expected_height_px_)) {
    bad_frame = "frame size differs from the taught one";
  } else if (auto st = host_.active_detector()->detect(image, features_); !st) {
    bad_frame = "detector failed on the frame";
    if (!warned_bad_frame_) host_.logger().warn(path(), "detector: " + st.error().message);
  }
  if (bad_frame != nullptr) {
    features_.clear();  // the core keeps the recorded command (style B) / drives straight (style A)
    if (!warned_bad_frame_) host_.logger().warn(path(), std::string(bad_frame) + ": no correction this frame");
    warned_bad_frame_ = true;
  }
  const double width_px = image.empty() ? 0.0 : static_cast<double>(image.cols);

  Twist command;
  ReplayState state;
  bool finished;
  double distance_m;
  double confidence;
  bool saturated;
  bool informative = true;
  if (segment_) {
    const SegmentReplayOutput out = segment_->step(odom->distance_m, features_, width_px);
    command = out.command;
    state = out.state;
    finished = out.finished;
    status_.matches = out.estimate.matches;
    status_.inliers = out.estimate.inliers;
    status_.offset_px = out.estimate.offset_px;
    distance_m = out.distance_m;
    confidence = out.estimate.confidence;
    saturated = state == ReplayState::steering && std::abs(command.angular_radps) >= max_angular_radps_ - 1e-9;
    informative = out.expected_landmarks >= min_expected_features_;
  } else {
    const LocalMapReplayOutput out = localmaps_->step(odom->distance_m, features_, width_px);
    command = out.command;
    state = out.state;
    finished = out.finished;
    status_.matches = out.estimate.matches;
    status_.inliers = out.estimate.inliers;
    status_.offset_px = out.estimate.offset_px;
    distance_m = out.distance_m;
    confidence = out.estimate.confidence;
    saturated = state == ReplayState::steering && max_correction_radps_ > 0.0 &&
                std::abs(out.correction_radps) >= max_correction_radps_ - 1e-9;
    const auto& maps = localmaps_->path().maps;
    informative = out.map_index < 0 || out.map_index >= static_cast<int>(maps.size()) ||
                  static_cast<int>(maps[static_cast<std::size_t>(out.map_index)].positions_px.size()) >=
                      min_expected_features_;
    if (out.lap_completed) {
      (void)set_output("lap", out.lap);
      host_.logger().info(path(), "edge " + edge_id_ + ": lap " + std::to_string(out.lap + 1) + " started");
    }
  }
  if (state != last_state_ && (state == ReplayState::low_confidence || state == ReplayState::no_features ||
                               state == ReplayState::bad_input)) {
    host_.logger().log(LogLevel::debug, path(), std::string("edge ") + edge_id_ + ": " + to_string(state) + " (no correction)");
  }
  last_state_ = state;

  if (bad_frame != nullptr) confidence = 0.0;
  if (phase_ != StartPhase::driving) {
    // Where the map itself holds little at the start (open grass), there is no view to search for.
    if (phase_ == StartPhase::probe && !informative) {
      phase_ = StartPhase::driving;
    } else if (auto st = search_start_view(*robot, *odom, confidence)) {
      if (Telemetry* telemetry = host_.telemetry()) {
        status_.distance_m = distance_m;
        status_.command = last_command_;
        status_.confidence = confidence;
        status_.status = phase_ == StartPhase::probe ? "looking for the start view" : "turning to find the start view";
        telemetry->publish(status_);
      }
      return *st;
    }
  }
  const NavHealthVerdict& health =
      health_.update(odom->distance_m, odom->pose.heading_rad, distance_m, image, confidence, saturated, informative);
  bt::store_nav_health(health_, *this);
  // A robot that is not sure where the route is slows down (the recorded curvature is kept).
  command.linear_mps *= health.speed_factor;
  command.angular_radps *= health.speed_factor;
  // Blindness at the end of an edge is carried into the next one (confident_at_m), so the
  // next edge stops within max_blind_m unless it sees the route again.
  if (Telemetry* telemetry = host_.telemetry()) {
    status_.distance_m = distance_m;
    status_.command = health.must_stop() ? Twist{} : command;
    status_.confidence = health.window_confidence;
    status_.blind_m = health.blind_m;
    status_.status = bad_frame != nullptr ? "bad frame" : to_string(state);
    if (health.state == NavHealthState::slowing || health.must_stop())
      status_.status += std::string(" | ") + to_string(health.state);
    telemetry->publish(status_);
  }
  if (health.must_stop()) {
    return failed(health.reason + " on edge " + edge_id_ + " (" + edge_kind_ + ", " + std::to_string(status_.inliers) +
                  " inliers, window confidence " + format_double(health.window_confidence) + ")");
  }
  if (finished) {
    (void)robot->stop();
    last_command_ = Twist{};
    segment_.reset();
    localmaps_.reset();
    return NodeStatus::success;
  }
  last_command_ = command;
  if (auto st = robot->send_command(command); !st) return failed("sending the command: " + st.error().message);
  return NodeStatus::running;
}

std::optional<NodeStatus> ReplayFeatureEdge::search_start_view(Robot& robot, const Odometry& odom, double confidence) {
  const double heading = odom.pose.heading_rad;
  auto turn = [&](double w) {
    last_command_ = Twist{0.0, w};
    if (auto st = robot.send_command(last_command_); !st) return failed("sending the command: " + st.error().message);
    return NodeStatus::running;
  };
  auto unwrap = [&]() {
    scan_turned_rad_ += wrap_angle_rad(heading - scan_last_rad_);
    scan_last_rad_ = heading;
  };
  auto track = [&]() {
    unwrap();
    if (confidence > best_confidence_) {
      best_confidence_ = confidence;
      best_turn_rad_ = scan_turned_rad_;
    }
  };
  switch (phase_) {
    case StartPhase::probe: {
      // Three frames standing at the start: is the taught start view there?
      probe_confidence_sum_ += confidence;
      if (++probe_frames_ < 3) return turn(0.0);
      if (probe_confidence_sum_ / probe_frames_ >= health_.policy().min_confidence) {
        phase_ = StartPhase::driving;
        return std::nullopt;
      }
      host_.logger().warn(path(), "edge " + edge_id_ + ": start view not seen (confidence " +
                                      format_double(probe_confidence_sum_ / probe_frames_) + "); searching by turning");
      phase_ = StartPhase::scan_left;
      scan_last_rad_ = heading;
      scan_turned_rad_ = 0.0;
      best_confidence_ = confidence;
      best_turn_rad_ = 0.0;
      return turn(scan_speed_radps_);
    }
    case StartPhase::scan_left:
      track();
      if (scan_turned_rad_ < scan_rad_) return turn(scan_speed_radps_);
      phase_ = StartPhase::scan_right;
      return turn(-scan_speed_radps_);
    case StartPhase::scan_right:
      track();
      if (scan_turned_rad_ > -scan_rad_) return turn(-scan_speed_radps_);
      if (best_confidence_ < health_.policy().min_confidence) {
        // Nothing matched anywhere: start on the odometric heading and leave it to the lost
        // policy (a stretch that was hard to see when taught may still be driven on odometry).
        host_.logger().warn(path(), "edge " + edge_id_ + ": start view not found within +-" +
                                        format_double(scan_rad_ * 180.0 / std::numbers::pi) +
                                        " deg; starting on the odometric heading");
        best_turn_rad_ = 0.0;
      }
      phase_ = StartPhase::turn_to_best;
      return turn(scan_speed_radps_);
    case StartPhase::turn_to_best: {
      unwrap();
      const double left = best_turn_rad_ - scan_turned_rad_;
      if (std::abs(left) > 0.03) return turn(std::copysign(std::min(scan_speed_radps_, 0.2 + std::abs(left)), left));
      if (best_confidence_ >= health_.policy().min_confidence)
        host_.logger().info(path(), "edge " + edge_id_ + ": start view found " +
                                        format_double(scan_turned_rad_ * 180.0 / std::numbers::pi) +
                                        " deg from the odometric heading (confidence " + format_double(best_confidence_) + ")");
      phase_ = StartPhase::driving;
      return std::nullopt;
    }
    case StartPhase::driving: break;
  }
  return std::nullopt;
}

void ReplayFeatureEdge::on_halted() {
  if (Robot* robot = host_.robot()) (void)robot->stop();
  segment_.reset();
  localmaps_.reset();
}

}  // namespace visnav::feature_replay
