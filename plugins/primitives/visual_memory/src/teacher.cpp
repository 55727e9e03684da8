#include "visnav/visual_memory/teacher.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace visnav::visual_memory {

void to_grey(const cv::Mat& image, cv::Mat& grey) {
  if (image.type() == CV_8UC1) grey = image;
  else if (image.type() == CV_8UC3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  else grey.release();
}

MemoryTeacher::MemoryTeacher(const TeachParams& params) : params_(params) {
  klt_ = {params.klt_window_px, params.klt_levels, params.klt_max_fb_error_px};
  geometry_ = {params.min_baseline_m, params.ransac_threshold_px, params.estimator, params.max_triangulation_error_px,
               params.min_parallax_deg};
}

Result<MemoryTeacher> MemoryTeacher::create(const TeachParams& params) {
  VISNAV_TRY(params.validate());
  return MemoryTeacher(params);
}

void MemoryTeacher::detect_more(const cv::Mat& grey) {
  const int wanted = params_.max_features - static_cast<int>(tracks_.size());
  if (wanted <= 0) return;
  cv::Mat mask(grey.size(), CV_8UC1, cv::Scalar(255));
  const int r = static_cast<int>(std::ceil(params_.min_corner_distance_px));
  for (const auto& p : tracks_) cv::circle(mask, p, r, cv::Scalar(0), -1);
  std::vector<cv::Point2f> corners;
  cv::goodFeaturesToTrack(grey, corners, wanted, params_.harris_quality, params_.min_corner_distance_px, mask, 3, true,
                          params_.harris_k);
  if (!corners.empty())
    cv::cornerSubPix(grey, corners, cv::Size(3, 3), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 10, 0.03));
  // cornerSubPix may move a corner at the border a hair outside the image (-0.002 px seen on the
  // campus route), which the payload decoder rightly rejects: keep corners inside [0, size - 1].
  const float max_x = static_cast<float>(grey.cols - 1), max_y = static_cast<float>(grey.rows - 1);
  for (const auto& c : corners) {
    tracks_.push_back({std::clamp(c.x, 0.0f, max_x), std::clamp(c.y, 0.0f, max_y)});
    track_ids_.push_back(next_id_++);
  }
}

TeachFrameResult MemoryTeacher::make_reference(const std::string& reason) {
  TeachFrameResult out;
  out.new_reference = true;
  out.reason = reason;
  Reference ref;
  ref.distance_m = last_distance_m_;
  ref.heading_rad = last_odometry_.pose.heading_rad;
  ref.image = previous_.clone();
  if (!memory_.references.empty()) {
    const Reference& prev = memory_.references.back();
    std::vector<cv::Point2f> a, b;
    for (std::size_t j = 0; j < tracks_.size(); ++j) {
      const int k = prev.find(track_ids_[j]);
      if (k < 0) continue;
      a.push_back(prev.points_px[static_cast<std::size_t>(k)]);
      b.push_back(tracks_[j]);
    }
    const double baseline_m = std::hypot(last_odometry_.pose.x_m - reference_pose_.x_m,
                                         last_odometry_.pose.y_m - reference_pose_.y_m);
    const RelativeGeometry g = relative_geometry(a, b, intrinsics_, baseline_m, geometry_);
    out.geometry = g.status;
    if (g.status == GeometryStatus::ok) {
      ref.R_from_prev = g.R;
      ref.t_from_prev_m = g.t_m;
    } else {
      // Odometric relative pose: rotation about the camera's y axis by the heading change,
      // forward translation by the baseline (the camera looks along the robot's x).
      const double dth = last_odometry_.pose.heading_rad - reference_pose_.heading_rad;
      ref.R_from_prev = cv::Matx33d(std::cos(dth), 0, std::sin(dth), 0, 1, 0, -std::sin(dth), 0, std::cos(dth));
      ref.t_from_prev_m = cv::Vec3d(0, 0, -baseline_m);
    }
    // has_3d per current track, from the correspondence order above
    std::size_t c = 0;
    ref.ids = track_ids_;
    ref.points_px = tracks_;
    ref.has_3d.assign(tracks_.size(), 0);
    ref.points3d_m.assign(tracks_.size(), cv::Point3f(0, 0, 0));
    for (std::size_t j = 0; j < tracks_.size(); ++j) {
      if (prev.find(track_ids_[j]) < 0) continue;
      if (g.status == GeometryStatus::ok && g.has_3d[c]) {
        ref.has_3d[j] = 1;
        ref.points3d_m[j] = g.points_m[c];
      }
      ++c;
    }
    if (ref.count_3d() == 0) ++without_3d_;
  }
  // Top up the tracker with new corners; they belong to this reference too.
  detect_more(previous_);
  ref.ids = track_ids_;
  ref.points_px = tracks_;
  ref.has_3d.resize(tracks_.size(), 0);
  ref.points3d_m.resize(tracks_.size(), cv::Point3f(0, 0, 0));
  if (memory_.references.empty()) ++without_3d_;
  memory_.references.push_back(std::move(ref));
  reference_distance_m_ = last_distance_m_;
  reference_pose_ = last_odometry_.pose;
  reference_poses_.push_back(reference_pose_);
  last_is_reference_ = true;
  out.tracked = static_cast<int>(tracks_.size());
  return out;
}

