// Small helpers shared by the stability plugin's commands: option walking, number parsing and a
// progress line on stderr. Not thread-safe (one per command, used from its main thread).
#pragma once

#include <chrono>
#include <string>
#include <vector>

#include "visnav/result.hpp"

namespace visnav::stability::cli {

/// Parses a whole string as a finite number in [lo, hi]; the error names `what` and the text.
[[nodiscard]] Result<double> parse_number(const std::string& text, double lo, double hi, const std::string& what);

/// True when -h or --help is among argv[1..]; then `usage` has been printed on stdout.
[[nodiscard]] bool help_asked(int argc, char** argv, const char* usage);

/// Prints "<command>: <message>" and `usage` on stderr; returns 2.
int usage_error(const std::string& command, const std::string& message, const char* usage);

/// Walks argv[1..]: next() moves to the next argument, value()/number() take the one after it.
class Options {
 public:
  Options(int argc, char** argv) : argc_(argc), argv_(argv) {}
  bool next();
  [[nodiscard]] const std::string& arg() const { return arg_; }
  Result<std::string> value();
  Result<double> number(double lo, double hi);

 private:
  int argc_;
  char** argv_;
  int i_ = 0;
  std::string arg_;
};

/// "  label [#########.........]  45 % 450000/1000000 scenarios  12 s, ~15 s left" on stderr: one
/// line redrawn at most every 0.5 s on a terminal; a new line per tenth otherwise (logs).
class Progress {
 public:
  explicit Progress(std::string label);
  void show(double done, double total, const std::string& unit);
  void end();

 private:
  std::string label_;
  bool terminal_;
  std::chrono::steady_clock::time_point start_, last_{};
  int last_tenth_ = -1;
  bool drawn_ = false;
};

/// Words of `s` split at whitespace.
[[nodiscard]] std::vector<std::string> split_spaces(const std::string& s);

/// Path of the running executable (/proc/self/exe), "visnav" if unknown.
[[nodiscard]] std::string self_exe();

/// Runs `args` (args[0] looked up on PATH) with stdout and stderr to the file `log` and stdin
/// from /dev/null; returns its exit status (128 + signal when killed). A child still running
/// after `timeout_s` is killed with SIGKILL and reported as 124. Error when it cannot start.
[[nodiscard]] Result<int> run_child(const std::vector<std::string>& args, const std::string& log, double timeout_s);

/// `v` with `precision` digits after the point.
[[nodiscard]] std::string fixed(double v, int precision = 3);

}  // namespace visnav::stability::cli
