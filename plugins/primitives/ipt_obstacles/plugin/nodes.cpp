#include "nodes.hpp"

#include "visnav/bt/param_ports.hpp"
#include "visnav/edge_progress.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "visnav/map.hpp"

namespace visnav::ipt {

using bt::NodeStatus;

namespace {

/// Sends a velocity command; a command the robot refuses stops it and fails the node (a robot
/// that cannot be commanded must not be left on its last command).
NodeStatus send(HostServices& host, const bt::TreeNode& node, double v_mps, double w_radps) {
  Robot* robot = host.robot();
  if (robot == nullptr) return NodeStatus::running;
  if (auto st = robot->send_command(Twist{v_mps, w_radps}); !st) {
    (void)robot->stop();
    host.logger().error(node.path(), "stopped: the robot refused the velocity command: " + st.error().message);
    return NodeStatus::failure;
  }
  return NodeStatus::running;
}

/// Debug log of a pair's points (odom frame) for diagnosing detours.
void log_points(HostServices& host, const bt::TreeNode& node, const Pose2D& pose, const std::vector<cv::Point2d>& pts) {
  if (pts.empty()) return;
  std::string m = "pair at (" + std::to_string(pose.x_m) + ", " + std::to_string(pose.y_m) + "):";
  char buf[48];
  for (const auto& p : pts) {
    std::snprintf(buf, sizeof buf, " (%.2f, %.2f)", p.x, p.y);
    m += buf;
  }
  host.logger().log(LogLevel::debug, node.path(), m);
}

void stop(HostServices& host) {
  if (Robot* robot = host.robot()) (void)robot->stop();
}

}  // namespace

Result<IptCamera> ipt_camera(HostServices& host, const cv::Mat& image) {
  auto mount = host.camera_mount();
  if (!mount) return mount.error().with_context("the IPT needs the camera mount");
  IptCamera c;
  c.height_m = mount->height_m;
  c.forward_m = mount->forward_m;
  c.lateral_m = mount->lateral_m;
  c.width_px = image.cols;
  c.height_px = image.rows;
  c.fx_px = c.fy_px = 0.5 * image.cols / std::tan(0.5 * mount->hfov_deg * CV_PI / 180.0);
  c.cx_px = 0.5 * (image.cols - 1);
  c.cy_px = 0.5 * (image.rows - 1);
  c.pitch_rad = -mount->pitch_down_deg * CV_PI / 180.0;
  VISNAV_TRY(c.validate());
  return c;
}

std::optional<Pose2D> PipelineRunner::pose(HostServices& host) const {
  FrameBus* bus = host.frame_bus();
  if (bus == nullptr) return std::nullopt;
  auto odom = bus->latest_odometry();
  if (!odom) return std::nullopt;
  return odom->pose;
}

Result<std::optional<std::vector<cv::Point2d>>> PipelineRunner::step(HostServices& host, const ContactParams& contacts) {
  FrameBus* bus = host.frame_bus();
  if (bus == nullptr) return Error{"no frame bus (not running)", ErrorCode::missing};
  auto frame = bus->latest_frame();
  auto odom = bus->latest_odometry();
  if (!frame || !odom || frame->image.empty()) return std::optional<std::vector<cv::Point2d>>{};
  if (have_sequence_ && frame->sequence == last_sequence_) return std::optional<std::vector<cv::Point2d>>{};
  have_sequence_ = true;
  last_sequence_ = frame->sequence;
  if (frame->image.channels() == 3) cv::cvtColor(frame->image, grey_, cv::COLOR_BGR2GRAY);
  else grey_ = frame->image;
  if (!pipeline_) {
    VISNAV_ASSIGN(IptCamera camera, ipt_camera(host, grey_));
    ProfileParams profiles;
    profiles.span_max_m = contacts.span_max_m;
    profiles.ground_reach_px = contacts.contact_ground_reach_px;
    profiles.foot_radius_px = contacts.foot_radius_px;
    VISNAV_ASSIGN(auto p, ObstaclePipeline::create(camera, PipelineParams{}, ClassifierParams{}, profiles));
    pipeline_.emplace(std::move(p));
  }
  VISNAV_ASSIGN(auto pair, pipeline_->process(grey_, odom->pose));
  if (!pair) return std::optional<std::vector<cv::Point2d>>{};
  std::vector<cv::Point2d> points;
  points.reserve(pair->contacts.size());
  for (const auto& c : pair->contacts) points.push_back(c.ground_m);
  points.insert(points.end(), pair->span_points.begin(), pair->span_points.end());
  if (correcting_ && ground_) {
    // A rejected update leaves the filter on the odometry for this pair: nothing to stop for.
    (void)ground_->add_pair(pair->first_pose, pair->pose, pair->features);
    heading_offset_rad_ = std::remainder(ground_->pose().heading_rad - pair->pose.heading_rad, 2.0 * CV_PI);
    // The points were placed from the raw pose; move them with the robot into the corrected frame.
    const Pose2D raw = pair->pose, fixed = correct(raw);
    const double dh = fixed.heading_rad - raw.heading_rad, c = std::cos(dh), s = std::sin(dh);
    for (auto& p : points) {
      const double dx = p.x - raw.x_m, dy = p.y - raw.y_m;
      p = {fixed.x_m + c * dx - s * dy, fixed.y_m + s * dx + c * dy};
    }
  }
  return std::optional<std::vector<cv::Point2d>>{std::move(points)};
}

Status PipelineRunner::start_correction(const Pose2D& raw, const GroundOdometryParams& params) {
  correcting_ = false;
  if (!pipeline_) return Error{"ekf_heading: the IPT pipeline has not seen a frame yet", ErrorCode::missing};
  VISNAV_ASSIGN(auto filter, GroundOdometry::create(pipeline_->camera(), params));
  filter.reset(raw);
  ground_.emplace(std::move(filter));
  last_raw_ = corrected_ = raw;
  heading_offset_rad_ = 0.0;
  correcting_ = true;
  return ok();
}

Pose2D PipelineRunner::correct(const Pose2D& raw) {
  if (!correcting_) return raw;
  const double c = std::cos(heading_offset_rad_), s = std::sin(heading_offset_rad_);
  const double dx = raw.x_m - last_raw_.x_m, dy = raw.y_m - last_raw_.y_m;
  corrected_.x_m += c * dx - s * dy;
  corrected_.y_m += s * dx + c * dy;
  corrected_.heading_rad = std::remainder(raw.heading_rad + heading_offset_rad_, 2.0 * CV_PI);
  last_raw_ = raw;
  return corrected_;
}

// ------------------------------------------------------------------------------ ObstacleAhead

ObstacleAhead::ObstacleAhead(const std::string& name, const bt::NodeConfig& config, HostServices& host)
    : bt::ConditionNode(name, config), host_(host) {}

void CorridorMemory::add(const std::vector<cv::Point2d>& points, const Odometry& odom) {
  sightings_.add(points, {odom.pose.x_m, odom.pose.y_m}, odom.distance_m);
}

std::vector<cv::Point2d> CorridorMemory::add_and_confirm(const std::vector<cv::Point2d>& points, const Odometry& odom) {
  if (!filter_on_) return points;
  sightings_.forget(odom.distance_m, memory_m_);
  const std::size_t first = sightings_.size();
  add(points, odom);
  return sightings_.confirmed_since(first);
}

Result<bool> CorridorMemory::blocked(const CorridorParams& params, const Odometry& odom) {
  const double lookahead = params.lookahead_m, half_width = params.corridor_half_width_m, memory = params.memory_m;
  memory_m_ = memory;
  if (!configured_) {
    filter_on_ = params.confirm_baseline_m > 0.0;
    if (filter_on_) {
      ContactPersistenceParams persistence;
      persistence.min_baseline_m = params.confirm_baseline_m;
      persistence.max_radius_m = params.confirm_radius_m;
      persistence.min_views = params.confirm_views;
      persistence.min_view_share = params.confirm_view_share;
      if (auto st = persistence.validate(); !st)
        return st.error().with_context("keys 'confirm_baseline_m'/'confirm_radius_m'/'confirm_views'/'confirm_view_share'");
      sightings_.set_params(persistence);  // the sightings added before the first test stay
    }
    configured_ = true;
  }
  sightings_.forget(odom.distance_m, memory);
  const Pose2D& r = odom.pose;
  const double c = std::cos(r.heading_rad), s = std::sin(r.heading_rad);
  auto in_corridor = [&](const cv::Point2d& p) {
    const double dx = p.x - r.x_m, dy = p.y - r.y_m;
    const double fwd = c * dx + s * dy, lat = -s * dx + c * dy;
    return fwd > 0.0 && fwd <= lookahead && std::fabs(lat) <= half_width;
  };
  std::vector<cv::Point2d> in;
  if (filter_on_) {
    in = sightings_.confirmed(in_corridor);
  } else {
    for (const auto& p : sightings_.all())
      if (in_corridor(p)) in.push_back(p);
  }
  if (in.empty()) return false;
  blocking_.clear();
  char buf[48];
  for (const auto& p : in) {
    std::snprintf(buf, sizeof buf, "%s(%.2f, %.2f)", blocking_.empty() ? "" : " ", p.x, p.y);
    blocking_ += buf;
  }
  return true;
}

bt::PortsList ObstacleAhead::provided_ports() {
  bt::PortsList ports;
  bt::append_param_ports(ports, ContactParams::schema());
  bt::append_param_ports(ports, CorridorParams::schema());
  return ports;
}

NodeStatus ObstacleAhead::tick() {
  if (!contacts_) {
    auto contacts = bt::parse_param_ports(*this, ContactParams::schema());
    auto corridor = bt::parse_param_ports(*this, CorridorParams::schema());
    if (!contacts || !corridor) {
      host_.logger().error(path(), (!contacts ? contacts.error() : corridor.error()).message);
      return NodeStatus::failure;
    }
    contacts_ = *contacts;
    corridor_params_ = *corridor;
  }
  auto fresh = runner_.step(host_, *contacts_);
  if (!fresh) {
    host_.logger().warn(path(), fresh.error().message);
    return NodeStatus::failure;
  }
  FrameBus* bus = host_.frame_bus();
  auto odom = bus != nullptr ? bus->latest_odometry() : std::nullopt;
  if (!odom) return NodeStatus::failure;
  if (*fresh) corridor_.add(**fresh, *odom);
  auto blocked = corridor_.blocked(corridor_params_, *odom);
  if (!blocked) {
    host_.logger().warn(path(), blocked.error().message);
    return NodeStatus::failure;
  }
  return *blocked ? NodeStatus::success : NodeStatus::failure;
}

// ------------------------------------------------------------------------------- DetourDriver

Status DetourDriver::begin(const DriveParams& drive, const ThesisDetourParams& thesis, const Pose2D& pose) {
  PolarMapParams params;
  params.security_distance_m = thesis.security_distance_m;
  params.gap_width_m = thesis.gap_width_m;
  params.reset_keep_near_m = thesis.reset_keep_near_m;
  VISNAV_TRY(params.validate());
  drive_ = drive;
  const double goal_ahead_m = thesis.goal_ahead_m;
  filter_.emplace(params);
  goal_m_ = {pose.x_m + goal_ahead_m * std::cos(pose.heading_rad), pose.y_m + goal_ahead_m * std::sin(pose.heading_rad)};
  blocked_cycles_ = 0;
  stall_cycles_ = 0;
  best_distance_m_ = goal_ahead_m;
  last_situation_ = Situation::blocked;
  return ok();
}

NodeStatus DetourDriver::step(const bt::TreeNode& node, HostServices& host, PipelineRunner& runner,
                              const ContactParams& contacts) {
  if (!filter_) return NodeStatus::failure;
  auto fresh = runner.step(host, contacts);
  if (!fresh) {
    host.logger().error(node.path(), fresh.error().message);
    stop(host);
    return NodeStatus::failure;
  }
  auto pose = runner.pose(host);
  if (!pose) return NodeStatus::running;
  if (*fresh) {
    log_points(host, node, *pose, **fresh);
    filter_->add_points(**fresh);
  }
  const Decision d = filter_->decide(*pose, goal_m_);
  if (d.situation != last_situation_) {
    host.logger().info(node.path(), std::string(to_string(d.situation)) + " at (" + std::to_string(pose->x_m) + ", " +
                                        std::to_string(pose->y_m) + "): " + d.reason);
    last_situation_ = d.situation;
  }
  if (d.situation == Situation::goal_reached) {
    stop(host);
    return NodeStatus::success;
  }
  if (d.situation == Situation::no_candidate) {
    if (++blocked_cycles_ >= drive_.max_blocked_cycles) {
      host.logger().error(node.path(), "stopped: " + d.reason + " for " + std::to_string(blocked_cycles_) + " cycles");
      stop(host);
      return NodeStatus::failure;
    }
  } else {
    blocked_cycles_ = 0;
  }
  const double to_goal_m = std::hypot(goal_m_.x - pose->x_m, goal_m_.y - pose->y_m);
  if (to_goal_m < best_distance_m_ - 0.1) {
    best_distance_m_ = to_goal_m;
    stall_cycles_ = 0;
  } else if (++stall_cycles_ >= drive_.max_stall_cycles) {
    host.logger().error(node.path(), "stopped: no progress towards the goal for " + std::to_string(stall_cycles_) +
                                         " cycles (" + std::to_string(to_goal_m) + " m left; last: " + d.reason + ")");
    stop(host);
    return NodeStatus::failure;
  }
  const double w = std::clamp(drive_.turn_gain_per_s * d.heading_rad, -drive_.max_angular_radps, drive_.max_angular_radps);
  const double v = d.translate ? drive_.speed_mps * std::max(0.0, std::cos(d.heading_rad)) : 0.0;
  return send(host, node, v, d.translate ? w : std::copysign(drive_.max_angular_radps, d.heading_rad));
}

// ----------------------------------------------------------------------------- AvoidObstacles

AvoidObstacles::AvoidObstacles(const std::string& name, const bt::NodeConfig& config, HostServices& host)
    : bt::StatefulActionNode(name, config), host_(host) {}

bt::PortsList AvoidObstacles::provided_ports() {
  bt::PortsList ports;
  bt::append_param_ports(ports, ContactParams::schema());
  bt::append_param_ports(ports, DriveParams::schema());
  bt::append_param_ports(ports, ThesisDetourParams::schema());
  ports.push_back(bt::output_port<std::string>("situation", "{avoid_situation}", "the last decision's situation"));
  return ports;
}

NodeStatus AvoidObstacles::on_start() {
  auto contacts = bt::parse_param_ports(*this, ContactParams::schema());
  auto drive = bt::parse_param_ports(*this, DriveParams::schema());
  auto thesis = bt::parse_param_ports(*this, ThesisDetourParams::schema());
  auto pose = runner_.pose(host_);
  if (!contacts || !drive || !thesis || !pose) {
    host_.logger().error(path(), !contacts ? contacts.error().message
                                 : !drive  ? drive.error().message
                                 : !thesis ? thesis.error().message
                                           : "no odometry: cannot place the goal");
    stop(host_);
    return NodeStatus::failure;
  }
  contacts_ = *contacts;
  if (auto st = detour_.begin(*drive, *thesis, *pose); !st) {
    host_.logger().error(path(), st.error().message);
    stop(host_);
    return NodeStatus::failure;
  }
  runner_.restart();
  return on_running();
}

NodeStatus AvoidObstacles::on_running() {
  const NodeStatus st = detour_.step(*this, host_, runner_, contacts_);
  (void)set_output("situation", std::string(to_string(detour_.last_situation())));
  if (st != NodeStatus::running) detour_.end();
  return st;
}

void AvoidObstacles::on_halted() {
  stop(host_);
  detour_.end();
}

// ----------------------------------------------------------------------------- ReplayAvoiding

ReplayAvoiding::ReplayAvoiding(const std::string& name, const bt::NodeConfig& config, HostServices& host,
                               const AvoidingParams& defaults)
    : bt::DecoratorNode(name, config), defaults_(defaults), host_(host) {}

bt::PortsList ReplayAvoiding::provided_ports() { return ports_with(replay_defaults()); }

namespace {

Status check_detour_mode(std::string_view text) {
  if (text == "lane" || text == "thesis") return ok();
  return Error{"value '" + std::string(text) + "' is not one of: lane thesis", ErrorCode::invalid_value};
}

// The edge progress shared with FollowRoute and the replay child (docs/obstacles.md, "Nodes and
// ports"): the blackboard entries the replay adapter writes and reads.
void append_progress_ports(bt::PortsList& ports) {
  ports.push_back(bt::input_port<std::string>("edge", edge_progress::edge,
                                              "the edge being replayed (its length ends a lane detour); empty = unknown"));
  ports.push_back(bt::inout_port<double>("carried_m", edge_progress::carried_m,
                                         "edge distance already covered when the child starts, taught m (FollowRoute "
                                         "writes it; rewritten after a detour)"));
  ports.push_back(bt::with_range(bt::input_port<double>("distance_scale", edge_progress::distance_scale,
                                         "odometric metres per taught metre (FollowRoute's estimate, as the replay "
                                         "child's port): the rewritten carried_m is in taught metres; unset counts as 1"), 0.5, 2.0));
  ports.push_back(bt::input_port<double>(
      "child_shift_m", edge_progress::shift_m,
      "the child's visual along-track correction so far (the replay nodes' output 'shift_m', taught m): every restart "
      "of the child after a stop, look, back-off or detour carries it in carried_m, so the correction of a path or "
      "feature edge survives the interruptions; unset counts as 0"));
  ports.push_back(bt::output_port<double>(
      "extra_travel_m", edge_progress::extra_travel_m,
      "when the child ends an edge on which the node detoured, reversed, probed or crossed: the odometric metres "
      "driven that were not progress along the edge (a detour's sideways legs), so FollowRoute leaves them out of "
      "the next edge's carried distance and of its distance-scale fixes; not written otherwise"));
  ports.push_back(bt::inout_port<double>(
      "end_shift_m", edge_progress::end_shift_m,
      "when the child ends the edge: its own end shift (the replay nodes' output) plus the corrections carried "
      "over its restarts, rewritten so that FollowRoute sees the whole edge's correction"));
  ports.push_back(bt::inout_port<double>("confident_at_m", edge_progress::confident_at_m,
                                         "the replay's last confident odometer reading (lost detection); set to the "
                                         "odometer when a detour ends: the detour was driven on the IPT, not blind"));
  ports.push_back(bt::inout_port<double>("image_changed_at_m", edge_progress::image_changed_at_m,
                                         "the replay's frozen-image count, restarted likewise after a detour"));
  ports.push_back(bt::input_port<std::string>("failure", edge_progress::failure,
                                              "the child's reason of failure (the replay nodes' output 'failure')"));
  ports.push_back(bt::input_port<std::string>("failure_code", edge_progress::failure_code,
                                              "the child's failure code (the replay nodes' output 'failure_code'): "
                                              "view_lost starts the probe (probe group)"));
}

}  // namespace

bt::PortsList ReplayAvoiding::ports_with(const AvoidingParams& defaults) {
  bt::PortsList ports;
  append_progress_ports(ports);
  bt::PortInfo detour = bt::input_port<std::string>(
      "detour", "lane",
      "lane: a free lateral offset from the taught line, back onto it past the obstacle (lane group; measured: "
      "docs/obstacles.md); thesis: the Ch. 6 strategy to a goal along the line (thesis group)");
  detour.check = check_detour_mode;
  detour.constraint = "one of: lane thesis";
  ports.push_back(std::move(detour));
  ports.push_back(bt::with_range(
      bt::input_port<double>("body_radius_m", "0.25", "lane detour and crossing policy: robot disc radius, m"), 0.01, 5.0));
  ports.push_back(bt::output_port<std::string>("situation", "{avoid_situation}", "the detour's last decision"));
  append_avoiding_group_ports(ports, defaults);
  return ports;
}

bool ReplayAvoiding::read_params() {
  if (params_read_) return true;
  auto parsed = parse_avoiding_groups(*this, defaults_);
  if (!parsed) {
    host_.logger().error(path(), parsed.error().message);
    stop(host_);
    return false;
  }
  auto mode = get_input<std::string>("detour");
  auto body = get_input<double>("body_radius_m");
  Status st = !mode ? Status(mode.error().with_context("port 'detour'"))
              : !body ? Status(body.error().with_context("port 'body_radius_m'"))
                      : check_detour_mode(*mode);
  if (st && !(*body >= 0.01 && *body <= 5.0))
    st = Error{"port 'body_radius_m': value " + std::to_string(*body) + " is out of range [0.01, 5]", ErrorCode::out_of_range};
  if (!st) {
    host_.logger().error(path(), st.error().message);
    stop(host_);
    return false;
  }
  p_ = *parsed;
  lane_mode_ = *mode == "lane";
  body_radius_m_ = *body;
  params_read_ = true;
  return true;
}

// ReplayAvoiding::tick(): the state machine of ReplayAvoiding::Phase; one phase runs per tick.
//  * detouring (detour_step(); lane_ set: the lane detour, lane_step(); else the thesis detour,
//    DetourDriver): RUNNING until it ends; its failure fails the node, its success resumes the
//    child ("detour done") -> replaying.
//  * looking (look_step()): stopped, watching the corridor with the frame difference (and the
//    crossing policy) once the odometry says still:
//      - nothing moved for look_frames frames (look_still()): at a person's way, first the
//        crossing's wait_s; then a contact in the corridor -> detouring (begin_detour), or, on a
//        way seen crossing, looking again at that way (at_kerb_); no contact -> backing_off
//        (begin_backoff) or replaying ("nothing moves ahead");
//      - motion seen (saw_motion_, look_wait()): waiting; the crossing policy's go -> crossing
//        (begin_crossing) or replaying (crossing_go()); clear_frames still frames (and at a way
//        the crossing's wait_s unseen) -> replaying; more than max_wait_frames -> FAILURE.
//  * crossing (cross_step()): drives across a person's way on the heading -> replaying.
//  * backing_off (backoff_step()): reverses while triangulating; something stands -> detouring,
//    else -> replaying.
//  * replaying and probing: a run of the child starts when none has (replay_start(): a new edge
//    unless resume_child() set carried_m). Then, in order, each able to stop the replay (a stop
//    ends a probe):
//      - the IPT's contact in the corridor ahead (corridor_stop()) -> looking (detouring when
//        look_frames = 0);
//      - the drive watch: something moves close ahead (drive_watch_stop()) -> looking;
//      - the crossing watch: a person's way ahead (kerb_stop()) -> looking at the way (at_kerb_);
//      - probing (probe_step(); entered when the child failed with failure code view_lost and the
//        probe on): creeping on on the heading; the probe's min_points corners ahead ->
//        detouring; the budget used -> FAILURE;
//      - replaying: the standing watch fires (standing_stop()) -> detouring (lane); else the
//        child ticks (child_step()): RUNNING; SUCCESS -> the edge is done (edge_done(), the
//        node's SUCCESS); FAILURE -> probing (child_failed()) or the node's FAILURE.
// "-> replaying" after a stop is resume_child(): the child starts again at the along-track
// distance reached. An error of a port, the camera or the pipeline stops the robot and fails the
// node (phase replaying, so a later tick starts the edge afresh).
NodeStatus ReplayAvoiding::tick() {
  FrameBus* bus = host_.frame_bus();
  auto odom = bus != nullptr ? bus->latest_odometry() : std::nullopt;
  if (!odom) {
    host_.logger().error(path(), "no odometry");
    return NodeStatus::failure;
  }
  if (!read_params()) return NodeStatus::failure;
  switch (phase_) {
    case Phase::detouring: return detour_step(*odom);
    case Phase::looking: return look_step(*odom);
    case Phase::crossing: return cross_step(*odom);
    case Phase::backing_off: return backoff_step(*odom);
    case Phase::replaying:
    case Phase::probing: break;
  }
  // Replaying or probing: the watches first, each able to stop the replay.
  const bool probing = phase_ == Phase::probing;
  if (!child_started_ && !probing && !replay_start(*odom)) return NodeStatus::failure;
  if (auto st = corridor_stop(*odom)) return *st;
  if (auto st = drive_watch_stop(*odom)) return *st;
  if (auto st = kerb_stop(*odom)) return *st;
  if (probing) return probe_step(*odom);
  if (auto st = standing_stop(*odom)) return *st;
  return child_step(*odom);
}

const char* ReplayAvoiding::phase_name(Phase phase) {
  switch (phase) {
    case Phase::replaying: return "replaying";
    case Phase::probing: return "probing";
    case Phase::looking: return "looking";
    case Phase::crossing: return "crossing";
    case Phase::backing_off: return "backing_off";
    case Phase::detouring: return "detouring";
  }
  return "?";
}

void ReplayAvoiding::enter(Phase next) {
  if (next == phase_) return;
  host_.logger().log(LogLevel::debug, path(), std::string("phase ") + phase_name(phase_) + " -> " + phase_name(next));
  phase_ = next;
}

NodeStatus ReplayAvoiding::detour_step(const Odometry& odom) {
  NodeStatus st = NodeStatus::failure;
  if (lane_) {
    st = lane_step(odom);
  } else {
    st = detour_.step(*this, host_, runner_, p_.contacts);
    (void)set_output("situation", std::string(to_string(detour_.last_situation())));
  }
  if (st == NodeStatus::running) return NodeStatus::running;
  detour_.end();
  lane_.reset();
  runner_.stop_correction();
  enter(Phase::replaying);
  if (st == NodeStatus::failure) return NodeStatus::failure;
  if (probe_) probe_->reset();  // past the obstacle: a later hidden path gets a new budget
  resume_child(odom, "detour done");
  return NodeStatus::running;
}

bool ReplayAvoiding::replay_start(const Odometry& odom) {
  auto carried = get_input<double>("carried_m");
  const double carried_m = carried && std::isfinite(*carried) ? *carried : 0.0;
  if (!resumed_) {
    // A new edge: nothing carried over yet, nothing driven off it.
    carried_shift_m_ = 0.0;
    moved_off_line_ = false;
    edge_start_odometer_m_ = odom.distance_m;
    edge_start_carried_m_ = carried_m;
  }
  resumed_ = false;
  child_ran_ = false;
  // As the replay adapter: the edge counts in taught metres, odometry reads scale_ times them.
  auto scale = get_input<double>("distance_scale");  // unset counts as 1; a set value must be in range
  if (scale && !(*scale >= 0.5 && *scale <= 2.0)) {
    host_.logger().error(path(), "port 'distance_scale': value " + std::to_string(*scale) + " is not in [0.5, 2]");
    stop(host_);
    return false;
  }
  scale_ = scale ? *scale : 1.0;
  replay_origin_m_ = odom.distance_m - scale_ * carried_m;
  child_started_ = true;
  if (drive_watch_) drive_watch_->reset();
  drive_shimmer_.reset_hits();
  return true;
}

NodeStatus ReplayAvoiding::replay_failed(const std::string& message) {
  host_.logger().error(path(), message);
  halt_child();
  stop(host_);
  return NodeStatus::failure;
}

void ReplayAvoiding::interrupt_replay(const Odometry& odom) {
  halt_child();
  enter(Phase::replaying);  // a probe ends here too; the caller enters the next phase
  replay_done_m_ = odom.distance_m - replay_origin_m_;
  detour_start_ = odom.pose;
}

std::optional<NodeStatus> ReplayAvoiding::corridor_stop(const Odometry& odom) {
  auto fresh = runner_.step(host_, p_.contacts);
  if (!fresh) return replay_failed(fresh.error().message);
  if (*fresh) {
    log_points(host_, *this, odom.pose, **fresh);
    corridor_.add(**fresh, odom);
  }
  auto blocked = corridor_.blocked(p_.corridor, odom);
  if (!blocked) return replay_failed(blocked.error().message);
  if (!*blocked) return std::nullopt;
  interrupt_replay(odom);
  if (p_.look.look_frames == 0) return begin_detour(odom);
  begin_look(odom, "obstacle ahead at " + std::to_string(replay_done_m_) + " m of the edge (robot at (" +
                       std::to_string(odom.pose.x_m) + ", " + std::to_string(odom.pose.y_m) + "), contacts " +
                       corridor_.blocking_points() + "): stop and look");
  return NodeStatus::running;
}

std::optional<NodeStatus> ReplayAvoiding::drive_watch_stop(const Odometry& odom) {
  auto near = moving_near(odom);
  if (!near) return replay_failed(near.error().message);
  stop_by_drive_watch_ = *near;
  if (!*near) return std::nullopt;
  interrupt_replay(odom);
  begin_look(odom, "something moves close ahead at " + std::to_string(replay_done_m_) + " m of the edge: stop and look");
  return NodeStatus::running;
}

std::optional<NodeStatus> ReplayAvoiding::kerb_stop(const Odometry& odom) {
  auto kerb = kerb_near(odom);
  if (!kerb) return replay_failed(kerb.error().message);
  if (!*kerb) return std::nullopt;
  interrupt_replay(odom);
  begin_look(odom, "a person was seen crossing ahead: stop before its way at " + std::to_string(replay_done_m_) +
                       " m of the edge and watch it pass");
  at_kerb_ = true;
  kerb_since_s_ = odom.timestamp_s;
  return NodeStatus::running;
}

std::optional<NodeStatus> ReplayAvoiding::standing_stop(const Odometry& odom) {
  auto standing = standing_ahead(odom);
  if (!standing) return replay_failed(standing.error().message);
  if (*standing) return **standing;
  return std::nullopt;
}

NodeStatus ReplayAvoiding::probe_step(const Odometry& odom) {
  auto probe_failed = [&](const std::string& message) {
    host_.logger().error(path(), message);
    enter(Phase::replaying);
    stop(host_);
    return NodeStatus::failure;
  };
  auto near_points = triangulate_near(odom);
  if (!near_points) return probe_failed(near_points.error().message);
  const int min_points = p_.probe.min_points;
  const double lookahead = p_.corridor.lookahead_m, half_width = p_.corridor.corridor_half_width_m;
  const Pose2D& r = odom.pose;
  const double c = std::cos(r.heading_rad), sn = std::sin(r.heading_rad);
  int ahead = 0;
  for (const auto& p : *near_points) {
    const double fwd = c * (p.x - r.x_m) + sn * (p.y - r.y_m), lat = -sn * (p.x - r.x_m) + c * (p.y - r.y_m);
    if (fwd > 0.0 && fwd <= lookahead + 1.0 && std::fabs(lat) <= half_width) ++ahead;
  }
  if (!near_points->empty()) {
    log_points(host_, *this, r, *near_points);
    near_points_.insert(near_points_.end(), near_points->begin(), near_points->end());
  }
  if (ahead >= min_points) {
    enter(Phase::replaying);
    stop(host_);
    replay_done_m_ = odom.distance_m - replay_origin_m_;
    detour_start_ = odom.pose;
    host_.logger().info(path(), "probe: " + std::to_string(ahead) + " corners triangulated above the ground in the corridor ahead at " +
                                    std::to_string(replay_done_m_) + " m of the edge");
    const NodeStatus st = begin_detour(odom);
    if (lane_) lane_->add_points(near_points_);
    return st;
  }
  const HiddenPathProbe::Step s = probe_->step(odom.pose, odom.distance_m);
  if (s.exhausted) {
    enter(Phase::replaying);
    corridor_.clear();
    stop(host_);
    host_.logger().error(path(), "stopped: " + probe_reason_ + "; nothing found ahead while probing on");
    return NodeStatus::failure;
  }
  return send(host_, *this, s.command.linear_mps, s.command.angular_radps);
}

NodeStatus ReplayAvoiding::child_step(const Odometry& odom) {
  const NodeStatus st = child()->execute_tick();
  child_ran_ = true;
  if (st == NodeStatus::running) return st;
  child_started_ = false;
  if (st == NodeStatus::failure) return child_failed(odom);
  edge_done(odom);
  return st;
}

void ReplayAvoiding::edge_done(const Odometry& odom) {
  {
    auto end_shift = get_input<double>("end_shift_m");
    const double child_end_m = end_shift && std::isfinite(*end_shift) ? *end_shift : 0.0;
    const double end_shift_m = child_end_m + carried_shift_m_;
    // FollowRoute takes the end node from end_shift_m: the child's last run saw only its own part.
    if (carried_shift_m_ != 0.0) (void)set_output("end_shift_m", end_shift_m);
    if (moved_off_line_) report_extra_travel(odom, end_shift_m);
  }
  carried_shift_m_ = 0.0;
  moved_off_line_ = false;
  if (probe_) probe_->reset();
  if (crossing_) crossing_->forget_person();  // the next edge's person is another
  corridor_.clear();
}

NodeStatus ReplayAvoiding::child_failed(const Odometry& odom) {
  // The probe keys on the child's failure code, never on its message text.
  auto code = get_input<std::string>("failure_code");
  auto failure = get_input<std::string>("failure");
  if (!p_.probe.enabled || !code || *code != "view_lost") {
    corridor_.clear();
    return NodeStatus::failure;
  }
  if (!probe_) {
    HiddenPathProbeParams params;
    params.distance_m = p_.probe.budget_m;
    params.speed_mps = p_.probe.speed_mps;
    if (auto st = params.validate(); !st) {
      host_.logger().error(path(), "port 'probe': " + st.error().message);
      stop(host_);
      return NodeStatus::failure;
    }
    probe_.emplace(params);
  }
  probe_->begin(odom.pose, odom.distance_m);
  enter(Phase::probing);
  moved_off_line_ = true;
  near_points_.clear();
  if (near_) near_->reset();
  probe_reason_ = failure ? *failure : std::string("view_lost");
  host_.logger().info(path(), "the child gave up (" + probe_reason_ + "): probing on for " +
                                  std::to_string(probe_->left_m(odom.distance_m)) +
                                  " m while the IPT and the frame difference look");
  return NodeStatus::running;
}

Result<std::vector<cv::Point2d>> ReplayAvoiding::triangulate_near(const Odometry& odom) {
  std::vector<cv::Point2d> out;
  FrameBus* bus = host_.frame_bus();
  auto frame = bus != nullptr ? bus->latest_frame() : std::nullopt;
  if (!frame || frame->image.empty() || (have_near_sequence_ && frame->sequence == near_sequence_)) return out;
  have_near_sequence_ = true;
  near_sequence_ = frame->sequence;
  if (frame->image.channels() == 3) cv::cvtColor(frame->image, near_grey_, cv::COLOR_BGR2GRAY);
  else near_grey_ = frame->image;
  if (!near_) {
    VISNAV_ASSIGN(IptCamera camera, ipt_camera(host_, near_grey_));
    VISNAV_ASSIGN(auto made, NearTriangulation::create(camera, NearTriangulationParams{}));
    near_.emplace(std::move(made));
  }
  VISNAV_ASSIGN(const auto points, near_->observe(near_grey_, odom.pose));
  out.reserve(points.size());
  for (const auto& p : points) out.push_back(p.ground_m);
  return out;
}

void ReplayAvoiding::report_extra_travel(const Odometry& odom, double end_shift_m) {
  // Driven straight, the edge takes scale_ * (length - carried at the start - the visual
  // corrections) of odometry; what the node drove beyond that went sideways or back and forth.
  auto edge = get_input<std::string>("edge");
  if (!edge || edge->empty() || host_.map() == nullptr) return;
  const EdgeRecord* record = host_.map()->find_edge(*edge);
  if (record == nullptr) return;
  const double straight_m = scale_ * (record->length_m - edge_start_carried_m_ - end_shift_m);
  const double extra_m = (odom.distance_m - edge_start_odometer_m_) - straight_m;
  if (!std::isfinite(extra_m) || extra_m <= 0.0) return;
  (void)set_output("extra_travel_m", extra_m);
  host_.logger().info(path(), "edge " + *edge + " done: " + std::to_string(extra_m) +
                                  " m of its odometry went off the route (detours, reversing), not along it");
}

void ReplayAvoiding::resume_child(const Odometry& odom, const std::string& why) {
  // The edge continues from the along-track distance reached (a detour's progress projected on
  // the line; nothing after a wait).
  const double along_m = (odom.pose.x_m - detour_start_.x_m) * std::cos(detour_start_.heading_rad) +
                         (odom.pose.y_m - detour_start_.y_m) * std::sin(detour_start_.heading_rad);
  // The child's visual along-track correction of the run just interrupted (taught metres): the
  // restarted child begins a new estimate from 0, so the correction is carried in its start
  // distance instead of being lost at every stop (a path edge stopped every 0.7 m by ground
  // shimmer otherwise ends on odometry alone). Only a run the child made since its last start.
  double shift_m = 0.0;
  if (child_ran_) {
    auto child_shift = get_input<double>("child_shift_m");
    if (child_shift && std::isfinite(*child_shift)) shift_m = *child_shift;
  }
  child_ran_ = false;
  resumed_ = true;
  carried_shift_m_ += shift_m;
  // odometric metres -> the edge's taught metres
  const double carried = (replay_done_m_ + along_m) / scale_ + shift_m;
  (void)set_output("carried_m", carried);
  (void)set_output("confident_at_m", odom.distance_m);
  (void)set_output("image_changed_at_m", odom.distance_m);
  host_.logger().info(path(), why + ": the edge resumes at " + std::to_string(carried) + " m");
  if (drive_watch_) drive_watch_->reset();
  drive_shimmer_.reset_hits();
  if (crossing_ && at_kerb_) crossing_->clear_lanes();  // crossing now (or given up waiting)
  at_kerb_ = false;
  corridor_.clear();
  runner_.restart();
  child_started_ = false;
  near_points_.clear();
}

Status ReplayAvoiding::read_crossing(const cv::Mat& grey) {
  if (crossing_read_) return ok();
  VISNAV_ASSIGN(IptCamera camera, ipt_camera(host_, grey));
  VISNAV_ASSIGN(crossing_, CrossingWatch::create(p_.crossing, p_.look, body_radius_m_, camera));
  crossing_read_ = true;
  return ok();
}

Result<bool> ReplayAvoiding::kerb_near(const Odometry& odom) {
  if (crossing_read_ && !crossing_) return false;
  FrameBus* bus = host_.frame_bus();
  auto frame = bus != nullptr ? bus->latest_frame() : std::nullopt;
  if (!frame || frame->image.empty() || (have_kerb_sequence_ && frame->sequence == kerb_sequence_)) return false;
  const bool first = !have_kerb_sequence_;
  have_kerb_sequence_ = true;
  kerb_sequence_ = frame->sequence;
  if (frame->image.channels() == 3) cv::cvtColor(frame->image, watch_grey_, cv::COLOR_BGR2GRAY);
  else watch_grey_ = frame->image;
  VISNAV_TRY(read_crossing(watch_grey_));
  if (!crossing_) return false;
  const Pose2D& a = kerb_pose_;
  const double c = std::cos(a.heading_rad), s = std::sin(a.heading_rad);
  const double dx = odom.pose.x_m - a.x_m, dy = odom.pose.y_m - a.y_m;
  const Pose2D motion{c * dx + s * dy, -s * dx + c * dy, std::remainder(odom.pose.heading_rad - a.heading_rad, 2.0 * CV_PI)};
  kerb_pose_ = odom.pose;
  if (first) crossing_->reset();
  return crossing_->drive(watch_grey_, motion, odom.pose, frame->timestamp_s);
}

void ReplayAvoiding::begin_look(const Odometry& odom, const std::string& why) {
  (void)odom;
  stop(host_);
  enter(Phase::looking);
  saw_motion_ = false;
  look_frames_ = still_frames_ = wait_frames_ = settle_frames_ = 0;
  have_watch_sequence_ = false;
  have_drive_sequence_ = false;
  drive_shimmer_.reset_hits();
  if (watch_) watch_->reset();
  if (drive_watch_) drive_watch_->reset();
  if (crossing_) crossing_->reset();
  crossing_kind_ = CrossingDecision::Kind::no_track;
  at_kerb_ = false;
  have_kerb_sequence_ = false;
  host_.logger().info(path(), why);
}

Result<bool> ReplayAvoiding::moving_near(const Odometry& odom) {
  const double stop_m = p_.look.moving_stop_m;
  if (stop_m <= 0.0 || odom.distance_m < drive_quiet_until_m_) return false;
  FrameBus* bus = host_.frame_bus();
  auto frame = bus != nullptr ? bus->latest_frame() : std::nullopt;
  if (!frame || frame->image.empty() || (have_drive_sequence_ && frame->sequence == drive_sequence_)) return false;
  have_drive_sequence_ = true;
  drive_sequence_ = frame->sequence;
  if (frame->image.channels() == 3) cv::cvtColor(frame->image, watch_grey_, cv::COLOR_BGR2GRAY);
  else watch_grey_ = frame->image;
  if (!drive_watch_) {
    VISNAV_ASSIGN(IptCamera camera, ipt_camera(host_, watch_grey_));
    MotionWatchParams params;
    params.diff_threshold = p_.look.motion_threshold;
    params.min_changed_px = p_.look.motion_min_px;
    params.near_m = 0.8;  // below, a millimetre of odometry error is a pixel of ground
    params.far_m = std::max(stop_m, 1.3);
    params.half_width_m = 1.2;
    params.min_changed_px *= 4;  // driving: a person 2 m ahead changes thousands of pixels
    auto made = MotionWatch::create(camera, params);
    if (!made) return made.error().with_context("port 'look', key 'moving_stop_m'");
    drive_watch_.emplace(std::move(*made));
  }
  // The robot's motion since the previous frame, in the previous robot frame.
  const Pose2D& a = drive_watch_pose_;
  const double c = std::cos(a.heading_rad), s = std::sin(a.heading_rad);
  const double dx = odom.pose.x_m - a.x_m, dy = odom.pose.y_m - a.y_m;
  const Pose2D motion{c * dx + s * dy, -s * dx + c * dy, std::remainder(odom.pose.heading_rad - a.heading_rad, 2.0 * CV_PI)};
  drive_watch_pose_ = odom.pose;
  VISNAV_ASSIGN(const auto changed, drive_watch_->observe(watch_grey_, motion));
  if (!changed) return false;
  host_.logger().log(LogLevel::debug, path(),
                     "near corridor: " + std::to_string(*changed) + " changed pixels, motion " + std::to_string(motion.x_m) +
                         " m " + std::to_string(motion.heading_rad) + " rad");
  // Only at cruising speed (>= 2 cm per frame): the shimmer of fine ground texture grows with
  // the speed, so counts while starting or stopping say nothing about it (ShimmerTrigger).
  const bool cruising = std::abs(motion.x_m) >= 0.02;
  if (!drive_shimmer_.update(*changed, cruising, drive_watch_->moving())) return false;
  // What stopped the robot: one compact region (a face close ahead) or scattered shimmer; the
  // back-off after a fruitless look asks for the former (the backoff group's compact).
  stop_shape_ = change_shape(drive_watch_->last_changed(), ChangeShapeParams{}, shape_labels_, shape_stats_, shape_centroids_);
  host_.logger().info(path(), "near corridor changed: " + std::to_string(stop_shape_.changed_px) + " px in " +
                                  std::to_string(stop_shape_.pieces) + " pieces (largest " +
                                  std::to_string(stop_shape_.largest_px) + " px), " + std::to_string(stop_shape_.solid_px) +
                                  " px in solid pieces (share " + std::to_string(stop_shape_.share) + "): " +
                                  (stop_shape_.compact ? "solid (something close)" : "specks (shimmer)"));
  return true;
}

NodeStatus ReplayAvoiding::look_failed(const std::string& message) {
  host_.logger().error(path(), message);
  enter(Phase::replaying);
  stop(host_);
  return NodeStatus::failure;
}

std::optional<NodeStatus> ReplayAvoiding::make_look_watch() {
  if (watch_) return std::nullopt;
  auto camera = ipt_camera(host_, watch_grey_);
  if (!camera) return look_failed(camera.error().message);
  MotionWatchParams params;
  params.diff_threshold = p_.look.motion_threshold;
  params.min_changed_px = p_.look.motion_min_px;
  params.far_m = std::max(params.near_m + 0.5, p_.corridor.lookahead_m + 1.0);
  auto made = MotionWatch::create(*camera, params);
  if (!made) return look_failed("port 'look': " + made.error().message);
  watch_.emplace(std::move(*made));
  return std::nullopt;
}

std::optional<NodeStatus> ReplayAvoiding::look_crossing(const Odometry& odom, double timestamp_s,
                                                        std::optional<CrossingDecision>& crossing) {
  if (!crossing_) return std::nullopt;
  // Cautious (an unknown return holds the robot) at the edge of a person's way, and at any stop
  // with such a way remembered close ahead (session 12, seed 3: a stop on an IPT contact 0.9 m
  // before the way crossed on an unknown return and was hit by the person coming back).
  const bool cautious = at_kerb_ || crossing_->way_ahead(odom.pose, timestamp_s, 2.5);
  // The clear time counts from the tracked person's range (an upper bound when its feet are
  // below the image), not from the remembered way: a way remembered from a sighting while
  // driving was 1 m short on the campus (seeds 1, 2, 4) and the crossing ended in front of it.
  auto d = crossing_->observe(watch_grey_, timestamp_s, cautious);
  if (!d) return look_failed(d.error().message);
  crossing = *d;
  // Logged when the decision or the kind of its reason changes (the text before the figures).
  const std::string head = d->reason.substr(0, d->reason.find_first_of("(0123456789"));
  if (d->kind != crossing_kind_ || head != crossing_head_)
    host_.logger().info(path(), std::string("crossing policy: ") + to_string(d->kind) + ", " + d->reason);
  crossing_kind_ = d->kind;
  crossing_head_ = head;
  return std::nullopt;
}

NodeStatus ReplayAvoiding::look_step(const Odometry& odom) {
  stop(host_);
  FrameBus* bus = host_.frame_bus();
  auto frame = bus != nullptr ? bus->latest_frame() : std::nullopt;
  if (!frame || frame->image.empty() || (have_watch_sequence_ && frame->sequence == watch_sequence_)) return NodeStatus::running;
  have_watch_sequence_ = true;
  watch_sequence_ = frame->sequence;
  if (frame->image.channels() == 3) cv::cvtColor(frame->image, watch_grey_, cv::COLOR_BGR2GRAY);
  else watch_grey_ = frame->image;
  if (auto st = make_look_watch()) return *st;
  if (auto st = read_crossing(watch_grey_); !st) return look_failed(st.error().message);
  // Compare only frames of a standing camera: wait until the odometry says stopped.
  if (std::abs(odom.twist.linear_mps) > 0.01 || std::abs(odom.twist.angular_radps) > 0.01 || settle_frames_++ < 2) {
    watch_->reset();
    if (crossing_) crossing_->restart_difference();
    return NodeStatus::running;
  }
  // The crossing policy (crossing speed_mps > 0): where the person is and goes, over a wide band.
  std::optional<CrossingDecision> crossing;
  if (auto st = look_crossing(odom, frame->timestamp_s, crossing)) return *st;
  auto changed = watch_->observe(watch_grey_);
  if (!changed) return look_failed(changed.error().message);
  if (!*changed) return NodeStatus::running;
  const bool moving = watch_->moving() || (crossing && crossing->kind == CrossingDecision::Kind::wait);
  if (!saw_motion_) {
    if (moving) {
      saw_motion_ = true;
      host_.logger().info(path(), "a moving obstacle in the corridor (" + std::to_string(**changed) +
                                      " changed pixels): wait until it is clear");
    } else if (++look_frames_ >= p_.look.look_frames) {
      return look_still(odom, frame->timestamp_s);
    }
    return NodeStatus::running;
  }
  return look_wait(odom, frame->timestamp_s, moving, crossing, p_.look.clear_frames, p_.look.max_wait_frames);
}

NodeStatus ReplayAvoiding::look_still(const Odometry& odom, double timestamp_s) {
  // Before a person's way: watch for it to pass (the crossing's wait_s) before going on.
  if (at_kerb_ && crossing_ && timestamp_s - kerb_since_s_ < crossing_->kerb_wait_s()) return NodeStatus::running;
  if (at_kerb_ && crossing_) crossing_->clear_lanes();
  enter(Phase::replaying);
  auto blocked = corridor_.blocked(p_.corridor, odom);
  if (!blocked) return look_failed(blocked.error().message);
  // A contact where a person was seen crossing: likely that person, out of view now; wait
  // at its way (crossing policy) rather than detour into it.
  if (*blocked && crossing_ && !at_kerb_ && crossing_->way_ahead(odom.pose, timestamp_s, 2.5)) {
    enter(Phase::looking);
    at_kerb_ = true;
    kerb_since_s_ = timestamp_s;
    host_.logger().info(path(), "the contact ahead lies on a person's way seen crossing: wait there for it to pass");
    return NodeStatus::running;
  }
  if (*blocked) return begin_detour(odom);  // it stands: drive around it
  // Nothing moves and the IPT has no contact in the corridor: what stopped the robot was
  // parallax of something standing near (or a false alarm); back off and look (backoff_m),
  // or go on and let the IPT judge.
  drive_quiet_until_m_ = odom.distance_m + 0.5;
  if (!at_kerb_) {
    auto backing = begin_backoff(odom);
    if (!backing) return look_failed(backing.error().message);
    if (*backing) return NodeStatus::running;
  }
  resume_child(odom, "nothing moves ahead");
  return NodeStatus::running;
}

NodeStatus ReplayAvoiding::look_wait(const Odometry& odom, double timestamp_s, bool moving,
                                     const std::optional<CrossingDecision>& crossing, int clear, int max_wait) {
  if (++wait_frames_ > max_wait)
    return look_failed("stopped: a moving obstacle stayed in the corridor ahead for " + std::to_string(wait_frames_) +
                       " frames" + (crossing ? "; crossing policy: " + crossing->reason : std::string()));
  still_frames_ = moving ? 0 : still_frames_ + 1;
  if (crossing && crossing->kind == CrossingDecision::Kind::go) return crossing_go(odom, timestamp_s, *crossing);
  if (still_frames_ < clear) return NodeStatus::running;
  // At the edge of a person's way: only the policy, or crossing_wait_s without seeing it, ends the wait.
  if (at_kerb_ && crossing_ && crossing_->unseen_s(timestamp_s) < crossing_->kerb_wait_s()) return NodeStatus::running;
  enter(Phase::replaying);
  drive_quiet_until_m_ = odom.distance_m + 0.3;  // let the IPT look again before the frame difference
  resume_child(odom, "the corridor is clear after " + std::to_string(wait_frames_) + " frames of waiting");
  return NodeStatus::running;
}

NodeStatus ReplayAvoiding::crossing_go(const Odometry& odom, double timestamp_s, const CrossingDecision& crossing) {
  enter(Phase::replaying);
  if (crossing.range_m <= crossing_->kerb_m() + 0.3) {
    // It walked away just ahead: cross now (a crossing watch exists only with speed_mps > 0).
    crossing_->clear_lanes();
    begin_crossing(odom, crossing.way_ahead_m, "the crossing policy lets the robot go after " +
                                                   std::to_string(wait_frames_) + " frames (" + crossing.reason + ")");
    return NodeStatus::running;
  } else {
    // Too far from its way to cross before it could be back: drive up to the edge of the way
    // (as now seen) and watch it pass there.
    crossing_->clear_lanes();
    crossing_->remember_way(odom.pose, crossing.range_m, timestamp_s);
    at_kerb_ = false;  // resume_child() keeps the way
  }
  // The person it saw walks away beside the lane: no stop for it until past its line.
  drive_quiet_until_m_ = odom.distance_m + std::clamp(crossing.range_m + 0.5, 0.3, 3.0);
  resume_child(odom, "the crossing policy lets the robot go after " + std::to_string(wait_frames_) + " frames (" +
                         crossing.reason + ")");
  return NodeStatus::running;
}

void ReplayAvoiding::begin_crossing(const Odometry& odom, double way_ahead_m, const std::string& why) {
  HiddenPathProbeParams params;
  params.distance_m = crossing_->clear_distance_m(way_ahead_m);
  params.speed_mps = crossing_->crossing_speed_mps();
  crossing_drive_.emplace(params);
  moved_off_line_ = true;
  crossing_drive_->begin(odom.pose, odom.distance_m);
  enter(Phase::crossing);
  at_kerb_ = false;
  host_.logger().info(path(), why + ": crossing the person's way, " + std::to_string(params.distance_m) + " m at " +
                                  std::to_string(params.speed_mps) + " m/s on the heading");
}

NodeStatus ReplayAvoiding::cross_step(const Odometry& odom) {
  const HiddenPathProbe::Step s = crossing_drive_->step(odom.pose, odom.distance_m);
  if (!s.exhausted) {
    return send(host_, *this, s.command.linear_mps, s.command.angular_radps);
  }
  crossing_drive_.reset();
  enter(Phase::replaying);
  // The person it crossed walks away beside the lane: no stop for it right after.
  drive_quiet_until_m_ = odom.distance_m + 0.5;
  resume_child(odom, "across the person's way");  // the along-track count includes the crossing
  return NodeStatus::running;
}

NodeStatus ReplayAvoiding::begin_detour(const Odometry& odom) {
  moved_off_line_ = true;
  {
    if (lane_mode_) {
      const LaneParams& lp = p_.lane;
      LaneDetourParams params;
      params.behind_m = lp.behind_m;
      if (auto edge = get_input<std::string>("edge"); edge && !edge->empty() && host_.map() != nullptr)
        for (const auto& e : host_.map()->edges())
          if (e.id == *edge) params.end_s_m = std::max(0.0, scale_ * e.length_m - replay_done_m_);
      params.body_radius_m = body_radius_m_;
      params.clearance_m = lp.clearance_m;
      params.max_offset_m = lp.max_offset_m;
      params.commit_m = lp.commit_m;
      params.drift_rad_per_m = lp.drift_rad_per_m;
      params.max_recoveries = lp.max_recoveries;
      params.recover_clear_m = lp.recover_clear_m;
      params.max_reverse_m = lp.max_reverse_m;
      if (auto st = params.validate(); !st) {
        host_.logger().error(path(), st.error().with_context("ports 'lane', 'body_radius_m'").message);
        stop(host_);
        return NodeStatus::failure;
      }
      detour_.end();
      runner_.stop_correction();
      if (lp.ekf_heading) {
        if (auto started = runner_.start_correction(odom.pose); !started)
          host_.logger().warn(path(), "lane detour on the raw odometry: " + started.error().message);
      }
      lane_.emplace(params, odom.pose);
      lane_.value().add_points(corridor_.points());
      lane_kind_ = LaneDecision::Kind::blocked;
      lane_target_m_ = 1e9;
      lane_blocked_cycles_ = lane_stall_cycles_ = 0;
      lane_best_s_m_ = 0.0;
    } else if (auto st = detour_.begin(p_.drive, p_.thesis, odom.pose); !st) {
      host_.logger().error(path(), st.error().message);
      stop(host_);
      return NodeStatus::failure;
    }
    host_.logger().info(path(), "obstacle ahead at " + std::to_string(replay_done_m_) + " m of the edge: detour");
    enter(Phase::detouring);
    return NodeStatus::running;
  }
}

NodeStatus ReplayAvoiding::lane_step(const Odometry& raw_odom) {
  auto fresh = runner_.step(host_, p_.contacts);
  // With ekf_heading the detour steers by the ground-feature EKF's heading (the raw pose otherwise).
  Odometry odom = raw_odom;
  odom.pose = runner_.correct(raw_odom.pose);
  if (!fresh) {
    host_.logger().error(path(), fresh.error().message);
    stop(host_);
    return NodeStatus::failure;
  }
  if (*fresh && !lane_->reversing()) {
    log_points(host_, *this, odom.pose, **fresh);
    // With the filter on, only confirmed contacts steer the detour too.
    lane_->add_points(corridor_.add_and_confirm(**fresh, odom));
  }
  if (lane_->reversing()) {
    // Reversing on the line's heading (a recovery): the longer-baseline triangulation looks, as
    // while backing off; the other side is chosen with what it adds.
    auto points = triangulate_near(odom);
    if (!points) {
      host_.logger().error(path(), points.error().message);
      stop(host_);
      return NodeStatus::failure;
    }
    if (!points->empty()) {
      log_points(host_, *this, odom.pose, *points);
      lane_->add_points(*points);
    }
  }

  const bool was_reversing = lane_->reversing();
  const LaneDecision d = lane_->decide(odom.pose);
  (void)set_output("situation", std::string(d.kind == LaneDecision::Kind::blocked   ? "blocked"
                                            : d.kind == LaneDecision::Kind::done    ? "done"
                                            : d.kind == LaneDecision::Kind::reverse ? "reverse"
                                                                                    : "lane"));
  if (d.kind != lane_kind_ || (d.kind == LaneDecision::Kind::drive && d.lane_m != lane_target_m_)) {
    host_.logger().info(path(), "lane detour at s=" + std::to_string(d.s_m) + " m, l=" + std::to_string(d.l_m) +
                                    " m: " + d.reason);
    lane_kind_ = d.kind;
    lane_target_m_ = d.lane_m;
  }
  if (d.kind == LaneDecision::Kind::done) {
    if (runner_.heading_correction_rad() != 0.0)
      host_.logger().info(path(), "lane detour done; the ground-feature EKF turned the odometry's heading by " +
                                      std::to_string(runner_.heading_correction_rad() * 180.0 / CV_PI) + " deg");
    stop(host_);
    return NodeStatus::success;
  }
  const DriveParams& lim = p_.drive;
  if (d.kind == LaneDecision::Kind::blocked) {
    // Wait (a person may walk away); new pairs need motion, so the map only changes by waiting.
    stop(host_);
    if (++lane_blocked_cycles_ >= lim.max_blocked_cycles) {
      host_.logger().error(path(), "stopped: " + d.reason + " for " + std::to_string(lane_blocked_cycles_) + " cycles");
      return NodeStatus::failure;
    }
    return NodeStatus::running;
  }
  lane_blocked_cycles_ = 0;
  if (d.kind == LaneDecision::Kind::reverse) {
    if (!was_reversing && near_) near_->reset();  // a new reference for the triangulation
    return send(host_, *this, -p_.lane.reverse_speed_mps,
                std::clamp(lim.turn_gain_per_s * d.heading_rad, -lim.max_angular_radps, lim.max_angular_radps));
  }
  if (was_reversing) lane_best_s_m_ = d.s_m;  // progress counts again from where the reversing ended
  if (d.s_m > lane_best_s_m_ + 0.1) {
    lane_best_s_m_ = d.s_m;
    lane_stall_cycles_ = 0;
  } else if (++lane_stall_cycles_ >= lim.max_stall_cycles) {
    host_.logger().error(path(), "stopped: no progress along the line for " + std::to_string(lane_stall_cycles_) +
                                     " cycles (last: " + d.reason + ")");
    stop(host_);
    return NodeStatus::failure;
  }
  const double w = std::clamp(lim.turn_gain_per_s * d.heading_rad, -lim.max_angular_radps, lim.max_angular_radps);
  // hold_forward: a known point in the body's way straight ahead: turn in place (lane_detour.hpp).
  const double v = d.hold_forward || std::fabs(d.heading_rad) > 1.0 ? 0.0
                                                                     : lim.speed_mps * std::max(0.0, std::cos(d.heading_rad));
  return send(host_, *this, v, w);
}

void ReplayAvoiding::halt() {
  if (phase_ != Phase::replaying) stop(host_);
  crossing_drive_.reset();
  enter(Phase::replaying);
  detour_.end();
  lane_.reset();
  runner_.stop_correction();
  child_started_ = false;
  resumed_ = false;
  child_ran_ = false;
  carried_shift_m_ = 0.0;
  moved_off_line_ = false;
  corridor_.clear();
  halt_child();
}

Result<bool> ReplayAvoiding::begin_backoff(const Odometry& odom) {
  const double distance = p_.backoff.distance_m;
  // Not at an edge's first metre (the frame difference fires after the turn at a node), and once
  // per place: after a fruitless back-off, none until 2 distance_m past where it stopped (a
  // shimmering floor stops the robot every 0.6 m; measured on the campus, e12 and e14).
  if (distance <= 0.0 || replay_done_m_ < 1.0 || odom.distance_m < backoff_again_at_m_) return false;
  // Only after a stop on something close standing ahead: ground shimmer stops the robot too
  // (campus gravel and tiles, 2-12 times a run), and each fruitless back-off costs accuracy.
  if (p_.backoff.compact && stop_by_drive_watch_ && !stop_shape_.compact) {
    host_.logger().info(path(), "nothing moves ahead and no contact; the stop's changed pixels were specks (ground shimmer): no back-off");
    return false;
  }
  BackOffLookParams params;
  params.distance_m = distance;
  params.speed_mps = p_.backoff.speed_mps;
  params.min_points = p_.backoff.min_points;
  params.corridor_half_width_m = p_.corridor.corridor_half_width_m;
  if (auto st = params.validate(); !st) return st.error().with_context("port 'backoff'");
  backoff_.emplace(params);
  backoff_->begin(odom.pose, odom.distance_m);
  backoff_trail_.clear();
  if (near_) near_->reset();
  enter(Phase::backing_off);
  moved_off_line_ = true;
  host_.logger().info(path(), "nothing moves ahead and no contact: backing off " + std::to_string(distance) +
                                  " m while triangulating what stands ahead");
  return true;
}

NodeStatus ReplayAvoiding::backoff_step(const Odometry& odom) {
  auto points = triangulate_near(odom);
  if (!points) {
    host_.logger().error(path(), points.error().message);
    enter(Phase::replaying);
    stop(host_);
    return NodeStatus::failure;
  }
  backoff_->add_points(*points);
  if (!points->empty()) log_points(host_, *this, odom.pose, *points);
  if (!near_grey_.empty()) backoff_trail_.add(near_grey_, odom.pose, -odom.distance_m);
  const BackOffLook::Step s = backoff_->step(odom.pose, odom.distance_m);
  if (!s.done) {
    return send(host_, *this, s.command.linear_mps, s.command.angular_radps);
  }
  stop(host_);
  enter(Phase::replaying);
  const BackOffVerdict v = backoff_->verdict(odom.pose);
  if (!v.found) {
    backoff_again_at_m_ = odom.distance_m + 3.0 * backoff_->params().distance_m;  // 2 backoff_m past the stop
    resume_child(odom, "backed off: " + std::to_string(v.in_corridor) + " corners in the corridor ahead, nothing stands there");
    return NodeStatus::running;
  }
  // The detour's line starts here: the edge distance reached is the stop's minus the way back.
  const double back_m = (odom.pose.x_m - detour_start_.x_m) * std::cos(detour_start_.heading_rad) +
                        (odom.pose.y_m - detour_start_.y_m) * std::sin(detour_start_.heading_rad);
  replay_done_m_ += back_m;
  detour_start_ = odom.pose;
  host_.logger().info(path(), "backed off: " + std::to_string(v.in_corridor) + " corners in the corridor, " +
                                  std::to_string(v.range_m) + " m ahead, points from " + std::to_string(v.right_m) +
                                  " to " + std::to_string(v.left_m) + " m left of the heading: detour");
  const NodeStatus st = begin_detour(odom);
  if (lane_) {
    lane_->add_points(backoff_->points());
    add_backoff_extent(odom, v);
  }
  backoff_trail_.clear();
  return st;
}

void ReplayAvoiding::add_backoff_extent(const Odometry& odom, const BackOffVerdict& v) {
  const double baseline = p_.standing.extent_m;
  if (baseline <= 0.0 || near_grey_.empty()) return;
  // The back-off's triangulated corners cover the part of the face with texture; the plane sweep
  // reads the face's edges from the image (campus seed 3, session 17). The frame the standing watch's extent_m
  // nearer the face is the "earlier" one.
  const FrameTrail::Kept* nearer = backoff_trail_.back(-odom.distance_m, baseline);
  if (nearer == nullptr) return;
  auto camera = ipt_camera(host_, near_grey_);
  if (!camera) {
    host_.logger().warn(path(), "back-off: no extent from the image: " + camera.error().message);
    return;
  }
  auto e = face_extent(*camera, nearer->grey, nearer->pose, near_grey_, odom.pose, v.range_m, v.right_m, v.left_m,
                       FaceExtentParams{});
  if (!e) {
    host_.logger().warn(path(), "back-off: no extent from the image: " + e.error().message);
    return;
  }
  host_.logger().info(path(), "back-off: the face's extent from the image: " + describe_extent(*e));
  steer_by_extent(*lane_, v.right_m, v.left_m, *e);
}

Status register_ipt_nodes(bt::NodeRegistry& registry, HostServices& host) {
  VISNAV_TRY(registry.register_node<ObstacleAhead>(
      "ObstacleAhead", "True while the IPT finds an obstacle's ground contact in the corridor ahead",
      [&host](const std::string& name, const bt::NodeConfig& config) {
        return std::make_unique<ObstacleAhead>(name, config, host);
      }));
  VISNAV_TRY(registry.register_node<AvoidObstacles>(
      "AvoidObstacles", "Goal-directed obstacle avoidance (IPT polar map, thesis Ch. 6) to a point ahead on the heading line",
      [&host](const std::string& name, const bt::NodeConfig& config) {
        return std::make_unique<AvoidObstacles>(name, config, host);
      }));
  VISNAV_TRY(registry.register_node<ReplayAvoiding>(
      "ReplayAvoiding", "Runs an edge's replay child; detours around obstacles in the corridor ahead and resumes it",
      [&host](const std::string& name, const bt::NodeConfig& config) {
        return std::make_unique<ReplayAvoiding>(name, config, host);
      }));
  // FollowRoute picks its child for an edge kind by node ID, and a decorator has one child: the
  // path-following edges get the node under a second ID with their own defaults.
  VISNAV_TRY(registry.register_node<ReplayPathAvoiding>(
      "ReplayPathAvoiding",
      "ReplayAvoiding under a second node ID with the path-following edges' defaults (probe, back-off and standing "
      "watch on), for a second replay child under FollowRoute (FollowPathEdge)",
      [&host](const std::string& name, const bt::NodeConfig& config) {
        return std::make_unique<ReplayPathAvoiding>(name, config, host);
      }));
  return ok();
}

}  // namespace visnav::ipt
