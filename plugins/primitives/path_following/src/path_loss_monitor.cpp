#include "visnav/path_following/path_loss_monitor.hpp"

#include <algorithm>

namespace visnav::path_following {

PathLossMonitor::PathLossMonitor(double grace_s) : grace_s_(std::max(0.0, grace_s)) {}

PathLossMonitor::Verdict PathLossMonitor::update(double timestamp_s, PathStatus status) {
  if (last_timestamp_s_ && timestamp_s < *last_timestamp_s_) timestamp_s = *last_timestamp_s_;
  last_timestamp_s_ = timestamp_s;
  if (status == PathStatus::ok) {
    bad_since_s_.reset();
    return Verdict::ok;
  }
  last_bad_ = status;
  if (!bad_since_s_) bad_since_s_ = timestamp_s;
  return timestamp_s - *bad_since_s_ > grace_s_ ? Verdict::lost : Verdict::grace;
}

void PathLossMonitor::reset() {
  last_timestamp_s_.reset();
  bad_since_s_.reset();
  last_bad_.reset();
}

double PathLossMonitor::bad_duration_s() const {
  if (!bad_since_s_ || !last_timestamp_s_) return 0.0;
  return *last_timestamp_s_ - *bad_since_s_;
}

std::string_view to_string(PathLossMonitor::Verdict verdict) {
  switch (verdict) {
    case PathLossMonitor::Verdict::ok: return "ok";
    case PathLossMonitor::Verdict::grace: return "grace";
    case PathLossMonitor::Verdict::lost: return "path lost";
  }
  return "unknown";
}

}  // namespace visnav::path_following
