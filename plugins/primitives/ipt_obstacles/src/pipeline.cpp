#include "visnav/ipt_obstacles/pipeline.hpp"

#include <cmath>
#include <limits>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

namespace visnav::ipt {

Status PipelineParams::validate() const {
  if (auto st = schema().check(*this); !st) return st.error().with_default_code(ErrorCode::out_of_range);
  if (max_pair_distance_m <= pair_distance_m)
    return Error{"max_pair_distance_m must exceed pair_distance_m", ErrorCode::inconsistent};
  return ok();
}

const ParamSchema<PipelineParams>& PipelineParams::schema() {
  using P = PipelineParams;
  static const auto s =
      ParamSchema<P>{}
          .field("max_features", &P::max_features, "Shi-Tomasi corners per pair (thesis 250)").range(8, 5000)
          .field("quality_level", &P::quality_level, "goodFeaturesToTrack quality level").range(1e-4, 1.0)
          .field("min_distance_px", &P::min_distance_px, "minimum corner spacing").range(0.0, 100.0)
          .field("lk_window_px", &P::lk_window_px, "Lucas-Kanade window side").range(5, 101)
          .field("lk_levels", &P::lk_levels, "Lucas-Kanade pyramid levels").range(0, 8)
          .field("ransac_threshold_px", &P::ransac_threshold_px, "RANSAC on F inlier threshold (thesis 1 px)")
          .range(0.1, 20.0)
          .field("ransac_iterations", &P::ransac_iterations, "RANSAC iterations (thesis 500)").range(10, 100000)
          .field("pair_distance_m", &P::pair_distance_m, "lens travel between the frames of a pair (thesis 2 cm)")
          .range(0.002, 1.0)
          .field("max_pair_distance_m", &P::max_pair_distance_m, "longer gaps restart the pair").range(0.005, 10.0)
          .field("max_pair_rotation_rad", &P::max_pair_rotation_rad, "a larger turn within a pair restarts it")
          .range(0.001, 3.2)
          .field("forward_backward_px", &P::forward_backward_px,
                 "drop tracks whose backward track misses the corner by more (0 = off)")
          .range(0.0, 100.0)
          .field("odometry_epipolar_px", &P::odometry_epipolar_px,
                 "also drop matches farther from the odometry's epipolar line (0 = off)")
          .range(0.0, 100.0);
  return s;
}

double odometry_epipolar_distance_px(const OdometryEpipolar& motion, const cv::Point2d& a, const cv::Point2d& b) {
  const IptCamera& cam = motion.camera;
  // the ray of `a` from the first lens: x_n·r + y_n·w + o with project_point()'s right, up and
  // optical-axis vectors, so that its projection into the first frame is `a` again
  const double theta = motion.first.azimuth_rad - CV_PI / 2.0;
  const double ct = std::cos(theta), st = std::sin(theta);
  const double cp = std::cos(cam.pitch_rad), sp = std::sin(cam.pitch_rad);
  const double xn = (a.x - cam.cx_px) / cam.fx_px, yn = (cam.cy_px - a.y) / cam.fy_px;
  const cv::Vec3d r(ct, st, 0.0), w(sp * st, -sp * ct, cp), o(-cp * st, cp * ct, sp);
  const cv::Vec3d ray = xn * r + yn * w + o;
  const cv::Vec3d lens(motion.first.x_m, motion.first.y_m, cam.height_m);
  const auto near_px = project_point(cam, motion.second, lens + 0.3 * ray);
  const auto far_px = project_point(cam, motion.second, lens + 1000.0 * ray);
  if (!near_px || !far_px) return std::numeric_limits<double>::infinity();
  const cv::Point2d d = *far_px - *near_px;
  const double length = std::hypot(d.x, d.y);
  if (length < 1e-9) return cv::norm(b - *far_px);
  return std::fabs(d.x * (b.y - near_px->y) - d.y * (b.x - near_px->x)) / length;
}

int track_pair(const cv::Mat& first, const cv::Mat& second, const PipelineParams& params, std::vector<cv::Point2f>& a,
               std::vector<cv::Point2f>& b, TrackScratch& t, const OdometryEpipolar* motion) {
  a.clear();
  b.clear();
  cv::goodFeaturesToTrack(first, t.corners, params.max_features, params.quality_level, params.min_distance_px);
  if (t.corners.size() < 8) return 0;
  const cv::Size window(params.lk_window_px, params.lk_window_px);
  cv::calcOpticalFlowPyrLK(first, second, t.corners, t.tracked, t.status, t.errors, window, params.lk_levels);
  const bool fb = params.forward_backward_px > 0.0;
  if (fb) cv::calcOpticalFlowPyrLK(second, first, t.tracked, t.back, t.back_status, t.errors, window, params.lk_levels);
  for (std::size_t i = 0; i < t.corners.size(); ++i) {
    if (t.status[i] == 0) continue;
    if (fb && (t.back_status[i] == 0 || cv::norm(t.back[i] - t.corners[i]) > params.forward_backward_px)) continue;
    a.push_back(t.corners[i]);
    b.push_back(t.tracked[i]);
  }
  return reject_epipolar_outliers(a, b, params, t.inliers, motion);
}

int reject_epipolar_outliers(std::vector<cv::Point2f>& a, std::vector<cv::Point2f>& b, const PipelineParams& params,
                             std::vector<std::uint8_t>& inliers, const OdometryEpipolar* motion) {
  if (a.size() < 8 || a.size() != b.size()) return 0;
  cv::findFundamentalMat(a, b, cv::FM_RANSAC, params.ransac_threshold_px, 0.99, params.ransac_iterations, inliers);
  if (inliers.empty()) return 0;
  if (motion != nullptr && params.odometry_epipolar_px > 0.0) {
    for (std::size_t i = 0; i < a.size(); ++i)
      if (inliers[i] != 0 && odometry_epipolar_distance_px(*motion, a[i], b[i]) > params.odometry_epipolar_px) inliers[i] = 0;
  }
  std::size_t kept = 0;
  int outliers = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (inliers[i] == 0) {
      ++outliers;
      continue;
    }
    a[kept] = a[i];
    b[kept] = b[i];
    ++kept;
  }
  a.resize(kept);
  b.resize(kept);
  return outliers;
}

