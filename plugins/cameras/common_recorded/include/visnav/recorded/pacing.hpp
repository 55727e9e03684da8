// visnav recorded-run helpers — when a file-backed camera (video, image_folder, recorded)
// delivers its next frame.
//
// Modes (camera param `pacing`):
//  * "fast"     every grab() returns the next frame at once (as fast as the consumer ticks);
//               the frame timestamp is the run clock at delivery (so the run loop's staleness
//               check holds whatever the recorded times were).
//  * "realtime" frames are released at their recorded spacing in wall time: frame i is due at
//               origin + (t_i - t_0), where origin is the wall time of the first grab. grab()
//               waits up to its timeout for the next due frame; frames that are already overdue
//               are skipped (a real camera also only has its newest image). Timestamp: run clock
//               at the first grab + (t_i - t_0).
//  * "clock"    frame i is due once the run clock (HostServices::clock()) reaches t_i; grab()
//               returns the newest due frame not returned yet, or nothing. The timestamp is the
//               recorded t_i. This is the lock-step mode used with the `recorded` robot, whose
//               SimulationControl::step() moves the run clock from frame to frame.
// Thread-safety: one thread at a time.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace visnav::recorded {

enum class Pacing { fast, realtime, clock };

/// Parses "fast", "realtime", "clock" (validated by the schema's one_of before).
[[nodiscard]] Pacing parse_pacing(const std::string& text);

/// Decides which frame index to deliver next, given the recorded times.
class FramePacer {
 public:
  explicit FramePacer(Pacing pacing) : pacing_(pacing) {}

  /// Index of the frame to deliver now (>= next), or nullopt when none is due yet.
  /// `times_s` are the recorded times (non-decreasing) of frames next.. that are known so far;
  /// `wall_now_s` is a monotonic wall time, `clock_now_s` the run clock.
  /// For realtime/clock: returns the newest due frame (skipping overdue ones).
  [[nodiscard]] std::optional<std::size_t> due(const std::vector<double>& times_s, std::size_t next, double wall_now_s,
                                               double clock_now_s);
  /// Seconds of wall time until frame `index` is due (realtime; 0 otherwise or when due).
  [[nodiscard]] double wait_s(const std::vector<double>& times_s, std::size_t index, double wall_now_s) const;
  /// The timestamp to stamp on frame `index` delivered now (see the modes above).
  [[nodiscard]] double stamp(const std::vector<double>& times_s, std::size_t index, double clock_now_s) const;
  [[nodiscard]] Pacing pacing() const { return pacing_; }

 private:
  void start(const std::vector<double>& times_s, double wall_now_s, double clock_now_s);
  Pacing pacing_;
  bool started_ = false;
  double wall_origin_s_ = 0.0;
  double clock_origin_s_ = 0.0;
  double t0_s_ = 0.0;
};

}  // namespace visnav::recorded
