// visnav recorded-run helpers — reading a recorded-run folder (format: docs/recorded_runs.md;
// written by `visnav record`) and other frame-time lists.
//
//   RUN/run.yaml          format: visnav-recorded-run, version: 1, and what was recorded
//   RUN/frames.csv        index,t_s,sequence,file        (file relative to RUN/)
//   RUN/frames/NNNNNN.png one image per frame (PNG: lossless, or JPEG)
//   RUN/odometry.csv      t_s,x_m,y_m,heading_rad,distance_m,linear_mps,angular_radps
//   RUN/commands.csv      tick,t_s,frame_index,linear_mps,angular_radps,commands_sent
//   RUN/ground_truth.csv  t_s,x_m,y_m,heading_rad       (simulated robots only)
//   RUN/config.yaml       copy of the run configuration used
//
// Thread-safety: pure functions.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "visnav/recorded/odometry_log.hpp"
#include "visnav/result.hpp"

namespace visnav::recorded {

inline constexpr const char* kRunFormatName = "visnav-recorded-run";
inline constexpr int kRunFormatVersion = 1;
inline constexpr const char* kRunInfoFile = "run.yaml";
inline constexpr const char* kFramesFile = "frames.csv";
inline constexpr const char* kFramesFolder = "frames";
inline constexpr const char* kOdometryFile = "odometry.csv";
inline constexpr const char* kCommandsFile = "commands.csv";
inline constexpr const char* kGroundTruthFile = "ground_truth.csv";
inline constexpr const char* kConfigCopyFile = "config.yaml";

/// One image of a frame list.
struct FrameEntry {
  double t_s = 0.0;
  std::uint64_t sequence = 0;
  std::string path;  ///< absolute or relative to the process cwd (already resolved)
  int line = 0;      ///< line in the list file (0 when the list is a folder listing)
};

struct FrameList {
  std::string file;  ///< the list file (or the folder) errors should name
  std::vector<FrameEntry> frames;

  [[nodiscard]] std::vector<TimedLine> times() const;
};

/// Checks that `dir` holds a recorded run: a folder, run.yaml (if present) of this format and a
/// supported version, frames.csv present. Errors name the folder/file.
[[nodiscard]] Status check_run_folder(const std::string& dir);

/// Reads RUN/frames.csv: columns t_s and file (index/sequence optional). Times must not decrease
/// (file:line otherwise), files are resolved against RUN/ and must exist (file:line naming it).
[[nodiscard]] Result<FrameList> read_run_frames(const std::string& run_dir);

/// Lists the images of a folder (png, jpg, jpeg, bmp, tif, tiff, pgm, ppm, webp; case-insensitive),
/// sorted by name (natural order: "img2" < "img10"), and attaches times:
///  * `timestamps_file` given (or `timestamps.csv` / `timestamps.txt` present in the folder):
///    CSV with columns file and t_s (matched by file name), or a text file with one time per line
///    (or "name time"), in the sorted image order; a count mismatch, an unknown name, a bad number
///    or a decreasing time is an error naming the file and line;
///  * otherwise t_i = i / default_rate_hz.
/// A folder without images is an error naming the folder.
[[nodiscard]] Result<FrameList> list_image_folder(const std::string& folder, const std::string& timestamps_file,
                                                  double default_rate_hz);

/// Ground-truth poses of a run (empty when the file does not exist).
[[nodiscard]] Result<std::vector<std::pair<double, Pose2D>>> read_ground_truth(const std::string& run_dir);

}  // namespace visnav::recorded