Result<ObstaclePipeline> ObstaclePipeline::create(IptCamera camera, PipelineParams pipeline, ClassifierParams classifier,
                                                  ProfileParams profiles) {
  VISNAV_TRY(camera.validate());
  VISNAV_TRY(pipeline.validate());
  VISNAV_TRY(classifier.validate());
  VISNAV_TRY(profiles.validate());
  return ObstaclePipeline(camera, pipeline, std::move(classifier), profiles);
}

void ObstaclePipeline::restart() { have_first_ = false; }

Result<std::optional<PairResult>> ObstaclePipeline::process(const cv::Mat& grey, const Pose2D& odom_pose) {
  if (grey.type() != CV_8UC1 || grey.cols != camera_.width_px || grey.rows != camera_.height_px)
    return Error{"ObstaclePipeline: expected a " + std::to_string(camera_.width_px) + "x" +
                     std::to_string(camera_.height_px) + " grey frame, got " + std::to_string(grey.cols) + "x" +
                     std::to_string(grey.rows) + " with " + std::to_string(grey.channels()) + " channel(s)",
                 ErrorCode::invalid_value};
  const LensPose lens = lens_pose(camera_, odom_pose);
  if (!have_first_) {
    grey.copyTo(first_);
    first_pose_ = odom_pose;
    have_first_ = true;
    return std::optional<PairResult>{};
  }
  const LensPose first_lens = lens_pose(camera_, first_pose_);
  const double moved_m = std::hypot(lens.x_m - first_lens.x_m, lens.y_m - first_lens.y_m);
  if (moved_m < pipeline_.pair_distance_m) return std::optional<PairResult>{};
  const double turned_rad = std::fabs(std::remainder(odom_pose.heading_rad - first_pose_.heading_rad, 2.0 * CV_PI));
  if (moved_m > pipeline_.max_pair_distance_m || turned_rad > pipeline_.max_pair_rotation_rad) {
    // stale first frame or a fast turn: start a new pair here
    grey.copyTo(first_);
    first_pose_ = odom_pose;
    return std::optional<PairResult>{};
  }
  PairResult out;
  out.pose = odom_pose;
  out.first_pose = first_pose_;
  const OdometryEpipolar motion{camera_, first_lens, lens};
  out.ransac_outliers = track_pair(first_, grey, pipeline_, a_, b_, tracks_, &motion);
  VISNAV_ASSIGN(out.features, classify_features(camera_, first_lens, lens, a_, b_, classifier_));
  reduced_canny(grey, profiles_, edges_, scratch_);
  out.contacts = contact_points(edges_, out.features, camera_, odom_pose, profiles_);
  correct_contact_ranges(out.contacts, out.features, lens, moved_m, odom_pose, profiles_);
  out.span_points = fill_obstacle_spans(out.contacts, out.features, camera_, profiles_);
  grey.copyTo(first_);
  first_pose_ = odom_pose;
  return std::optional<PairResult>{std::move(out)};
}

}  // namespace visnav::ipt
