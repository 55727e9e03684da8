#include "visnav/path_following/path_follower.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc/segmentation.hpp>

namespace visnav::path_following {

namespace {

struct HueTable {
  std::array<double, 180> cos_h{};
  std::array<double, 180> sin_h{};
  HueTable() {
    for (int h = 0; h < 180; ++h) {
      const double rad = 2.0 * h * std::numbers::pi / 180.0;  // OpenCV 8-bit hue is degrees / 2
      cos_h[static_cast<std::size_t>(h)] = std::cos(rad);
      sin_h[static_cast<std::size_t>(h)] = std::sin(rad);
    }
  }
};

const HueTable& hue_table() {
  static const HueTable table;
  return table;
}

Eigen::Matrix3d regularised(const Eigen::Matrix3d& cov, double noise_floor) {
  return cov + Eigen::Matrix3d::Identity() * (noise_floor * noise_floor);
}

std::string describe_type(const cv::Mat& m) {
  return std::to_string(m.channels()) + "-channel " + (m.depth() == CV_8U ? std::string("8-bit") : "non-8-bit");
}

}  // namespace

std::string_view to_string(PathStatus status) {
  switch (status) {
    case PathStatus::ok: return "ok";
    case PathStatus::path_lost: return "path lost";
    case PathStatus::path_fills_image: return "path fills image";
    case PathStatus::dark_frame: return "dark frame";
    case PathStatus::no_reference: return "no reference";
  }
  return "unknown";
}

std::string_view to_string(ReferenceSource source) {
  switch (source) {
    case ReferenceSource::learned: return "learned";
    case ReferenceSource::previous: return "previous";
    case ReferenceSource::taught: return "taught";
  }
  return "unknown";
}

ColourModel ColourMoments::model() const {
  ColourModel m;
  m.pixels = n;
  if (n <= 0.0) return m;
  m.mean = sum / n;
  m.cov = sum_sq / n - m.mean * m.mean.transpose();
  m.cov = 0.5 * (m.cov + m.cov.transpose());
  // Guard tiny negative variances from cancellation.
  for (int i = 0; i < 3; ++i) m.cov(i, i) = std::max(m.cov(i, i), 0.0);
  return m;
}

Eigen::Vector3d hsv_cone_feature(std::uint8_t h, std::uint8_t s, std::uint8_t v) {
  const auto& t = hue_table();
  const std::size_t hi = std::min<std::size_t>(h, 179);
  return {s * t.cos_h[hi], s * t.sin_h[hi], static_cast<double>(v)};
}

double merge_distance_sq(const ColourModel& a, const ColourModel& b, double noise_floor) {
  const Eigen::Vector3d d = a.mean - b.mean;
  const Eigen::Matrix3d c = regularised(a.cov + b.cov, noise_floor);
  return d.dot(c.ldlt().solve(d));
}

double class_distance_sq(const ColourModel& segment, const ColourModel& reference, double noise_floor) {
  const Eigen::Vector3d d = segment.mean - reference.mean;
  const Eigen::Matrix3d c = regularised(reference.cov, noise_floor);
  return d.dot(c.ldlt().solve(d));
}

ColourModel pool_models(const ColourModel& a, const ColourModel& b) {
  const double na = std::max(a.pixels, 1.0);
  const double nb = std::max(b.pixels, 1.0);
  const double wa = na / (na + nb);
  const double wb = 1.0 - wa;
  ColourModel m;
  m.mean = wa * a.mean + wb * b.mean;
  const Eigen::Vector3d da = a.mean - m.mean;
  const Eigen::Vector3d db = b.mean - m.mean;
  m.cov = wa * (a.cov + da * da.transpose()) + wb * (b.cov + db * db.transpose());
  m.pixels = na + nb;
  return m;
}

AppearanceSummary::AppearanceSummary(const PathFollowerParams& params, double min_frame_share)
    : merge_distance_(params.ref_merge_distance),
      noise_floor_(params.colour_noise_floor),
      min_frame_share_(std::clamp(min_frame_share, 1e-6, 1.0)) {}

void AppearanceSummary::clear() {
  frames_ = 0;
  clusters_.clear();
}

void AppearanceSummary::add_frame(std::span<const ColourModel> models) {
  if (models.empty()) return;
  const int frame = frames_++;
  const double limit_sq = merge_distance_ * merge_distance_;
  for (const auto& m : models) {
    if (!m.mean.allFinite() || !m.cov.allFinite()) continue;
    Cluster* best = nullptr;
    double best_d = limit_sq;
    for (auto& c : clusters_) {
      const double d = merge_distance_sq(m, c.model, noise_floor_);
      if (d <= best_d) {
        best_d = d;
        best = &c;
      }
    }
    if (best == nullptr) {
      clusters_.push_back(Cluster{m, 0, -1});
      best = &clusters_.back();
    } else {
      best->model = pool_models(best->model, m);
    }
    if (best->last_frame != frame) {  // several models of one frame in a cluster count once
      best->last_frame = frame;
      ++best->frames;
    }
  }
}

std::vector<ColourModel> AppearanceSummary::summary() const {
  std::vector<const Cluster*> order;
  for (const auto& c : clusters_) order.push_back(&c);
  std::stable_sort(order.begin(), order.end(), [](const Cluster* a, const Cluster* b) { return a->frames > b->frames; });
  std::vector<ColourModel> out;
  for (std::size_t i = 0; i < order.size(); ++i)
    if (i == 0 || order[i]->frames >= min_frame_share_ * frames_) out.push_back(order[i]->model);
  return out;
}

HorizonEstimate detect_horizon(const cv::Mat& bgr, const PathFollowerParams& params, cv::Mat& row_means_scratch) {
  HorizonEstimate h;
  const int rows = bgr.rows;
  const int max_row = std::max(0, rows - kMinGroundRowsPx);
  auto clamp_row = [&](double r) { return std::clamp(static_cast<int>(std::lround(r)), 0, max_row); };
  if (params.horizon_mode == "row") {
    h.row_px = clamp_row(params.horizon_row_px);
    return h;
  }
  h.row_px = clamp_row(params.horizon_ratio * rows);
  if (params.horizon_mode != "auto" || bgr.empty()) return h;

  cv::reduce(bgr, row_means_scratch, 1, cv::REDUCE_AVG, CV_32F);  // rows × 1, CV_32FC3
  const int win = params.horizon_window_px;
  const int lo = std::max(win, static_cast<int>(std::ceil(params.horizon_search_min_ratio * rows)));
  const int hi = std::min(rows - win, static_cast<int>(std::floor(params.horizon_search_max_ratio * rows)));
  double best = -1.0;
  int best_row = -1;
  for (int r = lo; r <= hi; ++r) {
    cv::Vec3d above(0, 0, 0), below(0, 0, 0);
    for (int i = 0; i < win; ++i) {
      above += cv::Vec3d(row_means_scratch.at<cv::Vec3f>(r - 1 - i, 0));
      below += cv::Vec3d(row_means_scratch.at<cv::Vec3f>(r + i, 0));
    }
    const double contrast = cv::norm(above - below) / win;
    if (contrast > best) {
      best = contrast;
      best_row = r;
    }
  }
  if (best_row >= 0) h.contrast = best;
  if (best_row >= 0 && best >= params.horizon_min_contrast) {
    h.row_px = clamp_row(best_row);
    h.detected = true;
  }
  return h;
}

Twist steering_command(std::span<const cv::Point2f> middle_points, int image_width_px, int ground_rows,
                       const PathFollowerParams& params, double& offset, int path_rows, double target_offset) {
  offset = 0.0;
  Twist cmd;
  if (middle_points.empty() || image_width_px <= 0 || ground_rows <= 0) return cmd;
  const double half_w = 0.5 * image_width_px;
  double sum = 0.0;
  for (const auto& p : middle_points) sum += (p.x - half_w) / half_w;
  offset = sum / static_cast<double>(middle_points.size());
  const double n = path_rows >= 0 ? static_cast<double>(path_rows) : static_cast<double>(middle_points.size());
  cmd.angular_radps = std::clamp(-params.alpha_radps * (offset - target_offset), -params.max_angular_radps, params.max_angular_radps);
  const double v = params.beta_mps * std::min(1.0, n / ground_rows) -
                   params.turn_slowdown_mps_per_radps * std::abs(cmd.angular_radps);
  cmd.linear_mps = std::clamp(v, 0.0, params.max_linear_mps);
  return cmd;
}

// ---------------------------------------------------------------------------------------------

Result<PathFollower> PathFollower::create(const PathFollowerParams& params) {
  auto valid = params.validate();
  if (!valid) return valid.error().with_context("path follower params");
  return PathFollower(params);
}

PathFollower::PathFollower(const PathFollowerParams& params) : params_(params) {
  const double area_scale = params_.seg_scale * params_.seg_scale;
  const int min_size = std::max(1, static_cast<int>(std::lround(params_.seg_min_size_px * area_scale)));
  segmenter_ = cv::ximgproc::segmentation::createGraphSegmentation(params_.seg_sigma, static_cast<float>(params_.seg_k),
                                                                    min_size);
  if (params_.opening_kernel_px > 0)
    opening_kernel_ = cv::getStructuringElement(cv::MORPH_ELLIPSE,
                                                cv::Size(params_.opening_kernel_px, params_.opening_kernel_px));
}

PathFollower::PathFollower(PathFollower&&) noexcept = default;
PathFollower& PathFollower::operator=(PathFollower&&) noexcept = default;
PathFollower::~PathFollower() = default;

void PathFollower::reset() {
  previous_models_.clear();
  stages_.reference_models.clear();
  taught_models_.clear();
  taught_inverse_.clear();
  target_offset_ = 0.0;
}

void PathFollower::set_taught_models(std::vector<ColourModel> models) {
  taught_models_.clear();
  taught_inverse_.clear();
  for (auto& m : models) {
    if (!m.mean.allFinite() || !m.cov.allFinite()) continue;
    taught_inverse_.push_back(regularised(m.cov, params_.colour_noise_floor).inverse());
    taught_models_.push_back(std::move(m));
  }
}

void PathFollower::gate_reference_models() {
  gated_models_ = 0;
  reference_source_ = ReferenceSource::learned;
  auto& models = stages_.reference_models;
  if (!(params_.taught_gate_distance > 0.0) || taught_models_.empty() || models.empty()) return;
  const double limit_sq = params_.taught_gate_distance * params_.taught_gate_distance;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < models.size(); ++i) {
    bool near_taught = false;
    for (std::size_t t = 0; t < taught_models_.size() && !near_taught; ++t) {
      const Eigen::Vector3d d = models[i].mean - taught_models_[t].mean;
      near_taught = d.dot(taught_inverse_[t] * d) <= limit_sq;
    }
    if (!near_taught) continue;
    if (kept != i) {
      models[kept] = models[i];
      kept_clusters_[kept] = kept_clusters_[i];
    }
    ++kept;
  }
  gated_models_ = static_cast<int>(models.size() - kept);
  models.resize(kept);
  kept_clusters_.resize(kept);
  if (kept > 0) return;
  // Every re-learned model drifted: keep the previous accepted ones, else the taught ones.
  reference_source_ = previous_models_.empty() ? ReferenceSource::taught : ReferenceSource::previous;
  models = previous_models_.empty() ? taught_models_ : previous_models_;
  kept_clusters_.assign(models.size(), -1);
}

