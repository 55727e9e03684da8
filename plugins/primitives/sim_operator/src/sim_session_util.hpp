// Small helpers shared by the simulator experiment commands of the sim_operator plugin
// (`visnav convergence`, `visnav experiment`): project-file lookup, a progress line, option
// reading (help, values, numbers, usage errors) and fixed-point formatting. Plain functions, no
// global state except the compile-time source directory; ProgressLine and OptionReader are not
// thread-safe (one per command).
#pragma once

#include <chrono>
#include <string>
#include <vector>

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

/// `v` joined with `sep` between the items.
[[nodiscard]] std::string join(const std::vector<std::string>& v, const std::string& sep);

/// True when `-h` or `--help` stands anywhere in argv[1..]; then `usage` has been printed on stdout.
[[nodiscard]] bool print_help_if_asked(int argc, char** argv, const char* usage);

/// Prints "<command>: <message>" and `usage` on stderr; returns 2 (the usage-error exit status).
int usage_error(const std::string& command, const Error& error, const char* usage);

/// Walks argv[1..] option by option: next() moves to the next option name (arg()), value() and
/// number() consume the argument after it. Errors name the option.
class OptionReader {
 public:
  OptionReader(int argc, char** argv) : argc_(argc), argv_(argv) {}
  /// Moves to the next argument; false when none is left.
  bool next();
  /// The current option name.
  [[nodiscard]] const std::string& arg() const { return arg_; }
  /// The argument after the option ("<arg> needs a value" when there is none).
  Result<std::string> value();
  /// value() parsed as a number in [lo, hi] (parse_number, named after the option).
  Result<double> number(double lo, double hi);

 private:
  int argc_;
  char** argv_;
  int i_ = 0;
  std::string arg_;
};

/// Progress on stderr ("  phase [#####.....] done / total unit"), the phase padded to
/// `phase_width` characters. On a terminal one line is redrawn in place at most every 0.5 s of
/// wall time (and once more when done first reaches total); when stderr is not a terminal (CI
/// logs, pipes) a new line is written only when another tenth of the total is done, so logs stay
/// short.
class ProgressLine {
 public:
  explicit ProgressLine(int phase_width = 30);
  void show(const std::string& phase, double done, double total, const std::string& unit);
  /// Ends the line (newline) if something was drawn since the last end().
  void end();

 private:
  int phase_width_;
  bool terminal_;
  std::chrono::steady_clock::time_point last_{};
  bool drawn_ = false;
  bool drawn_full_ = false;   // the 100 % state was drawn for this phase
  int last_tenth_ = -1;       // non-terminal: the last tenth written for this phase
  std::string last_phase_;
};

}  // namespace visnav::simop
