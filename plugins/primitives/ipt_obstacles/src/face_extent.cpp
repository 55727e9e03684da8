#include "visnav/ipt_obstacles/face_extent.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>

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

enum class Judged : int { unknown, face, other };

struct Column {
  double lateral_m = 0.0;
  Judged judged = Judged::unknown;
};

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
  if (!std::isfinite(seen_right_m) || !std::isfinite(seen_left_m) || seen_right_m > seen_left_m)
    return Error{"face extent: seen span " + std::to_string(seen_right_m) + ".." + std::to_string(seen_left_m) +
                     " m is inverted",
                 ErrorCode::inconsistent, ErrorLocation({}, 0, "seen_right_m")};

  cv::Mat a, b;  // slightly smoothed: the predictions interpolate, the noise does not
  earlier.convertTo(a, CV_32F);
  now.convertTo(b, CV_32F);
  cv::GaussianBlur(a, a, cv::Size(3, 3), 0.8);
  cv::GaussianBlur(b, b, cv::Size(3, 3), 0.8);

  const LensPose lens_now = lens_pose(camera, now_pose), lens_then = lens_pose(camera, earlier_pose);
  const cv::Vec3d o(lens_now.x_m, lens_now.y_m, camera.height_m);
  const cv::Vec2d h(std::cos(now_pose.heading_rad), std::sin(now_pose.heading_rad));
  const cv::Vec2d n(-h[1], h[0]);
  const double o_fwd = (o[0] - now_pose.x_m) * h[0] + (o[1] - now_pose.y_m) * h[1];

  std::vector<Column> columns;
  columns.reserve(static_cast<std::size_t>(camera.width_px));
  for (int u = 0; u < camera.width_px; ++u) {
    double err_face = 0.0, err_other = 0.0, lateral_sum = 0.0;
    int count = 0;
    for (int v = 0; v < camera.height_px; ++v) {
      const cv::Vec3d d =
          NearTriangulation::ray(camera, lens_now, {static_cast<double>(u), static_cast<double>(v)});
      const double d_fwd = d[0] * h[0] + d[1] * h[1];
      if (d_fwd <= 1e-6) continue;
      const double t = (range_m - o_fwd) / d_fwd;
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
    if (count < params.min_pixels) continue;
    Column c;
    c.lateral_m = lateral_sum / count;
    const double mf = err_face / count, mo = err_other / count;
    if (mf <= params.max_ratio * mo && mo - mf >= params.min_gain_grey) c.judged = Judged::face;
    else if (mo <= params.max_ratio * mf && mf - mo >= params.min_gain_grey) c.judged = Judged::other;
    if (std::fabs(c.lateral_m) <= params.max_lateral_m) columns.push_back(c);
  }
  std::sort(columns.begin(), columns.end(), [](const Column& x, const Column& y) { return x.lateral_m < y.lateral_m; });

  FaceExtent out;
  out.right_m = seen_right_m;
  out.left_m = seen_left_m;
  for (const Column& c : columns)
    if (c.judged == Judged::other) ++out.other_columns;
  // Grows from the seen span to one side (dir +1: left, −1: right) over face columns, across gaps
  // narrower than max_gap_m.
  auto grow = [&](int dir, double& edge_m, bool& clipped) {
    double last_face = edge_m;
    bool ended = false;
    const auto visit = [&](const Column& c) {
      if (ended) return;
      const double beyond = dir * (c.lateral_m - edge_m);
      if (beyond <= 0.0) return;
      if (dir * (c.lateral_m - last_face) > params.max_gap_m) {
        ended = true;
        return;
      }
      if (c.judged == Judged::face) {
        last_face = c.lateral_m;
        ++out.face_columns;
      }
    };
    if (dir > 0)
      for (const Column& c : columns) visit(c);
    else
      for (auto it = columns.rbegin(); it != columns.rend(); ++it) visit(*it);
    clipped = !ended && dir * (last_face - edge_m) > 0.0;
    edge_m = last_face;
  };
  grow(1, out.left_m, out.clipped_left);
  grow(-1, out.right_m, out.clipped_right);
  for (const Column& c : columns)
    if (c.judged == Judged::face && c.lateral_m >= seen_right_m && c.lateral_m <= seen_left_m) ++out.face_columns;

  const double span = out.left_m - out.right_m;
  const int steps = static_cast<int>(std::floor(span / params.step_m));
  for (int i = 0; i <= steps + 1; ++i) {
    const double l = i <= steps ? out.right_m + i * params.step_m : out.left_m;
    if (i == steps + 1 && out.left_m - (out.right_m + steps * params.step_m) < 1e-6) break;
    out.points.emplace_back(now_pose.x_m + range_m * h[0] + l * n[0], now_pose.y_m + range_m * h[1] + l * n[1]);
  }
  return out;
}

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