void PathFollower::ensure_buffers(cv::Size size) {
  if (size == buffer_size_) return;
  buffer_size_ = size;
  blurred_.create(size, CV_8UC3);
  hsv_.create(size, CV_8UC3);
  labels_.create(size, CV_32SC1);
  roi_.create(size, CV_8UC1);
  classified_.create(size, CV_8UC1);
  opened_.create(size, CV_8UC1);
  components_.create(size, CV_32SC1);
  region_.create(size, CV_8UC1);
  if (params_.seg_scale < 1.0) {
    const cv::Size small(std::max(1, static_cast<int>(std::lround(size.width * params_.seg_scale))),
                         std::max(1, static_cast<int>(std::lround(size.height * params_.seg_scale))));
    small_.create(small, CV_8UC3);
    small_labels_.create(small, CV_32SC1);
  }
  roi_rows_ = roi_cols_ = -1;
}

void PathFollower::build_reference_roi(int ground_rows, int width) {
  if (ground_rows == roi_rows_ && width == roi_cols_) return;
  roi_rows_ = ground_rows;
  roi_cols_ = width;
  cv::Mat roi = roi_.rowRange(0, ground_rows);
  roi.setTo(0);
  const double cx = 0.5 * width;
  const double bottom_half = 0.5 * params_.ref_bottom_width_ratio * width;
  const double top_half = 0.5 * params_.ref_top_width_ratio * width;
  const int height = std::max(1, static_cast<int>(std::lround(params_.ref_height_ratio * ground_rows)));
  const int y_bottom = ground_rows - 1;
  const int y_top = std::max(0, ground_rows - height);
  const std::array<cv::Point, 4> corners{
      cv::Point(static_cast<int>(std::lround(cx - bottom_half)), y_bottom),
      cv::Point(static_cast<int>(std::lround(cx + bottom_half)) - 1, y_bottom),
      cv::Point(static_cast<int>(std::lround(cx + top_half)) - 1, y_top),
      cv::Point(static_cast<int>(std::lround(cx - top_half)), y_top)};
  cv::fillConvexPoly(roi, corners.data(), static_cast<int>(corners.size()), cv::Scalar(255));
}

