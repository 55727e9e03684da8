// visnav IPT obstacles — the parameters of the avoidance nodes, one struct per mechanism.
//
// Each struct has a ParamSchema (visnav/params.hpp): the keys, their descriptions, ranges and
// cross-key rules are written once, here. The nodes get their ports from these schemas
// (visnav/bt/param_ports.hpp):
//  * ObstacleAhead and AvoidObstacles: one port per key (append_param_ports), with the
//    defaults the struct initialisers give (the thesis-side values);
//  * ReplayAvoiding / ReplayPathAvoiding: one group port per mechanism (param_group_port), e.g.
//    corridor="lookahead_m=3; confirm_views=4", with the tuned defaults of
//    replay_defaults() / path_replay_defaults(), so the shipped trees need not repeat them.
// A tree loader and `visnav validate` check every literal (each key's range and the struct's
// validate()) before the first tick; the nodes parse the same text again when they start.
// Units are in the key names. Thread-safety: plain values; the schemas are immutable.
#pragma once

#include <string>

#include "visnav/bt/node.hpp"
#include "visnav/bt/ports.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav::ipt {

/// Contact points from the IPT pairs (profiles.hpp): the span filler and the contact range cut.
struct ContactParams {
  double span_max_m = 2.2;               ///< neighbouring contacts this close bound one obstacle (0 = off)
  double contact_ground_reach_px = 2.0;  ///< a GROUND feature this close ends a border's trace (spec 4.2)
  double foot_radius_px = 0.0;           ///< contact range cut to the triangulated foot within this (0 = off)
  [[nodiscard]] Status validate() const;
  [[nodiscard]] static const ParamSchema<ContactParams>& schema();
};

/// The corridor ahead and the contact persistence filter (contact_persistence.hpp).
struct CorridorParams {
  double lookahead_m = 1.5;            ///< contact points up to this far ahead count
  double corridor_half_width_m = 0.45; ///< half width of the corridor ahead
  double memory_m = 1.0;               ///< contact points are kept for this much travel
  double confirm_baseline_m = 0.0;     ///< > 0: a contact counts only when seen again from this far away
  double confirm_radius_m = 0.3;       ///< largest distance between two sightings of one contact
  int confirm_views = 3;               ///< ... found by this many pairs
  double confirm_view_share = 0.0;     ///< ... and by this share of the pairs between the first and last (0 = off)
  [[nodiscard]] Status validate() const;
  [[nodiscard]] static const ParamSchema<CorridorParams>& schema();
};

/// Driving a detour: speed, turn gain and limits (both detours), and when to give up.
struct DriveParams {
  double speed_mps = 0.2;          ///< forward speed
  double turn_gain_per_s = 1.5;    ///< omega = gain * heading error
  double max_angular_radps = 0.6;  ///< turn-rate limit
  int max_blocked_cycles = 60;     ///< cycles without any free way before giving up
  int max_stall_cycles = 300;      ///< cycles without 0.1 m of progress before giving up
  [[nodiscard]] Status validate() const;
  [[nodiscard]] static const ParamSchema<DriveParams>& schema();
};

/// The thesis's Ch. 6 strategy to a goal ahead (polar_map.hpp, NavigationFilter).
struct ThesisDetourParams {
  double goal_ahead_m = 4.0;          ///< goal on the heading line, this far ahead
  double security_distance_m = 0.95;  ///< S_dist (thesis 0.95 m)
  double gap_width_m = 0.95;          ///< narrowest permitted gap (thesis 0.95 m)
  double reset_keep_near_m = 1.9;     ///< points this close survive the filter resets (0 = the thesis)
  [[nodiscard]] Status validate() const;
  [[nodiscard]] static const ParamSchema<ThesisDetourParams>& schema();
};

/// ReplayAvoiding's lane detour (lane_detour.hpp) beyond the core's own constants.
struct LaneParams {
  double clearance_m = 0.35;        ///< free space kept beyond the body
  double max_offset_m = 2.5;        ///< widest lane searched on either side
  double behind_m = 6.5;            ///< an obstacle point holds the lane until this far behind
  double drift_rad_per_m = 0.012;   ///< heading drift assumed while passing points out of view (0 = off)
  bool ekf_heading = false;         ///< steer by the ground-feature EKF's heading (ground_odometry.hpp)
  double commit_m = 2.0;            ///< the chosen side is kept within this of an obstacle point (0 = off)
  int max_recoveries = 1;           ///< closed side: reverse and take the other side this often (0 = stop)
  double recover_clear_m = 3.0;     ///< reverse until no obstacle point is this close ahead
  double max_reverse_m = 10.0;      ///< most reversing per recovery
  double reverse_speed_mps = 0.15;  ///< the recovery's reverse speed
  [[nodiscard]] Status validate() const;
  [[nodiscard]] static const ParamSchema<LaneParams>& schema();
};

