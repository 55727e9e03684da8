// The avoidance nodes' parameters (see the header). The descriptions are what `visnav nodes`
// prints for each key; docs/obstacles.md explains the mechanisms and the measurements.
#include "avoiding_params.hpp"

#include "visnav/bt/param_ports.hpp"

namespace visnav::ipt {
namespace {

template <typename P>
Status checked(const P& p) {
  if (auto st = P::schema().check(p); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  return ok();
}

}  // namespace

Status ContactParams::validate() const { return checked(*this); }

const ParamSchema<ContactParams>& ContactParams::schema() {
  using P = ContactParams;
  static const auto s =
      ParamSchema<P>{}
          .field("span_max_m", &P::span_max_m,
                 "neighbouring contact points this close bound one obstacle when its face shows between them; the "
                 "span is filled (0 = contact points only), m")
          .range(0.0, 20.0)
          .field("contact_ground_reach_px", &P::contact_ground_reach_px,
                 "a GROUND feature this close ends an obstacle border's trace (spec 4.2), px")
          .range(0.0, 20.0)
          .field("foot_radius_px", &P::foot_radius_px,
                 "a contact's range is cut to the triangulated foot of the OBSTACLE features this many columns from "
                 "it (0 = the back-projection alone; the lane detour needs it), px")
          .range(0.0, 100.0);
  return s;
}

Status CorridorParams::validate() const {
  VISNAV_TRY(checked(*this));
  if (confirm_baseline_m > 0.0 && confirm_baseline_m < 0.01)
    return Error{"key 'confirm_baseline_m': " + std::to_string(confirm_baseline_m) + " is below 0.01 m (0 = off)",
                 ErrorCode::out_of_range, {{}, 0, "confirm_baseline_m"}};
  return ok();
}

const ParamSchema<CorridorParams>& CorridorParams::schema() {
  using P = CorridorParams;
  static const auto s =
      ParamSchema<P>{}
          .field("lookahead_m", &P::lookahead_m, "contact points up to this far ahead count, m")
          .range(0.1, 20.0)
          .field("corridor_half_width_m", &P::corridor_half_width_m, "half width of the corridor ahead, m")
          .range(0.05, 5.0)
          .field("memory_m", &P::memory_m, "contact points are kept for this much travel, m")
          .range(0.0, 50.0)
          .field("confirm_baseline_m", &P::confirm_baseline_m,
                 "a contact counts only when seen again at the same ground point (within half the travel, at most "
                 "confirm_radius_m) from a robot position this far away: rejects contacts that move with the robot "
                 "(sliding tracks on paver joints); 0 = every contact, m")
          .range(0.0, 10.0)
          .field("confirm_radius_m", &P::confirm_radius_m, "largest distance between two sightings of one contact, m")
          .range(0.01, 5.0)
          .field("confirm_views", &P::confirm_views,
                 "... and a contact must have been found at that ground point by this many pairs (distinct robot "
                 "positions; rejects occasional mis-tracks in periodic textures)")
          .range(2, 1000)
          .field("confirm_view_share", &P::confirm_view_share,
                 "... and by this share of the pairs made between the first and the last of them (0 = off; rejects the "
                 "ends of noise traces on a tiled floor)")
          .range(0.0, 1.0);
  return s;
}

Status DriveParams::validate() const { return checked(*this); }

const ParamSchema<DriveParams>& DriveParams::schema() {
  using P = DriveParams;
  static const auto s = ParamSchema<P>{}
                            .field("speed_mps", &P::speed_mps, "forward speed of a detour, m/s")
                            .range(0.01, 2.0)
                            .field("turn_gain_per_s", &P::turn_gain_per_s, "omega = gain * heading error, 1/s")
                            .range(0.0, 20.0)
                            .field("max_angular_radps", &P::max_angular_radps, "turn-rate limit, rad/s")
                            .range(0.01, 5.0)
                            .field("max_blocked_cycles", &P::max_blocked_cycles,
                                   "cycles without any free way (gap, lane) before giving up")
                            .range(1, 1000000)
                            .field("max_stall_cycles", &P::max_stall_cycles,
                                   "cycles without 0.1 m of progress (towards the goal, along the line) before giving "
                                   "up: a trap, a potential-field minimum")
                            .range(1, 1000000);
  return s;
}

Status ThesisDetourParams::validate() const { return checked(*this); }

const ParamSchema<ThesisDetourParams>& ThesisDetourParams::schema() {
  using P = ThesisDetourParams;
  static const auto s =
      ParamSchema<P>{}
          .field("goal_ahead_m", &P::goal_ahead_m, "goal on the current heading line, this far ahead, m")
          .range(0.1, 100.0)
          .field("security_distance_m", &P::security_distance_m, "S_dist (thesis 0.95 m), m")
          .range(0.05, 10.0)
          .field("gap_width_m", &P::gap_width_m, "narrowest permitted gap (thesis experiments 0.95 m), m")
          .range(0.05, 20.0)
          .field("reset_keep_near_m", &P::reset_keep_near_m,
                 "points this close survive the filter resets (0 = the thesis; measured: the thesis reset forgets a "
                 "crate beside the robot and drives into it), m")
          .range(0.0, 100.0);
  return s;
}

Status LaneParams::validate() const { return checked(*this); }

const ParamSchema<LaneParams>& LaneParams::schema() {
  using P = LaneParams;
  static const auto s =
      ParamSchema<P>{}
          .field("clearance_m", &P::clearance_m, "free space kept beyond the body, m")
          .range(0.0, 5.0)
          .field("max_offset_m", &P::max_offset_m, "widest lane searched on either side, m")
          .range(0.1, 50.0)
          .field("behind_m", &P::behind_m,
                 "an obstacle point holds the robot in its lane until it is this far behind (the obstacle's unseen "
                 "length), m")
          .range(0.0, 50.0)
          .field("drift_rad_per_m", &P::drift_rad_per_m,
                 "odometry heading drift assumed while passing points out of view; a point's clearance grows by "
                 "0.5*drift*d^2 (d: travel along the line since it was seen, at most 0.4 m more); 0 = off, rad/m")
          .range(0.0, 1.0)
          .field("ekf_heading", &P::ekf_heading,
                 "steer by the heading of the thesis's robocentric EKF on the IPT pairs' GROUND features "
                 "(ground_odometry.hpp); not for an odometry whose heading noise per 5 cm reaches about 0.03 rad "
                 "(docs/obstacles.md)")
          .field("commit_m", &P::commit_m,
                 "the chosen side is kept within this of an obstacle point (its closing blocks the detour instead of a "
                 "swing across the obstacle); 0 = off, m")
          .range(0.0, 50.0)
          .field("max_recoveries", &P::max_recoveries,
                 "the chosen side closes within commit_m and the other side is free: reverse along the line until no "
                 "obstacle point is within recover_clear_m ahead, then take the other side; this often per detour "
                 "(0 = stop with the reason)")
          .range(0, 10)
          .field("recover_clear_m", &P::recover_clear_m, "recovery: reverse until no obstacle point is this close ahead, m")
          .range(0.5, 20.0)
          .field("max_reverse_m", &P::max_reverse_m, "recovery: most reversing along the line; then stop, m")
          .range(0.5, 50.0)
          .field("reverse_speed_mps", &P::reverse_speed_mps, "recovery: reverse speed, m/s")
          .range(0.01, 1.0);
  return s;
}

Status LookParams::validate() const { return checked(*this); }

const ParamSchema<LookParams>& LookParams::schema() {
  using P = LookParams;
  static const auto s =
      ParamSchema<P>{}
          .field("look_frames", &P::look_frames,
                 "frames the stopped robot watches the corridor before a detour (motion: wait instead); 0 = detour at "
                 "once")
          .range(0, 1000000)
          .field("clear_frames", &P::clear_frames, "still frames before the replay resumes")
          .range(1, 1000000)
          .field("max_wait_frames", &P::max_wait_frames,
                 "frames of waiting for the corridor to clear before failing")
          .range(1, 100000000)
          .field("motion_threshold", &P::motion_threshold, "grey-level change of a pixel that counts (frame difference)")
          .range(1.0, 255.0)
          .field("motion_min_px", &P::motion_min_px, "changed corridor pixels that count as motion")
          .range(1, 1000000)
          .field("moving_stop_m", &P::moving_stop_m,
                 "while replaying, what moves (or stands) in the corridor this close (ground-compensated frame "
                 "difference, +-1.2 m wide) stops the robot to look; 0 = off, m")
          .range(0.0, 20.0);
  return s;
}

Status CrossingPortParams::validate() const { return checked(*this); }

const ParamSchema<CrossingPortParams>& CrossingPortParams::schema() {
  using P = CrossingPortParams;
  static const auto s =
      ParamSchema<P>{}
          .field("speed_mps", &P::speed_mps,
                 "> 0 turns the crossing policy on: the robot crosses a person's way at this speed, holding its "
                 "heading, and goes only when the person's arrival in its lane leaves the time it needs (from the "
                 "geometry) + margin_s; 0 = off, m/s")
          .range(0.0, 2.0)
          .field("margin_s", &P::margin_s, "time the person's arrival must leave beyond the robot's clear time, s")
          .range(0.0, 30.0)
          .field("lane_m", &P::lane_m, "half width of the robot's lane (body + a person + margin), m")
          .range(0.1, 5.0)
          .field("clear_m", &P::clear_m,
                 "a person walking away (or standing) this far beyond the lane's edge lets the robot go, m")
          .range(0.0, 10.0)
          .field("band_m", &P::band_m, "half width of the band watched for the person (frame difference 0.3-8 m ahead), m")
          .range(0.05, 10.0)
          .field("kerb_m", &P::kerb_m,
                 "a person seen crossing ahead while driving stops the robot when its way is this far ahead of the "
                 "robot centre, to watch it pass, m")
          .range(0.0, 5.0)
          .field("wait_s", &P::wait_s, "at such a stop, seconds of waiting for the person to pass before going on, s")
          .range(0.0, 600.0);
  return s;
}

Status StandingPortParams::validate() const {
  VISNAV_TRY(checked(*this));
  if (min_range_m >= range_m)
    return Error{"key 'min_range_m': " + std::to_string(min_range_m) + " must be below range_m (" +
                     std::to_string(range_m) + ")",
                 ErrorCode::inconsistent, {{}, 0, "min_range_m"}};
  if (min_face_share > 0.0 && extent_m == 0.0)
    return Error{"key 'min_face_share' needs extent_m > 0 (the share comes from the extent's plane sweep)",
                 ErrorCode::inconsistent, {{}, 0, "min_face_share"}};
  return ok();
}

const ParamSchema<StandingPortParams>& StandingPortParams::schema() {
  using P = StandingPortParams;
  static const auto s =
      ParamSchema<P>{}
          .field("min_points", &P::min_points,
                 "while the child drives: corners triangulated above the ground (near_triangulation.hpp) within one "
                 "face's depth in the corridor ahead, from at least 2 triangulations of the last 1.5 m, that stop the "
                 "child and start the lane detour with the face's points (standing_watch.hpp); 0 = off")
          .range(0, 10000)
          .field("one_batch_points", &P::one_batch_points,
                 "a face with at least this many corners fires from one triangulation (a path follower's steering may "
                 "leave no second straight baseline); pair it with min_face_share; 0 = off")
          .range(0, 100000)
          .field("depth_m", &P::depth_m, "forward depth of one face's points, m")
          .range(0.05, 5.0)
          .field("range_m", &P::range_m, "corners at most this far ahead count (the triangulation's reach), m")
          .range(0.5, 50.0)
          .field("min_width_m", &P::min_width_m, "the face's points must span this much across, m")
          .range(0.0, 10.0)
          .field("min_range_m", &P::min_range_m,
                 "a face found nearer than this is left to the other watches (frame difference, back-off); 0 = any, m")
          .range(0.0, 50.0)
          .field("extent_m", &P::extent_m,
                 "when it fires, the face's full width from the image (a plane sweep at its distance against the frame "
                 "this far back, face_extent.hpp) joins the lane detour's points; 0 = off, m")
          .range(0.0, 1.0)
          .field("min_face_share", &P::min_face_share,
                 "with extent_m > 0: a firing whose plane sweep judges less than this share of the image columns a "
                 "face is dropped and the child resumes (campus: false firings 0.07-0.10, the van 0.57-0.89); 0 = off")
          .range(0.0, 1.0);
  return s;
}

Status ProbeParams::validate() const { return checked(*this); }

const ParamSchema<ProbeParams>& ProbeParams::schema() {
  using P = ProbeParams;
  static const auto s =
      ParamSchema<P>{}
          .field("enabled", &P::enabled,
                 "when the child fails because it lost sight of the route (failure code view_lost: FollowPathEdge's "
                 "path hidden by an obstacle of its colour), drive on slowly on the heading while the IPT, the frame "
                 "difference and the triangulation look; something found: stop, look and detour as usual; nothing: "
                 "fail with the child's reason")
          .field("budget_m", &P::budget_m, "odometry budget per place, m")
          .range(0.01, 20.0)
          .field("speed_mps", &P::speed_mps, "forward speed while probing, m/s")
          .range(0.01, 2.0)
          .field("min_points", &P::min_points,
                 "corners triangulated 0.15-2.5 m above the ground within lookahead_m + 1 m ahead in the corridor over a "
                 "0.3 m baseline that stop the probe and start the detour (near_triangulation.hpp)")
          .range(1, 10000);
  return s;
}

Status BackoffParams::validate() const {
  VISNAV_TRY(checked(*this));
  if (distance_m > 0.0 && distance_m < 0.1)
    return Error{"key 'distance_m': " + std::to_string(distance_m) + " is below 0.1 m (0 = off)", ErrorCode::out_of_range,
                 {{}, 0, "distance_m"}};
  return ok();
}

const ParamSchema<BackoffParams>& BackoffParams::schema() {
  using P = BackoffParams;
  static const auto s =
      ParamSchema<P>{}
          .field("distance_m", &P::distance_m,
                 "a stop-and-look that sees nothing move and no contact: reverse this far on the heading while the "
                 "longer-baseline triangulation looks; min_points corners in the corridor ahead: lane detour with all "
                 "of them (the face's full width), else resume (back_off_look.hpp); 0 = off, m")
          .range(0.0, 10.0)
          .field("speed_mps", &P::speed_mps, "reverse speed, m/s")
          .range(0.01, 1.0)
          .field("compact", &P::compact,
                 "back off only after a stop whose changed pixels (the drive watch's frame difference) came in solid "
                 "pieces (a face close ahead), not in the specks of ground shimmer (motion_watch.hpp, change_shape()); "
                 "false = after every fruitless look")
          .field("min_points", &P::min_points, "corners in the corridor ahead that make an obstacle")
          .range(1, 10000);
  return s;
}

const AvoidingParams& replay_defaults() {
  static const AvoidingParams d = [] {
    AvoidingParams p;
    p.contacts.foot_radius_px = 10.0;
    p.corridor.lookahead_m = 2.5;          // leaves the lane detour room to move sideways
    // The persistence filter stays off (a site setting): it rejects the campus's paver-joint
    // tracks, but delays a real contact, and on van_path the van and the crate come too close for
    // the lane detour (tests ReplayAvoiding.TaughtOnAClearPathReplayedPastAParkedVan,
    // APathFollowingEdgeResumesPastACrate). The campus patrol turns it on in its subtree.
    p.thesis.goal_ahead_m = 8.0;
    p.thesis.reset_keep_near_m = 3.0;
    p.crossing.speed_mps = 0.6;            // the crossing policy on
    return p;
  }();
  return d;
}

const AvoidingParams& path_replay_defaults() {
  static const AvoidingParams d = [] {
    AvoidingParams p = replay_defaults();
    p.probe.enabled = true;
    p.backoff.distance_m = 3.0;
    p.standing.min_points = 6;
    p.standing.one_batch_points = 10;
    p.standing.min_range_m = 2.0;
    p.standing.extent_m = 0.5;
    p.standing.min_face_share = 0.3;
    return p;
  }();
  return d;
}

void append_avoiding_group_ports(bt::PortsList& ports, const AvoidingParams& d) {
  ports.push_back(bt::param_group_port("contacts", ContactParams::schema(), d.contacts,
                                       "Contact points from the IPT pairs (the pipeline's profiles)."));
  ports.push_back(bt::param_group_port("corridor", CorridorParams::schema(), d.corridor,
                                       "The corridor ahead whose contacts stop the replay, and the persistence filter."));
  ports.push_back(bt::param_group_port("drive", DriveParams::schema(), d.drive,
                                       "Driving a detour (lane and thesis): speed, steering, when to give up."));
  ports.push_back(bt::param_group_port("thesis", ThesisDetourParams::schema(), d.thesis,
                                       "detour=\"thesis\": the thesis's Ch. 6 strategy to a goal along the line."));
  ports.push_back(bt::param_group_port("lane", LaneParams::schema(), d.lane,
                                       "detour=\"lane\": a free lateral offset from the line, back onto it past the obstacle."));
  ports.push_back(bt::param_group_port("look", LookParams::schema(), d.look,
                                       "Stop and look (frame difference of the standing camera) and the drive watch."));
  ports.push_back(bt::param_group_port("crossing", CrossingPortParams::schema(), d.crossing,
                                       "The crossing policy for people crossing the robot's way."));
  ports.push_back(bt::param_group_port("standing", StandingPortParams::schema(), d.standing,
                                       "The standing watch: a face triangulated ahead while the child drives."));
  ports.push_back(bt::param_group_port("probe", ProbeParams::schema(), d.probe,
                                       "The probe on a route the child lost sight of (failure code view_lost)."));
  ports.push_back(bt::param_group_port("backoff", BackoffParams::schema(), d.backoff,
                                       "Back off and look after a stop that saw nothing move and no contact."));
}

Result<AvoidingParams> parse_avoiding_groups(const bt::TreeNode& node, const AvoidingParams& d) {
  AvoidingParams p;
  VISNAV_ASSIGN(p.contacts, bt::parse_param_group(node, "contacts", ContactParams::schema(), d.contacts));
  VISNAV_ASSIGN(p.corridor, bt::parse_param_group(node, "corridor", CorridorParams::schema(), d.corridor));
  VISNAV_ASSIGN(p.drive, bt::parse_param_group(node, "drive", DriveParams::schema(), d.drive));
  VISNAV_ASSIGN(p.thesis, bt::parse_param_group(node, "thesis", ThesisDetourParams::schema(), d.thesis));
  VISNAV_ASSIGN(p.lane, bt::parse_param_group(node, "lane", LaneParams::schema(), d.lane));
  VISNAV_ASSIGN(p.look, bt::parse_param_group(node, "look", LookParams::schema(), d.look));
  VISNAV_ASSIGN(p.crossing, bt::parse_param_group(node, "crossing", CrossingPortParams::schema(), d.crossing));
  VISNAV_ASSIGN(p.standing, bt::parse_param_group(node, "standing", StandingPortParams::schema(), d.standing));
  VISNAV_ASSIGN(p.probe, bt::parse_param_group(node, "probe", ProbeParams::schema(), d.probe));
  VISNAV_ASSIGN(p.backoff, bt::parse_param_group(node, "backoff", BackoffParams::schema(), d.backoff));
  return p;
}

}  // namespace visnav::ipt
