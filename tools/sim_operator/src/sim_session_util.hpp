// Small helpers shared by the simulator experiment commands of the sim_operator plugin
// (`visnav convergence`, `visnav experiment`): project-file lookup and formatting. Plain
// functions, no global state except the compile-time source directory.
#pragma once

#include <chrono>
#include <string>
#include <vector>

#include "visnav/command_line.hpp"
#include "visnav/result.hpp"

namespace visnav::simop {

/// A project file (config, tree, world): `path` itself when it exists or is absolute, else the
/// same relative path under the source tree this plugin was built from (VISNAV_SOURCE_DIR),
/// else `path` unchanged (the caller's open then reports it).
[[nodiscard]] std::string project_file(const std::string& path);

/// `v` with `precision` digits after the point.
[[nodiscard]] std::string fixed(double v, int precision = 3);

/// `v` joined with `sep` between the items.
[[nodiscard]] std::string join(const std::vector<std::string>& v, const std::string& sep);

// Option reading, numbers, help, usage errors and the progress line are the SDK's
// (visnav/command_line.hpp), shared with every plugin command.
using visnav::cli::OptionReader;
using visnav::cli::parse_number;
using visnav::cli::print_help_if_asked;
using visnav::cli::ProgressLine;
using visnav::cli::usage_error;

}  // namespace visnav::simop
