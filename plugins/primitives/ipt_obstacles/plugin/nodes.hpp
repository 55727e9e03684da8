// Behaviour-tree nodes of the ipt_obstacles plugin. Thin adapters over the core:
//  * ObstacleAhead (condition): runs the IPT pipeline on the camera stream; success while a
//    contact point lies in the corridor ahead of the robot (|lateral| ≤ corridor_half_width_m,
//    0 < forward ≤ lookahead_m). Contact points are kept in the odom frame for memory_m of
//    travel, so an obstacle that left the field of view still counts until passed.
//  * AvoidObstacles (stateful action): the thesis's goal-directed strategy (NavigationFilter)
//    towards a goal goal_ahead_m ahead of where it started, on the line of the robot's heading
//    then (the taught edge when it interrupts a replay). (v, ω): ω = gain·θ_mot saturated,
//    v = speed·max(0, cos θ_mot). Success at the goal; failure, with a logged reason, when no
//    gap exists for max_blocked_cycles cycles in a row, when it gets no 0.1 m closer to the
//    goal for max_stall_cycles cycles (a trap), or when the camera/odometry are missing.
//  * ReplayAvoiding (decorator around a replay primitive): the two above inside an edge replay,
//    see the class comment.
// The camera mount comes from the camera plugin (HostServices::camera_mount(), docs/cameras.md);
// the image size from the frames. Parameters: avoiding_params.hpp (one struct per mechanism,
// ports generated from its schema). Both nodes stop the robot when halted or failing.
#pragma once

#include <memory>
#include <utility>
#include <optional>
#include <string>
#include <vector>

#include "visnav/bt/node.hpp"
#include "visnav/bt/registry.hpp"
#include "visnav/host.hpp"
#include "avoiding_params.hpp"
#include "crossing_watch.hpp"
#include "standing_check.hpp"
#include "visnav/ipt_obstacles/back_off_look.hpp"
#include "visnav/ipt_obstacles/contact_persistence.hpp"
#include "visnav/ipt_obstacles/ground_odometry.hpp"
#include "visnav/ipt_obstacles/hidden_path_probe.hpp"
#include "visnav/ipt_obstacles/lane_detour.hpp"
#include "visnav/ipt_obstacles/motion_watch.hpp"
#include "visnav/ipt_obstacles/near_triangulation.hpp"
#include "visnav/ipt_obstacles/pipeline.hpp"
#include "visnav/ipt_obstacles/polar_map.hpp"

namespace visnav::ipt {

/// Pipeline state shared by both node kinds: frames in, contact points (odom frame) out.
class PipelineRunner {
 public:
  /// Asks the host for the camera mount on first use. Returns the contact points of a new pair
  /// (may be empty), nullopt when no new pair closed this tick. Error: no frame bus, no or bad
  /// camera mount, bad `contacts`.
  Result<std::optional<std::vector<cv::Point2d>>> step(HostServices& host, const ContactParams& contacts);
  [[nodiscard]] std::optional<Pose2D> pose(HostServices& host) const;
  void restart() {
    if (pipeline_) pipeline_->restart();
  }
  /// Heading correction by the ground-feature EKF (ground_odometry.hpp) from here until
  /// stop_correction(): every pair feeds the filter, step() returns its points in the corrected
  /// frame and correct() maps the raw odometry pose into it. Error when the pipeline has not run
  /// yet (no camera) or a param is out of range; the caller then drives on the raw odometry.
  Status start_correction(const Pose2D& raw, const GroundOdometryParams& params = {});
  void stop_correction() { correcting_ = false; }
  /// The corrected pose of the raw odometry pose `raw` (call once per tick with the newest
  /// pose; `raw` unchanged when not correcting). Translation stays the wheels' (the edge's
  /// along-track distance keeps its meaning); only the heading takes the filter's.
  Pose2D correct(const Pose2D& raw);
  [[nodiscard]] double heading_correction_rad() const { return correcting_ ? heading_offset_rad_ : 0.0; }

