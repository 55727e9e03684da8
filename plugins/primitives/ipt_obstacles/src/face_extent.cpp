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

}  // namespace

Result<FaceExtent> face_extent(const IptCamera& camera, const cv::Mat& earlier, const Pose2D& earlier_pose,
                               const cv::Mat& now, const Pose2D& now_pose, double range_m, double seen_right_m,
                               double seen_left_m, const FaceExtentParams& params) {
  VISNAV_TRY(params.validate());
  VISNAV_TRY(camera.validate());
  for (const cv::Mat* m : {&earlier, &now})
    if (m->type() != CV_8UC1 || m->cols != camera.width_px || m->rows != camera.height_px)
      return Error{"face extent: expected " + std::to_string(camera.width_px) + "x" +
                       std::to_string(camera.height_px) + " CV_8UC1 frames",
                   ErrorCode::invalid_value};
  if (!std::isfinite(range_m) || range_m <= 0.0)
    return Error{"face extent: range " + std::to_string(range_m) + " m must be positive", ErrorCode::out_of_range,
                 ErrorLocation({}, 0, "range_m")};
  FaceExtent out;
  if (!std::isfinite(seen_right_m) || !std::isfinite(seen_left_m) || seen_right_m > seen_left_m)
    return Error{"face extent: seen span " + std::to_string(seen_right_m) + ".." + std::to_string(seen_left_m) +
                     " m is inverted",
                 ErrorCode::inconsistent, ErrorLocation({}, 0, "seen_right_m")};

  cv::Mat a, b;  // slightly smoothed: the predictions interpolate, the noise does not
  earlier.convertTo(a, CV_32F);
  now.convertTo(b, CV_32F);
  if (params.smooth_sigma_px > 0.0) {
    cv::GaussianBlur(a, a, cv::Size(), params.smooth_sigma_px);
    cv::GaussianBlur(b, b, cv::Size(), params.smooth_sigma_px);
  }

  const LensPose lens_now = lens_pose(camera, now_pose);
  LensPose lens_then = lens_pose(camera, earlier_pose);
  const cv::Vec3d o(lens_now.x_m, lens_now.y_m, camera.height_m);
  const cv::Vec2d h(std::cos(now_pose.heading_rad), std::sin(now_pose.heading_rad));
  const cv::Vec2d n(-h[1], h[0]);
  const double o_fwd = (o[0] - now_pose.x_m) * h[0] + (o[1] - now_pose.y_m) * h[1];

  // The odometry's heading change between the frames is corrected first: the yaw (within
  // ±max_yaw_fix_rad) that best aligns the ground nearer than the face (the image's bottom rows,
  // ground under both hypotheses) under the ground prediction. A yaw error of 0.004 rad is a
  // pixel at f = 277 px, as much as the two hypotheses differ by near the face's foot.
  if (params.max_yaw_fix_rad > 0.0) {
    const double near_m = std::max(0.5, range_m - params.depth_below_m - 0.3);
    std::vector<std::pair<cv::Point, cv::Vec3d>> ground;  // pixel, its ground point
    for (int v = camera.height_px - 1; v >= 0; v -= 2)
      for (int u = 0; u < camera.width_px; u += 2) {
        const GroundHit g = back_project(camera, lens_now, {static_cast<double>(u), static_cast<double>(v)});
        if (!g.valid()) continue;
        const double fwd = (g.ground_m.x - now_pose.x_m) * h[0] + (g.ground_m.y - now_pose.y_m) * h[1];
        if (fwd > near_m) continue;
        ground.emplace_back(cv::Point(u, v), cv::Vec3d(g.ground_m.x, g.ground_m.y, 0.0));
      }
    const double base_azimuth = lens_then.azimuth_rad;
    double best_err = 1e300, best_fix = 0.0;
    const double step = 0.0005;
    for (double fix = -params.max_yaw_fix_rad; fix <= params.max_yaw_fix_rad + 1e-12; fix += step) {
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
    lens_then.azimuth_rad = base_azimuth + best_fix;
    out.yaw_fix_rad = best_fix;
    // The exposure's change between the frames (auto-exposure flicker): one gain, from the same
    // ground pixels.
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

  // The rays of every pixel, once.
  std::vector<cv::Vec3d> rays(static_cast<std::size_t>(camera.width_px) * static_cast<std::size_t>(camera.height_px));
  for (int v = 0; v < camera.height_px; ++v)
    for (int u = 0; u < camera.width_px; ++u)
      rays[static_cast<std::size_t>(v * camera.width_px + u)] =
          NearTriangulation::ray(camera, lens_now, {static_cast<double>(u), static_cast<double>(v)});

  // Judges every column for the plane at `depth_m`; columns sorted by lateral offset.
  auto judge = [&](double depth_m, std::vector<FaceColumn>& judged) {
    judged.clear();
    for (int u = 0; u < camera.width_px; ++u) {
      double err_face = 0.0, err_other = 0.0, lateral_sum = 0.0;
      int count = 0;
      for (int v = 0; v < camera.height_px; ++v) {
        const cv::Vec3d& d = rays[static_cast<std::size_t>(v * camera.width_px + u)];
        const double d_fwd = d[0] * h[0] + d[1] * h[1];
        if (d_fwd <= 1e-6) continue;
        const double t = (depth_m - o_fwd) / d_fwd;
        if (t <= 0.0) continue;
        const cv::Vec3d p = o + t * d;
        if (p[2] < params.min_height_m || p[2] > params.max_height_m) continue;
        const double lateral = (p[0] - now_pose.x_m) * n[0] + (p[1] - now_pose.y_m) * n[1];
        const cv::Vec3d q = d[2] < -1e-9 ? cv::Vec3d(o + (-o[2] / d[2]) * d) : cv::Vec3d(o + params.far_m * d);
        const auto pf = project_point(camera, lens_then, p);
        const auto po = project_point(camera, lens_then, q);
        if (!pf || !po) continue;
        const auto vf = sample(a, *pf), vo = sample(a, *po);
        if (!vf || !vo) continue;
        const double value = b.at<float>(v, u);
        err_face += std::fabs(value - *vf);
        err_other += std::fabs(value - *vo);
        lateral_sum += lateral;
        ++count;
      }
      if (count == 0) continue;
      FaceColumn c{u, lateral_sum / count, err_face / count, err_other / count, count, 0};
      if (count >= params.min_pixels) {
        if (c.err_face <= params.max_ratio * c.err_other && c.err_other - c.err_face >= params.min_gain_grey) c.judged = 1;
        else if (c.err_other <= params.max_ratio * c.err_face && c.err_face - c.err_other >= params.min_gain_grey)
          c.judged = -1;
      }
      if (std::fabs(c.lateral_m) <= params.max_lateral_m) judged.push_back(c);
    }
    std::sort(judged.begin(), judged.end(),
              [](const FaceColumn& x, const FaceColumn& y) { return x.lateral_m < y.lateral_m; });
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
  const double reach_right = std::min(seen_right_m, -params.corridor_half_width_m) - params.max_gap_m;
  const double reach_left = std::max(seen_left_m, params.corridor_half_width_m) + params.max_gap_m;
  auto best_run = [&](const std::vector<FaceColumn>& cols) {
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
      if (open && c.lateral_m - last > params.max_gap_m) close(false);
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
    if (open) close(cols.empty() || cols.back().lateral_m - last <= params.max_gap_m);
    return best;
  };

  // The depth: the plane whose run explains the image best (the most error removed by the face
  // prediction over its face columns; the count alone grows with the depth at 3-4 m, where
  // neighbouring planes differ by a fraction of a pixel), swept around the seen distance (a few triangulated
  // corners put a face 3.7 m ahead at 2.24 m on the campus).
  std::vector<FaceColumn> judged;
  Run best;
  double best_depth = range_m;
  const double first = std::max(0.5, range_m - params.depth_below_m), last_depth = range_m + params.depth_above_m;
  for (double depth = first; depth <= last_depth + 1e-9; depth += params.depth_step_m) {
    judge(depth, judged);
    const Run r = best_run(judged);
    const bool better = r.score > best.score;
    if (better) {
      best = r;
      best_depth = depth;
      out.columns = judged;
    }
  }
  if (best.faces == 0) judge(range_m, out.columns);
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

  const double span = out.left_m - out.right_m;
  const int steps = static_cast<int>(std::floor(span / params.step_m));
  const double depth = out.range_m;
  for (int i = 0; i <= steps; ++i) {
    const double l = out.right_m + i * params.step_m;
    out.points.emplace_back(now_pose.x_m + depth * h[0] + l * n[0], now_pose.y_m + depth * h[1] + l * n[1]);
  }
  if (out.left_m - (out.right_m + steps * params.step_m) > 1e-6)
    out.points.emplace_back(now_pose.x_m + depth * h[0] + out.left_m * n[0],
                            now_pose.y_m + depth * h[1] + out.left_m * n[1]);
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
