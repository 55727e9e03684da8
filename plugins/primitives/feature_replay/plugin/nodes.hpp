// feature_replay plugin — behaviour-tree adapters over the core (issue 4, item 5):
//
//  * TeachFeatureEdge  — records one map edge while the operator drives: style "segment" (map
//    style A, seed 000 Algorithm 1, edge kind `feature_segment`) or "localmaps" (map style B,
//    seed 002 Sec. 2.3, edge kind `feature_localmaps`, with the operator's (v, ω) taken from the
//    odometry twist). Never commands the robot.
//  * ReplayFeatureEdge — traverses an edge of either kind (seed 000 Algorithm 2 / seed 002
//    Sec. 2.4): newest frame → active detector → replayer → Robot::send_command, one NavStatus
//    per processed frame on HostServices::telemetry().
//
// Both follow the primitive protocol of docs/navigation.md (ports `{edge}`; `{edge_from}`,
// `{edge_to}`, `{finish_edge}`, `{taught_edge}`; statistic `end_heading_rad`). Ports and tuned
// defaults: docs/feature_replay.md, section "Behaviour-tree nodes".
//
// Frames: a frame is processed once (Frame::sequence must grow); ticks without a new frame
// re-send the last command (replay) or only record odometry (teach). Distances are
// Odometry::distance_m differences; headings are odom-frame radians, CCW positive.
// Allocation: the Features buffer and the core's buffers are reused frame to frame.
// Thread-safety: tick thread only; the HostServices reference outlives the tree.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "visnav/bt/node.hpp"
#include "visnav/nav_health.hpp"
#include "visnav/feature_replay/local_map.hpp"
#include "visnav/feature_replay/segment_map.hpp"
#include "visnav/host.hpp"

namespace visnav::feature_replay {

/// Edge kinds written by TeachFeatureEdge and read by ReplayFeatureEdge.
inline constexpr const char* kSegmentKind = "feature_segment";
inline constexpr const char* kLocalMapsKind = "feature_localmaps";

class TeachFeatureEdge final : public bt::StatefulActionNode {
 public:
  TeachFeatureEdge(const std::string& name, const bt::NodeConfig& config, HostServices& host);
  static bt::PortsList provided_ports();

  bt::NodeStatus on_start() override;
  bt::NodeStatus on_running() override;
  void on_halted() override;

 private:
  enum class Style : std::uint8_t { segment, localmaps };

  bt::NodeStatus failed(const std::string& message);
  /// Records odometry (style B command) and the newest frame if it is new.
  Status record(const Odometry& odom);
  bt::NodeStatus finish(const Odometry& odom);
  Result<std::string> resolve_or_create_node(const std::string& id_or_name, const char* default_name,
                                             const Pose2D& hint);

  HostServices& host_;
  Style style_ = Style::segment;
  std::optional<SegmentTeacher> segment_;
  std::optional<LocalMapTeacher> localmaps_;
  Features features_;
  std::uint64_t last_sequence_ = 0;
  bool have_frame_ = false;
  cv::Mat last_image_;
  double start_distance_m_ = 0.0;
  Pose2D start_pose_;
  std::uint64_t frames_ = 0;
  std::uint64_t bad_frames_ = 0;
  int image_width_px_ = 0;
  int image_height_px_ = 0;
  double min_record_speed_mps_ = 0.02;
};

class ReplayFeatureEdge final : public bt::StatefulActionNode {
 public:
  ReplayFeatureEdge(const std::string& name, const bt::NodeConfig& config, HostServices& host);
  static bt::PortsList provided_ports();

  bt::NodeStatus on_start() override;
  bt::NodeStatus on_running() override;
  void on_halted() override;

 private:
  bt::NodeStatus failed(const std::string& message);
  Status load_edge();
  /// One frame of the start-view search; returns the status to report, or nullopt once driving.
  std::optional<bt::NodeStatus> search_start_view(Robot& robot, const Odometry& odom, double confidence,
                                                  double offset_fraction);

  HostServices& host_;
  std::string edge_id_;
  std::string from_node_;
  std::optional<SegmentReplayer> segment_;
  std::optional<LocalMapReplayer> localmaps_;
  Features features_;
  std::uint64_t last_sequence_ = 0;
  bool have_frame_ = false;
  Twist last_command_;
  int expected_width_px_ = 0;   ///< from the edge statistics (0 = unknown)
  int expected_height_px_ = 0;
  ReplayState last_state_ = ReplayState::steering;
  bool warned_bad_frame_ = false;
  NavStatus status_;
  NavHealthMonitor health_;
  TaughtHeading taught_heading_;
  double max_angular_radps_ = 0.5;
  double max_correction_radps_ = 0.3;
  int laps_ = 1;
  int min_expected_features_ = 15;
  // Start-view search (scan_deg > 0): when the first frames of an edge do not see the taught
  // start view, the robot turns in place left then right by up to scan_deg, remembers the
  // heading with the best match, turns there and starts the edge. An odometric turn at a node
  // carries the teach run's heading drift (e.g. the turn that closes a loop: the whole loop's
  // drift); this finds the view instead. The probe must see the view near the image centre: a
  // view 40 deg off still overlaps a 60 deg camera's image enough for a confident match. When nothing matches it starts on the odometric heading
  // and the lost policy decides.
  enum class StartPhase : std::uint8_t { probe, scan_left, scan_right, turn_to_best, driving };
  StartPhase phase_ = StartPhase::driving;
  double scan_rad_ = 0.0;
  double scan_speed_radps_ = 0.4;
  double scan_last_rad_ = 0.0;      // previous heading (unwrapping)
  double scan_turned_rad_ = 0.0;    // unwrapped turn since the scan started
  double best_turn_rad_ = 0.0;
  double best_confidence_ = -1.0;
  double best_score_ = -1.0;        // confidence weighted by how centred the view is
  double start_max_offset_ = 0.15;  // probe passes only with |offset| <= this fraction of the width
  int probe_frames_ = 0;
  double probe_confidence_sum_ = 0.0;
  double probe_offset_sum_ = 0.0;   // sum of |offset_px| / width over the probe frames
  std::string edge_kind_;
};

}  // namespace visnav::feature_replay