void PathFollower::accumulate_segment_statistics(const cv::Mat& hsv, const cv::Mat& labels, const cv::Mat& roi,
                                                 int segments) {
  segment_stats_.assign(static_cast<std::size_t>(segments), SegmentStats{});
  const auto& t = hue_table();
  for (int y = 0; y < hsv.rows; ++y) {
    const auto* px = hsv.ptr<cv::Vec3b>(y);
    const auto* lab = labels.ptr<int>(y);
    const auto* in_roi = roi.ptr<std::uint8_t>(y);
    for (int x = 0; x < hsv.cols; ++x) {
      const cv::Vec3b& p = px[x];
      const std::size_t hi = std::min<std::size_t>(p[0], 179);
      const Eigen::Vector3d f(p[1] * t.cos_h[hi], p[1] * t.sin_h[hi], static_cast<double>(p[2]));
      SegmentStats& s = segment_stats_[static_cast<std::size_t>(lab[x])];
      s.moments.add(f);
      if (in_roi[x] != 0) {
        s.roi_moments.add(f);
        s.roi_pixels += 1.0;
      }
    }
  }
}

int PathFollower::learn_reference_models(double roi_pixels) {
  const double merge_sq = params_.ref_merge_distance * params_.ref_merge_distance;
  const auto segments = segment_stats_.size();
  order_.clear();
  for (std::size_t s = 0; s < segments; ++s)
    if (segment_stats_[s].roi_pixels > 0.0) order_.push_back(static_cast<int>(s));
  std::sort(order_.begin(), order_.end(), [&](int a, int b) {
    return segment_stats_[static_cast<std::size_t>(a)].roi_pixels > segment_stats_[static_cast<std::size_t>(b)].roi_pixels;
  });

  // Greedy merge, largest contribution to the reference region first. Only the pixels inside the
  // reference region count, so a segment that leaks across the path edge does not drag the
  // surroundings into the path model.
  clusters_.clear();
  segment_cluster_.assign(segments, -1);
  for (int s : order_) {
    const SegmentStats& st = segment_stats_[static_cast<std::size_t>(s)];
    const ColourModel m = st.roi_moments.model();
    int best = -1;
    double best_d = merge_sq;
    for (std::size_t c = 0; c < clusters_.size(); ++c) {
      const double d = merge_distance_sq(m, clusters_[c].model, params_.colour_noise_floor);
      if (d <= best_d) {
        best_d = d;
        best = static_cast<int>(c);
      }
    }
    if (best < 0) {
      clusters_.push_back(Cluster{st.roi_moments, m, st.roi_pixels});
      best = static_cast<int>(clusters_.size()) - 1;
    } else {
      Cluster& c = clusters_[static_cast<std::size_t>(best)];
      c.moments.merge(st.roi_moments);
      c.model = c.moments.model();
      c.roi_pixels += st.roi_pixels;
    }
    segment_cluster_[static_cast<std::size_t>(s)] = best;
  }

  // Keep the models that cover enough of the reference region, largest coverage first.
  kept_clusters_.clear();
  for (std::size_t c = 0; c < clusters_.size(); ++c)
    if (roi_pixels > 0.0 && clusters_[c].roi_pixels / roi_pixels >= params_.ref_min_coverage)
      kept_clusters_.push_back(static_cast<int>(c));
  std::sort(kept_clusters_.begin(), kept_clusters_.end(), [&](int a, int b) {
    return clusters_[static_cast<std::size_t>(a)].roi_pixels > clusters_[static_cast<std::size_t>(b)].roi_pixels;
  });
  auto& models = stages_.reference_models;
  models.clear();
  for (int c : kept_clusters_) models.push_back(clusters_[static_cast<std::size_t>(c)].model);

  // Taught-appearance gate (see the header), before blending so a rejected model never leaks in.
  gate_reference_models();

  // Appearance adaptation: blend each model with the closest previous one (moment matching of
  // the two-component mixture with weights 1 − b and b).
  const double b = params_.model_blend;
  if (b > 0.0 && !previous_models_.empty() && reference_source_ == ReferenceSource::learned) {
    for (auto& m : models) {
      const ColourModel* closest = nullptr;
      double best_d = merge_sq;
      for (const auto& p : previous_models_) {
        const double d = merge_distance_sq(m, p, params_.colour_noise_floor);
        if (d <= best_d) {
          best_d = d;
          closest = &p;
        }
      }
      if (closest == nullptr) continue;
      const Eigen::Vector3d mean = (1.0 - b) * m.mean + b * closest->mean;
      const Eigen::Vector3d da = m.mean - mean;
      const Eigen::Vector3d db = closest->mean - mean;
      m.cov = (1.0 - b) * (m.cov + da * da.transpose()) + b * (closest->cov + db * db.transpose());
      m.mean = mean;
    }
  }

  reference_inverse_.clear();
  for (const auto& m : models) reference_inverse_.push_back(regularised(m.cov, params_.colour_noise_floor).inverse());
  return static_cast<int>(models.size());
}

