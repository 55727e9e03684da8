// visnav recorded-run helpers — timestamped odometry from a file, synchronised with frame times.
//
// Formats (chosen by extension: .yaml/.yml YAML, anything else CSV):
//  * CSV with a header. Columns (aliases in brackets): t_s [t, time, timestamp] — required;
//    x_m [x], y_m [y], heading_rad [theta, yaw, heading]; distance_m [distance, d];
//    linear_mps [v], angular_radps [omega, w]. Either x_m and y_m or distance_m must be present.
//  * YAML: a sequence of maps with the same keys, at the top level or under `odometry:`.
// Missing columns are derived: no distance → the summed planar path length; no pose → (distance,
// 0, heading or 0); no twist → finite differences between samples.
// Timestamps must be strictly increasing: an earlier or equal one is an error naming file:line.
//
// Synchronisation (`sample_at`): "latest" returns the sample at or before t (what a live robot
// reported at that time: exact replay of a recording); "interpolate" interpolates pose, distance and
// twist linearly between the neighbouring samples (heading along the shorter arc), stamped t.
// `check_coverage` rejects frames far from any odometry: a frame at t needs a sample at or before
// t no older than max_gap_s (and, for interpolate, one after it within max_gap_s unless t is the
// last sample's time); the error names the frame-times file and line.
// Thread-safety: immutable after loading; const methods may be called from any thread.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::recorded {

enum class OdometrySync { latest, interpolate };

/// A time at which something (a frame) needs odometry, with where it came from.
struct TimedLine {
  double t_s = 0.0;
  int line = 0;  ///< 1-based line in `file` (0 when unknown)
};

class OdometryLog {
 public:
  /// Loads a CSV/YAML log (see the file comment).
  [[nodiscard]] static Result<OdometryLog> load(const std::string& path);
  /// From samples in memory (tests); timestamps must increase.
  [[nodiscard]] static Result<OdometryLog> from_samples(std::vector<Odometry> samples, std::string label);

  [[nodiscard]] const std::vector<Odometry>& samples() const { return samples_; }
  [[nodiscard]] const std::string& file() const { return file_; }
  /// The reading at time t (see the file comment); nullopt before the first sample.
  [[nodiscard]] std::optional<Odometry> sample_at(double t_s, OdometrySync sync) const;
  /// Checks that every time in `times` has odometry within `max_gap_s` (see the file comment).
  [[nodiscard]] Status check_coverage(const std::vector<TimedLine>& times, const std::string& times_file,
                                      double max_gap_s, OdometrySync sync) const;

 private:
  std::string file_;
  std::vector<Odometry> samples_;
};

}  // namespace visnav::recorded