Result<TeachFrameResult> MemoryTeacher::add_frame(const cv::Mat& image, const Odometry& odometry, double edge_distance_m) {
  cv::Mat grey;
  to_grey(image, grey);
  if (grey.empty()) return fail("frame is empty or not 8-bit grey/BGR");
  if (memory_.width_px == 0) {
    memory_.width_px = grey.cols;
    memory_.height_px = grey.rows;
    intrinsics_ = Intrinsics::from_fov(grey.cols, grey.rows, params_.camera.horizontal_fov_deg);
    memory_.focal_px = intrinsics_.focal_px;
  } else if (grey.cols != memory_.width_px || grey.rows != memory_.height_px) {
    return fail("frame size changed during the teach");
  }
  const cv::Mat last = previous_;
  previous_ = grey.clone();
  last_odometry_ = odometry;
  last_distance_m_ = edge_distance_m;
  last_is_reference_ = false;
  if (memory_.references.empty()) return make_reference("first frame");

  std::vector<cv::Point2f> moved;
  std::vector<std::uint8_t> ok;
  track_klt(last, previous_, tracks_, moved, ok, klt_);
  std::vector<cv::Point2f> kept;
  std::vector<std::int32_t> kept_ids;
  for (std::size_t j = 0; j < tracks_.size(); ++j)
    if (ok[j]) {
      kept.push_back(moved[j]);
      kept_ids.push_back(track_ids_[j]);
    }
  tracks_ = std::move(kept);
  track_ids_ = std::move(kept_ids);

  const Reference& ref = memory_.references.back();
  TeachFrameResult out;
  out.tracked = 0;
  std::vector<cv::Point2f> a, b;
  for (std::size_t j = 0; j < tracks_.size(); ++j) {
    const int k = ref.find(track_ids_[j]);
    if (k < 0) continue;
    ++out.tracked;
    a.push_back(ref.points_px[static_cast<std::size_t>(k)]);
    b.push_back(tracks_[j]);
  }
  const double since_m = edge_distance_m - reference_distance_m_;
  if (since_m < params_.min_reference_spacing_m && out.tracked >= 5) return out;
  const double kept_share = ref.ids.empty() ? 0.0 : static_cast<double>(out.tracked) / static_cast<double>(ref.ids.size());
  if (kept_share < 1.0 - params_.lost_fraction || out.tracked < 5) return make_reference("features lost");
  if (since_m >= params_.max_reference_spacing_m) return make_reference("maximum spacing");
  // Seed 003: "if the 3D reconstruction error is low ... a new image is acquired".
  const RelativeGeometry g = relative_geometry(a, b, intrinsics_, 0.0, geometry_);
  if (g.inliers > 0 && g.rms_error_px > params_.max_reconstruction_error_px) return make_reference("reconstruction error");
  return out;
}

Result<VisualMemory> MemoryTeacher::finish() {
  if (memory_.references.empty()) return fail("no usable frame on the edge");
  if (!last_is_reference_) {
    // The goal image ends the chain. A reference made just before the end (closer than
    // min_reference_spacing_m) would leave the goal without baseline, hence without 3D points
    // and without the pose that recognises it: it gives way to the goal.
    if (memory_.references.size() >= 2 && last_distance_m_ - reference_distance_m_ < params_.min_reference_spacing_m) {
      if (memory_.references.back().count_3d() == 0) --without_3d_;
      memory_.references.pop_back();
      reference_poses_.pop_back();
      reference_pose_ = reference_poses_.back();
      reference_distance_m_ = memory_.references.back().distance_m;
    }
    (void)make_reference("goal");
  }
  return memory_;
}

}  // namespace visnav::visual_memory
