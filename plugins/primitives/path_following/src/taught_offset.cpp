// The taught lateral position (taught_offset.hpp).
#include "visnav/path_following/taught_offset.hpp"

#include <algorithm>

namespace visnav::path_following {

Status TaughtOffsetParams::validate() const { return schema().check(*this); }

const ParamSchema<TaughtOffsetParams>& TaughtOffsetParams::schema() {
  using P = TaughtOffsetParams;
  static const auto s =
      ParamSchema<P>{}
          .field("taught_offset_gain", &P::gain,
                 "repeat the taught lateral position: share of the path offset recorded at teach time (VPF3 "
                 "payloads) steered to instead of the path's middle (0 = off: centre on the path)")
          .range(0.0, 1.0)
          .field("taught_offset_window_m", &P::window_m,
                 "taught lateral position: teach samples within this of the edge distance are averaged, m")
          .range(0.05, 10.0)
          .field("taught_offset_max_sd", &P::max_sd,
                 "taught lateral position: no target where the window's teach samples have a larger standard "
                 "deviation (the taught view changes quickly there; the last target is held), normalised offset")
          .range(0.0, 2.0);
  return s;
}

TaughtOffsetProfile::TaughtOffsetProfile(const TaughtOffsetParams& params, std::vector<path_payload::OffsetSample> samples)
    : params_(params), samples_(std::move(samples)) {}

std::optional<double> TaughtOffsetProfile::target(double distance_m, bool junction) const {
  if (!active()) return std::nullopt;
  const auto first = std::lower_bound(samples_.begin(), samples_.end(), distance_m - params_.window_m,
                                      [](const path_payload::OffsetSample& s, double d) { return s.distance_m < d; });
  double sum = 0.0, sum_sq = 0.0;
  int n = 0;
  for (auto it = first; it != samples_.end() && it->distance_m <= distance_m + params_.window_m; ++it) {
    const double o = junction ? it->junction_offset : it->offset;
    sum += o;
    sum_sq += o * o;
    ++n;
  }
  if (n == 0) return std::nullopt;
  const double mean = sum / n;
  const double variance = std::max(0.0, sum_sq / n - mean * mean);
  if (variance > params_.max_sd * params_.max_sd) return std::nullopt;
  return params_.gain * mean;
}

}  // namespace visnav::path_following
