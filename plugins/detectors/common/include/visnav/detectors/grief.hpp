// visnav detectors — GRIEF comparison-pair files (Krajník et al. 2017: BRIEF whose comparison
// pairs are evolved for robustness to seasonal appearance change).
//
// A pairs file is YAML:
//
//   patch_size_px: 48            # BRIEF patch side S the pairs were made for
//   pairs:                       # exactly 256 tests [I(x1, y1) < I(x2, y2)], pixels relative to
//     - [-3, 5, 10, -2]          # the keypoint, x right, y down, inside the disc of radius S/2 − 1
//     - ...
//   training: {...}              # optional, written by `visnav train-descriptor` (generation,
//                                # seed, fitness, ...); ignored by the detector
//
// Every error names file:line and the offending key or pair (`pairs.yaml:17: pair 12: point
// (30, 0) is outside the patch disc of radius 23 px`). Unknown top-level keys are errors.
// Writing is crash-safe (temporary file, then rename), so an interrupted training run leaves
// the previous generation's file intact.
// Thread-safety: free functions; read_pairs_file only reads the named file.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "visnav/config_node.hpp"
#include "visnav/detectors/brief.hpp"
#include "visnav/result.hpp"

namespace visnav::detectors {

struct PairsFile {
  int patch_size_px = 48;
  std::vector<BriefTest> pairs;
  ConfigNode training;  ///< the optional `training:` map (null when absent)
};

/// Reads and validates a pairs file (BriefExtractor::validate_pattern for its patch_size_px).
[[nodiscard]] Result<PairsFile> read_pairs_file(const std::string& path);

/// Parses and validates pairs-file text; errors name `file_label`:line as read_pairs_file does.
[[nodiscard]] Result<PairsFile> parse_pairs_text(std::string_view yaml, const std::string& file_label);

/// The `pairs` name of the pattern that ships with the project (the default of `grief`): the
/// pairs trained by `visnav train-descriptor` on the project's appearance-change pair sets
/// (config/detectors/grief_seasonal.yaml, embedded into this library when it is built, so it is
/// found from any working directory and needs no installed data file).
inline constexpr std::string_view kSeasonalPairsName = "seasonal";

/// The text of config/detectors/grief_seasonal.yaml as it was when this library was built.
[[nodiscard]] std::string_view seasonal_pairs_yaml();

/// The shipped pattern, parsed from seasonal_pairs_yaml() (errors are labelled
/// "grief_seasonal.yaml (built in)"; a bad shipped file is caught by the tests). Thread-safe.
[[nodiscard]] Result<PairsFile> seasonal_pairs();

/// Writes `file` (pairs validated first). `training` entries are written in order under
/// `training:` as `key: value` (values are written verbatim; pass YAML scalars).
[[nodiscard]] Status write_pairs_file(const std::string& path, const PairsFile& file,
                                      const std::vector<std::pair<std::string, std::string>>& training = {},
                                      const std::string& comment = {});

}  // namespace visnav::detectors
