// visnav path following — the grace-period state machine behind "path lost".
//
// Feed it one observation per processed frame: the frame's timestamp (seconds on the run's
// clock) and the PathFollower status. It answers `lost` once the status has been other than
// `ok` continuously for MORE than grace_s; a single `ok` frame ends the bad streak.
// Timestamps must not decrease; a decreasing one is treated as equal to the previous one.
// Pure: no clock of its own. Thread-safety: not thread-safe; one per node.
#pragma once

#include <optional>

#include "visnav/path_following/path_follower.hpp"

namespace visnav::path_following {

class PathLossMonitor {
 public:
  enum class Verdict {
    ok,     ///< the last observation was ok
    grace,  ///< bad, but for no longer than grace_s
    lost,   ///< bad for longer than grace_s: the node returns FAILURE "path lost"
  };

  /// grace_s < 0 is treated as 0.
  explicit PathLossMonitor(double grace_s);

  Verdict update(double timestamp_s, PathStatus status);
  /// Forgets the streak (start of a new edge).
  void reset();

  [[nodiscard]] double grace_s() const { return grace_s_; }
  /// Seconds the current bad streak has lasted (0 when the last observation was ok).
  [[nodiscard]] double bad_duration_s() const;
  /// The status of the most recent bad observation (the reason to report), if any.
  [[nodiscard]] std::optional<PathStatus> last_bad_status() const { return last_bad_; }

 private:
  double grace_s_;
  std::optional<double> last_timestamp_s_;
  std::optional<double> bad_since_s_;
  std::optional<PathStatus> last_bad_;
};

[[nodiscard]] std::string_view to_string(PathLossMonitor::Verdict verdict);

}  // namespace visnav::path_following