 private:
  std::optional<ObstaclePipeline> pipeline_;
  std::optional<GroundOdometry> ground_;
  bool correcting_ = false;
  Pose2D last_raw_, corrected_;
  double heading_offset_rad_ = 0.0;
  std::uint64_t last_sequence_ = 0;
  bool have_sequence_ = false;
  cv::Mat grey_;
};

/// The IPT camera of the host's camera mount for frames of `image`'s size (a pinhole with a
/// centred principal point). Error: the camera declares no mount (naming the keys to add).
Result<IptCamera> ipt_camera(HostServices& host, const cv::Mat& image);

/// Contact points (odom frame) kept for memory_m of travel, and the corridor test shared by
/// ObstacleAhead and ReplayAvoiding (CorridorParams). With confirm_baseline_m > 0 only
/// persistent points count (ContactPersistence: seen again at the same ground point from robot
/// positions at least that far apart, by confirm_views pairs); 0 = every point (the thesis and
/// the default: measured, the confirmation delay lets a parked van come too close for the lane
/// detour, test ReplayAvoiding.TaughtOnAClearPathReplayedPastAParkedVan).
class CorridorMemory {
 public:
  /// Points of one pair, seen with the robot at `odom`.
  void add(const std::vector<cv::Point2d>& points, const Odometry& odom);
  /// The same during a detour: returns those of the new points that count (the confirmed ones
  /// when the filter is on, else all). Forgets by the memory_m read by the last blocked().
  std::vector<cv::Point2d> add_and_confirm(const std::vector<cv::Point2d>& points, const Odometry& odom);
  /// True when a kept (confirmed) point lies 0 < forward ≤ lookahead_m, |lateral| ≤
  /// corridor_half_width_m. Error: bad confirmation params.
  Result<bool> blocked(const CorridorParams& params, const Odometry& odom);
  void clear() { sightings_.clear(); }
  /// The kept points (odom frame): the confirmed ones when the filter is on.
  [[nodiscard]] std::vector<cv::Point2d> points() const {
    return filter_on_ ? sightings_.confirmed() : sightings_.all();
  }
  /// The kept points in the corridor at the last blocked() that returned true (odom frame), e.g.
  /// "(x, y) (x, y)", for the stop's log message.
  [[nodiscard]] const std::string& blocking_points() const { return blocking_; }

 private:
  ContactPersistence sightings_{ContactPersistenceParams{}};
  bool configured_ = false, filter_on_ = false;
  double memory_m_ = 1.0;
  std::string blocking_;
};

class ObstacleAhead : public bt::ConditionNode {
 public:
  ObstacleAhead(const std::string& name, const bt::NodeConfig& config, HostServices& host);
  static bt::PortsList provided_ports();
  bt::NodeStatus tick() override;

 private:
  HostServices& host_;
  PipelineRunner runner_;
  CorridorMemory corridor_;
  std::optional<ContactParams> contacts_;  // parsed at the first tick
  CorridorParams corridor_params_;
};

/// The detour shared by AvoidObstacles and ReplayAvoiding: NavigationFilter decisions to a goal
/// on the line of the heading where it began, turned into (v, ω) (see the file comment).
class DetourDriver {
 public:
  /// Places the goal thesis.goal_ahead_m ahead of `pose` on its heading. Error: bad params.
  Status begin(const DriveParams& drive, const ThesisDetourParams& thesis, const Pose2D& pose);
  /// One cycle: success at the goal, failure (reason logged, robot stopped) when blocked or
  /// stalled, running otherwise.
  bt::NodeStatus step(const bt::TreeNode& node, HostServices& host, PipelineRunner& runner, const ContactParams& contacts);
  void end() { filter_.reset(); }
  [[nodiscard]] Situation last_situation() const { return last_situation_; }

