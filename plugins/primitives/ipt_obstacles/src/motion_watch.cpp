// Frame differencing over the corridor ahead of a standing robot (see the header).
#include "visnav/ipt_obstacles/motion_watch.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace visnav::ipt {

Status MotionWatchParams::validate() const {
  if (auto st = schema().check(*this); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  if (far_m <= near_m)
    return Error{"far_m " + std::to_string(far_m) + " must exceed near_m " + std::to_string(near_m), ErrorCode::inconsistent,
                 ErrorLocation({}, 0, "far_m")};
  return ok();
}

const ParamSchema<MotionWatchParams>& MotionWatchParams::schema() {
  using P = MotionWatchParams;
  static const auto s = ParamSchema<P>{}
                            .field("near_m", &P::near_m, "corridor start ahead of the robot centre, m").range(0.0, 20.0)
                            .field("far_m", &P::far_m, "corridor end, m").range(0.1, 50.0)
                            .field("half_width_m", &P::half_width_m, "corridor half width, m").range(0.05, 10.0)
                            .field("diff_threshold", &P::diff_threshold, "grey-level change that counts").range(1.0, 255.0)
                            .field("min_changed_px", &P::min_changed_px, "changed mask pixels that count as motion")
                            .range(1, 1000000);
  return s;
}

Result<MotionWatch> MotionWatch::create(const IptCamera& camera, const MotionWatchParams& params) {
  VISNAV_TRY(camera.validate());
  VISNAV_TRY(params.validate());
  MotionWatch w(camera, params);
  w.mask_ = cv::Mat::zeros(camera.height_px, camera.width_px, CV_8UC1);
  const LensPose lens = lens_pose(camera, Pose2D{});
  // Rows from 2 px below the horizon (ranges there are unreliable) to the bottom.
  const int first_row = std::clamp(static_cast<int>(std::ceil(horizon_row_px(camera) + 2.0)), 0, camera.height_px);
  for (int u = 0; u < camera.width_px; ++u) {
    for (int v = first_row; v < camera.height_px; ++v) {
      const GroundHit hit = back_project(camera, lens, {static_cast<double>(u), static_cast<double>(v)});
      if (!hit.valid()) continue;
      const cv::Point2d p = to_robot_frame(Pose2D{}, hit.ground_m);
      const bool inside = p.x > params.near_m && p.x <= params.far_m && std::abs(p.y) <= params.half_width_m;
      if (inside) w.mask_.at<std::uint8_t>(v, u) = 255;
      // Beyond far_m but within the corridor's width: what stands in the corridor occludes it.
      if (p.x > params.far_m && std::abs(p.y) * params.far_m / p.x <= params.half_width_m)
        w.mask_.at<std::uint8_t>(v, u) = 255;
    }
  }
  if (cv::countNonZero(w.mask_) == 0)
    return Error{"motion watch: the corridor ahead is not in the camera's view", ErrorCode::out_of_range,
                 ErrorLocation({}, 0, "far_m")};
  return w;
}

namespace {

/// Ground-plane homography (current pixel -> previous pixel) for a robot motion `motion` (now
/// in the previous robot frame), from four ground points seen now; nullopt when one leaves the
/// previous view.
std::optional<cv::Mat> ground_homography(const IptCamera& camera, const Pose2D& motion) {
  const LensPose lens = lens_pose(camera, Pose2D{});
  const double v_top = std::max(horizon_row_px(camera) + 0.35 * (camera.height_px - horizon_row_px(camera)), 0.0);
  const double v_bottom = camera.height_px - 5.0;
  const cv::Point2f now_px[4] = {{10.0f, static_cast<float>(v_top)},
                                 {static_cast<float>(camera.width_px - 10), static_cast<float>(v_top)},
                                 {10.0f, static_cast<float>(v_bottom)},
                                 {static_cast<float>(camera.width_px - 10), static_cast<float>(v_bottom)}};
  cv::Point2f prev_px[4];
  const double c = std::cos(motion.heading_rad), s = std::sin(motion.heading_rad);
  for (int k = 0; k < 4; ++k) {
    const GroundHit hit = back_project(camera, lens, now_px[k]);
    if (!hit.valid()) return std::nullopt;
    const cv::Vec3d g_prev(motion.x_m + c * hit.ground_m.x - s * hit.ground_m.y,
                           motion.y_m + s * hit.ground_m.x + c * hit.ground_m.y, 0.0);
    const auto px = project_point(camera, lens, g_prev);
    if (!px) return std::nullopt;
    prev_px[k] = cv::Point2f(static_cast<float>(px->x), static_cast<float>(px->y));
  }
  return cv::getPerspectiveTransform(now_px, prev_px);
}

}  // namespace

int MotionWatch::count_changed(const cv::Mat& previous, const cv::Mat& valid) {
  const double mean_prev = cv::mean(previous, valid)[0], mean_now = cv::mean(blurred_, valid)[0];
  const double gain = mean_now > 1.0 ? mean_prev / mean_now : 1.0;
  blurred_.convertTo(diff_, CV_16S, gain);
  previous.convertTo(prev16_, CV_16S);
  cv::absdiff(diff_, prev16_, diff_);
  changed_ = diff_ > params_.diff_threshold;
  changed_ &= valid;
  return cv::countNonZero(changed_);
}

Result<std::optional<int>> MotionWatch::observe(const cv::Mat& grey, const Pose2D& motion) {
  if (grey.type() != CV_8UC1 || grey.rows != camera_.height_px || grey.cols != camera_.width_px)
    return Error{"motion watch: expected a " + std::to_string(camera_.width_px) + "x" + std::to_string(camera_.height_px) +
                     " grey image",
                 ErrorCode::invalid_value};
  cv::blur(grey, blurred_, cv::Size(5, 5));
  if (!have_previous_) {
    blurred_.copyTo(previous_);
    have_previous_ = true;
    last_changed_px_ = 0;
    return std::optional<int>{};
  }
  const bool moved = std::abs(motion.x_m) + std::abs(motion.y_m) + std::abs(motion.heading_rad) > 1e-9;
  if (!moved) {
    last_changed_px_ = count_changed(previous_, mask_);
  } else {
    // The odometry motion is known to a few millimetres only, and a frame is not taken exactly
    // at the odometry's time; near the robot a millimetre of ground is a pixel. So the motion's
    // scale is searched (0.5-1.5, the fewest changed pixels wins): the ground lines up, a
    // person walking across does not with any scale of the robot's motion.
    int best = -1;
    for (const double k : {1.0, 0.75, 1.25, 0.5, 1.5}) {
      const auto H = ground_homography(camera_, Pose2D{k * motion.x_m, k * motion.y_m, k * motion.heading_rad});
      if (!H) continue;
      cv::warpPerspective(previous_, warped_, *H, previous_.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                          cv::BORDER_REPLICATE);
      // Pixels the previous frame did not see (and a margin for the blur) are not compared.
      cv::Mat all(previous_.size(), CV_8UC1, cv::Scalar(255));
      cv::warpPerspective(all, valid_, *H, previous_.size(), cv::INTER_NEAREST | cv::WARP_INVERSE_MAP,
                          cv::BORDER_CONSTANT, cv::Scalar(0));
      cv::erode(valid_, valid_, cv::Mat(), cv::Point(-1, -1), 3);
      cv::bitwise_and(valid_, mask_, valid_);
      const int n = count_changed(warped_, valid_);
      if (best < 0 || n < best) {
        best = n;
        changed_.copyTo(best_changed_);
      }
      if (best < params_.min_changed_px) break;
    }
    if (best < 0) {  // the motion was too large to line the frames up: start again from this one
      blurred_.copyTo(previous_);
      last_changed_px_ = 0;
      return std::optional<int>{};
    }
    last_changed_px_ = best;
    cv::swap(changed_, best_changed_);  // last_changed(): the changed pixels of the best scale
  }
  blurred_.copyTo(previous_);
  return std::optional<int>{last_changed_px_};
}

Status ChangeShapeParams::validate() const {
  if (auto st = schema().check(*this); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  return ok();
}

const ParamSchema<ChangeShapeParams>& ChangeShapeParams::schema() {
  using P = ChangeShapeParams;
  static const auto s = ParamSchema<P>{}
                            .field("min_piece_px", &P::min_piece_px, "a changed piece this large is solid, px").range(1, 1000000)
                            .field("min_share", &P::min_share, "solid pieces' share of the changed pixels").range(0.0, 1.0)
                            .field("min_solid_px", &P::min_solid_px, "solid pixels at least").range(0, 1000000);
  return s;
}

ChangeShape change_shape(const cv::Mat& changed, const ChangeShapeParams& params, cv::Mat& scratch_labels,
                         cv::Mat& scratch_stats, cv::Mat& scratch_centroids) {
  ChangeShape out;
  if (changed.empty()) return out;
  out.changed_px = cv::countNonZero(changed);
  if (out.changed_px == 0) return out;
  const int n = cv::connectedComponentsWithStats(changed, scratch_labels, scratch_stats, scratch_centroids, 4, CV_32S);
  out.pieces = n - 1;
  for (int k = 1; k < n; ++k) {
    const int area = scratch_stats.at<int>(k, cv::CC_STAT_AREA);
    out.largest_px = std::max(out.largest_px, area);
    if (area >= params.min_piece_px) out.solid_px += area;
  }
  out.share = static_cast<double>(out.solid_px) / out.changed_px;
  out.compact = out.share >= params.min_share && out.solid_px >= params.min_solid_px;
  return out;
}

bool ShimmerTrigger::update(int changed_px, bool cruising, bool moving) {
  int level = 0;
  if (count_n_ > 0) {
    std::array<int, kHistory> sorted = counts_;
    const auto mid = sorted.begin() + static_cast<std::ptrdiff_t>(count_n_ / 2);
    std::nth_element(sorted.begin(), mid, sorted.begin() + static_cast<std::ptrdiff_t>(count_n_));
    level = *mid;
  }
  const bool hit = cruising && count_n_ >= 5 && moving && changed_px > 3 * level;
  if (cruising && !hit) {
    counts_[next_] = changed_px;
    next_ = (next_ + 1) % kHistory;
    count_n_ = std::min(count_n_ + 1, kHistory);
  }
  hits_ = hit ? hits_ + 1 : 0;
  return hits_ >= 2;
}

}  // namespace visnav::ipt