void PathFollower::classify_segments(int segments, int used_models) {
  const double limit_sq = params_.class_distance * params_.class_distance;
  const auto& models = stages_.reference_models;
  const std::size_t used = std::min(models.size(), static_cast<std::size_t>(std::max(used_models, 0)));
  segment_is_path_.assign(static_cast<std::size_t>(segments), 0);
  for (std::size_t s = 0; s < static_cast<std::size_t>(segments); ++s) {
    const ColourMoments& mo = segment_stats_[s].moments;
    if (mo.n <= 0.0) continue;
    const Eigen::Vector3d mean = mo.sum / mo.n;
    for (std::size_t r = 0; r < used; ++r) {
      const Eigen::Vector3d d = mean - models[r].mean;
      if (d.dot(reference_inverse_[r] * d) <= limit_sq) {
        segment_is_path_[s] = 1;
        break;
      }
    }
  }
}

int PathFollower::extract_region(int segments, int used_models, const cv::Mat& labels, const cv::Mat& roi,
                                 bool all_large_components) {
  const int ground_rows = labels.rows;
  const int width = labels.cols;
  classify_segments(segments, used_models);
  cv::Mat classified = classified_.rowRange(0, ground_rows);
  for (int y = 0; y < ground_rows; ++y) {
    const auto* lab = labels.ptr<int>(y);
    auto* dst = classified.ptr<std::uint8_t>(y);
    for (int x = 0; x < width; ++x) dst[x] = segment_is_path_[static_cast<std::size_t>(lab[x])] != 0 ? 255 : 0;
  }
  cv::Mat opened = opened_.rowRange(0, ground_rows);
  // BORDER_ISOLATED: `classified` is a view of the top rows of a larger buffer, and without it
  // OpenCV's filters read the rows below the view as if they were image (left over from earlier
  // frames, or never written): the opening's last rows, and through them the region, then
  // depended on heap contents, and the same seed drove differently beside other runs.
  if (!opening_kernel_.empty())
    cv::morphologyEx(classified, opened, cv::MORPH_OPEN, opening_kernel_, cv::Point(-1, -1), 1,
                     cv::BORDER_CONSTANT | cv::BORDER_ISOLATED, cv::morphologyDefaultBorderValue());
  else classified.copyTo(opened);

  cv::Mat components = components_.rowRange(0, ground_rows);
  const int component_count = cv::connectedComponents(opened, components, 8, CV_32S);
  component_overlap_.assign(static_cast<std::size_t>(std::max(component_count, 1)), 0.0);
  component_pixels_.assign(static_cast<std::size_t>(std::max(component_count, 1)), 0.0);
  for (int y = 0; y < ground_rows; ++y) {
    const auto* c = components.ptr<int>(y);
    const auto* in_roi = roi.ptr<std::uint8_t>(y);
    for (int x = 0; x < width; ++x) {
      if (c[x] <= 0) continue;
      component_pixels_[static_cast<std::size_t>(c[x])] += 1.0;
      if (in_roi[x] != 0) component_overlap_[static_cast<std::size_t>(c[x])] += 1.0;
    }
  }
  cv::Mat region = region_.rowRange(0, ground_rows);
  if (all_large_components) {
    // Another surface is in the trapezoid (the gate rejected a model): it cannot anchor the region.
    // Every path component of at least min_area_share of the ground image counts — e.g. the gravel
    // left and right of a crossing road and beyond it — so the row-wise middles stay on the path.
    const double min_pixels = std::max(1.0, params_.min_area_share * ground_rows * width);
    int count = 0;
    for (int y = 0; y < ground_rows; ++y) {
      const auto* c = components.ptr<int>(y);
      auto* dst = region.ptr<std::uint8_t>(y);
      for (int x = 0; x < width; ++x) {
        const bool in = c[x] > 0 && component_pixels_[static_cast<std::size_t>(c[x])] >= min_pixels;
        dst[x] = in ? 255 : 0;
        count += in ? 1 : 0;
      }
    }
    return count;
  }
  int best = 0;
  for (int c = 1; c < component_count; ++c)
    if (component_overlap_[static_cast<std::size_t>(c)] > component_overlap_[static_cast<std::size_t>(best)]) best = c;
  if (best == 0) {
    region.setTo(0);
    return 0;
  }
  cv::compare(components, cv::Scalar(best), region, cv::CMP_EQ);
  return cv::countNonZero(region);
}