 private:
  std::optional<NavigationFilter> filter_;
  cv::Point2d goal_m_;
  DriveParams drive_;
  int blocked_cycles_ = 0;
  int stall_cycles_ = 0;
  double best_distance_m_ = 0.0;
  Situation last_situation_ = Situation::blocked;
};

class AvoidObstacles : public bt::StatefulActionNode {
 public:
  AvoidObstacles(const std::string& name, const bt::NodeConfig& config, HostServices& host);
  static bt::PortsList provided_ports();
  bt::NodeStatus on_start() override;
  bt::NodeStatus on_running() override;
  void on_halted() override;

 private:
  HostServices& host_;
  PipelineRunner runner_;
  DetourDriver detour_;
  ContactParams contacts_;
};

/// Replay with avoidance (decorator around an edge's replay primitive, e.g. ReplayFeatureEdge):
/// while an obstacle's ground contact lies in the corridor ahead (as ObstacleAhead), the child
/// is halted and a detour drives around the obstacle along the line of the heading at that
/// moment — the taught edge: detour="lane" (default) with LaneDetour (lane_detour.hpp: a free
/// lateral offset, back onto the line past the obstacle), detour="thesis" with the Ch. 6
/// strategy (as AvoidObstacles) to a point the thesis group's goal_ahead_m further along the line. Then the child
/// starts again with `carried_m` set to the along-track distance already covered: the replay's
/// distance before the obstacle plus the detour's progress projected on that line, so the edge
/// keeps counting and its visual correction resumes. No gap: failure with the reason.
/// Moving obstacles (look group, look_frames > 0): before a detour the robot stops and watches the
/// corridor for look_frames frames (MotionWatch, frame differencing of the standing camera). No motion:
/// the obstacle stands, detour as above. Motion (a person crossing): wait until the corridor has
/// been still for clear_frames frames, then resume the replay where it stopped (the stale
/// contact points are dropped; a person who stopped in the corridor is found again by the IPT
/// and, standing, detoured). Still moving after max_wait_frames: failure with the reason.
/// Register the edge kinds to it in FollowRoute's `primitives` port. The child may be any replay
/// primitive with the adapter's carried_m port (ReplayFeatureEdge, FollowPathEdge).
/// Parameters: one group port per mechanism (avoiding_params.hpp), parsed once at the first tick
/// on top of `defaults` (replay_defaults(); ReplayPathAvoiding: path_replay_defaults()).
/// Distances: the odometry's, divided by distance_scale where the edge's taught metres are meant.
class ReplayAvoiding : public bt::DecoratorNode {
 public:
  /// The node's state machine (the transitions: the comment above ReplayAvoiding::tick() in
  /// nodes.cpp, and docs/obstacles.md "The replay state machine"). Exactly one phase is current.
  enum class Phase {
    replaying,    ///< the child replays the edge; the watches may stop it
    probing,      ///< the child lost sight of the route (view_lost): creeping on, triangulating
    looking,      ///< stopped, watching the corridor for motion (and a person's way)
    crossing,     ///< driving across a person's way on the heading
    backing_off,  ///< reversing on the heading while triangulating what stands ahead
    detouring,    ///< the lane (or thesis) detour round an obstacle
  };
  static const char* phase_name(Phase phase);
  ReplayAvoiding(const std::string& name, const bt::NodeConfig& config, HostServices& host,
                 const AvoidingParams& defaults = replay_defaults());
  static bt::PortsList provided_ports();
  /// The ports with the group defaults of `defaults` (ReplayPathAvoiding's provided_ports()).
  static bt::PortsList ports_with(const AvoidingParams& defaults);
  bt::NodeStatus tick() override;
  void halt() override;

