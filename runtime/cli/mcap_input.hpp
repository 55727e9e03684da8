// A recorded run given as an MCAP file to a command that works on run folders (`visnav play`):
// the bag is converted into a temporary folder that lives as long as the TempRun.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>

#include "args.hpp"
#include "visnav/config.hpp"
#include "visnav/mcap.hpp"

namespace visnav::cli {

/// Topics of a ROS 2 bag: the defaults, then run.bag_image_topic / bag_odom_topic /
/// bag_joy_topic of `config_file` (when given, with its --set overrides), then the command's
/// --image-topic / --odom-topic / --joy-topic. Errors: the config does not load.
struct BagTopics {
  mcap::RunTopics run;
  std::string joy;  ///< empty: no gamepad marks
};
inline Result<BagTopics> bag_topics(const Args& a, const std::string& config_file,
                                    const std::vector<std::string>& overrides = {}) {
  BagTopics t;
  if (!config_file.empty()) {
    VISNAV_ASSIGN(RunConfig config, load_run_config(config_file, overrides));
    t.run.image = config.run.bag_image_topic;
    t.run.odometry = config.run.bag_odom_topic;
    t.joy = config.run.bag_joy_topic;
  }
  t.run.image = a.get("--image-topic", t.run.image);
  t.run.odometry = a.get("--odom-topic", t.run.odometry);
  t.joy = a.get("--joy-topic", t.joy);
  return t;
}

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
