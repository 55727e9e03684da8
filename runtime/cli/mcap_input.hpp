// A recorded run given as an MCAP file to a command that works on run folders (`visnav play`):
// the bag is converted into a temporary folder that lives as long as the TempRun.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>

#include "visnav/mcap.hpp"

namespace visnav::cli {

struct TempRun {
  std::string dir;
  TempRun() = default;
  TempRun(const TempRun&) = delete;
  TempRun& operator=(const TempRun&) = delete;
  ~TempRun() {
    std::error_code ec;
    if (!dir.empty()) std::filesystem::remove_all(dir, ec);
  }
};

/// `path` itself when it is not a file; else the folder the MCAP file was converted into.
inline Result<std::string> run_folder_of(const std::string& path, const mcap::RunTopics& topics, TempRun& temp) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return path;
  temp.dir = (std::filesystem::temp_directory_path() /
              ("visnav_run_" + std::to_string(::getpid()) + "_" + std::filesystem::path(path).stem().string()))
                 .string();
  std::filesystem::remove_all(temp.dir, ec);
  VISNAV_ASSIGN(auto report, mcap::mcap_to_run_folder(path, temp.dir, topics));
  (void)report;
  return temp.dir;
}

}  // namespace visnav::cli
