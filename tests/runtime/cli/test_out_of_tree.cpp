// The core is closed for modification: an out-of-tree plugin project builds against the
// installed SDK (find_package(visnav)) and is loaded by the installed CLI through config only.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "visnav/plugin.hpp"

namespace fs = std::filesystem;

namespace {

std::string read_file(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Runs a shell command, output appended to `log`; returns the exit status.
int sh(const std::string& command, const fs::path& log) {
  const std::string full = "(" + command + ") >>'" + log.string() + "' 2>&1";
  const int rc = std::system(full.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : 128;
}

}  // namespace

TEST(OutOfTreePlugin, BuildsAgainstTheInstalledSdkAndLoadsThroughConfig) {
  std::string pattern = (fs::temp_directory_path() / "visnav_oot_XXXXXX").string();
  ASSERT_NE(mkdtemp(pattern.data()), nullptr);
  const fs::path dir(pattern);
  const fs::path prefix = dir / "prefix";
  const fs::path build = dir / "build";
  const fs::path log = dir / "log.txt";
  const std::string cmake = VISNAV_TEST_CMAKE;

  ASSERT_EQ(sh(cmake + " --install '" VISNAV_TEST_BINARY_DIR "' --component sdk --prefix '" + prefix.string() + "'", log), 0)
      << read_file(log);
  ASSERT_TRUE(fs::exists(prefix / "include/visnav/plugin.hpp"));
  ASSERT_TRUE(fs::exists(prefix / "bin/visnav"));

  ASSERT_EQ(sh(cmake + " -S '" VISNAV_TEST_SOURCE_DIR "/examples/out_of_tree_plugin' -B '" + build.string() +
                   "' -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH='" + prefix.string() + "'",
               log),
            0)
      << read_file(log);
  ASSERT_EQ(sh(cmake + " --build '" + build.string() + "'", log), 0) << read_file(log);
  ASSERT_TRUE(fs::exists(build / "libvisnav_example_nodes.so")) << read_file(log);

  // The installed CLI lists it when pointed at the folder...
  const std::string visnav = (prefix / "bin/visnav").string();
  const fs::path out = dir / "plugins.txt";
  ASSERT_EQ(sh("VISNAV_PLUGIN_PATH='" + build.string() + "' '" + visnav + "' plugins >'" + out.string() + "'", log), 0)
      << read_file(log);
  const std::string listed = "nodes  example_nodes 1.0  (ABI " + std::to_string(visnav::kPluginAbiVersion) + ")";
  EXPECT_NE(read_file(out).find(listed), std::string::npos) << read_file(out);

  // ...and runs a mission with its node, found through the config's plugin_path alone.
  std::ofstream(dir / "setup.yaml") << "robot: {type: fixture}\n"
                                       "camera: {type: fixture}\n"
                                       "plugin_path: ['" VISNAV_TEST_FIXTURE_PLUGIN_DIR "', build]\n"
                                       "nodes: [example_nodes]\n";
  std::ofstream(dir / "turn.xml") << R"(<root BTCPP_format="4"><BehaviorTree ID="Main">
  <ExampleTurn angle_rad="1.57" rate_radps="0.5"/>
</BehaviorTree></root>)";
  const fs::path run_out = dir / "run.txt";
  const int rc = sh("cd '" + dir.string() + "' && '" + visnav + "' run --config setup.yaml --tree turn.xml >'" +
                        run_out.string() + "'",
                    log);
  EXPECT_EQ(rc, 0) << read_file(log) << read_file(run_out);
  EXPECT_NE(read_file(run_out).find("success"), std::string::npos) << read_file(run_out);
  fs::remove_all(dir);
}
