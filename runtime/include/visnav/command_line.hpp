// visnav SDK — helpers for the `visnav <name>` commands a plugin contributes (CommandEntry):
// help, option values and numbers with errors naming the option, the usage-error exit status, and
// a progress line for long work.
//
// Thread-safety: OptionReader and ProgressLine are single-threaded (one per command run); the
// free functions are pure apart from writing the stream they name.
#pragma once

#include <chrono>
#include <string>

#include "visnav/result.hpp"

namespace visnav::cli {

/// Parses a whole string as a finite number in [lo, hi]; the error names `what` and the text
/// ("--seeds: 'x' is not a number in [1, 100]").
[[nodiscard]] Result<double> parse_number(const std::string& text, double lo, double hi, const std::string& what);

/// True when `-h` or `--help` stands anywhere in argv[1..]; then `usage` has been printed on stdout.
[[nodiscard]] bool print_help_if_asked(int argc, char** argv, const char* usage);

/// Prints "<command>: <message>" and `usage` on stderr; returns 2, the usage-error exit status.
int usage_error(const std::string& command, const std::string& message, const char* usage);

/// Walks argv[1..] option by option: next() moves to the next argument (arg()); value() and
/// number() consume the argument after it. Errors name the option.
class OptionReader {
 public:
  OptionReader(int argc, char** argv) : argc_(argc), argv_(argv) {}
  /// Moves to the next argument; false when none is left.
  bool next();
  /// The current argument.
  [[nodiscard]] const std::string& arg() const { return arg_; }
  /// The argument after the option ("<option> needs a value" when there is none).
  Result<std::string> value();
  /// value() parsed as a number in [lo, hi] (parse_number, named after the option).
  Result<double> number(double lo, double hi);

 private:
  int argc_;
  char** argv_;
  int i_ = 0;
  std::string arg_;
};

/// Progress of long work on stderr:
///   "  phase [#########.....................]  30 % 300/1000 scenarios  12 s, ~28 s left"
/// On a terminal one line is redrawn in place at most every 0.5 s (and once when a phase first
/// completes); when stderr is not a terminal (CI logs, pipes) a new line is written only when
/// another tenth of the phase is done, so logs stay short. Elapsed time and the estimate left
/// count from the start of the work: a new total or a count that goes back restarts them, a new
/// phase label alone does not.
class ProgressLine {
 public:
  /// `phase_width`: the phase name is padded to this many characters.
  explicit ProgressLine(int phase_width = 12);
  void show(const std::string& phase, double done, double total, const std::string& unit);
  /// Ends the line (newline) if one is drawn in place.
  void end();

 private:
  int phase_width_;
  bool terminal_;
  std::chrono::steady_clock::time_point phase_start_{}, last_{};
  bool drawn_ = false;       // a terminal line is open
  bool drawn_full_ = false;  // the 100 % state was drawn for this phase
  int last_tenth_ = -1;      // non-terminal: the last tenth written for this phase
  std::string phase_;
  double total_ = 0.0;
  double done_ = 0.0;
};

}  // namespace visnav::cli
