#include "nodes.hpp"

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

Result<IptCamera> read_camera(const bt::TreeNode& node, const cv::Mat& image) {
  IptCamera c;
  VISNAV_ASSIGN(const double hfov_deg, node.get_input<double>("hfov_deg"));
  VISNAV_ASSIGN(c.height_m, node.get_input<double>("camera_height_m"));
  VISNAV_ASSIGN(const double pitch_down_deg, node.get_input<double>("camera_pitch_down_deg"));
  VISNAV_ASSIGN(c.forward_m, node.get_input<double>("camera_forward_m"));
  VISNAV_ASSIGN(c.lateral_m, node.get_input<double>("camera_lateral_m"));
  if (!(hfov_deg > 1.0 && hfov_deg < 179.0))
    return Error{"hfov_deg must lie in (1, 179) (got " + std::to_string(hfov_deg) + ")", ErrorCode::out_of_range};
  c.width_px = image.cols;
  c.height_px = image.rows;
  c.fx_px = c.fy_px = 0.5 * image.cols / std::tan(0.5 * hfov_deg * CV_PI / 180.0);
  c.cx_px = 0.5 * (image.cols - 1);
  c.cy_px = 0.5 * (image.rows - 1);
  c.pitch_rad = -pitch_down_deg * CV_PI / 180.0;
  VISNAV_TRY(c.validate());
  return c;
}

bt::PortsList camera_ports(const char* foot_radius_default_px) {
  return {bt::input_port<double>("hfov_deg", "60", "camera horizontal field of view (pinhole, centred principal point)"),
          bt::input_port<double>("camera_height_m", "0.5", "lens height above the ground"),
          bt::input_port<double>("camera_pitch_down_deg", "5", "downward tilt of the optical axis"),
          bt::input_port<double>("camera_forward_m", "0", "lens ahead of the robot origin"),
          bt::input_port<double>("camera_lateral_m", "0", "lens left of the robot origin"),
          bt::input_port<double>("span_max_m", "2.2",
                                 "neighbouring contact points this close bound one obstacle when its face shows "
                                 "between them; the span is filled (0 = contact points only)"),
          bt::input_port<double>("contact_ground_reach_px", "2",
                                 "a GROUND feature this close ends an obstacle border's trace (spec 4.2)"),
          bt::input_port<double>("foot_radius_px", foot_radius_default_px,
                                 "a contact's range is cut to the triangulated foot of the OBSTACLE features this many "
                                 "columns from it (0 = the back-projection alone; measured: the Ch. 6 strategy "
                                 "stalls before the course's crates with it, the lane detour needs it)")};
}

std::optional<Pose2D> PipelineRunner::pose(HostServices& host) const {
  FrameBus* bus = host.frame_bus();
  if (bus == nullptr) return std::nullopt;
  auto odom = bus->latest_odometry();
  if (!odom) return std::nullopt;
  return odom->pose;
}

