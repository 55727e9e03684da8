// Real sessions for the FollowPathEdge / TeachPathEdge tests (test_follow_path_edge*.cpp): a
// scratch folder, a session on the sim robot and a 320x240 sim camera with the path_following
// nodes (lock-step, 10 Hz frame ticks) and its map in <dir>/map, trees from an XML body.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "visnav/runner.hpp"

namespace visnav::test {

/// <tmp>/visnav_follow_path_<name>_<pid>, emptied and created.
inline std::filesystem::path path_test_dir(const std::string& name) {
  std::filesystem::path d =
      std::filesystem::temp_directory_path() / ("visnav_follow_path_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

/// Writes <dir>/setup.yaml (sim robot with `robot_params`, e.g. "world: campus", at `log_level`)
/// and creates the session with `so` and its map in <dir>/map; fails the test (nullptr) on error.
inline std::unique_ptr<Session> make_path_session(const std::filesystem::path& dir, const std::string& robot_params,
                                                  const std::string& log_level = "warn", SessionOptions so = {}) {
  const std::filesystem::path cfg = dir / "setup.yaml";
  std::ofstream(cfg) << "robot: {type: sim, params: {" << robot_params << "}}\n"
                     << "camera: {type: sim, params: {width_px: 320, height_px: 240}}\n"
                     << "nodes: [path_following]\n"
                     << "run: {tick: frame, rate_hz: 10, lockstep: on, log_level: " << log_level << "}\n";
  auto config = load_run_config(cfg.string(), {});
  EXPECT_TRUE(config.ok()) << (config.ok() ? "" : config.error().message);
  if (!config.ok()) return nullptr;
  so.map_path = (dir / "map").string();
  auto session = Session::create(std::move(*config), so);
  EXPECT_TRUE(session.ok()) << (session.ok() ? "" : session.error().message);
  return session.ok() ? std::move(*session) : nullptr;
}

/// Writes `body` as the tree "Main" to <dir>/tree.xml and loads it into `s`.
inline Result<bt::Tree> tree_from(Session& s, const std::filesystem::path& dir, const std::string& body) {
  const std::filesystem::path file = dir / "tree.xml";
  std::ofstream(file) << "<root BTCPP_format=\"4\"><BehaviorTree ID=\"Main\">" << body << "</BehaviorTree></root>";
  return s.load_tree(file.string());
}

}  // namespace visnav::test
