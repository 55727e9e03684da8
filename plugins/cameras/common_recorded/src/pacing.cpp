// Frame pacing of file-backed cameras (pacing.hpp).
#include "visnav/recorded/pacing.hpp"

namespace visnav::recorded {

Pacing parse_pacing(const std::string& text) {
  if (text == "realtime") return Pacing::realtime;
  if (text == "clock") return Pacing::clock;
  return Pacing::fast;
}

void FramePacer::start(const std::vector<double>& times_s, double wall_now_s, double clock_now_s) {
  if (started_ || times_s.empty()) return;
  started_ = true;
  wall_origin_s_ = wall_now_s;
  clock_origin_s_ = clock_now_s;
  t0_s_ = times_s.front();
}

std::optional<std::size_t> FramePacer::due(const std::vector<double>& times_s, std::size_t next, double wall_now_s,
                                           double clock_now_s) {
  if (next >= times_s.size()) return std::nullopt;
  start(times_s, wall_now_s, clock_now_s);
  constexpr double kEps = 1e-9;
  switch (pacing_) {
    case Pacing::fast: return next;
    case Pacing::realtime: {
      const double elapsed = wall_now_s - wall_origin_s_;
      if (times_s[next] - t0_s_ > elapsed + kEps) return std::nullopt;
      std::size_t i = next;
      while (i + 1 < times_s.size() && times_s[i + 1] - t0_s_ <= elapsed + kEps) ++i;
      return i;
    }
    case Pacing::clock: {
      if (times_s[next] > clock_now_s + kEps) return std::nullopt;
      std::size_t i = next;
      while (i + 1 < times_s.size() && times_s[i + 1] <= clock_now_s + kEps) ++i;
      return i;
    }
  }
  return std::nullopt;
}

double FramePacer::wait_s(const std::vector<double>& times_s, std::size_t index, double wall_now_s) const {
  if (pacing_ != Pacing::realtime || !started_ || index >= times_s.size()) return 0.0;
  const double due_at = wall_origin_s_ + (times_s[index] - t0_s_);
  return due_at > wall_now_s ? due_at - wall_now_s : 0.0;
}

double FramePacer::stamp(const std::vector<double>& times_s, std::size_t index, double clock_now_s) const {
  switch (pacing_) {
    case Pacing::fast: return clock_now_s;
    case Pacing::realtime: return clock_origin_s_ + (times_s[index] - t0_s_);
    case Pacing::clock: return times_s[index];
  }
  return clock_now_s;
}

}  // namespace visnav::recorded
