// Lost detection shared by every navigation primitive (see nav_health.hpp).
#include "visnav/nav_health.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>

namespace visnav {
namespace {

std::string metres(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f m", v);
  return buf;
}

double wrap_rad(double a) { return std::remainder(a, 2.0 * std::numbers::pi); }

}  // namespace

Status LostPolicy::validate() const {
  if (!(min_confidence >= 0.0 && min_confidence <= 1.0))
    return Error{"lost policy: min_confidence must be in [0, 1]", ErrorCode::out_of_range, {{}, 0, "min_confidence"}};
  if (window_frames < 1 || window_frames > 64)
    return Error{"lost policy: window_frames must be in [1, 64]", ErrorCode::out_of_range, {{}, 0, "window_frames"}};
  if (!(slow_after_m >= 0.0))
    return Error{"lost policy: slow_after_m must be >= 0", ErrorCode::out_of_range, {{}, 0, "slow_after_m"}};
  if (!(slow_speed_factor > 0.0 && slow_speed_factor <= 1.0))
    return Error{"lost policy: slow_speed_factor must be in (0, 1]", ErrorCode::out_of_range, {{}, 0, "slow_speed_factor"}};
  if (!(max_blind_m > 0.0) || max_blind_m < slow_after_m)
    return Error{"lost policy: max_blind_m must be > 0 and >= slow_after_m", ErrorCode::inconsistent, {{}, 0, "max_blind_m"}};
  if (!(max_frozen_m > 0.0))
    return Error{"lost policy: max_frozen_m must be > 0", ErrorCode::out_of_range, {{}, 0, "max_frozen_m"}};
  if (!(max_saturated_m > 0.0))
    return Error{"lost policy: max_saturated_m must be > 0", ErrorCode::out_of_range, {{}, 0, "max_saturated_m"}};
  if (!(max_heading_deviation_rad >= 0.0 && max_heading_deviation_rad <= std::numbers::pi))
    return Error{"lost policy: max_heading_deviation must be in [0, 180] deg", ErrorCode::out_of_range, {{}, 0, "max_heading_deviation"}};
  return ok();
}

const char* to_string(NavHealthState state) {
  switch (state) {
    case NavHealthState::seeing: return "seeing";
    case NavHealthState::blind: return "blind";
    case NavHealthState::slowing: return "slowing";
    case NavHealthState::lost: return "lost";
    case NavHealthState::frozen: return "camera frozen";
  }
  return "unknown";
}

NavHealthMonitor::NavHealthMonitor(LostPolicy policy) : policy_(policy) {
  policy_.window_frames = std::clamp(policy_.window_frames, 1, kMaxWindow);
}

std::uint64_t NavHealthMonitor::image_hash(const cv::Mat& image) {
  // FNV-1a over 8-byte words, row by row (padding is skipped). Not cryptographic: it only has
  // to tell a repeated frame from a new one, and any sensor noise changes it.
  std::uint64_t h = 1469598103934665603ULL ^ (static_cast<std::uint64_t>(image.rows) << 32) ^
                    static_cast<std::uint64_t>(image.cols) ^ (static_cast<std::uint64_t>(image.type()) << 48);
  const std::size_t row_bytes = image.cols * image.elemSize();
  for (int r = 0; r < image.rows; ++r) {
    const auto* p = image.ptr<unsigned char>(r);
    std::size_t i = 0;
    for (; i + 8 <= row_bytes; i += 8) {
      std::uint64_t w;
      std::memcpy(&w, p + i, 8);
      h = (h ^ w) * 1099511628211ULL;
    }
    for (; i < row_bytes; ++i) h = (h ^ p[i]) * 1099511628211ULL;
  }
  return h;
}

void NavHealthMonitor::begin(double odom_distance_m, double odom_heading_rad, std::optional<double> confident_at_m,
                             std::optional<double> changed_at_m, std::optional<TaughtHeading> taught) {
  auto carried = [&](std::optional<double> v) {
    // A carried value from the future (odometry was reset) or a non-finite one restarts the count.
    return v && std::isfinite(*v) && *v <= odom_distance_m ? *v : odom_distance_m;
  };
  confident_at_m_ = carried(confident_at_m);
  changed_at_m_ = carried(changed_at_m);
  window_size_ = 0;
  window_next_ = 0;
  saturated_since_m_ = -1.0;
  last_odom_m_ = odom_distance_m;
  start_heading_rad_ = odom_heading_rad;
  taught_ = taught;
  have_hash_ = false;
  identical_frames_ = 0;
  verdict_ = NavHealthVerdict{};
  verdict_.blind_m = odom_distance_m - confident_at_m_;
}

const NavHealthVerdict& NavHealthMonitor::update(double odom_distance_m, double odom_heading_rad, double edge_distance_m,
                                                 const cv::Mat& image, double confidence, bool saturated,
                                                 bool informative) {
  NavHealthVerdict& v = verdict_;
  v.reason.clear();
  const double step_m = std::max(0.0, odom_distance_m - last_odom_m_);
  last_odom_m_ = odom_distance_m;

  // Frozen camera: compare with the previous frame; travel while identical counts.
  if (!image.empty()) {
    const std::uint64_t h = image_hash(image);
    if (have_hash_ && h == last_hash_) {
      ++identical_frames_;
    } else {
      identical_frames_ = 0;
      changed_at_m_ = odom_distance_m;
    }
    last_hash_ = h;
    have_hash_ = true;
  }
  v.identical_frames = identical_frames_;
  v.frozen_m = identical_frames_ > 0 ? std::abs(odom_distance_m - changed_at_m_) : 0.0;
  // A frozen image can still match the map well, so it must not count as seeing.
  if (identical_frames_ > 0) confidence = 0.0;

  if (informative || identical_frames_ > 0 || (std::isfinite(confidence) && confidence >= policy_.min_confidence)) {
    window_[static_cast<std::size_t>(window_next_)] = std::isfinite(confidence) ? std::clamp(confidence, 0.0, 1.0) : 0.0;
    window_next_ = (window_next_ + 1) % policy_.window_frames;
    window_size_ = std::min(window_size_ + 1, policy_.window_frames);
  } else {
    // Nothing to see here by the map's own account: the blind count pauses.
    confident_at_m_ = std::min(odom_distance_m, confident_at_m_ + step_m);
  }
  double sum = 0.0;
  for (int i = 0; i < window_size_; ++i) sum += window_[static_cast<std::size_t>(i)];
  v.window_confidence = window_size_ > 0 ? sum / window_size_ : 0.0;
  if (window_size_ > 0 && v.window_confidence >= policy_.min_confidence && window_size_ >= std::min(3, policy_.window_frames))
    confident_at_m_ = odom_distance_m;
  v.blind_m = std::max(0.0, odom_distance_m - confident_at_m_);

  if (saturated) {
    if (saturated_since_m_ < 0.0) saturated_since_m_ = odom_distance_m;
  } else {
    saturated_since_m_ = -1.0;
  }

  if (v.frozen_m > policy_.max_frozen_m) {
    v.state = NavHealthState::frozen;
    v.speed_factor = 0.0;
    v.reason = "camera frozen: " + std::to_string(identical_frames_ + 1) + " identical frames over " + metres(v.frozen_m);
    return v;
  }
  if (v.blind_m > policy_.max_blind_m) {
    v.state = NavHealthState::lost;
    v.speed_factor = 0.0;
    v.reason = "lost: no confident frame for " + metres(v.blind_m);
    return v;
  }
  if (saturated_since_m_ >= 0.0 && odom_distance_m - saturated_since_m_ > policy_.max_saturated_m) {
    v.state = NavHealthState::lost;
    v.speed_factor = 0.0;
    v.reason = "lost: heading correction saturated for " + metres(odom_distance_m - saturated_since_m_);
    return v;
  }
  if (taught_ && policy_.max_heading_deviation_rad > 0.0) {
    const double f = taught_->length_m > 0.0 ? std::clamp(edge_distance_m / taught_->length_m, 0.0, 1.0) : 0.0;
    const double expected = start_heading_rad_ + f * taught_->end_turn_rad;
    const double deviation = std::abs(wrap_rad(odom_heading_rad - expected));
    if (deviation > policy_.max_heading_deviation_rad) {
      v.state = NavHealthState::lost;
      v.speed_factor = 0.0;
      char buf[96];
      std::snprintf(buf, sizeof buf, "lost: odometry heading %.0f deg off the taught heading",
                    deviation * 180.0 / std::numbers::pi);
      v.reason = buf;
      return v;
    }
  }
  if (v.blind_m <= 0.0) {
    v.state = NavHealthState::seeing;
    v.speed_factor = 1.0;
  } else if (v.blind_m <= policy_.slow_after_m) {
    v.state = NavHealthState::blind;
    v.speed_factor = 1.0;
  } else {
    v.state = NavHealthState::slowing;
    v.speed_factor = policy_.slow_speed_factor;
  }
  return v;
}

}  // namespace visnav