int PathFollower::extract_middle_points(const cv::Mat& region, int row_offset, std::vector<cv::Point2f>& out,
                                        bool junction) const {
  // Junction mode (see the header): rows whose path run reaches an image border are left out of
  // the steering as long as enough rows lie inside the image.
  out.clear();
  int path_rows = 0;
  std::size_t inside = 0;
  for (int pass = 0; pass < 2; ++pass) {
    if (pass == 1) {
      if (!junction) return path_rows;
      const std::size_t min_inside = std::max<std::size_t>(5, static_cast<std::size_t>(path_rows) / 5);
      if (inside < min_inside) return path_rows;  // too few: keep every row (the original law)
      out.clear();
    }
  for (int y = 0; y < region.rows; ++y) {
    const auto* p = region.ptr<std::uint8_t>(y);
    int left = -1;
    for (int x = 0; x < region.cols; ++x)
      if (p[x] != 0) { left = x; break; }
    if (left < 0) continue;
    int right = left;
    for (int x = region.cols - 1; x > left; --x)
      if (p[x] != 0) { right = x; break; }
    const bool touches_border = junction && (left == 0 || right == region.cols - 1);
    if (pass == 0) {
      ++path_rows;
      if (!touches_border) ++inside;
    } else if (touches_border) {
      continue;
    }
    // Continuous coordinates: pixel i spans [i, i+1), so a band symmetric about the image
    // centre has its middle exactly at w/2.
    out.emplace_back(0.5f * static_cast<float>(left + right + 1), static_cast<float>(y + row_offset));
  }
  }
  return path_rows;
}