 private:
  /// One cycle of the lane detour (detour="lane"): success when back on the line past the
  /// obstacle, failure (reason logged, robot stopped) when no lane is free for
  /// max_blocked_cycles or no along-line progress for max_stall_cycles.
  bt::NodeStatus lane_step(const Odometry& odom);
  /// Starts the detour of the `detour` port from the current pose (robot already stopped).
  bt::NodeStatus begin_detour(const Odometry& odom);
  // The phases and decisions of tick() (its comment in nodes.cpp lists the states).
  /// The detouring phase: one cycle of the lane or thesis detour; when it ends, failure or the
  /// child's resumption.
  bt::NodeStatus detour_step(const Odometry& odom);
  /// A run of the child starts (a new edge unless resume_child() set carried_m): the edge's
  /// origin on the odometry. False on a bad distance_scale (logged, robot stopped).
  bool replay_start(const Odometry& odom);
  /// Logs `message`, halts the child, stops the robot: FAILURE.
  bt::NodeStatus replay_failed(const std::string& message);
  /// Halts the child (and the probe) where the replay stopped: the edge distance done and the
  /// detour's line start.
  void interrupt_replay(const Odometry& odom);
  // While replaying, in this order: a status ends the tick (the replay stopped or failed),
  // nullopt lets the replay go on.
  /// The IPT's new pair and the corridor ahead: a contact stops the replay to look (or to detour
  /// at once with look_frames = 0).
  std::optional<bt::NodeStatus> corridor_stop(const Odometry& odom);
  /// The drive watch (moving_near()): something moving close ahead stops the replay to look.
  std::optional<bt::NodeStatus> drive_watch_stop(const Odometry& odom);
  /// The crossing watch (kerb_near()): a person's way ahead stops the replay before it.
  std::optional<bt::NodeStatus> kerb_stop(const Odometry& odom);
  /// The standing watch (standing_ahead()): a face ahead starts the lane detour.
  std::optional<bt::NodeStatus> standing_stop(const Odometry& odom);
  /// The probing phase: one cycle of creeping on after the child gave up (failure code view_lost): enough
  /// corners ahead start the detour; the budget used fails.
  bt::NodeStatus probe_step(const Odometry& odom);
  /// The child's tick while replaying: its end ends the edge (edge_done()) or, failed, goes to
  /// child_failed().
  bt::NodeStatus child_step(const Odometry& odom);
  /// The child finished the edge: the whole edge's end shift and extra travel written, the
  /// per-edge state cleared.
  void edge_done(const Odometry& odom);
  /// One cycle of the stop-and-look phase (see the class comment).
  bt::NodeStatus look_step(const Odometry& odom);
  // The steps of look_step().
  /// Logs `message`, ends the look, stops the robot: FAILURE.
  bt::NodeStatus look_failed(const std::string& message);
  /// Creates watch_ from the ports on the first look frame; a status on failure.
  std::optional<bt::NodeStatus> make_look_watch();
  /// The crossing policy's decision on the look frame into `crossing`, logged
  /// when it changes; a status on failure.
  std::optional<bt::NodeStatus> look_crossing(const Odometry& odom, double timestamp_s,
                                              std::optional<CrossingDecision>& crossing);
  /// Nothing moved for look_frames frames: detour round a contact, wait at a person's way, back
  /// off, or resume the child.
  bt::NodeStatus look_still(const Odometry& odom, double timestamp_s);
  /// Motion was seen: one frame of waiting for the corridor to clear (or the crossing policy's go).
  bt::NodeStatus look_wait(const Odometry& odom, double timestamp_s, bool moving,
                           const std::optional<CrossingDecision>& crossing, int clear, int max_wait);
  /// The crossing policy's go while waiting: cross the person's way, or drive on to it.
  bt::NodeStatus crossing_go(const Odometry& odom, double timestamp_s, const CrossingDecision& crossing);
  /// The replay child starts again at the along-track distance reached (after a detour or a wait).
  void resume_child(const Odometry& odom, const std::string& why);
  /// The child ended the edge after the node drove off its line: writes extra_travel_m, the
  /// odometry beyond what the edge takes driven straight (`end_shift_m`: the whole edge's visual
  /// correction), when positive.
  void report_extra_travel(const Odometry& odom, double end_shift_m);
  /// While replaying: true when the ground-compensated frame difference shows something moving
  /// or standing within moving_stop_m ahead on two frames in a row (a person stepping in).
  Result<bool> moving_near(const Odometry& odom);
  /// Stops the robot and starts the stop-and-look phase.
  void begin_look(const Odometry& odom, const std::string& why);
  /// The child failed: with the probe on and failure code view_lost, start (or continue) the probe ahead
  /// (hidden_path_probe.hpp) and return RUNNING; otherwise FAILURE.
  bt::NodeStatus child_failed(const Odometry& odom);
  /// While probing: feeds the new frame to the longer-baseline
  /// triangulation (near_triangulation.hpp); returns the obstacle points it found (odom frame).
  Result<std::vector<cv::Point2d>> triangulate_near(const Odometry& odom);
  /// After a look that saw nothing move and no contact: starts backing off (backoff distance_m > 0;
  /// back_off_look.hpp) and returns true, or false when it is off. Error: bad ports.
  Result<bool> begin_backoff(const Odometry& odom);
  /// One cycle of backing off: reverse and triangulate; at the end detour (something stands
  /// ahead) or resume the child.
  bt::NodeStatus backoff_step(const Odometry& odom);
  std::optional<BackOffLook> backoff_;
  /// The back-off's frames, keyed by the negated odometer (it decreases while reversing), for the
  /// face's extent from the image when the back-off finds something (standing extent_m > 0).
  FrameTrail backoff_trail_{0.05, 1.2};
  /// After a back-off that found a face (`v`, last frame near_grey_ at `odom`): the face's full
  /// width from the image (face_extent.hpp), against the back-off's frame standing extent_m
  /// nearer the face; added to the lane detour's points, and its side chosen for that width.
  /// Logs and ignores a failure (the detour keeps the triangulated points).
  void add_backoff_extent(const Odometry& odom, const BackOffVerdict& v);
  /// While the child drives (standing min_points > 0; standing_check.hpp): feeds the frame to the
  /// triangulation and the standing watch; when it fires, stops the child and starts the lane
  /// detour with the face's points and returns the detour's first status. Error: bad ports.
  Result<std::optional<bt::NodeStatus>> standing_ahead(const Odometry& odom);
  /// Parses the group ports into p_ on the first tick; false (logged, robot stopped) on an error.
  bool read_params();
  /// Makes `next` the current phase (logged at debug level when it changes).
  void enter(Phase next);
  Phase phase_ = Phase::replaying;
  const AvoidingParams& defaults_;
  AvoidingParams p_;
  bool lane_mode_ = true;       // detour="lane" (else "thesis")
  double body_radius_m_ = 0.25;
  bool params_read_ = false;
  std::optional<StandingCheck> standing_;
  bool standing_read_ = false;
  std::uint64_t standing_sequence_ = 0;
  bool have_standing_sequence_ = false;
  cv::Mat standing_grey_;
  double backoff_again_at_m_ = -1e300;  // odometer reading before which no back-off starts

