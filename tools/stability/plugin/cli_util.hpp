// Small helpers shared by the stability plugin's commands: splitting, the running executable,
// child processes and fixed-point formatting. Not thread-safe (one per command, used from its
// main thread).
#pragma once

#include <chrono>
#include <string>
#include <vector>

#include "visnav/command_line.hpp"
#include "visnav/result.hpp"

namespace visnav::stability::cli {

// Option reading, numbers, help, usage errors and the progress line are the SDK's
// (visnav/command_line.hpp), shared with every plugin command.
using visnav::cli::OptionReader;
using visnav::cli::parse_number;
using visnav::cli::print_help_if_asked;
using visnav::cli::ProgressLine;
using visnav::cli::usage_error;

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