Result<std::optional<std::vector<cv::Point2d>>> PipelineRunner::step(const bt::TreeNode& node, HostServices& host) {
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
    VISNAV_ASSIGN(IptCamera camera, read_camera(node, grey_));
    ProfileParams profiles;
    VISNAV_ASSIGN(profiles.span_max_m, node.get_input<double>("span_max_m"));
    VISNAV_ASSIGN(profiles.ground_reach_px, node.get_input<double>("contact_ground_reach_px"));
    VISNAV_ASSIGN(profiles.foot_radius_px, node.get_input<double>("foot_radius_px"));
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

bt::PortsList corridor_ports(const char* lookahead_default_m, const char* confirm_baseline_default_m) {
  return {bt::input_port<double>("lookahead_m", lookahead_default_m, "contact points up to this far ahead count"),
          bt::input_port<double>("corridor_half_width_m", "0.45", "half width of the corridor ahead"),
          bt::input_port<double>("memory_m", "1.0", "contact points are kept for this much travel"),
          bt::with_range(bt::input_port<double>("confirm_baseline_m", confirm_baseline_default_m,
                                 "a contact counts only when seen again at the same ground point (within half the "
                                 "travel, at most confirm_radius_m) from a robot position this far away: rejects "
                                 "contacts that move with the robot (sliding tracks on paver joints); 0 = every contact"), 0.0, 1e6),
          bt::input_port<double>("confirm_radius_m", "0.3", "largest distance between two sightings of one contact"),
          bt::input_port<int>("confirm_views", "3",
                              "... and a contact must have been found at that ground point by this many pairs "
                              "(distinct robot positions; rejects occasional mis-tracks in periodic textures)"),
          bt::input_port<double>("confirm_view_share", "0",
                                 "... and by this share of the pairs made between the first and the last of them "
                                 "(0 = off; rejects the ends of noise traces on a tiled floor)")};
}

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

Result<bool> CorridorMemory::blocked(const bt::TreeNode& node, const Odometry& odom) {
  VISNAV_ASSIGN(const double lookahead, node.get_input<double>("lookahead_m"));
  VISNAV_ASSIGN(const double half_width, node.get_input<double>("corridor_half_width_m"));
  VISNAV_ASSIGN(const double memory, node.get_input<double>("memory_m"));
  memory_m_ = memory;
  if (!configured_) {
    VISNAV_ASSIGN(const double baseline, node.get_input<double>("confirm_baseline_m"));
    VISNAV_ASSIGN(const double radius, node.get_input<double>("confirm_radius_m"));
    VISNAV_ASSIGN(const int views, node.get_input<int>("confirm_views"));
    VISNAV_ASSIGN(const double share, node.get_input<double>("confirm_view_share"));
    filter_on_ = baseline > 0.0;
    if (filter_on_) {
      ContactPersistenceParams params;
      params.min_baseline_m = baseline;
      params.max_radius_m = radius;
      params.min_views = views;
      params.min_view_share = share;
      if (auto st = params.validate(); !st)
        return st.error().with_context("ports 'confirm_baseline_m'/'confirm_radius_m'/'confirm_views'/'confirm_view_share'");
      sightings_.set_params(params);  // the sightings added before the first test stay
    } else if (baseline < 0.0) {
      return Error{"port 'confirm_baseline_m': must be >= 0 (got " + std::to_string(baseline) + ")", ErrorCode::out_of_range};
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
  bt::PortsList ports = camera_ports("0");
  for (auto& p : corridor_ports("1.5", "0")) ports.push_back(std::move(p));
  return ports;
}

NodeStatus ObstacleAhead::tick() {
  auto fresh = runner_.step(*this, host_);
  if (!fresh) {
    host_.logger().warn(path(), fresh.error().message);
    return NodeStatus::failure;
  }
  FrameBus* bus = host_.frame_bus();
  auto odom = bus != nullptr ? bus->latest_odometry() : std::nullopt;
  if (!odom) return NodeStatus::failure;
  if (*fresh) corridor_.add(**fresh, *odom);
  auto blocked = corridor_.blocked(*this, *odom);
  if (!blocked) {
    host_.logger().warn(path(), blocked.error().message);
    return NodeStatus::failure;
  }
  return *blocked ? NodeStatus::success : NodeStatus::failure;
}

// ------------------------------------------------------------------------------- DetourDriver

bt::PortsList avoid_ports() {
  return {
      bt::input_port<double>("goal_ahead_m", "4.0", "goal on the current heading line, this far ahead"),
      bt::input_port<double>("speed_mps", "0.2", "forward speed"),
      bt::input_port<double>("turn_gain_per_s", "1.5", "omega = gain * theta_mot"),
      bt::input_port<double>("max_angular_radps", "0.6", "turn-rate limit"),
      bt::input_port<int>("max_blocked_cycles", "60", "cycles without any gap before giving up"),
      bt::input_port<int>("max_stall_cycles", "300",
                          "cycles without getting 0.1 m closer to the goal before giving up (a trap, a potential-field "
                          "minimum)"),
      bt::input_port<double>("security_distance_m", "0.95", "S_dist (thesis 0.95 m)"),
      bt::input_port<double>("gap_width_m", "0.95", "narrowest permitted gap (thesis experiments 0.95 m)"),
      bt::input_port<double>("reset_keep_near_m", "1.9",
                             "points this close survive the filter resets (0 = the thesis; measured: the thesis reset "
                             "forgets a crate beside the robot and drives into it)"),
      bt::output_port<std::string>("situation", "{avoid_situation}", "the last decision's situation")};
}

Status DetourDriver::begin(const bt::TreeNode& node, const Pose2D& pose, double goal_ahead_m) {
  PolarMapParams params;
  VISNAV_ASSIGN(params.security_distance_m, node.get_input<double>("security_distance_m"));
  VISNAV_ASSIGN(params.gap_width_m, node.get_input<double>("gap_width_m"));
  VISNAV_ASSIGN(params.reset_keep_near_m, node.get_input<double>("reset_keep_near_m"));
  VISNAV_ASSIGN(speed_mps_, node.get_input<double>("speed_mps"));
  VISNAV_ASSIGN(gain_per_s_, node.get_input<double>("turn_gain_per_s"));
  VISNAV_ASSIGN(max_angular_radps_, node.get_input<double>("max_angular_radps"));
  VISNAV_ASSIGN(max_blocked_, node.get_input<int>("max_blocked_cycles"));
  VISNAV_ASSIGN(max_stall_, node.get_input<int>("max_stall_cycles"));
  VISNAV_TRY(params.validate());
  filter_.emplace(params);
  goal_m_ = {pose.x_m + goal_ahead_m * std::cos(pose.heading_rad), pose.y_m + goal_ahead_m * std::sin(pose.heading_rad)};
  blocked_cycles_ = 0;
  stall_cycles_ = 0;
  best_distance_m_ = goal_ahead_m;
  last_situation_ = Situation::blocked;
  return ok();
}

NodeStatus DetourDriver::step(const bt::TreeNode& node, HostServices& host, PipelineRunner& runner) {
  if (!filter_) return NodeStatus::failure;
  auto fresh = runner.step(node, host);
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
    if (++blocked_cycles_ >= max_blocked_) {
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
  } else if (++stall_cycles_ >= max_stall_) {
    host.logger().error(node.path(), "stopped: no progress towards the goal for " + std::to_string(stall_cycles_) +
                                         " cycles (" + std::to_string(to_goal_m) + " m left; last: " + d.reason + ")");
    stop(host);
    return NodeStatus::failure;
  }
  const double w = std::clamp(gain_per_s_ * d.heading_rad, -max_angular_radps_, max_angular_radps_);
  const double v = d.translate ? speed_mps_ * std::max(0.0, std::cos(d.heading_rad)) : 0.0;
  return send(host, node, v, d.translate ? w : std::copysign(max_angular_radps_, d.heading_rad));
}

// ----------------------------------------------------------------------------- AvoidObstacles

AvoidObstacles::AvoidObstacles(const std::string& name, const bt::NodeConfig& config, HostServices& host)
    : bt::StatefulActionNode(name, config), host_(host) {}

bt::PortsList AvoidObstacles::provided_ports() {
  bt::PortsList ports = camera_ports("0");
  for (auto& p : avoid_ports()) ports.push_back(std::move(p));
  return ports;
}

NodeStatus AvoidObstacles::on_start() {
  auto ahead = get_input<double>("goal_ahead_m");
  auto pose = runner_.pose(host_);
  if (!ahead || !pose) {
    host_.logger().error(path(), !ahead ? ahead.error().message : "no odometry: cannot place the goal");
    stop(host_);
    return NodeStatus::failure;
  }
  if (auto st = detour_.begin(*this, *pose, *ahead); !st) {
    host_.logger().error(path(), st.error().message);
    stop(host_);
    return NodeStatus::failure;
  }
  runner_.restart();
  return on_running();
}

NodeStatus AvoidObstacles::on_running() {
  const NodeStatus st = detour_.step(*this, host_, runner_);
  (void)set_output("situation", std::string(to_string(detour_.last_situation())));
  if (st != NodeStatus::running) detour_.end();
  return st;
}

void AvoidObstacles::on_halted() {
  stop(host_);
  detour_.end();
}

// ----------------------------------------------------------------------------- ReplayAvoiding

ReplayAvoiding::ReplayAvoiding(const std::string& name, const bt::NodeConfig& config, HostServices& host)
    : bt::DecoratorNode(name, config), host_(host) {}

bt::PortsList ReplayAvoiding::provided_ports() {
  bt::PortsList ports = camera_ports("10");
  for (auto& p : avoid_ports()) ports.push_back(std::move(p));
  for (auto& p : corridor_ports("1.5", "0")) ports.push_back(std::move(p));
  ports.push_back(bt::input_port<std::string>("detour", "lane",
                                              "lane: a free lateral offset from the taught line, back onto it past the "
                                              "obstacle (measured: docs/obstacles.md); thesis: the Ch. 6 strategy to a "
                                              "goal goal_ahead_m along the line"));
  ports.push_back(bt::input_port<double>("body_radius_m", "0.25", "lane detour and crossing policy: robot disc radius"));
  ports.push_back(bt::input_port<double>("clearance_m", "0.35", "lane detour: free space kept beyond the body"));
  ports.push_back(bt::input_port<double>("max_offset_m", "2.5", "lane detour: widest lane searched on either side"));
  ports.push_back(bt::input_port<std::string>("edge", "{edge}",
                                              "the edge being replayed (its length ends a lane detour); empty = unknown"));
  ports.push_back(bt::input_port<double>("behind_m", "6.5",
                                         "lane detour: an obstacle point holds the robot in its lane until it is this far "
                                         "behind (the obstacle's unseen length)"));
  ports.push_back(bt::inout_port<double>("carried_m", "{edge_carried_m}",
                                         "edge distance already covered when the child starts, taught m (FollowRoute "
                                         "writes it; rewritten after a detour)"));
  ports.push_back(bt::with_range(bt::input_port<double>("distance_scale", "{edge_distance_scale}",
                                         "odometric metres per taught metre (FollowRoute's estimate, as the replay "
                                         "child's port): the rewritten carried_m is in taught metres; unset counts as 1"), 0.5, 2.0));
  ports.push_back(bt::input_port<double>(
      "child_shift_m", "{edge_shift_m}",
      "the child's visual along-track correction so far (the replay nodes' output 'shift_m', taught m): every restart "
      "of the child after a stop, look, back-off or detour carries it in carried_m, so the correction of a path or "
      "feature edge survives the interruptions; unset counts as 0"));
  ports.push_back(bt::output_port<double>(
      "extra_travel_m", "{edge_extra_travel_m}",
      "when the child ends an edge on which the node detoured, reversed, probed or crossed: the odometric metres "
      "driven that were not progress along the edge (a detour's sideways legs), so FollowRoute leaves them out of "
      "the next edge's carried distance and of its distance-scale fixes; not written otherwise"));
  ports.push_back(bt::inout_port<double>(
      "end_shift_m", "{edge_end_shift_m}",
      "when the child ends the edge: its own end shift (the replay nodes' output) plus the corrections carried "
      "over its restarts, rewritten so that FollowRoute sees the whole edge's correction"));
  ports.push_back(bt::inout_port<double>("confident_at_m", "{nav_confident_at_m}",
                                         "the replay's last confident odometer reading (lost detection); set to the "
                                         "odometer when a detour ends: the detour was driven on the IPT, not blind"));
  ports.push_back(bt::inout_port<double>("image_changed_at_m", "{nav_image_changed_at_m}",
                                         "the replay's frozen-image count, restarted likewise after a detour"));
  ports.push_back(bt::with_range(bt::input_port<int>("look_frames", "8",
                                      "moving obstacles: frames the stopped robot watches the corridor before a detour "
                                      "(motion: wait instead); 0 = detour at once"), 0, 1000000));
  ports.push_back(bt::input_port<int>("clear_frames", "15", "moving obstacles: still frames before the replay resumes"));
  ports.push_back(bt::input_port<int>("max_wait_frames", "600",
                                      "moving obstacles: frames of waiting for the corridor to clear before failing"));
  ports.push_back(bt::input_port<double>("motion_threshold", "18",
                                         "moving obstacles: grey-level change of a pixel that counts (frame difference)"));
  ports.push_back(bt::input_port<int>("motion_min_px", "80", "moving obstacles: changed corridor pixels that count as motion"));
  for (auto& p : crossing_ports()) ports.push_back(std::move(p));
  for (auto& p : standing_ports()) ports.push_back(std::move(p));
  ports.push_back(bt::input_port<double>("moving_stop_m", "2.0",
                                         "moving obstacles: while replaying, what moves (or stands) in the corridor this "
                                         "close (ground-compensated frame difference, ±1.2 m wide) stops the robot to "
                                         "look; 0 = off"));
  ports.push_back(bt::input_port<std::string>(
      "probe_on", "",
      "when the child fails with a reason containing this text (e.g. 'path lost on edge', FollowPathEdge's path "
      "hidden), drive on slowly on the heading for at most probe_m while the IPT and the frame difference look; "
      "something found: stop, look and detour as usual; nothing: fail with the child's reason; empty = off"));
  ports.push_back(bt::input_port<std::string>("failure", "{edge_failure}",
                                              "the child's reason of failure (the replay nodes' output 'failure')"));
  ports.push_back(bt::input_port<double>("probe_m", "1.5", "probe: odometry budget per place, m"));
  ports.push_back(bt::input_port<double>("probe_speed_mps", "0.15", "probe: forward speed"));
  ports.push_back(bt::input_port<int>(
      "probe_min_points", "4",
      "probe: corners triangulated 0.15-2.5 m above the ground within lookahead_m + 1 m ahead in the corridor over a "
      "0.3 m baseline that stop the probe and start the detour (near_triangulation.hpp)"));
  ports.push_back(bt::input_port<double>(
      "backoff_m", "0",
      "a stop-and-look that sees nothing move and no contact: reverse this far on the heading while the "
      "longer-baseline triangulation looks; probe_min_points corners in the corridor ahead: lane detour with all of "
      "them (the face's full width), else resume (back_off_look.hpp); 0 = off (resume at once)"));
  ports.push_back(bt::input_port<double>("backoff_speed_mps", "0.15", "back-off: reverse speed"));
  ports.push_back(bt::input_port<double>(
      "drift_rad_per_m", "0.012",
      "lane detour: odometry heading drift assumed while passing points out of view; a point's clearance grows by "
      "0.5*drift*d^2 (d: travel along the line since it was seen, at most 0.4 m more); 0 = off"));
  ports.push_back(bt::input_port<bool>(
      "ekf_heading", "false",
      "lane detour: steer by the heading of the thesis's robocentric EKF whose landmarks are the IPT pairs' GROUND "
      "features (ground_odometry.hpp; corrects the odometry's heading drift in the blind pass past an obstacle); "
      "false = the raw odometry. Not for an odometry whose heading noise per 5 cm reaches about 0.03 rad: the "
      "pipeline drops the pairs it turned and the filter then loses to dead reckoning (docs/obstacles.md)"));
  ports.push_back(bt::input_port<bool>(
      "backoff_compact", "true",
      "back-off only after a stop whose changed pixels (moving_stop_m's frame difference) came in solid pieces "
      "(a face close ahead, its texture magnified), not in the specks of ground shimmer (motion_watch.hpp, change_shape()); false = after every "
      "fruitless look"));
  ports.push_back(bt::input_port<double>("commit_m", "2.0",
                                         "lane detour: the chosen side is kept within this of an obstacle point (its "
                                         "closing blocks the detour instead of a swing across the obstacle); 0 = off"));
  ports.push_back(bt::input_port<int>(
      "max_recoveries", "1",
      "lane detour: the chosen side closes within commit_m of the obstacle and the other side is free: reverse along "
      "the line (backoff_speed_mps) until no obstacle point is within recover_clear_m ahead, then take the other side; "
      "this often per detour; 0 = stop with the reason (lane_detour.hpp)"));
  ports.push_back(bt::input_port<double>("recover_clear_m", "3.0",
                                         "lane detour recovery: reverse until no obstacle point is this close ahead"));
  ports.push_back(bt::input_port<double>("max_reverse_m", "10.0",
                                         "lane detour recovery: most reversing along the line; then stop with the reason"));
  return ports;
}

// ReplayAvoiding::tick(): a state machine held in flags, tested in this order every tick (one
// phase runs per tick):
//  * detouring_ (detour_step(); lane_ set: the lane detour, lane_step(); else the thesis detour,
//    DetourDriver): RUNNING until it ends; its failure fails the node, its success resumes the
//    child ("detour done") -> replaying.
//  * looking_ (look_step()): stopped, watching the corridor with the frame difference (and the
//    crossing policy) once the odometry says still:
//      - nothing moved for look_frames frames (look_still()): at a person's way, first
//        crossing_wait_s; then a contact in the corridor -> detouring (begin_detour), or, on a
//        way seen crossing, looking again at that way (at_kerb_); no contact -> backing_
//        (begin_backoff) or replaying ("nothing moves ahead");
//      - motion seen (saw_motion_, look_wait()): waiting; the crossing policy's go ->
//        crossing_drive_ (begin_crossing) or replaying (crossing_go()); clear_frames still frames
//        (and at a way crossing_wait_s unseen) -> replaying; more than max_wait_frames -> FAILURE.
//  * crossing_drive_ (cross_step()): drives across a person's way on the heading -> replaying.
//  * backing_ (backoff_step()): reverses while triangulating; something stands -> detouring,
//    else -> replaying.
//  * replaying (none of the above): a run of the child starts when none has (replay_start(): a new
//    edge unless resume_child() set carried_m). Then, in order, each able to stop the replay:
//      - the IPT's contact in the corridor ahead (corridor_stop()) -> looking_ (detouring when
//        look_frames = 0);
//      - the drive watch: something moves close ahead (drive_watch_stop()) -> looking_;
//      - the crossing watch: a person's way ahead (kerb_stop()) -> looking_ at the way (at_kerb_);
//      - not probing: the standing watch fires (standing_stop()) -> detouring (lane);
//      - probing_ (probe_step(); entered when the child failed with probe_on's reason): creeping on
//        on the heading; probe_min_points corners ahead -> detouring; the budget used -> FAILURE;
//      - else the child ticks (child_step()): RUNNING; SUCCESS -> the edge is done (edge_done(),
//        the node's SUCCESS); FAILURE -> probing_ (child_failed()) or the node's FAILURE.
// "-> replaying" is resume_child(): the child starts again at the along-track distance reached.
// An error of a port, the camera or the pipeline stops the robot and fails the node.
NodeStatus ReplayAvoiding::tick() {
  FrameBus* bus = host_.frame_bus();
  auto odom = bus != nullptr ? bus->latest_odometry() : std::nullopt;
  if (!odom) {
    host_.logger().error(path(), "no odometry");
    return NodeStatus::failure;
  }
  if (detouring_) return detour_step(*odom);
  if (looking_) return look_step(*odom);
  if (crossing_drive_) return cross_step(*odom);
  if (backing_) return backoff_step(*odom);
  if (!child_started_ && !probing_ && !replay_start(*odom)) return NodeStatus::failure;
  if (auto st = corridor_stop(*odom)) return *st;
  if (auto st = drive_watch_stop(*odom)) return *st;
  if (auto st = kerb_stop(*odom)) return *st;
  if (!probing_) {
    if (auto st = standing_stop(*odom)) return *st;
  }
  if (probing_) return probe_step(*odom);
  return child_step(*odom);
}

NodeStatus ReplayAvoiding::detour_step(const Odometry& odom) {
  NodeStatus st = NodeStatus::failure;
  if (lane_) {
    st = lane_step(odom);
  } else {
    st = detour_.step(*this, host_, runner_);
    (void)set_output("situation", std::string(to_string(detour_.last_situation())));
  }
  if (st == NodeStatus::running) return NodeStatus::running;
  detour_.end();
  lane_.reset();
  runner_.stop_correction();
  detouring_ = false;
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
  probing_ = false;
  replay_done_m_ = odom.distance_m - replay_origin_m_;
  detour_start_ = odom.pose;
}

std::optional<NodeStatus> ReplayAvoiding::corridor_stop(const Odometry& odom) {
  auto fresh = runner_.step(*this, host_);
  if (!fresh) return replay_failed(fresh.error().message);
  if (*fresh) {
    log_points(host_, *this, odom.pose, **fresh);
    corridor_.add(**fresh, odom);
  }
  auto blocked = corridor_.blocked(*this, odom);
  if (!blocked) return replay_failed(blocked.error().message);
  if (!*blocked) return std::nullopt;
  interrupt_replay(odom);
  auto look = get_input<int>("look_frames");
  if (!look || *look < 0) {
    host_.logger().error(path(), !look ? look.error().message : "port 'look_frames': must be >= 0");
    stop(host_);
    return NodeStatus::failure;
  }
  if (*look == 0) return begin_detour(odom);
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
    probing_ = false;
    stop(host_);
    return NodeStatus::failure;
  };
  auto near_points = triangulate_near(odom);
  if (!near_points) return probe_failed(near_points.error().message);
  auto min_points = get_input<int>("probe_min_points");
  auto lookahead = get_input<double>("lookahead_m");
  auto half_width = get_input<double>("corridor_half_width_m");
  if (!min_points || !lookahead || !half_width)
    return probe_failed("ports 'probe_min_points', 'lookahead_m', 'corridor_half_width_m' must be numbers");
  const Pose2D& r = odom.pose;
  const double c = std::cos(r.heading_rad), sn = std::sin(r.heading_rad);
  int ahead = 0;
  for (const auto& p : *near_points) {
    const double fwd = c * (p.x - r.x_m) + sn * (p.y - r.y_m), lat = -sn * (p.x - r.x_m) + c * (p.y - r.y_m);
    if (fwd > 0.0 && fwd <= *lookahead + 1.0 && std::fabs(lat) <= *half_width) ++ahead;
  }
  if (!near_points->empty()) {
    log_points(host_, *this, r, *near_points);
    near_points_.insert(near_points_.end(), near_points->begin(), near_points->end());
  }
  if (ahead >= *min_points) {
    probing_ = false;
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
    probing_ = false;
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
  auto trigger = get_input<std::string>("probe_on");
  auto failure = get_input<std::string>("failure");
  if (!trigger || !failure || !probe_triggered(*failure, *trigger)) {
    corridor_.clear();
    return NodeStatus::failure;
  }
  if (!probe_) {
    HiddenPathProbeParams params;
    auto distance = get_input<double>("probe_m");
    auto speed = get_input<double>("probe_speed_mps");
    Status st = !distance ? Status(distance.error()) : !speed ? Status(speed.error()) : ok();
    if (st) {
      params.distance_m = *distance;
      params.speed_mps = *speed;
      st = params.validate();
    }
    if (!st) {
      host_.logger().error(path(), "ports 'probe_m'/'probe_speed_mps': " + st.error().message);
      stop(host_);
      return NodeStatus::failure;
    }
    probe_.emplace(params);
  }
  probe_->begin(odom.pose, odom.distance_m);
  probing_ = true;
  moved_off_line_ = true;
  near_points_.clear();
  if (near_) near_->reset();
  probe_reason_ = *failure;
  host_.logger().info(path(), "the child gave up (" + *failure + "): probing on for " +
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
    VISNAV_ASSIGN(IptCamera camera, read_camera(*this, near_grey_));
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
  VISNAV_ASSIGN(IptCamera camera, read_camera(*this, grey));
  VISNAV_ASSIGN(crossing_, CrossingWatch::from_ports(*this, camera));
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
  looking_ = true;
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
  VISNAV_ASSIGN(const double stop_m, get_input<double>("moving_stop_m"));
  if (stop_m <= 0.0 || odom.distance_m < drive_quiet_until_m_) return false;
  FrameBus* bus = host_.frame_bus();
  auto frame = bus != nullptr ? bus->latest_frame() : std::nullopt;
  if (!frame || frame->image.empty() || (have_drive_sequence_ && frame->sequence == drive_sequence_)) return false;
  have_drive_sequence_ = true;
  drive_sequence_ = frame->sequence;
  if (frame->image.channels() == 3) cv::cvtColor(frame->image, watch_grey_, cv::COLOR_BGR2GRAY);
  else watch_grey_ = frame->image;
  if (!drive_watch_) {
    VISNAV_ASSIGN(IptCamera camera, read_camera(*this, watch_grey_));
    MotionWatchParams params;
    VISNAV_ASSIGN(params.diff_threshold, get_input<double>("motion_threshold"));
    VISNAV_ASSIGN(params.min_changed_px, get_input<int>("motion_min_px"));
    params.near_m = 0.8;  // below, a millimetre of odometry error is a pixel of ground
    params.far_m = std::max(stop_m, 1.3);
    params.half_width_m = 1.2;
    params.min_changed_px *= 4;  // driving: a person 2 m ahead changes thousands of pixels
    auto made = MotionWatch::create(camera, params);
    if (!made) return made.error().with_context("port 'moving_stop_m'");
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
  // back-off after a fruitless look asks for the former (backoff_compact).
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
  looking_ = false;
  stop(host_);
  return NodeStatus::failure;
}

std::optional<NodeStatus> ReplayAvoiding::make_look_watch() {
  if (watch_) return std::nullopt;
  auto camera = read_camera(*this, watch_grey_);
  if (!camera) return look_failed(camera.error().message);
  MotionWatchParams params;
  auto threshold = get_input<double>("motion_threshold");
  auto min_px = get_input<int>("motion_min_px");
  if (!threshold) return look_failed(threshold.error().message);
  if (!min_px) return look_failed(min_px.error().message);
  params.diff_threshold = *threshold;
  params.min_changed_px = *min_px;
  auto lookahead = get_input<double>("lookahead_m");
  if (lookahead) params.far_m = std::max(params.near_m + 0.5, *lookahead + 1.0);
  auto made = MotionWatch::create(*camera, params);
  if (!made) return look_failed("port 'motion_threshold'/'motion_min_px': " + made.error().message);
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
  // The crossing policy (crossing_s > 0): where the person is and goes, over a wide band.
  std::optional<CrossingDecision> crossing;
  if (auto st = look_crossing(odom, frame->timestamp_s, crossing)) return *st;
  auto changed = watch_->observe(watch_grey_);
  if (!changed) return look_failed(changed.error().message);
  if (!*changed) return NodeStatus::running;
  const bool moving = watch_->moving() || (crossing && crossing->kind == CrossingDecision::Kind::wait);
  auto look = get_input<int>("look_frames");
  auto clear = get_input<int>("clear_frames");
  auto max_wait = get_input<int>("max_wait_frames");
  if (!look || !clear || !max_wait) return look_failed("ports 'look_frames', 'clear_frames', 'max_wait_frames' must be integers");
  if (!saw_motion_) {
    if (moving) {
      saw_motion_ = true;
      host_.logger().info(path(), "a moving obstacle in the corridor (" + std::to_string(**changed) +
                                      " changed pixels): wait until it is clear");
    } else if (++look_frames_ >= *look) {
      return look_still(odom, frame->timestamp_s);
    }
    return NodeStatus::running;
  }
  return look_wait(odom, frame->timestamp_s, moving, crossing, *clear, *max_wait);
}

NodeStatus ReplayAvoiding::look_still(const Odometry& odom, double timestamp_s) {
  // Before a person's way: watch for it to pass (crossing_wait_s) before going on.
  if (at_kerb_ && crossing_ && timestamp_s - kerb_since_s_ < crossing_->kerb_wait_s()) return NodeStatus::running;
  if (at_kerb_ && crossing_) crossing_->clear_lanes();
  looking_ = false;
  auto blocked = corridor_.blocked(*this, odom);
  if (!blocked) return look_failed(blocked.error().message);
  // A contact where a person was seen crossing: likely that person, out of view now; wait
  // at its way (crossing policy) rather than detour into it.
  if (*blocked && crossing_ && !at_kerb_ && crossing_->way_ahead(odom.pose, timestamp_s, 2.5)) {
    looking_ = true;
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
  looking_ = false;
  drive_quiet_until_m_ = odom.distance_m + 0.3;  // let the IPT look again before the frame difference
  resume_child(odom, "the corridor is clear after " + std::to_string(wait_frames_) + " frames of waiting");
  return NodeStatus::running;
}

NodeStatus ReplayAvoiding::crossing_go(const Odometry& odom, double timestamp_s, const CrossingDecision& crossing) {
  looking_ = false;
  if (crossing.range_m <= crossing_->kerb_m() + 0.3) {
    crossing_->clear_lanes();  // it walked away just ahead: cross now
    if (crossing_->crossing_speed_mps() > 0.0) {
      begin_crossing(odom, crossing.way_ahead_m, "the crossing policy lets the robot go after " +
                                                     std::to_string(wait_frames_) + " frames (" + crossing.reason + ")");
      return NodeStatus::running;
    }
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
  // The person it crossed walks away beside the lane: no stop for it right after.
  drive_quiet_until_m_ = odom.distance_m + 0.5;
  resume_child(odom, "across the person's way");  // the along-track count includes the crossing
  return NodeStatus::running;
}

NodeStatus ReplayAvoiding::begin_detour(const Odometry& odom) {
  moved_off_line_ = true;
  {
    auto ahead = get_input<double>("goal_ahead_m");
    if (!ahead) return NodeStatus::failure;
    auto mode = get_input<std::string>("detour");
    if (!mode || (*mode != "lane" && *mode != "thesis")) {
      host_.logger().error(path(), !mode ? mode.error().message
                                         : "port 'detour': expected 'lane' or 'thesis' (got '" + *mode + "')");
      stop(host_);
      return NodeStatus::failure;
    }
    if (*mode == "lane") {
      LaneDetourParams params;
      auto body = get_input<double>("body_radius_m");
      auto clearance = get_input<double>("clearance_m");
      auto widest = get_input<double>("max_offset_m");
      if (auto behind = get_input<double>("behind_m")) params.behind_m = *behind;
      if (auto edge = get_input<std::string>("edge"); edge && !edge->empty() && host_.map() != nullptr)
        for (const auto& e : host_.map()->edges())
          if (e.id == *edge) params.end_s_m = std::max(0.0, scale_ * e.length_m - replay_done_m_);
      if (body) params.body_radius_m = *body;
      if (clearance) params.clearance_m = *clearance;
      if (widest) params.max_offset_m = *widest;
      if (auto commit = get_input<double>("commit_m")) params.commit_m = *commit;
      if (auto drift = get_input<double>("drift_rad_per_m")) params.drift_rad_per_m = *drift;
      if (auto n = get_input<int>("max_recoveries")) params.max_recoveries = *n;
      if (auto clear = get_input<double>("recover_clear_m")) params.recover_clear_m = *clear;
      if (auto most = get_input<double>("max_reverse_m")) params.max_reverse_m = *most;
      Status st = !body ? Status(body.error()) : !clearance ? Status(clearance.error()) : !widest ? Status(widest.error()) : params.validate();
      if (st) st = detour_.begin(*this, odom.pose, *ahead);  // reads the shared detour ports (speed, gains, limits)
      if (!st) {
        host_.logger().error(path(), st.error().message);
        stop(host_);
        return NodeStatus::failure;
      }
      detour_.end();
      runner_.stop_correction();
      if (auto ekf = get_input<bool>("ekf_heading"); ekf && *ekf) {
        if (auto started = runner_.start_correction(odom.pose); !started)
          host_.logger().warn(path(), "lane detour on the raw odometry: " + started.error().message);
      }
      lane_.emplace(params, odom.pose);
      lane_.value().add_points(corridor_.points());
      lane_kind_ = LaneDecision::Kind::blocked;
      lane_target_m_ = 1e9;
      lane_blocked_cycles_ = lane_stall_cycles_ = 0;
      lane_best_s_m_ = 0.0;
    } else if (auto st = detour_.begin(*this, odom.pose, *ahead); !st) {
      host_.logger().error(path(), st.error().message);
      stop(host_);
      return NodeStatus::failure;
    }
    host_.logger().info(path(), "obstacle ahead at " + std::to_string(replay_done_m_) + " m of the edge: detour");
    detouring_ = true;
    return NodeStatus::running;
  }
}

NodeStatus ReplayAvoiding::lane_step(const Odometry& raw_odom) {
  auto fresh = runner_.step(*this, host_);
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
  const DetourDriver::Limits lim = detour_.limits();
  if (d.kind == LaneDecision::Kind::blocked) {
    // Wait (a person may walk away); new pairs need motion, so the map only changes by waiting.
    stop(host_);
    if (++lane_blocked_cycles_ >= lim.max_blocked) {
      host_.logger().error(path(), "stopped: " + d.reason + " for " + std::to_string(lane_blocked_cycles_) + " cycles");
      return NodeStatus::failure;
    }
    return NodeStatus::running;
  }
  lane_blocked_cycles_ = 0;
  if (d.kind == LaneDecision::Kind::reverse) {
    if (!was_reversing && near_) near_->reset();  // a new reference for the triangulation
    auto speed = get_input<double>("backoff_speed_mps");
    if (!speed || *speed <= 0.0 || *speed > 1.0) {
      host_.logger().error(path(), "port 'backoff_speed_mps': must be in (0, 1] m/s (the recovery's reverse speed)");
      stop(host_);
      return NodeStatus::failure;
    }
    return send(host_, *this, -*speed, std::clamp(lim.gain_per_s * d.heading_rad, -lim.max_angular_radps, lim.max_angular_radps));
  }
  if (was_reversing) lane_best_s_m_ = d.s_m;  // progress counts again from where the reversing ended
  if (d.s_m > lane_best_s_m_ + 0.1) {
    lane_best_s_m_ = d.s_m;
    lane_stall_cycles_ = 0;
  } else if (++lane_stall_cycles_ >= lim.max_stall) {
    host_.logger().error(path(), "stopped: no progress along the line for " + std::to_string(lane_stall_cycles_) +
                                     " cycles (last: " + d.reason + ")");
    stop(host_);
    return NodeStatus::failure;
  }
  const double w = std::clamp(lim.gain_per_s * d.heading_rad, -lim.max_angular_radps, lim.max_angular_radps);
  // hold_forward: a known point in the body's way straight ahead: turn in place (lane_detour.hpp).
  const double v = d.hold_forward || std::fabs(d.heading_rad) > 1.0 ? 0.0
                                                                     : lim.speed_mps * std::max(0.0, std::cos(d.heading_rad));
  return send(host_, *this, v, w);
}

void ReplayAvoiding::halt() {
  if (detouring_ || looking_ || probing_ || crossing_drive_ || backing_) stop(host_);
  crossing_drive_.reset();
  looking_ = false;
  backing_ = false;
  probing_ = false;
  detour_.end();
  lane_.reset();
  runner_.stop_correction();
  detouring_ = false;
  child_started_ = false;
  resumed_ = false;
  child_ran_ = false;
  carried_shift_m_ = 0.0;
  moved_off_line_ = false;
  corridor_.clear();
  halt_child();
}

Result<bool> ReplayAvoiding::begin_backoff(const Odometry& odom) {
  VISNAV_ASSIGN(const double distance, get_input<double>("backoff_m"));
  // Not at an edge's first metre (the frame difference fires after the turn at a node), and once
  // per place: after a fruitless back-off, none until 2 backoff_m past where it stopped (a
  // shimmering floor stops the robot every 0.6 m; measured on the campus, e12 and e14).
  if (distance <= 0.0 || replay_done_m_ < 1.0 || odom.distance_m < backoff_again_at_m_) return false;
  // Only after a stop on something close standing ahead: ground shimmer stops the robot too
  // (campus gravel and tiles, 2-12 times a run), and each fruitless back-off costs accuracy.
  VISNAV_ASSIGN(const bool compact_only, get_input<bool>("backoff_compact"));
  if (compact_only && stop_by_drive_watch_ && !stop_shape_.compact) {
    host_.logger().info(path(), "nothing moves ahead and no contact; the stop's changed pixels were specks (ground shimmer): no back-off");
    return false;
  }
  BackOffLookParams params;
  params.distance_m = distance;
  VISNAV_ASSIGN(params.speed_mps, get_input<double>("backoff_speed_mps"));
  VISNAV_ASSIGN(params.min_points, get_input<int>("probe_min_points"));
  VISNAV_ASSIGN(params.corridor_half_width_m, get_input<double>("corridor_half_width_m"));
  if (auto st = params.validate(); !st) return st.error().with_context("ports 'backoff_m'/'backoff_speed_mps'");
  backoff_.emplace(params);
  backoff_->begin(odom.pose, odom.distance_m);
  backoff_trail_.clear();
  if (near_) near_->reset();
  backing_ = true;
  moved_off_line_ = true;
  host_.logger().info(path(), "nothing moves ahead and no contact: backing off " + std::to_string(distance) +
                                  " m while triangulating what stands ahead");
  return true;
}

NodeStatus ReplayAvoiding::backoff_step(const Odometry& odom) {
  auto points = triangulate_near(odom);
  if (!points) {
    host_.logger().error(path(), points.error().message);
    backing_ = false;
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
  backing_ = false;
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
  auto baseline = get_input<double>("standing_extent_m");
  if (!baseline || *baseline <= 0.0 || near_grey_.empty()) return;
  // The back-off's triangulated corners cover the part of the face with texture; the plane sweep
  // reads the face's edges from the image (campus seed 3, session 17). The frame standing_extent_m
  // nearer the face is the "earlier" one.
  const FrameTrail::Kept* nearer = backoff_trail_.back(-odom.distance_m, *baseline);
  if (nearer == nullptr) return;
  auto camera = read_camera(*this, near_grey_);
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
  // path-following edges get the same node under a second ID (trees/replay_route_avoiding.xml).
  VISNAV_TRY(registry.register_node<ReplayAvoiding>(
      "ReplayPathAvoiding",
      "ReplayAvoiding under a second node ID, for a second replay child under FollowRoute (e.g. FollowPathEdge)",
      [&host](const std::string& name, const bt::NodeConfig& config) {
        return std::make_unique<ReplayAvoiding>(name, config, host);
      }));
  return ok();
}

}  // namespace visnav::ipt