Result<PathEstimate> PathFollower::process(const cv::Mat& bgr) {
  PathEstimate out;
  VISNAV_TRY(process(bgr, out));
  return out;
}

namespace {

Status check_image(const cv::Mat& bgr) {
  if (bgr.empty()) return fail(ErrorCode::invalid_value, "path follower: empty image");
  if (bgr.type() != CV_8UC3)
    return fail(ErrorCode::invalid_value, "path follower: expected an 8-bit 3-channel BGR image (CV_8UC3), got a " + describe_type(bgr) +
                " image");
  if (bgr.cols < kMinImageWidthPx || bgr.rows < kMinImageHeightPx)
    return fail(ErrorCode::out_of_range, "path follower: image " + std::to_string(bgr.cols) + "x" + std::to_string(bgr.rows) +
                " is smaller than the minimum " + std::to_string(kMinImageWidthPx) + "x" +
                std::to_string(kMinImageHeightPx));
  return ok();
}

}  // namespace

void PathFollower::begin_frame(PathEstimate& out, const cv::Mat& bgr, int top) {
  out.status = PathStatus::ok;
  out.ground_top_px = top;
  out.mask.create(bgr.size(), CV_8UC1);
  out.mask.setTo(0);
  out.contour.clear();
  out.middle_points.clear();
  out.area_share = 0.0;
  out.mean_offset = 0.0;
  out.plain_offset = 0.0;
  out.junction_offset = 0.0;
  out.segments = 0;
  out.reference_models = 0;
  out.gated_models = 0;
  out.reference_source = ReferenceSource::learned;
  out.command = Twist{};

  stages_.ground_top_px = top;
  stages_.blurred = cv::Mat();
  stages_.labels = cv::Mat();
  stages_.reference_roi = cv::Mat();
  stages_.classified = cv::Mat();
  stages_.opened = cv::Mat();
  stages_.segment_is_reference.clear();
}

