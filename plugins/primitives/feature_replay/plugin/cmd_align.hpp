// `visnav align` — horizontal offset between two images by histogram voting (issue 4, item 6).
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "visnav/devices.hpp"
#include "visnav/feature_replay/heading.hpp"
#include "visnav/host.hpp"

namespace visnav::feature_replay {

/// Usage text of the command.
extern const char* const kAlignUsage;

/// Runs `visnav align` (argv[0] == "align"). Returns the process exit status: 0 every estimate
/// valid, 1 a pair failed (image unreadable, detector error) or had no valid estimate, 2 usage error.
int run_align(int argc, char** argv, HostServices& host);

/// Detects `image` with a new detector of `type` whose adaptive threshold is settled on this
/// image alone (up to 8 frames of the same image, stopping when the keypoint count repeats), so
/// the result does not depend on any other image. Errors name `name`.
Status detect_settled(HostServices& host, const std::string& type, const ConfigNode& params, const cv::Mat& image,
                      Features& out, const std::string& name);

/// A path from a pairs file: as given if it exists (or is absolute), else relative to `base`.
std::string resolve_pair_path(const std::string& path, const std::filesystem::path& base);

/// Shared start of the pair commands (`align`, `train-descriptor`): true when -h/--help stands
/// in argv[1..] (then `usage` was printed on stdout).
bool print_usage_if_help(int argc, char** argv, const char* usage);

/// HeadingParams from the commands' `--set` values over `base` (null = `base`: `align` passes
/// calibrated_heading_params(), `train-descriptor` the SDK's HeadingParams{}); on error prints
/// "visnav <command>: --set: <reason>" on stderr and returns nullopt (exit status 2).
std::optional<HeadingParams> heading_params_or_report(const ConfigNode& sets, const char* command,
                                                     const HeadingParams& base);

}  // namespace visnav::feature_replay