/// Stop and look (motion_watch.hpp): the standing camera's frame difference, and the drive
/// watch that stops the replay for something moving close ahead.
struct LookParams {
  int look_frames = 8;           ///< frames watched before a detour (0 = detour at once)
  int clear_frames = 15;         ///< still frames before the replay resumes
  int max_wait_frames = 600;     ///< frames of waiting for the corridor to clear before failing
  double motion_threshold = 18;  ///< grey-level change of a pixel that counts
  int motion_min_px = 80;        ///< changed corridor pixels that count as motion
  double moving_stop_m = 2.0;    ///< drive watch reach (0 = off)
  [[nodiscard]] Status validate() const;
  [[nodiscard]] static const ParamSchema<LookParams>& schema();
};

/// The crossing policy (crossing_policy.hpp) for people crossing the robot's way.
struct CrossingPortParams {
  double speed_mps = 0.0;   ///< > 0: policy on, the robot crosses a person's way at this speed (0 = off)
  double margin_s = 0.5;    ///< time the person's arrival must leave beyond the robot's clear time
  double lane_m = 0.6;      ///< half width of the robot's lane (body + a person + margin)
  double clear_m = 0.3;     ///< a person this far beyond the lane's edge lets the robot go
  double band_m = 4.0;      ///< half width of the band watched for the person
  double kerb_m = 0.7;      ///< a way seen crossing ahead stops the robot this far before it
  double wait_s = 15.0;     ///< at such a stop, seconds of waiting for the person to pass
  [[nodiscard]] Status validate() const;
  [[nodiscard]] static const ParamSchema<CrossingPortParams>& schema();
};

/// The standing watch while the child drives (standing_watch.hpp, face_extent.hpp).
struct StandingPortParams {
  int min_points = 0;            ///< corners of one face that fire (0 = off)
  int one_batch_points = 0;      ///< a face with this many corners fires from one triangulation (0 = off)
  double depth_m = 0.6;          ///< forward depth of one face's points
  double range_m = 4.0;          ///< corners at most this far ahead count
  double min_width_m = 0.5;      ///< the face's points must span this much across
  double min_range_m = 0.0;      ///< a face nearer than this is left to the other watches
  double extent_m = 0.0;         ///< plane-sweep baseline for the face's full width (0 = off)
  double min_face_share = 0.0;   ///< firings whose sweep sees less of a face are dropped (0 = off)
  [[nodiscard]] Status validate() const;
  [[nodiscard]] static const ParamSchema<StandingPortParams>& schema();
};

/// The probe on a hidden route (hidden_path_probe.hpp): after the child gives up because it lost
/// sight of the route (failure code view_lost, e.g. FollowPathEdge's path hidden).
struct ProbeParams {
  bool enabled = false;     ///< probe when the child fails with view_lost
  double budget_m = 1.5;    ///< odometry budget per place
  double speed_mps = 0.15;  ///< forward speed
  int min_points = 4;       ///< triangulated corners in the corridor ahead that start the detour
  [[nodiscard]] Status validate() const;
  [[nodiscard]] static const ParamSchema<ProbeParams>& schema();
};

/// Back off and look (back_off_look.hpp) after a stop that saw nothing move and no contact.
struct BackoffParams {
  double distance_m = 0.0;   ///< reverse this far while triangulating (0 = off)
  double speed_mps = 0.15;   ///< reverse speed
  bool compact = true;       ///< only after a stop whose changed pixels came in solid pieces
  int min_points = 4;        ///< corners in the corridor ahead that start the detour
  [[nodiscard]] Status validate() const;
  [[nodiscard]] static const ParamSchema<BackoffParams>& schema();
};

/// Every mechanism's params of one ReplayAvoiding node.
struct AvoidingParams {
  ContactParams contacts;
  CorridorParams corridor;
  DriveParams drive;
  ThesisDetourParams thesis;
  LaneParams lane;
  LookParams look;
  CrossingPortParams crossing;
  StandingPortParams standing;
  ProbeParams probe;
  BackoffParams backoff;
};

/// ReplayAvoiding's defaults: the values the campus and the held-out benchmark were measured with
/// on feature edges (docs/obstacles.md, "Defaults").
[[nodiscard]] const AvoidingParams& replay_defaults();
/// ReplayPathAvoiding's: replay_defaults() plus the probe, the back-off and the standing watch of
/// the path-following edges.
[[nodiscard]] const AvoidingParams& path_replay_defaults();

/// The group ports of `defaults` (names: contacts, corridor, drive, thesis, lane, look, crossing,
/// standing, probe, backoff).
void append_avoiding_group_ports(bt::PortsList& ports, const AvoidingParams& defaults);
/// Parses every group port of `node` on top of `defaults`. Error: the first bad group, naming
/// the port and the key, located at the node's file:line.
[[nodiscard]] Result<AvoidingParams> parse_avoiding_groups(const bt::TreeNode& node, const AvoidingParams& defaults);

}  // namespace visnav::ipt
