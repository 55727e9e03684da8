// Shared set-up of the recorded-run integration tests: a simulated setup (config + tree) whose
// mission is recorded once per test binary with `visnav record`.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace visnav::testing {

namespace fs = std::filesystem;

inline std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

inline void put(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  out << text;
}

/// Runs a shell command with stdout+stderr to `log`; returns the exit status (-1 if killed).
inline int shell(const std::string& command, const std::string& log) {
  const int rc = std::system((command + " > '" + log + "' 2>&1").c_str());
  if (rc == -1 || !WIFEXITED(rc)) return -1;
  return WEXITSTATUS(rc);
}

inline std::vector<std::string> lines_of(const std::string& path) {
  std::vector<std::string> out;
  std::ifstream in(path);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

/// The simulated setup: folder with config.yaml and steer.xml.
struct SimSetup {
  std::string dir;
  std::string config;
  std::string tree;
  std::string cli = VISNAV_TEST_CLI;
};

inline SimSetup make_setup(const std::string& name, double distance_m, double heading_deg = 8.0) {
  SimSetup s;
  s.dir = (fs::path(VISNAV_TEST_BINARY_DIR) / "test_scratch" / name).string();
  fs::remove_all(s.dir);
  fs::create_directories(s.dir);
  s.config = s.dir + "/config.yaml";
  s.tree = s.dir + "/steer.xml";
  std::ostringstream c;
  c << "robot:\n  type: sim\n  params:\n    world: straight6m\n    odom_rate_hz: 50\n"
    << "    odom_distance_noise_m_per_sqrt_m: 0.01\n    displacement_heading_deg: " << heading_deg << "\n    seed: 3\n"
    << "camera:\n  type: sim\n  params:\n    width_px: 120\n    height_px: 90\n    noise_std: 2\n"
    << "detector:\n  type: orb\n  params: {}\n"
    << "nodes: [fixture_recorded_nodes]\n"
    << "plugin_path: [" << VISNAV_TEST_FIXTURE_PLUGIN_DIR << "]\n"
    << "run:\n  tick: frame\n  rate_hz: 10\n  lockstep: on\n  log_level: warn\n";
  put(s.config, c.str());
  std::ostringstream t;
  t << "<root BTCPP_format=\"4\" main_tree_to_execute=\"Main\">\n  <BehaviorTree ID=\"Main\">\n"
    << "    <RecSteer distance_m=\"" << distance_m << "\" speed_mps=\"0.5\" gain_radps=\"0.4\"/>\n"
    << "  </BehaviorTree>\n</root>\n";
  put(s.tree, t.str());
  return s;
}

}  // namespace visnav::testing
