// Small helpers shared by the simulator experiment commands of the sim_operator plugin
// (`visnav convergence`; meant for `visnav experiment` too): project-file lookup, a progress
// line, number parsing and fixed-point formatting. Plain functions, no global state except the
// compile-time source directory; ProgressLine is not thread-safe (one per command).
#pragma once

#include <chrono>
#include <string>

#include "visnav/result.hpp"

namespace visnav::simop {

/// A project file (config, tree, world): `path` itself when it exists or is absolute, else the
/// same relative path under the source tree this plugin was built from (VISNAV_SOURCE_DIR),
/// else `path` unchanged (the caller's open then reports it).
[[nodiscard]] std::string project_file(const std::string& path);

/// Parses a whole string as a finite number in [lo, hi]; the error names `what` and the text.
[[nodiscard]] Result<double> parse_number(const std::string& text, double lo, double hi, const std::string& what);

/// `v` with `precision` digits after the point.
[[nodiscard]] std::string fixed(double v, int precision = 3);

/// One progress line on stderr ("  phase [#####.....] done / total unit"), redrawn at most every
/// 0.5 s of wall time (and always when done reaches total).
class ProgressLine {
 public:
  void show(const std::string& phase, double done, double total, const std::string& unit);
  /// Ends the line (newline) if something was drawn since the last end().
  void end();

 private:
  std::chrono::steady_clock::time_point last_{};
  bool drawn_ = false;
};

}  // namespace visnav::simop