int PathFollower::segment_ground(const cv::Mat& ground, int ground_rows, cv::Mat& blurred, cv::Mat& labels) {
  // Buffers are views of the top rows of the full-size buffers so that a moving horizon never
  // reallocates.
  blurred = blurred_.rowRange(0, ground_rows);
  if (params_.median_blur_px > 1) cv::medianBlur(ground, blurred, params_.median_blur_px);
  else ground.copyTo(blurred);
  labels = labels_.rowRange(0, ground_rows);
  if (params_.seg_scale < 1.0) {
    const int small_rows = std::clamp(static_cast<int>(std::lround(ground_rows * params_.seg_scale)), 1, small_.rows);
    // A header of its own (no parent extent): the segmenter smooths its input, and OpenCV's
    // filters read a view's parent rows beyond the view as image (see extract_region).
    cv::Mat small(small_rows, small_.cols, small_.type(), small_.data, small_.step);
    cv::Mat small_labels = small_labels_.rowRange(0, small_rows);
    cv::resize(blurred, small, small.size(), 0.0, 0.0, cv::INTER_AREA);
    segmenter_->processImage(small, small_labels);
    cv::resize(small_labels, labels, labels.size(), 0.0, 0.0, cv::INTER_NEAREST);
  } else {
    segmenter_->processImage(blurred, labels);
  }
  double max_label = 0.0;
  cv::minMaxIdx(labels, nullptr, &max_label);
  return static_cast<int>(max_label) + 1;
}

int PathFollower::extract_path_region(int segments, const cv::Mat& labels, const cv::Mat& roi, double ground_pixels,
                                      PathEstimate& out) {
  // When the reference region straddles the path edge, the surroundings' model passes the
  // coverage test too and the region swallows (nearly) the whole image; then the least covering
  // models are dropped one by one while the region is larger than multi_model_max_share.
  int used = out.reference_models;
  int region_pixels = 0;
  for (;; --used) {
    region_pixels = extract_region(segments, used, labels, roi, gated_models_ > 0);
    if (used == 1 || region_pixels / ground_pixels <= params_.multi_model_max_share) break;
  }
  out.reference_models = used;
  stages_.reference_models.resize(static_cast<std::size_t>(used));
  previous_models_ = stages_.reference_models;  // what the next frame blends with
  stages_.segment_is_reference.assign(static_cast<std::size_t>(segments), 0);
  for (std::size_t s = 0; s < static_cast<std::size_t>(segments); ++s)
    for (int k = 0; k < used; ++k)
      if (kept_clusters_[static_cast<std::size_t>(k)] >= 0 &&
          segment_cluster_[s] == kept_clusters_[static_cast<std::size_t>(k)])
        stages_.segment_is_reference[s] = 1;
  return region_pixels;
}

