// Matching and histogram voting (see heading.hpp for the contract).
#include "visnav/histogram_voting.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>

#include <opencv2/core/hal/hal.hpp>

namespace visnav::feature_replay {

Status HeadingParams::validate() const {
  VISNAV_TRY(schema().check(*this));
  if (bin_count % 2 == 0) return fail("bin_count must be odd (one bin centred on zero), got " + std::to_string(bin_count));
  if (full_confidence_inliers < min_inliers)
    return fail("full_confidence_inliers (" + std::to_string(full_confidence_inliers) + ") must be >= min_inliers (" +
                std::to_string(min_inliers) + ")");
  return ok();
}

const ParamSchema<HeadingParams>& HeadingParams::schema() {
  static const auto s =
      ParamSchema<HeadingParams>{}
          .field("ratio", &HeadingParams::ratio, "Lowe ratio test: best < ratio * second best distance (1 = off)")
          .range(0.1, 1.0)
          .field("cross_check", &HeadingParams::cross_check, "keep only mutual best matches")
          .field("max_descriptor_distance", &HeadingParams::max_descriptor_distance,
                 "absolute descriptor distance gate (Hamming bits or L2); 0 = off")
          .range(0.0, 1e6)
          .field("max_vertical_px", &HeadingParams::max_vertical_px, "vertical displacement gate |dv|, px; 0 = off")
          .range(0.0, 10000.0)
          .field("bin_width_px", &HeadingParams::bin_width_px, "histogram bin width, px")
          .range(0.5, 1000.0)
          .field("bin_count", &HeadingParams::bin_count, "histogram bins (odd), centred on zero")
          .range(1, 10001)
          .field("refine_window_px", &HeadingParams::refine_window_px,
                 "half-width of the inlier window around the refined peak, px")
          .range(0.5, 1000.0)
          .field("min_inliers", &HeadingParams::min_inliers, "fewer inliers give confidence 0")
          .range(1, 100000)
          .field("full_confidence_inliers", &HeadingParams::full_confidence_inliers,
                 "inlier count at which the count term of the confidence reaches 1")
          .range(1, 100000)
          .field("min_confidence", &HeadingParams::min_confidence, "estimates below this confidence are not valid")
          .range(0.0, 1.0)
          .field("horizontal_fov_deg", &HeadingParams::horizontal_fov_deg,
                 "camera horizontal field of view, deg (offset to heading conversion)")
          .range(1.0, 179.0);
  return s;
}

Status check_features(const Features& features, const char* what) {
  const auto& d = features.descriptors;
  if (features.keypoints.empty() && d.empty()) return ok();
  if (static_cast<std::size_t>(d.rows) != features.keypoints.size())
    return fail(std::string(what) + ": " + std::to_string(features.keypoints.size()) + " keypoints but " +
                std::to_string(d.rows) + " descriptor rows");
  if (d.channels() != 1 || (d.depth() != CV_8U && d.depth() != CV_32F))
    return fail(std::string(what) + ": descriptors must be CV_8UC1 (binary) or CV_32FC1 (float)");
  return ok();
}

namespace {

inline int popcount_bytes(const std::uint8_t* a, const std::uint8_t* b, int bytes) {
  int n = 0;
  int i = 0;
  for (; i + 8 <= bytes; i += 8) {
    std::uint64_t x, y;
    std::memcpy(&x, a + i, 8);
    std::memcpy(&y, b + i, 8);
    n += __builtin_popcountll(x ^ y);
  }
  for (; i < bytes; ++i) n += __builtin_popcount(static_cast<unsigned>(a[i] ^ b[i]));
  return n;
}

struct KnnOut {
  int* best_train;
  float* best_d;
  float* second_d;
  int* train_best_query;  // may be null
  float* train_best_d;    // may be null
  const int* lo;          // per query: first train row to compare (null: 0)
  const int* hi;          // per query: one past the last (null: train.rows)
};

// Hamming kernel body; inlined into a popcnt-enabled and a generic entry point.
__attribute__((always_inline)) inline void hamming_kernel(const cv::Mat& q, const cv::Mat& t, const KnnOut& o) {
  const int bytes = q.cols;
  const int nq = q.rows;
  for (int i = 0; i < nq; ++i) {
    const std::uint8_t* qa = q.ptr<std::uint8_t>(i);
    const int j0 = o.lo != nullptr ? o.lo[i] : 0;
    const int j1 = o.hi != nullptr ? o.hi[i] : t.rows;
    int b1 = std::numeric_limits<int>::max(), b2 = std::numeric_limits<int>::max(), bi = -1;
    if (bytes == 32) {
      std::uint64_t q0, q1, q2, q3;
      std::memcpy(&q0, qa, 8); std::memcpy(&q1, qa + 8, 8); std::memcpy(&q2, qa + 16, 8); std::memcpy(&q3, qa + 24, 8);
      for (int j = j0; j < j1; ++j) {
        const std::uint8_t* ta = t.ptr<std::uint8_t>(j);
        std::uint64_t t0, t1, t2, t3;
        std::memcpy(&t0, ta, 8); std::memcpy(&t1, ta + 8, 8); std::memcpy(&t2, ta + 16, 8); std::memcpy(&t3, ta + 24, 8);
        const int d = __builtin_popcountll(q0 ^ t0) + __builtin_popcountll(q1 ^ t1) + __builtin_popcountll(q2 ^ t2) +
                      __builtin_popcountll(q3 ^ t3);
        if (d < b2) {
          if (d < b1) { b2 = b1; b1 = d; bi = j; } else { b2 = d; }
        }
        if (o.train_best_query != nullptr && d < o.train_best_d[j]) { o.train_best_d[j] = static_cast<float>(d); o.train_best_query[j] = i; }
      }
    } else {
      for (int j = j0; j < j1; ++j) {
        const int d = popcount_bytes(qa, t.ptr<std::uint8_t>(j), bytes);
        if (d < b1) { b2 = b1; b1 = d; bi = j; } else if (d < b2) { b2 = d; }
        if (o.train_best_query != nullptr && d < o.train_best_d[j]) { o.train_best_d[j] = static_cast<float>(d); o.train_best_query[j] = i; }
      }
    }
    o.best_train[i] = bi;
    o.best_d[i] = bi < 0 ? std::numeric_limits<float>::infinity() : static_cast<float>(b1);
    o.second_d[i] = b2 == std::numeric_limits<int>::max() ? std::numeric_limits<float>::infinity() : static_cast<float>(b2);
  }
}

#if defined(__x86_64__) || defined(__i386__)
__attribute__((target("popcnt"))) void hamming_popcnt(const cv::Mat& q, const cv::Mat& t, const KnnOut& o) {
  hamming_kernel(q, t, o);
}
#endif
void hamming_generic(const cv::Mat& q, const cv::Mat& t, const KnnOut& o) { hamming_kernel(q, t, o); }

void hamming_knn(const cv::Mat& q, const cv::Mat& t, const KnnOut& o) {
#if defined(__x86_64__) || defined(__i386__)
  static const bool has_popcnt = __builtin_cpu_supports("popcnt");
  if (has_popcnt) { hamming_popcnt(q, t, o); return; }
#endif
  hamming_generic(q, t, o);
}

void l2_knn(const cv::Mat& q, const cv::Mat& t, const KnnOut& o) {
  const int n = q.cols;
  for (int i = 0; i < q.rows; ++i) {
    const float* qa = q.ptr<float>(i);
    const int j0 = o.lo != nullptr ? o.lo[i] : 0;
    const int j1 = o.hi != nullptr ? o.hi[i] : t.rows;
    float b1 = std::numeric_limits<float>::infinity(), b2 = b1;
    int bi = -1;
    for (int j = j0; j < j1; ++j) {
      const float d2 = cv::hal::normL2Sqr_(qa, t.ptr<float>(j), n);
      if (d2 < b1) { b2 = b1; b1 = d2; bi = j; } else if (d2 < b2) { b2 = d2; }
      if (o.train_best_query != nullptr) {
        const float d = std::sqrt(d2);
        if (d < o.train_best_d[j]) { o.train_best_d[j] = d; o.train_best_query[j] = i; }
      }
    }
    o.best_train[i] = bi;
    o.best_d[i] = std::sqrt(b1);
    o.second_d[i] = std::sqrt(b2);
  }
}

bool knn2_ranges(const cv::Mat& query, const cv::Mat& train, const int* lo, const int* hi, std::vector<int>& best_train,
                 std::vector<float>& best_d, std::vector<float>& second_d, std::vector<int>* train_best_query,
                 std::vector<float>* train_best_d) {
  if (query.type() != train.type() || (query.cols != train.cols && !query.empty() && !train.empty())) return false;
  if (query.type() != CV_8UC1 && query.type() != CV_32FC1) return false;
  const auto nq = static_cast<std::size_t>(query.rows);
  best_train.resize(nq);
  best_d.resize(nq);
  second_d.resize(nq);
  if (train_best_query != nullptr) {
    train_best_query->assign(static_cast<std::size_t>(train.rows), -1);
    train_best_d->assign(static_cast<std::size_t>(train.rows), std::numeric_limits<float>::infinity());
  }
  if (nq == 0) return true;
  if (train.rows == 0) {
    std::fill(best_train.begin(), best_train.end(), -1);
    std::fill(best_d.begin(), best_d.end(), std::numeric_limits<float>::infinity());
    std::fill(second_d.begin(), second_d.end(), std::numeric_limits<float>::infinity());
    return true;
  }
  KnnOut o{best_train.data(), best_d.data(), second_d.data(),
           train_best_query != nullptr ? train_best_query->data() : nullptr,
           train_best_query != nullptr ? train_best_d->data() : nullptr, lo, hi};
  if (query.depth() == CV_8U) hamming_knn(query, train, o); else l2_knn(query, train, o);
  return true;
}

}  // namespace

bool knn2_bruteforce(const cv::Mat& query, const cv::Mat& train, std::vector<int>& best_train,
                     std::vector<float>& best_d, std::vector<float>& second_d, std::vector<int>* train_best_query,
                     std::vector<float>* train_best_d) {
  return knn2_ranges(query, train, nullptr, nullptr, best_train, best_d, second_d, train_best_query, train_best_d);
}

HeadingEstimator::HeadingEstimator(const HeadingParams& params) { set_params(params); }

void HeadingEstimator::set_params(const HeadingParams& params) {
  params_ = params;
  if (params_.bin_count < 1) params_.bin_count = 1;
  if (params_.bin_count % 2 == 0) params_.bin_count += 1;
  if (!(params_.bin_width_px > 0.0)) params_.bin_width_px = 20.0;
  if (!(params_.refine_window_px > 0.0)) params_.refine_window_px = params_.bin_width_px / 2.0;
  params_.min_inliers = std::max(1, params_.min_inliers);
  params_.full_confidence_inliers = std::max(params_.min_inliers, params_.full_confidence_inliers);
  histogram_.assign(static_cast<std::size_t>(params_.bin_count), 0);
}

Status HeadingEstimator::match(const cv::Mat& reference, std::span<const cv::Point2f> reference_px,
                               const Features& current) {
  matches_.clear();
  if (reference.empty() || current.descriptors.empty() || current.keypoints.empty()) return ok();
  if (reference.type() != current.descriptors.type() || reference.cols != current.descriptors.cols)
    return fail("descriptor mismatch: reference has " + std::to_string(reference.cols) + " columns of type " +
                std::to_string(reference.type()) + ", current has " + std::to_string(current.descriptors.cols) +
                " of type " + std::to_string(current.descriptors.type()) + " (was the map taught with another detector?)");

  auto& best_train = best_train_;
  auto& best_d = best_d_;
  auto& second_d = second_d_;
  std::vector<int>* train_best = params_.cross_check ? &reference_best_ : nullptr;
  std::vector<float>* train_best_d = params_.cross_check ? &reference_best_d_ : nullptr;
  const int nr = reference.rows;
  const int nq = current.descriptors.rows;
  const double max_v = params_.max_vertical_px;
  // Vertical gate first: with the reference sorted by v, each query only compares the rows whose
  // |dv| <= max_vertical_px (the ratio test then ranks plausible candidates only).
  const bool gate = max_v > 0.0;
  cv::Mat train = reference;
  if (gate) {
    order_.resize(static_cast<std::size_t>(nr));
    for (int j = 0; j < nr; ++j) order_[static_cast<std::size_t>(j)] = j;
    auto key = [&](int j) {  // NaN/inf positions sort last and are never inside a gate window
      const float v = reference_px[static_cast<std::size_t>(j)].y;
      return std::isfinite(v) ? v : std::numeric_limits<float>::max();
    };
    std::sort(order_.begin(), order_.end(), [&](int a, int b) { return key(a) < key(b); });
    if (sorted_desc_.rows < nr || sorted_desc_.cols != reference.cols || sorted_desc_.type() != reference.type())
      sorted_desc_.create(std::max(nr, sorted_desc_.rows * 2), reference.cols, reference.type());
    sorted_v_.resize(static_cast<std::size_t>(nr));
    const std::size_t rb = reference.cols * reference.elemSize();
    for (int k = 0; k < nr; ++k) {
      const int j = order_[static_cast<std::size_t>(k)];
      std::memcpy(sorted_desc_.ptr(k), reference.ptr(j), rb);
      sorted_v_[static_cast<std::size_t>(k)] = key(j);
    }
    train = sorted_desc_.rowRange(0, nr);
    lo_.resize(static_cast<std::size_t>(nq));
    hi_.resize(static_cast<std::size_t>(nq));
    for (int i = 0; i < nq; ++i) {
      const float v = current.keypoints[static_cast<std::size_t>(i)].pt.y;
      if (!std::isfinite(v)) { lo_[static_cast<std::size_t>(i)] = hi_[static_cast<std::size_t>(i)] = 0; continue; }
      const float a = static_cast<float>(v - max_v), b = static_cast<float>(v + max_v);
      lo_[static_cast<std::size_t>(i)] = static_cast<int>(std::lower_bound(sorted_v_.begin(), sorted_v_.end(), a) - sorted_v_.begin());
      hi_[static_cast<std::size_t>(i)] = static_cast<int>(std::upper_bound(sorted_v_.begin(), sorted_v_.end(), b) - sorted_v_.begin());
    }
  }
  if (!knn2_ranges(current.descriptors, train, gate ? lo_.data() : nullptr, gate ? hi_.data() : nullptr, best_train,
                   best_d, second_d, train_best, train_best_d))
    return fail("descriptors must be CV_8UC1 or CV_32FC1");

  const float ratio = static_cast<float>(params_.ratio);
  const double max_d = params_.max_descriptor_distance;
  for (int i = 0; i < nq; ++i) {
    const int k = best_train[static_cast<std::size_t>(i)];  // row of `train`
    if (k < 0) continue;
    const float b1 = best_d[static_cast<std::size_t>(i)];
    const float b2 = second_d[static_cast<std::size_t>(i)];
    if (ratio < 1.0f && std::isfinite(b2) && !(b1 < ratio * b2)) continue;
    if (max_d > 0.0 && b1 > max_d) continue;
    if (params_.cross_check && reference_best_[static_cast<std::size_t>(k)] != i) continue;
    const int j = gate ? order_[static_cast<std::size_t>(k)] : k;  // reference row
    const cv::Point2f& c = current.keypoints[static_cast<std::size_t>(i)].pt;
    const cv::Point2f& r = reference_px[static_cast<std::size_t>(j)];
    const float du = c.x - r.x, dv = c.y - r.y;
    if (!std::isfinite(du) || !std::isfinite(dv)) continue;
    if (max_v > 0.0 && std::abs(dv) > max_v) continue;
    matches_.push_back(FeatureMatch{i, j, b1, du, dv, false});
  }
  return ok();
}

HeadingEstimate HeadingEstimator::vote(double image_width_px) {
  HeadingEstimate e;
  std::fill(histogram_.begin(), histogram_.end(), 0);
  e.matches = static_cast<int>(matches_.size());
  if (matches_.empty()) return e;
  const int bins = params_.bin_count;
  const double w = params_.bin_width_px;
  const double half_range = w * bins / 2.0;
  for (const auto& m : matches_) {
    const double x = (m.du_px + half_range) / w;
    if (x < 0.0 || x >= bins) continue;
    ++histogram_[static_cast<std::size_t>(x)];
  }
  // Winning bin; ties go to the bin nearer zero.
  int peak = -1;
  for (int i = 0; i < bins; ++i) {
    const int c = histogram_[static_cast<std::size_t>(i)];
    if (c == 0) continue;
    if (peak < 0 || c > histogram_[static_cast<std::size_t>(peak)] ||
        (c == histogram_[static_cast<std::size_t>(peak)] && std::abs(i - bins / 2) < std::abs(peak - bins / 2)))
      peak = i;
  }
  if (peak < 0) return e;
  // Seed: mean of the displacements in the winning bin and its neighbours.
  const double lo = (peak - 1) * w - half_range, hi = (peak + 2) * w - half_range;
  double sum = 0.0;
  int n = 0;
  for (const auto& m : matches_) {
    if (m.du_px >= lo && m.du_px < hi) { sum += m.du_px; ++n; }
  }
  double centre = n > 0 ? sum / n : (peak + 0.5) * w - half_range;
  const double win = params_.refine_window_px;
  for (int iter = 0; iter < 4; ++iter) {
    sum = 0.0;
    n = 0;
    for (const auto& m : matches_) {
      if (std::abs(m.du_px - centre) <= win) { sum += m.du_px; ++n; }
    }
    if (n == 0) break;
    const double next = sum / n;
    if (std::abs(next - centre) < 1e-3) { centre = next; break; }
    centre = next;
  }
  int inliers = 0;
  for (auto& m : matches_) {
    m.inlier = std::abs(m.du_px - centre) <= win;
    inliers += m.inlier ? 1 : 0;
  }
  int runner_up = 0;
  for (int i = 0; i < bins; ++i) {
    if (std::abs(i - peak) >= 2) runner_up = std::max(runner_up, histogram_[static_cast<std::size_t>(i)]);
  }
  const double peak_count = histogram_[static_cast<std::size_t>(peak)];
  e.ambiguity = std::clamp(runner_up / peak_count, 0.0, 1.0);
  const double distinct = 1.0 - e.ambiguity;
  const double count_term = std::min(1.0, static_cast<double>(inliers) / params_.full_confidence_inliers);
  e.offset_px = centre;
  e.inliers = inliers;
  e.confidence = inliers < params_.min_inliers ? 0.0 : count_term * distinct;
  e.valid = e.confidence >= params_.min_confidence && e.confidence > 0.0;
  if (image_width_px > 0.0) {
    const double focal_px = (image_width_px / 2.0) / std::tan(params_.horizontal_fov_deg * std::numbers::pi / 360.0);
    e.heading_correction_rad = -std::atan(e.offset_px / focal_px);
  }
  return e;
}

Result<HeadingEstimate> HeadingEstimator::estimate(const ReferenceView& reference, const Features& current,
                                                   double image_width_px) {
  VISNAV_TRY(check_features(current, "current features"));
  if (static_cast<std::size_t>(reference.descriptors.rows) != reference.positions_px.size())
    return fail("reference: " + std::to_string(reference.positions_px.size()) + " positions but " +
                std::to_string(reference.descriptors.rows) + " descriptor rows");
  VISNAV_TRY(match(reference.descriptors, reference.positions_px, current));
  return vote(image_width_px);
}

Result<HeadingEstimate> HeadingEstimator::estimate(const Features& reference, const Features& current,
                                                   double image_width_px) {
  VISNAV_TRY(check_features(reference, "reference features"));
  positions_.resize(reference.keypoints.size());
  for (std::size_t i = 0; i < reference.keypoints.size(); ++i) positions_[i] = reference.keypoints[i].pt;
  return estimate(ReferenceView{reference.descriptors, positions_}, current, image_width_px);
}

}  // namespace visnav::feature_replay
