#include "visnav/visual_memory/follower.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>

#include "visnav/visual_memory/teacher.hpp"

namespace visnav::visual_memory {

const char* to_string(FollowStatus s) {
  switch (s) {
    case FollowStatus::following: return "following";
    case FollowStatus::no_pose: return "following without pose";
    case FollowStatus::switched: return "switched reference";
    case FollowStatus::relocalised: return "relocalised";
    case FollowStatus::lost: return "lost: relocalising";
    case FollowStatus::bad_frame: return "bad frame";
    case FollowStatus::goal: return "goal reached";
    case FollowStatus::goal_by_odometry: return "goal by odometry";
    case FollowStatus::failed: return "failed";
  }
  return "?";
}

MemoryFollower::MemoryFollower(const ReplayParams& params, VisualMemory memory, double edge_length_m, Controller controller)
    : params_(params), memory_(std::move(memory)), edge_length_m_(edge_length_m), controller_(controller) {
  intrinsics_ = Intrinsics::from_fov(memory_.width_px, memory_.height_px, params.camera.horizontal_fov_deg);
  klt_ = {params.klt_window_px, params.klt_levels, params.klt_max_fb_error_px};
  gains_ = {params.centroid_gain_radps, params.centroid_statistic == "median", params.lambda, params.uniform_depth_m};
  orb_cache_.resize(memory_.references.size());
  set_target(memory_.references.size() > 1 ? 1 : 0);
}

Result<MemoryFollower> MemoryFollower::create(const ReplayParams& params, VisualMemory memory, double edge_length_m) {
  VISNAV_TRY(params.validate());
  const auto controller = controller_from_string(params.controller);
  if (!controller) return Error{"unknown controller '" + params.controller + "'", ErrorCode::out_of_range};
  if (memory.references.empty()) return fail("the visual memory has no reference");
  return MemoryFollower(params, std::move(memory), edge_length_m, *controller);
}

void MemoryFollower::set_target(int index) {
  target_ = index;
  const Reference& ref = memory_.references[static_cast<std::size_t>(index)];
  points_ = ref.points_px;
  tracked_.assign(ref.points_px.size(), 0);
  have_min_error_ = false;
}

double MemoryFollower::taught_offset_norm(int from) const {
  if (from + 1 >= static_cast<int>(memory_.references.size()) || from < 0) return 0.0;
  const Reference& a = memory_.references[static_cast<std::size_t>(from)];
  const Reference& b = memory_.references[static_cast<std::size_t>(from + 1)];
  double sum = 0.0;
  int n = 0;
  for (std::size_t j = 0; j < b.ids.size(); ++j) {
    const int k = a.find(b.ids[j]);
    if (k < 0) continue;
    sum += intrinsics_.normalise(b.points_px[j]).x - intrinsics_.normalise(a.points_px[static_cast<std::size_t>(k)]).x;
    ++n;
  }
  return n > 0 ? sum / n : 0.0;
}

bool MemoryFollower::relocalise(const cv::Mat& grey) {
  const bool sift = params_.relocalise_detector == "sift";
  if (!orb_) {
    if (sift) orb_ = cv::SIFT::create(params_.orb_features);
    else orb_ = cv::ORB::create(params_.orb_features);
  }
  std::vector<cv::KeyPoint> kp;
  cv::Mat desc;
  try {
    orb_->detectAndCompute(grey, cv::noArray(), kp, desc);
  } catch (const cv::Exception&) {
    return false;
  }
  if (desc.empty()) return false;
  const int count = static_cast<int>(memory_.references.size());
  const int lo = std::max(count > 1 ? 1 : 0, target_ - params_.relocalise_window);
  const int hi = std::min(count - 1, target_ + params_.relocalise_window);
  cv::BFMatcher matcher(sift ? cv::NORM_L2 : cv::NORM_HAMMING);
  int best = -1, best_inliers = 0;
  cv::Mat best_H;
  for (int k = lo; k <= hi; ++k) {
    auto& cache = orb_cache_[static_cast<std::size_t>(k)];
    if (!cache) {
      std::vector<cv::KeyPoint> rk;
      cv::Mat rd;
      try {
        orb_->detectAndCompute(memory_.references[static_cast<std::size_t>(k)].image, cv::noArray(), rk, rd);
      } catch (const cv::Exception&) {
        rk.clear();
        rd.release();
      }
      cache.emplace(std::move(rk), std::move(rd));
    }
    if (cache->second.empty()) continue;
    std::vector<std::vector<cv::DMatch>> knn;
    matcher.knnMatch(cache->second, desc, knn, 2);
    std::vector<cv::Point2f> a, b;
    for (const auto& m : knn)
      if (m.size() == 2 && m[0].distance < params_.orb_ratio * m[1].distance) {
        a.push_back(cache->first[static_cast<std::size_t>(m[0].queryIdx)].pt);
        b.push_back(kp[static_cast<std::size_t>(m[0].trainIdx)].pt);
      }
    if (static_cast<int>(a.size()) < params_.min_relocalise_inliers) continue;
    cv::Mat mask;
    cv::Mat H;
    try {
      H = cv::findHomography(a, b, cv::RANSAC, 4.0, mask);
    } catch (const cv::Exception&) {
      H.release();
    }
    if (H.empty() || !cv::checkRange(H)) continue;
    const int inliers = cv::countNonZero(mask);
    if (inliers > best_inliers) {
      best_inliers = inliers;
      best = k;
      best_H = H;
    }
  }
  if (best < 0 || best_inliers < params_.min_relocalise_inliers) return false;
  set_target(best);
  const Reference& ref = memory_.references[static_cast<std::size_t>(best)];
  std::vector<cv::Point2f> guess;
  cv::perspectiveTransform(ref.points_px, guess, best_H);
  std::vector<std::uint8_t> ok;
  track_klt(ref.image, as_reference_lit(grey, ref.image), ref.points_px, guess, ok, klt_, true);
  int n = 0;
  for (std::size_t j = 0; j < ok.size(); ++j) {
    tracked_[j] = ok[j];
    if (ok[j]) {
      points_[j] = guess[j];
      ++n;
    }
  }
  return n >= params_.min_tracked;
}

const cv::Mat& MemoryFollower::as_reference_lit(const cv::Mat& grey, const cv::Mat& reference) {
  if (!params_.illumination_compensation) return grey;
  // Global affine (gain, offset) brightness model: the frame's mean and standard deviation are
  // mapped onto the reference image's before tracking from the reference.
  cv::Scalar mc, sc, mr, sr;
  cv::meanStdDev(grey, mc, sc);
  cv::meanStdDev(reference, mr, sr);
  const double gain = sc[0] > 1e-3 ? sr[0] / sc[0] : 1.0;
  grey.convertTo(lit_, CV_8U, gain, mr[0] - gain * mc[0]);
  return lit_;
}

PoseEstimate MemoryFollower::pose_now() const {
  const Reference& ref = memory_.references[static_cast<std::size_t>(target_)];
  std::vector<cv::Point3f> p3;
  std::vector<cv::Point2f> p2;
  for (std::size_t j = 0; j < tracked_.size(); ++j)
    if (tracked_[j] && ref.has_3d[j]) {
      p3.push_back(ref.points3d_m[j]);
      p2.push_back(points_[j]);
    }
  return estimate_pose(p3, p2, intrinsics_, params_.min_pose_points, params_.reprojection_gate_px * 0.5);
}

int MemoryFollower::resume_by_projection(const PoseEstimate& pose, const cv::Mat& grey, int* dropped) {
  const Reference& ref = memory_.references[static_cast<std::size_t>(target_)];
  std::vector<cv::Point2f> from, guess, predicted;
  std::vector<std::size_t> which;
  const float margin = static_cast<float>(params_.klt_window_px);
  const double gate2 = params_.reprojection_gate_px * params_.reprojection_gate_px;
  for (std::size_t j = 0; j < tracked_.size(); ++j) {
    if (!ref.has_3d[j]) continue;
    cv::Point2f p;
    if (!project(pose, ref.points3d_m[j], intrinsics_, p)) continue;
    if (tracked_[j]) {
      const cv::Point2f d = points_[j] - p;
      if (d.dot(d) > gate2) {
        tracked_[j] = 0;
        if (dropped != nullptr) ++*dropped;
      }
      continue;
    }
    if (p.x < margin || p.y < margin || p.x > grey.cols - 1 - margin || p.y > grey.rows - 1 - margin) continue;
    from.push_back(ref.points_px[j]);
    guess.push_back(p);
    predicted.push_back(p);
    which.push_back(j);
  }
  if (which.empty()) return 0;
  std::vector<std::uint8_t> ok;
  track_klt(ref.image, as_reference_lit(grey, ref.image), from, guess, ok, klt_, true);
  int resumed = 0;
  for (std::size_t k = 0; k < which.size(); ++k) {
    const cv::Point2f d = guess[k] - predicted[k];
    if (!ok[k] || d.dot(d) > gate2) continue;
    tracked_[which[k]] = 1;
    points_[which[k]] = guess[k];
    ++resumed;
  }
  return resumed;
}

void MemoryFollower::control(FollowStep& out, const PoseEstimate& pose) {
  const Reference& ref = memory_.references[static_cast<std::size_t>(target_)];
  ControlInput in;
  in.speed_mps = params_.speed_mps;
  in.camera_forward_m = params_.camera.camera_forward_m;
  std::vector<cv::Point2f> cur_px, ref_px;
  ControlInput depth_in = in;  // the 3D subset, for IJP/IJC
  for (std::size_t j = 0; j < tracked_.size(); ++j) {
    if (!tracked_[j]) continue;
    const cv::Point2d c = intrinsics_.normalise(points_[j]), r = intrinsics_.normalise(ref.points_px[j]);
    in.current_norm.push_back(c);
    in.reference_norm.push_back(r);
    cur_px.push_back(points_[j]);
    ref_px.push_back(ref.points_px[j]);
    if (!ref.has_3d[j]) continue;
    double z = ref.points3d_m[j].z;  // without a pose: the taught depth in I_i
    cv::Point2f unused;
    if (pose.ok && !project(pose, ref.points3d_m[j], intrinsics_, unused, &z)) continue;
    depth_in.current_norm.push_back(c);
    depth_in.reference_norm.push_back(r);
    depth_in.depth_m.push_back(z);
  }
  out.image_error_px = image_error_px(cur_px, ref_px);
  double offset = 0.0;
  for (std::size_t k = 0; k < in.current_norm.size(); ++k) offset += in.current_norm[k].x - in.reference_norm[k].x;
  out.offset_norm = in.current_norm.empty() ? 0.0 : offset / static_cast<double>(in.current_norm.size());
  if (pose.ok) in.heading_change_rad = pose.heading_change_rad();

  const bool use_depth = controller_ == Controller::IJP || controller_ == Controller::IJC;
  ControlOutput law = compute_control(controller_, use_depth ? depth_in : in, gains_);
  if (!law.angular_radps) {
    const std::string why = law.reason;
    law = compute_control(Controller::AIJCA, in, gains_);
    out.detail = "fallback AIJCA: " + why;
  }
  double omega = law.angular_radps.value_or(0.0);
  if (!law.angular_radps) out.detail += (out.detail.empty() ? "" : "; ") + law.reason;
  if (pose.ok) {
    // The image laws align the view, which leaves a lateral offset to decay only as fast as the
    // features' mean inverse depth (docs/visual_memory.md). Camera x is right: a robot right of
    // the taught line (x > 0) turns left (ω > 0).
    // Measured from the taught chord previous reference → I_i, not from I_i's optical axis: on
    // a curve the axis leaves the taught path behind I_i by the sagitta (κd²/2, 0.1 m at 0.7 m
    // on a 2.2 m radius), the chord by a quarter of that.
    const cv::Vec3d p = pose.position_in_reference_m();
    double path_x_m = 0.0;
    if (target_ > 0) {
      const cv::Vec3d& prev = ref.t_from_prev_m;  // the previous reference's camera in I_i's frame
      if (prev[2] < -1e-3) path_x_m = prev[0] * (p[2] / prev[2]);
    }
    out.lateral_m = p[0] - path_x_m;
    if (law.angular_radps && params_.lateral_gain_radps_per_m > 0.0 && std::isfinite(out.lateral_m)) {
      omega += params_.lateral_gain_radps_per_m * std::clamp(out.lateral_m, -params_.lateral_clamp_m, params_.lateral_clamp_m);
    }
  }
  out.saturated = std::abs(omega) > params_.max_angular_radps;
  omega = std::clamp(omega, -params_.max_angular_radps, params_.max_angular_radps);
  out.turning = std::abs(out.offset_norm) > params_.turn_offset_norm ||
                std::abs(taught_offset_norm(target_)) > params_.turn_offset_norm;
  const double v = out.turning ? params_.turn_speed_mps : params_.speed_mps;
  out.command = std::isfinite(omega) ? Twist{v, omega} : Twist{};
}

FollowStep MemoryFollower::step(const cv::Mat& image, double edge_distance_m) {
  FollowStep out;
  try {
    cv::Mat grey;
    to_grey(image, grey);
    if (grey.empty() || grey.cols != memory_.width_px || grey.rows != memory_.height_px) {
      out.status = FollowStatus::bad_frame;
      out.detail = grey.empty() ? "empty or not 8-bit grey/BGR" : "frame size differs from the taught one";
      out.target = target_;
      return out;
    }
    out = process(grey, edge_distance_m);
    previous_ = grey.clone();
  } catch (const std::exception& e) {
    out = FollowStep{};
    out.status = FollowStatus::bad_frame;
    out.detail = std::string("internal error: ") + e.what();
    initialised_ = false;
  }
  if (!std::isfinite(out.command.linear_mps) || !std::isfinite(out.command.angular_radps)) out.command = Twist{};
  return out;
}

FollowStep MemoryFollower::process(const cv::Mat& grey, double edge_distance_m) {
  FollowStep out;
  if (edge_distance_m > edge_length_m_ + params_.goal_overshoot_m) {
    out.status = FollowStatus::goal_by_odometry;
    out.target = target_;
    return out;
  }
  bool relocalised = false;
  if (initialised_) track_points(grey);
  if (!initialised_ || count_tracked() < params_.min_tracked) {
    if (!relocalise(grey)) {
      report_lost(out);
      return out;
    }
    initialised_ = true;
    relocalised = true;
  }
  lost_frames_ = 0;

  PoseEstimate pose = pose_now();
  if (pose.ok) {
    out.resumed = resume_by_projection(pose, grey, &out.dropped);
    pose = pose_now();
  }

  // Switching / goal.
  const SwitchDecision decision = decide_switch(pose, edge_distance_m);
  if (decision.passed && decision.last) {
    out.status = FollowStatus::goal;
    out.detail = decision.how;
    out.target = target_;
    out.image_error_px = decision.error_px;
    return out;
  }
  if (decision.passed) {
    switch_to_next(out, pose, grey);
    pose = pose_now();
    out.detail = decision.how;
  }

  finish_step(out, pose, relocalised, decision.passed);
  return out;
}

int MemoryFollower::count_tracked() const {
  return static_cast<int>(std::count(tracked_.begin(), tracked_.end(), std::uint8_t{1}));
}

void MemoryFollower::track_points(const cv::Mat& grey) {
  std::vector<cv::Point2f> moved = points_;
  std::vector<std::uint8_t> ok;
  std::vector<cv::Point2f> from;
  std::vector<std::size_t> which;
  for (std::size_t j = 0; j < tracked_.size(); ++j)
    if (tracked_[j]) {
      from.push_back(points_[j]);
      which.push_back(j);
    }
  std::vector<cv::Point2f> to;
  track_klt(previous_, grey, from, to, ok, klt_);
  for (std::size_t k = 0; k < which.size(); ++k) {
    tracked_[which[k]] = ok[k];
    if (ok[k]) points_[which[k]] = to[k];
  }
}

void MemoryFollower::report_lost(FollowStep& out) {
  initialised_ = false;
  ++lost_frames_;
  out.target = target_;
  out.status = FollowStatus::lost;
  out.detail = "tracking lost (fewer than " + std::to_string(params_.min_tracked) +
               " reference features) and no reference matched";
  if (lost_frames_ > params_.max_lost_frames) {
    out.status = FollowStatus::failed;
    out.failure = "visual memory lost: no reference matched for " + std::to_string(lost_frames_) + " frames";
  }
}

MemoryFollower::SwitchDecision MemoryFollower::decide_switch(const PoseEstimate& pose, double edge_distance_m) {
  const int count = static_cast<int>(memory_.references.size());
  const Reference& ref = memory_.references[static_cast<std::size_t>(target_)];
  std::vector<cv::Point2f> cur_px, ref_px;
  for (std::size_t j = 0; j < tracked_.size(); ++j)
    if (tracked_[j]) {
      cur_px.push_back(points_[j]);
      ref_px.push_back(ref.points_px[j]);
    }
  SwitchDecision decision;
  const double error_px = image_error_px(cur_px, ref_px);
  decision.error_px = error_px;
  const bool image_rule = have_min_error_ && min_error_px_ < params_.switch_error_px &&
                          error_px > min_error_px_ + params_.rise_px;
  if (!have_min_error_ || error_px < min_error_px_) {
    min_error_px_ = error_px;
    have_min_error_ = true;
  }
  const bool pose_rule = pose.ok && pose.position_in_reference_m()[2] >= -params_.switch_margin_m;
  const bool by_odometry = edge_distance_m > ref.distance_m + params_.switch_odometry_margin_m;
  const bool last = target_ == count - 1;
  decision.last = last;
  bool passed = false;
  std::string how;
  if (last) {
    passed = image_rule || pose_rule;
    how = image_rule ? "image error rises" : "pose past the goal reference";
  } else if (params_.switch_rule == "pose" && pose.ok) {
    passed = pose_rule;
    how = "pose";
  } else {
    passed = image_rule;
    how = pose.ok ? "image error" : "image error (no pose)";
  }
  if (!passed && by_odometry && !last) {
    passed = true;
    how = "switched by odometry";
  }
  decision.passed = passed;
  decision.how = std::move(how);
  return decision;
}

void MemoryFollower::switch_to_next(FollowStep& out, const PoseEstimate& pose, const cv::Mat& grey) {
  const Reference& ref = memory_.references[static_cast<std::size_t>(target_)];
  const Reference& next = memory_.references[static_cast<std::size_t>(target_ + 1)];
  std::vector<cv::Point2f> carried(next.points_px.size());
  std::vector<std::uint8_t> carried_ok(next.points_px.size(), 0);
  for (std::size_t j = 0; j < next.ids.size(); ++j) {
    const int k = ref.find(next.ids[j]);
    if (k >= 0 && tracked_[static_cast<std::size_t>(k)]) {
      carried[j] = points_[static_cast<std::size_t>(k)];
      carried_ok[j] = 1;
    }
  }
  PoseEstimate composed;
  if (pose.ok) {
    composed.ok = true;
    composed.R = pose.R * next.R_from_prev.t();
    composed.t_m = pose.t_m - composed.R * next.t_from_prev_m;
  }
  set_target(target_ + 1);
  for (std::size_t j = 0; j < carried.size(); ++j)
    if (carried_ok[j]) {
      points_[j] = carried[j];
      tracked_[j] = 1;
    }
  if (composed.ok) out.resumed += resume_by_projection(composed, grey, &out.dropped);
}

void MemoryFollower::finish_step(FollowStep& out, const PoseEstimate& pose, bool relocalised, bool passed) {
  control(out, pose);
  out.target = target_;
  out.pose_ok = pose.ok;
  out.tracked = count_tracked();
  const Reference& now = memory_.references[static_cast<std::size_t>(target_)];
  for (std::size_t j = 0; j < tracked_.size(); ++j) out.tracked_3d += tracked_[j] && now.has_3d[j];
  out.confidence = std::clamp(static_cast<double>(out.tracked) /
                                  std::max(2.0 * params_.min_tracked, 0.5 * static_cast<double>(now.ids.size())),
                              0.0, 1.0);
  out.status = relocalised ? FollowStatus::relocalised
               : passed    ? FollowStatus::switched
               : pose.ok   ? FollowStatus::following
                           : FollowStatus::no_pose;
  if (out.tracked < 5) {
    out.command = Twist{};
    out.detail += (out.detail.empty() ? "" : "; ") + std::string("fewer than 5 correspondences: holding still");
  }
}

}  // namespace visnav::visual_memory
