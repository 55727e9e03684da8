// ReplayAvoiding's standing-obstacle watch while the child drives (see standing_check.hpp).
#include "standing_check.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

#include "nodes.hpp"

namespace visnav::ipt {

std::string describe_extent(const FaceExtent& e) {
  return std::string(e.found ? "" : "no face found, ") + std::to_string(e.right_m) + " to " + std::to_string(e.left_m) +
         " m left, " + std::to_string(e.range_m) + " m ahead (" + std::to_string(e.face_columns) + " face, " +
         std::to_string(e.other_columns) + " other columns" + (e.clipped_right ? ", to the image's right edge" : "") +
         (e.clipped_left ? ", to the image's left edge" : "") + ")";
}

void steer_by_extent(LaneDetour& lane, double seen_right_m, double seen_left_m, const FaceExtent& e) {
  if (!e.found) return;
  lane.add_points(e.points);
  // The side for the face's whole width: its points may lie beyond the detour's lookahead,
  // where the first decision would not see them.
  lane.prefer_side(side_past(std::min(seen_right_m, e.right_m), std::max(seen_left_m, e.left_m)));
}

Result<std::optional<StandingCheck>> StandingCheck::create(const StandingPortParams& standing,
                                                          double corridor_half_width_m) {
  if (standing.min_points == 0) return std::optional<StandingCheck>{};
  if (auto st = standing.validate(); !st) return st.error().with_context("port 'standing'");
  StandingWatchParams params;
  params.min_points = standing.min_points;
  params.one_batch_points = standing.one_batch_points;
  params.depth_band_m = standing.depth_m;
  params.max_range_m = standing.range_m;
  params.min_width_m = standing.min_width_m;
  params.corridor_half_width_m = corridor_half_width_m;
  if (auto st = params.validate(); !st) return st.error().with_context("ports 'standing', 'corridor'");
  return std::optional<StandingCheck>(StandingCheck(params, standing.min_range_m, standing.extent_m, standing.min_face_share));
}

Result<StandingVerdict> StandingCheck::observe(const cv::Mat& grey, const IptCamera& camera, const Pose2D& pose,
                                               double odometer_m, int& new_points) {
  if (!have_last_ || std::fabs(odometer_m - last_odometer_m_) > 0.1) reset();
  have_last_ = true;
  last_odometer_m_ = odometer_m;
  if (!near_) {
    VISNAV_ASSIGN(auto made, NearTriangulation::create(camera, StandingWatch::triangulation_params()));
    near_.emplace(std::move(made));
  }
  VISNAV_ASSIGN(const auto points, near_->observe(grey, pose));
  if (extent_baseline_m_ > 0.0) trail_.add(grey, pose, odometer_m);
  ground_.clear();
  for (const auto& p : points) ground_.push_back(p.ground_m);
  new_points = static_cast<int>(ground_.size());
  return watch_.add(ground_, pose, odometer_m);
}

Result<std::optional<FaceExtent>> StandingCheck::extent(const cv::Mat& grey, const IptCamera& camera, const Pose2D& pose,
                                                         double odometer_m, const StandingVerdict& verdict) const {
  if (extent_baseline_m_ <= 0.0) return std::optional<FaceExtent>{};
  const FrameTrail::Kept* earlier = trail_.back(odometer_m, extent_baseline_m_);
  if (earlier == nullptr) return std::optional<FaceExtent>{};
  VISNAV_ASSIGN(FaceExtent e, face_extent(camera, earlier->grey, earlier->pose, grey, pose, verdict.range_m,
                                          verdict.right_m, verdict.left_m, FaceExtentParams{}));
  return std::optional<FaceExtent>(std::move(e));
}

Result<std::optional<bt::NodeStatus>> ReplayAvoiding::standing_ahead(const Odometry& odom) {
  if (!standing_read_) {
    VISNAV_ASSIGN(standing_, StandingCheck::create(p_.standing, p_.corridor.corridor_half_width_m));
    standing_read_ = true;
  }
  if (!standing_) return std::optional<bt::NodeStatus>{};
  FrameBus* bus = host_.frame_bus();
  auto frame = bus != nullptr ? bus->latest_frame() : std::nullopt;
  if (!frame || frame->image.empty() || (have_standing_sequence_ && frame->sequence == standing_sequence_))
    return std::optional<bt::NodeStatus>{};
  have_standing_sequence_ = true;
  standing_sequence_ = frame->sequence;
  if (frame->image.channels() == 3) cv::cvtColor(frame->image, standing_grey_, cv::COLOR_BGR2GRAY);
  else standing_grey_ = frame->image;
  VISNAV_ASSIGN(const IptCamera camera, ipt_camera(host_, standing_grey_));
  int new_points = 0;
  VISNAV_ASSIGN(const StandingVerdict v, standing_->observe(standing_grey_, camera, odom.pose, odom.distance_m, new_points));
  if (new_points > 0 && v.in_face > 0)
    host_.logger().log(LogLevel::debug, path(),
                       "standing watch: " + std::to_string(new_points) + " new corners; face " + std::to_string(v.in_face) +
                           " corners from " + std::to_string(v.batches) + " triangulations " + std::to_string(v.range_m) +
                           " m ahead, " + std::to_string(v.right_m) + " to " + std::to_string(v.left_m) + " m left");
  if (!v.found || v.range_m < standing_->min_range_m()) return std::optional<bt::NodeStatus>{};
  halt_child();
  if (Robot* robot = host_.robot()) (void)robot->stop();
  replay_done_m_ = odom.distance_m - replay_origin_m_;
  detour_start_ = odom.pose;
  host_.logger().info(path(), "standing obstacle: " + std::to_string(v.in_face) + " corners from " +
                                  std::to_string(v.batches) + " triangulations in the corridor " +
                                  std::to_string(v.range_m) + " m ahead at " + std::to_string(replay_done_m_) +
                                  " m of the edge, points from " + std::to_string(v.right_m) + " to " +
                                  std::to_string(v.left_m) + " m left of the heading: detour");
  VISNAV_ASSIGN(const auto extent, standing_->extent(standing_grey_, camera, odom.pose, odom.distance_m, v));
  if (extent) host_.logger().info(path(), "standing obstacle's extent from the image: " + describe_extent(*extent));
  if (extent && extent->face_share() < standing_->min_face_share()) {
    // The corners were not a face the image shows (ground texture triangulated above the ground):
    // a detour on them drives blind beside the line for the obstacle's assumed length.
    standing_->reset();
    resume_child(odom, "standing watch dropped: the image shows no standing face there (face share " +
                           std::to_string(extent->face_share()) + " < the standing watch's min_face_share " +
                           std::to_string(standing_->min_face_share()) + ")");
    return std::optional<bt::NodeStatus>(bt::NodeStatus::running);
  }
  const bt::NodeStatus st = begin_detour(odom);
  if (lane_) lane_->add_points(v.points);
  if (lane_ && extent) steer_by_extent(*lane_, v.right_m, v.left_m, *extent);
  standing_->reset();
  return std::optional<bt::NodeStatus>(st);
}

}  // namespace visnav::ipt
