#include "visnav/ipt_obstacles/face_extent.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "visnav/ipt_obstacles/near_triangulation.hpp"

namespace visnav::ipt {

Status FaceExtentParams::validate() const {
  if (auto st = schema().check(*this); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  if (max_height_m <= min_height_m)
    return Error{"max_height_m must exceed min_height_m", ErrorCode::inconsistent, ErrorLocation({}, 0, "max_height_m")};
  return ok();
}

const ParamSchema<FaceExtentParams>& FaceExtentParams::schema() {
  using P = FaceExtentParams;
  static const auto s =
      ParamSchema<P>{}
          .field("min_height_m", &P::min_height_m, "lowest height of the face band, m").range(0.0, 10.0)
          .field("max_height_m", &P::max_height_m, "highest height of the face band, m").range(0.01, 10.0)
          .field("far_m", &P::far_m, "distance of the background above the horizon, m").range(1.0, 1e4)
          .field("max_ratio", &P::max_ratio, "a column's winning prediction error at most this x the other's")
          .range(0.05, 1.0)
          .field("min_gain_grey", &P::min_gain_grey, "and lower by at least this per pixel, grey levels")
          .range(0.0, 255.0)
          .field("max_gap_m", &P::max_gap_m, "columns not judged face spanning this across end the face, m")
          .range(0.0, 10.0)
          .field("max_lateral_m", &P::max_lateral_m, "the extent is searched within this of the heading, m")
          .range(0.1, 50.0)
          .field("step_m", &P::step_m, "spacing of the points along the face, m").range(0.01, 5.0)
          .field("smooth_sigma_px", &P::smooth_sigma_px, "Gaussian smoothing of both frames, px; 0 = none")
          .range(0.0, 10.0)
          .field("max_yaw_fix_rad", &P::max_yaw_fix_rad, "largest heading correction searched on the near ground")
          .range(0.0, 0.2)
          .field("depth_below_m", &P::depth_below_m, "planes swept this far nearer than the seen distance, m")
          .range(0.0, 10.0)
          .field("depth_above_m", &P::depth_above_m, "and this far beyond it, m").range(0.0, 20.0)
          .field("depth_step_m", &P::depth_step_m, "step of the sweep, m").range(0.01, 2.0)
          .field("corridor_half_width_m", &P::corridor_half_width_m, "a face must reach the seen span or this corridor, m")
          .range(0.0, 10.0)
          .field("min_width_m", &P::min_width_m, "narrower runs of face columns are not a face, m").range(0.0, 10.0)
          .field("min_pixels", &P::min_pixels, "band pixels a column needs to be judged").range(1, 100000);
  return s;
}

namespace {

std::optional<double> sample(const cv::Mat& img, const cv::Point2d& p) {
  if (!(p.x >= 0.0 && p.y >= 0.0 && p.x < img.cols - 1 && p.y < img.rows - 1)) return std::nullopt;
  const int x = static_cast<int>(p.x), y = static_cast<int>(p.y);
  const double ax = p.x - x, ay = p.y - y;
  const float* r0 = img.ptr<float>(y);
  const float* r1 = img.ptr<float>(y + 1);
  return (1 - ay) * ((1 - ax) * r0[x] + ax * r0[x + 1]) + ay * ((1 - ax) * r1[x] + ax * r1[x + 1]);
}

// The steps of face_extent(), in the order it runs them.

/// The frames (the camera's size, CV_8UC1), the range (positive) and the seen span (not inverted).
Status check_inputs(const IptCamera& camera, const cv::Mat& earlier, const cv::Mat& now, double range_m,
                    double seen_right_m, double seen_left_m) {
  for (const cv::Mat* m : {&earlier, &now})
    if (m->type() != CV_8UC1 || m->cols != camera.width_px || m->rows != camera.height_px)
      return Error{"face extent: expected " + std::to_string(camera.width_px) + "x" +
                       std::to_string(camera.height_px) + " CV_8UC1 frames",
                   ErrorCode::invalid_value};
  if (!std::isfinite(range_m) || range_m <= 0.0)
    return Error{"face extent: range " + std::to_string(range_m) + " m must be positive", ErrorCode::out_of_range,
                 ErrorLocation({}, 0, "range_m")};
  if (!std::isfinite(seen_right_m) || !std::isfinite(seen_left_m) || seen_right_m > seen_left_m)
    return Error{"face extent: seen span " + std::to_string(seen_right_m) + ".." + std::to_string(seen_left_m) +
                     " m is inverted",
                 ErrorCode::inconsistent, ErrorLocation({}, 0, "seen_right_m")};
  return ok();
}

/// Where the planes are swept from: the lens at `now_pose`, its centre o (ground frame, at the
/// camera's height), the heading's unit vector h, its left normal n, and o's offset along h from
/// the robot.
struct SweepFrame {
  LensPose lens_now;
  cv::Vec3d o;
  cv::Vec2d h, n;
  double o_fwd;
};

SweepFrame sweep_frame(const IptCamera& camera, const Pose2D& now_pose) {
  const LensPose lens_now = lens_pose(camera, now_pose);
  const cv::Vec3d o(lens_now.x_m, lens_now.y_m, camera.height_m);
  const cv::Vec2d h(std::cos(now_pose.heading_rad), std::sin(now_pose.heading_rad));
  const cv::Vec2d n(-h[1], h[0]);
  const double o_fwd = (o[0] - now_pose.x_m) * h[0] + (o[1] - now_pose.y_m) * h[1];
  return {lens_now, o, h, n, o_fwd};
}

using GroundPixels = std::vector<std::pair<cv::Point, cv::Vec3d>>;  // pixel, its ground point

/// Every second pixel of the frame at `now_pose` whose ray meets the ground at most near_m ahead.
GroundPixels near_ground(const IptCamera& camera, const SweepFrame& f, const Pose2D& now_pose, double near_m) {
  GroundPixels ground;
  for (int v = camera.height_px - 1; v >= 0; v -= 2)
    for (int u = 0; u < camera.width_px; u += 2) {
      const GroundHit g = back_project(camera, f.lens_now, {static_cast<double>(u), static_cast<double>(v)});
      if (!g.valid()) continue;
      const double fwd = (g.ground_m.x - now_pose.x_m) * f.h[0] + (g.ground_m.y - now_pose.y_m) * f.h[1];
      if (fwd > near_m) continue;
      ground.emplace_back(cv::Point(u, v), cv::Vec3d(g.ground_m.x, g.ground_m.y, 0.0));
    }
  return ground;
}

/// The yaw (within ±max_yaw_fix_rad, in 0.0005 rad steps) added to the earlier lens's azimuth
/// that best aligns the ground pixels of `b` (now) with `a` (earlier).
double best_yaw_fix(const IptCamera& camera, LensPose lens_then, const GroundPixels& ground, const cv::Mat& a,
                    const cv::Mat& b, double max_yaw_fix_rad) {
  const double base_azimuth = lens_then.azimuth_rad;
  double best_err = 1e300, best_fix = 0.0;
  const double step = 0.0005;
  for (double fix = -max_yaw_fix_rad; fix <= max_yaw_fix_rad + 1e-12; fix += step) {
    lens_then.azimuth_rad = base_azimuth + fix;
    double err = 0.0;
    int count = 0;
    for (const auto& [px, g] : ground) {
      const auto pp = project_point(camera, lens_then, g);
      if (!pp) continue;
      const auto val = sample(a, *pp);
      if (!val) continue;
      err += std::fabs(b.at<float>(px.y, px.x) - *val);
      ++count;
    }
    if (count > 0 && err / count < best_err) {
      best_err = err / count;
      best_fix = fix;
    }
  }
  return best_fix;
}

/// The exposure's change between the frames (auto-exposure flicker): one gain, from the ground
/// pixels; `a` (earlier) is scaled by it and out.gain set, when the earlier ground is not black.
void correct_exposure(const IptCamera& camera, const LensPose& lens_then, const GroundPixels& ground, cv::Mat& a,
                      const cv::Mat& b, FaceExtent& out) {
  double sum_now = 0.0, sum_then = 0.0;
  for (const auto& [px, g] : ground) {
    const auto pp = project_point(camera, lens_then, g);
    if (!pp) continue;
    const auto val = sample(a, *pp);
    if (!val) continue;
    sum_now += b.at<float>(px.y, px.x);
    sum_then += *val;
  }
  if (sum_then > 0.0) {
    out.gain = sum_now / sum_then;
    a *= out.gain;
  }
}

/// The odometry's heading change between the frames is corrected first: the yaw (within
/// ±max_yaw_fix_rad) that best aligns the ground nearer than the face (the image's bottom rows,
/// ground under both hypotheses) under the ground prediction. A yaw error of 0.004 rad is a
/// pixel at f = 277 px, as much as the two hypotheses differ by near the face's foot. Then the
/// exposure, from the same ground.
void align_earlier(const IptCamera& camera, const SweepFrame& f, const Pose2D& now_pose, double range_m,
                   const FaceExtentParams& params, cv::Mat& a, const cv::Mat& b, LensPose& lens_then, FaceExtent& out) {
  const double near_m = std::max(0.5, range_m - params.depth_below_m - 0.3);
  const GroundPixels ground = near_ground(camera, f, now_pose, near_m);
  const double base_azimuth = lens_then.azimuth_rad;
  const double best_fix = best_yaw_fix(camera, lens_then, ground, a, b, params.max_yaw_fix_rad);
  lens_then.azimuth_rad = base_azimuth + best_fix;
  out.yaw_fix_rad = best_fix;
  correct_exposure(camera, lens_then, ground, a, b, out);
}

/// The rays of every pixel of the frame at `now_pose`, once (row by row).
std::vector<cv::Vec3d> pixel_rays(const IptCamera& camera, const LensPose& lens_now) {
  std::vector<cv::Vec3d> rays(static_cast<std::size_t>(camera.width_px) * static_cast<std::size_t>(camera.height_px));
  for (int v = 0; v < camera.height_px; ++v)
    for (int u = 0; u < camera.width_px; ++u)
      rays[static_cast<std::size_t>(v * camera.width_px + u)] =
          NearTriangulation::ray(camera, lens_now, {static_cast<double>(u), static_cast<double>(v)});
  return rays;
}

/// Judges the image columns for a plane across the heading: face, other or unknown.
class ColumnJudge {
 public:
  ColumnJudge(const IptCamera& camera, const SweepFrame& f, const Pose2D& now_pose, const LensPose& lens_then,
              const std::vector<cv::Vec3d>& rays, const cv::Mat& a, const cv::Mat& b, const FaceExtentParams& params)
      : camera_(camera), f_(f), now_pose_(now_pose), lens_then_(lens_then), rays_(rays), a_(a), b_(b), params_(params) {}

  /// Judges every column for the plane at `depth_m`; columns sorted by lateral offset.
  void judge(double depth_m, std::vector<FaceColumn>& judged) const {
    judged.clear();
    for (int u = 0; u < camera_.width_px; ++u) {
      const std::optional<FaceColumn> c = column(u, depth_m);
      if (!c) continue;
      if (std::fabs(c->lateral_m) <= params_.max_lateral_m) judged.push_back(*c);
    }
    std::sort(judged.begin(), judged.end(),
              [](const FaceColumn& x, const FaceColumn& y) { return x.lateral_m < y.lateral_m; });
  }

 private:
  /// Column u's band pixels on the plane at depth_m, both predictions compared; nullopt when
  /// no band pixel has both.
  [[nodiscard]] std::optional<FaceColumn> column(int u, double depth_m) const {
    const cv::Vec3d& o = f_.o;
    double err_face = 0.0, err_other = 0.0, lateral_sum = 0.0;
    int count = 0;
    for (int v = 0; v < camera_.height_px; ++v) {
      const cv::Vec3d& d = rays_[static_cast<std::size_t>(v * camera_.width_px + u)];
      const double d_fwd = d[0] * f_.h[0] + d[1] * f_.h[1];
      if (d_fwd <= 1e-6) continue;
      const double t = (depth_m - f_.o_fwd) / d_fwd;
      if (t <= 0.0) continue;
      const cv::Vec3d p = o + t * d;
      if (p[2] < params_.min_height_m || p[2] > params_.max_height_m) continue;
      const double lateral = (p[0] - now_pose_.x_m) * f_.n[0] + (p[1] - now_pose_.y_m) * f_.n[1];
      const cv::Vec3d q = d[2] < -1e-9 ? cv::Vec3d(o + (-o[2] / d[2]) * d) : cv::Vec3d(o + params_.far_m * d);
      const auto pf = project_point(camera_, lens_then_, p);
      const auto po = project_point(camera_, lens_then_, q);
      if (!pf || !po) continue;
      const auto vf = sample(a_, *pf), vo = sample(a_, *po);
      if (!vf || !vo) continue;
      const double value = b_.at<float>(v, u);
      err_face += std::fabs(value - *vf);
      err_other += std::fabs(value - *vo);
      lateral_sum += lateral;
      ++count;
    }
    if (count == 0) return std::nullopt;
    FaceColumn c{u, lateral_sum / count, err_face / count, err_other / count, count, 0};
    if (count >= params_.min_pixels) {
      if (c.err_face <= params_.max_ratio * c.err_other && c.err_other - c.err_face >= params_.min_gain_grey) c.judged = 1;
      else if (c.err_other <= params_.max_ratio * c.err_face && c.err_face - c.err_other >= params_.min_gain_grey)
        c.judged = -1;
    }
    return c;
  }

  const IptCamera& camera_;
  const SweepFrame& f_;
  const Pose2D& now_pose_;
  const LensPose& lens_then_;
  const std::vector<cv::Vec3d>& rays_;
  const cv::Mat& a_;
  const cv::Mat& b_;
  const FaceExtentParams& params_;
};

// A run: face columns with gaps (other or unknown columns) narrower than max_gap_m between
// them. The run that counts is the one with the most face columns that reaches the seen span
// or the corridor (within max_gap_m).
struct Run {
  double right_m = 0.0, left_m = 0.0;
  int faces = 0;
  double score = 0.0;  // sum of (other − face) error over its face columns
  bool clipped_right = false, clipped_left = false;
};

/// The best-scoring run of `cols` (sorted by lateral offset) that reaches reach_right..reach_left.
Run best_run(const std::vector<FaceColumn>& cols, double reach_right, double reach_left, double max_gap_m) {
  Run best, cur;
  bool open = false;
  double last = 0.0;
  auto close = [&](bool at_end) {
    if (!open) return;
    cur.clipped_left = at_end;
    if (cur.left_m >= reach_right && cur.right_m <= reach_left && cur.score > best.score) best = cur;
    open = false;
  };
  for (std::size_t k = 0; k < cols.size(); ++k) {
    const FaceColumn& c = cols[k];
    if (open && c.lateral_m - last > max_gap_m) close(false);
    if (c.judged != 1) continue;
    if (!open) {
      cur = Run{};
      cur.right_m = c.lateral_m;
      cur.clipped_right = k == 0;
      open = true;
    }
    cur.left_m = c.lateral_m;
    ++cur.faces;
    cur.score += c.err_other - c.err_face;
    last = c.lateral_m;
  }
  if (open) close(cols.empty() || cols.back().lateral_m - last <= max_gap_m);
  return best;
}

/// The depth: the plane whose run explains the image best (the most error removed by the face
/// prediction over its face columns; the count alone grows with the depth at 3-4 m, where
/// neighbouring planes differ by a fraction of a pixel), swept around the seen distance (a few
/// triangulated corners put a face 3.7 m ahead at 2.24 m on the campus). Sets out.columns to the
/// best plane's columns (those at range_m when no plane has a run); returns the best run and
/// sets `best_depth` (range_m when none).
Run sweep_depths(const ColumnJudge& judge, double range_m, double seen_right_m, double seen_left_m,
                 const FaceExtentParams& params, double& best_depth, FaceExtent& out) {
  const double reach_right = std::min(seen_right_m, -params.corridor_half_width_m) - params.max_gap_m;
  const double reach_left = std::max(seen_left_m, params.corridor_half_width_m) + params.max_gap_m;
  std::vector<FaceColumn> judged;
  Run best;
  best_depth = range_m;
  const double first = std::max(0.5, range_m - params.depth_below_m), last_depth = range_m + params.depth_above_m;
  for (double depth = first; depth <= last_depth + 1e-9; depth += params.depth_step_m) {
    judge.judge(depth, judged);
    const Run r = best_run(judged, reach_right, reach_left, params.max_gap_m);
    const bool better = r.score > best.score;
    if (better) {
      best = r;
      best_depth = depth;
      out.columns = judged;
    }
  }
  if (best.faces == 0) judge.judge(range_m, out.columns);
  return best;
}

/// The extent from the best run at best_depth: found when at least min_width_m wide (with the
/// seen span at the seen distance), else the seen span at range_m.
void set_extent(const Run& best, double best_depth, double range_m, double seen_right_m, double seen_left_m,
                const FaceExtentParams& params, FaceExtent& out) {
  for (const FaceColumn& c : out.columns)
    if (c.judged == -1) ++out.other_columns;
  out.face_columns = best.faces;
  out.range_m = best_depth;
  const double min_faces_width = params.min_width_m;
  if (best.faces > 0 && best.left_m - best.right_m >= min_faces_width) {
    out.found = true;
    out.right_m = best.right_m;
    out.left_m = best.left_m;
    out.clipped_right = best.clipped_right;
    out.clipped_left = best.clipped_left;
    // At the seen distance the seen span belongs to the face too.
    if (std::fabs(best_depth - range_m) <= 0.5 * params.depth_step_m + 1e-9) {
      out.right_m = std::min(out.right_m, seen_right_m);
      out.left_m = std::max(out.left_m, seen_left_m);
    }
  } else {
    out.range_m = range_m;
    out.right_m = seen_right_m;
    out.left_m = seen_left_m;
  }
}

/// Points every step_m from out.right_m to out.left_m (and at left_m) at out.range_m, odom frame.
void put_points(const Pose2D& now_pose, const SweepFrame& f, double step_m, FaceExtent& out) {
  const cv::Vec2d& h = f.h;
  const cv::Vec2d& n = f.n;
  const double span = out.left_m - out.right_m;
  const int steps = static_cast<int>(std::floor(span / step_m));
  const double depth = out.range_m;
  for (int i = 0; i <= steps; ++i) {
    const double l = out.right_m + i * step_m;
    out.points.emplace_back(now_pose.x_m + depth * h[0] + l * n[0], now_pose.y_m + depth * h[1] + l * n[1]);
  }
  if (out.left_m - (out.right_m + steps * step_m) > 1e-6)
    out.points.emplace_back(now_pose.x_m + depth * h[0] + out.left_m * n[0],
                            now_pose.y_m + depth * h[1] + out.left_m * n[1]);
}

}  // namespace

Result<FaceExtent> face_extent(const IptCamera& camera, const cv::Mat& earlier, const Pose2D& earlier_pose,
                               const cv::Mat& now, const Pose2D& now_pose, double range_m, double seen_right_m,
                               double seen_left_m, const FaceExtentParams& params) {
  VISNAV_TRY(params.validate());
  VISNAV_TRY(camera.validate());
  VISNAV_TRY(check_inputs(camera, earlier, now, range_m, seen_right_m, seen_left_m));
  FaceExtent out;

  cv::Mat a, b;  // slightly smoothed: the predictions interpolate, the noise does not
  earlier.convertTo(a, CV_32F);
  now.convertTo(b, CV_32F);
  if (params.smooth_sigma_px > 0.0) {
    cv::GaussianBlur(a, a, cv::Size(), params.smooth_sigma_px);
    cv::GaussianBlur(b, b, cv::Size(), params.smooth_sigma_px);
  }

  const SweepFrame f = sweep_frame(camera, now_pose);
  LensPose lens_then = lens_pose(camera, earlier_pose);
  if (params.max_yaw_fix_rad > 0.0) align_earlier(camera, f, now_pose, range_m, params, a, b, lens_then, out);

  const std::vector<cv::Vec3d> rays = pixel_rays(camera, f.lens_now);
  const ColumnJudge judge(camera, f, now_pose, lens_then, rays, a, b, params);
  double best_depth = range_m;
  const Run best = sweep_depths(judge, range_m, seen_right_m, seen_left_m, params, best_depth, out);
  set_extent(best, best_depth, range_m, seen_right_m, seen_left_m, params, out);
  put_points(now_pose, f, params.step_m, out);
  return out;
}

int side_past(double right_m, double left_m) { return left_m <= -right_m ? 1 : -1; }

void FrameTrail::add(const cv::Mat& grey, const Pose2D& pose, double odometer_m) {
  if (!kept_.empty() && std::fabs(odometer_m - kept_.back().odometer_m) < spacing_m_) return;
  while (!kept_.empty() && odometer_m - kept_.front().odometer_m > length_m_) kept_.erase(kept_.begin());
  kept_.push_back(Kept{grey.clone(), pose, odometer_m});
}

const FrameTrail::Kept* FrameTrail::back(double odometer_m, double baseline_m) const {
  const Kept* best = nullptr;
  for (const Kept& k : kept_) {
    const double d = odometer_m - k.odometer_m;
    if (d < 0.5 * baseline_m) continue;
    if (!best || std::fabs(d - baseline_m) < std::fabs(odometer_m - best->odometer_m - baseline_m)) best = &k;
  }
  return best;
}

}  // namespace visnav::ipt