  HostServices& host_;
  PipelineRunner runner_;
  DetourDriver detour_;
  std::optional<LaneDetour> lane_;
  LaneDecision::Kind lane_kind_ = LaneDecision::Kind::blocked;
  double lane_target_m_ = 0.0;
  int lane_blocked_cycles_ = 0, lane_stall_cycles_ = 0;
  double lane_best_s_m_ = 0.0;
  CorridorMemory corridor_;
  bool saw_motion_ = false;
  int look_frames_ = 0, still_frames_ = 0, wait_frames_ = 0, settle_frames_ = 0;
  std::uint64_t watch_sequence_ = 0;
  bool have_watch_sequence_ = false;
  std::optional<MotionWatch> watch_;
  std::optional<MotionWatch> drive_watch_;  // the near corridor while driving (moving_stop_m)
  std::optional<CrossingWatch> crossing_;    // the crossing policy (crossing speed_mps > 0; crossing_watch.hpp)
  bool crossing_read_ = false;
  CrossingDecision::Kind crossing_kind_ = CrossingDecision::Kind::no_track;
  std::string crossing_head_;     // the last logged decision's reason up to its figures
  bool at_kerb_ = false;          // stopped before a person's way seen while driving
  double kerb_since_s_ = 0.0;
  Pose2D kerb_pose_;              // odometry pose of the previous driving frame (crossing watch)
  std::uint64_t kerb_sequence_ = 0;
  bool have_kerb_sequence_ = false;
  /// Creates crossing_ from the ports on the first frame (crossing speed_mps > 0). Error: bad ports.
  Status read_crossing(const cv::Mat& grey);
  /// The crossing watch while driving: true when the robot is to stop before a person's way.
  Result<bool> kerb_near(const Odometry& odom);
  /// The policy's go at a person's way `way_ahead_m` ahead with the crossing's speed_mps: the node
  /// drives across itself at that speed holding the heading (HiddenPathProbe as the driver),
  /// then the child resumes (cross_step()).
  void begin_crossing(const Odometry& odom, double way_ahead_m, const std::string& why);
  bt::NodeStatus cross_step(const Odometry& odom);
  std::optional<HiddenPathProbe> crossing_drive_;  // the driver of the crossing phase
  Pose2D drive_watch_pose_;
  std::uint64_t drive_sequence_ = 0;
  bool have_drive_sequence_ = false;
  ShimmerTrigger drive_shimmer_;            // the near corridor's count against the texture's shimmer level
  ChangeShape stop_shape_;                  // the changed pixels that stopped the robot (drive watch)
  bool stop_by_drive_watch_ = false;        // the last stop-and-look began on the drive watch
  cv::Mat shape_labels_, shape_stats_, shape_centroids_;
  double drive_quiet_until_m_ = -1e300;     // odometer reading before which moving_near() is not asked
  cv::Mat watch_grey_;
  bool child_started_ = false;
  double replay_origin_m_ = 0.0;   // odometry distance at which the edge counts as 0
  double scale_ = 1.0;             // odometric metres per taught metre (distance_scale port)
  double replay_done_m_ = 0.0;     // edge distance covered when the detour began
  double carried_shift_m_ = 0.0;   // the child's along-track corrections carried over its restarts, taught m
  bool child_ran_ = false;         // the child was ticked since its last (re)start: its shift_m is its own
  bool resumed_ = false;           // resume_child() set carried_m for the next start (not a new edge)
  bool moved_off_line_ = false;    // this edge had a detour, back-off, probe or crossing (extra_travel_m)
  double edge_start_odometer_m_ = 0.0;  // odometer when the edge's child first started
  double edge_start_carried_m_ = 0.0;   // carried_m then (FollowRoute's), taught m
  std::optional<HiddenPathProbe> probe_;  // made at the first probe (probe group)
  std::string probe_reason_;       // the child's failure that started the probe
  std::optional<NearTriangulation> near_;   // made at the first probe
  std::vector<cv::Point2d> near_points_;    // the probe's triangulated points, for the lane detour
  std::uint64_t near_sequence_ = 0;
  bool have_near_sequence_ = false;
  cv::Mat near_grey_;
  Pose2D detour_start_;
};

/// ReplayAvoiding under a second node ID with the path-following edges' defaults
/// (path_replay_defaults(): the probe, the back-off and the standing watch on): FollowRoute picks
/// a child per edge kind by node ID, and a decorator has one child.
class ReplayPathAvoiding : public ReplayAvoiding {
 public:
  ReplayPathAvoiding(const std::string& name, const bt::NodeConfig& config, HostServices& host)
      : ReplayAvoiding(name, config, host, path_replay_defaults()) {}
  static bt::PortsList provided_ports() { return ports_with(path_replay_defaults()); }
};

Status register_ipt_nodes(bt::NodeRegistry& registry, HostServices& host);

}  // namespace visnav::ipt