void PathFollower::trace_path(const cv::Mat& region, int top, int width, int ground_rows, PathEstimate& out) {
  cv::findContours(region, contours_, hierarchy_, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE, cv::Point(0, top));
  std::size_t largest = 0;
  double largest_area = -1.0;
  for (std::size_t i = 0; i < contours_.size(); ++i) {
    const double a = std::abs(cv::contourArea(contours_[i]));
    if (a > largest_area) {
      largest_area = a;
      largest = i;
    }
  }
  if (!contours_.empty()) out.contour.assign(contours_[largest].begin(), contours_[largest].end());
  const int path_rows = extract_middle_points(region, top, out.middle_points, junction_mode_);

  double offset = 0.0;
  const Twist command = steering_command(out.middle_points, width, ground_rows, params_, offset, path_rows, target_offset_);
  out.mean_offset = offset;
  // The other mode's offset (the teacher records both; see PathEstimate).
  extract_middle_points(region, top, other_points_, !junction_mode_);
  double other = 0.0;
  for (const auto& q : other_points_) other += (q.x - 0.5 * width) / (0.5 * width);
  if (!other_points_.empty()) other /= static_cast<double>(other_points_.size());
  out.plain_offset = junction_mode_ ? other : offset;
  out.junction_offset = junction_mode_ ? offset : other;
  if (out.area_share < params_.min_area_share) out.status = PathStatus::path_lost;
  else if (out.area_share > params_.fill_area_share) out.status = PathStatus::path_fills_image;
  if (out.status == PathStatus::ok) out.command = command;
}

Status PathFollower::process(const cv::Mat& bgr, PathEstimate& out) {
  VISNAV_TRY(check_image(bgr));
  ensure_buffers(bgr.size());

  const int rows = bgr.rows;
  const int width = bgr.cols;
  out.horizon = detect_horizon(bgr, params_, row_means_);
  const int top = std::min(out.horizon.row_px + params_.horizon_margin_px, rows - kMinGroundRowsPx);
  const int ground_rows = rows - top;
  const double ground_pixels = static_cast<double>(ground_rows) * width;
  const cv::Mat ground = bgr.rowRange(top, rows);
  begin_frame(out, bgr, top);

  const cv::Scalar mean_bgr = cv::mean(ground);
  out.mean_intensity = (mean_bgr[0] + mean_bgr[1] + mean_bgr[2]) / 3.0;
  if (out.mean_intensity < params_.dark_mean_intensity) {
    out.status = PathStatus::dark_frame;
    stages_.reference_models.clear();
    return ok();
  }

  // Segmentation (Sec. 4.1).
  cv::Mat blurred, labels;
  const int segments = segment_ground(ground, ground_rows, blurred, labels);
  out.segments = segments;
  stages_.blurred = blurred;
  stages_.labels = labels;

  // Segment models and reference models (Sec. 4.2, steps 1-2).
  cv::Mat hsv = hsv_.rowRange(0, ground_rows);
  cv::cvtColor(blurred, hsv, cv::COLOR_BGR2HSV);
  build_reference_roi(ground_rows, width);
  const cv::Mat roi = roi_.rowRange(0, ground_rows);
  stages_.reference_roi = roi;
  accumulate_segment_statistics(hsv, labels, roi, segments);
  const double roi_pixels = cv::countNonZero(roi);
  out.reference_models = learn_reference_models(roi_pixels);
  out.gated_models = gated_models_;
  out.reference_source = reference_source_;
  if (out.reference_models == 0) {
    out.status = PathStatus::no_reference;
    return ok();
  }

  // Classification (step 3), mask, opening and the connected region overlapping the reference
  // region most (step 4).
  const int region_pixels = extract_path_region(segments, labels, roi, ground_pixels, out);
  stages_.classified = classified_.rowRange(0, ground_rows);
  stages_.opened = opened_.rowRange(0, ground_rows);
  if (region_pixels == 0) {
    out.status = PathStatus::path_lost;
    return ok();
  }
  const cv::Mat region = region_.rowRange(0, ground_rows);
  region.copyTo(out.mask.rowRange(top, rows));
  out.area_share = region_pixels / ground_pixels;

  // Contour and middle points (Sec. 4.3).
  trace_path(region, top, width, ground_rows, out);
  return ok();
}

}  // namespace visnav::path_following
