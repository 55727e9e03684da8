// The `visnav` command line, run as a real process (VISNAV_TEST_CLI) on the fixture plugins.
#include <gtest/gtest.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>
#include "visnav/plugin.hpp"

#include "visnav/plugin.hpp"

extern char** environ;

namespace fs = std::filesystem;

namespace {

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

std::string read_file(const fs::path& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string pattern = (fs::temp_directory_path() / "visnav_cli_XXXXXX").string();
    ASSERT_NE(mkdtemp(pattern.data()), nullptr);
    dir_ = pattern;
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }

  std::string write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
    return (dir_ / name).string();
  }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  struct Outcome {
    int exit_code = -1;
    std::string out;
    std::string err;
  };

  /// Starts `visnav args...` with stdout/stderr redirected to files; env entries are added
  /// ("NAME=value") to the current environment.
  pid_t spawn(const std::vector<std::string>& args, const std::vector<std::string>& env = {}) {
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, path("stdout.txt").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, path("stderr.txt").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    std::vector<std::string> argv_text{VISNAV_TEST_CLI};
    argv_text.insert(argv_text.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : argv_text) argv.push_back(a.data());
    argv.push_back(nullptr);
    std::vector<std::string> env_text;
    for (char** e = environ; *e != nullptr; ++e) {
      const std::string entry = *e;
      bool replaced = false;
      for (const auto& extra : env)
        replaced |= entry.substr(0, entry.find('=')) == extra.substr(0, extra.find('='));
      if (!replaced) env_text.push_back(entry);
    }
    env_text.insert(env_text.end(), env.begin(), env.end());
    std::vector<char*> envp;
    for (auto& e : env_text) envp.push_back(e.data());
    envp.push_back(nullptr);
    pid_t pid = -1;
    const int rc = posix_spawn(&pid, VISNAV_TEST_CLI, &actions, nullptr, argv.data(), envp.data());
    posix_spawn_file_actions_destroy(&actions);
    EXPECT_EQ(rc, 0);
    return pid;
  }
  Outcome wait(pid_t pid) {
    int status = 0;
    waitpid(pid, &status, 0);
    Outcome o;
    o.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    o.out = read_file(path("stdout.txt"));
    o.err = read_file(path("stderr.txt"));
    return o;
  }
  Outcome run(const std::vector<std::string>& args, const std::vector<std::string>& env = {}) {
    return wait(spawn(args, env));
  }

  static std::string fixture_env() { return std::string("VISNAV_PLUGIN_PATH=") + VISNAV_TEST_FIXTURE_PLUGIN_DIR; }

  std::string good_config(const std::string& robot_params = "{}") {
    return write("setup.yaml", "robot: {type: fixture, params: " + robot_params +
                                   "}\n"
                                   "camera: {type: fixture}\n"
                                   "detector: {type: grid_hamming, params: {cell_px: 8}}\n"
                                   "plugin_path: [" VISNAV_TEST_FIXTURE_PLUGIN_DIR "]\nnodes: [fixture_nodes]\n");
  }
  std::string drive_tree(const std::string& distance_m) {
    return write("mission.xml", R"(<root BTCPP_format="4">
  <BehaviorTree ID="Main">
    <Sequence>
      <FixtureHasFrame/>
      <FixtureDrive distance_m=")" + distance_m + R"(" speed_mps="0.5"/>
    </Sequence>
  </BehaviorTree>
</root>
)");
  }

  fs::path dir_;
};

}  // namespace

TEST_F(CliTest, VersionPrintsTheRuntimeVersion) {
  auto o = run({"--version"});
  EXPECT_EQ(o.exit_code, 0);
  EXPECT_TRUE(contains(o.out, "visnav 0.")) << o.out;
}

TEST_F(CliTest, EverySubcommandHasHelp) {
  for (const std::string cmd : {"run", "validate", "nodes", "plugins"}) {
    auto o = run({cmd, "--help"});
    EXPECT_EQ(o.exit_code, 0) << cmd;
    EXPECT_TRUE(contains(o.out, "usage: visnav " + cmd)) << cmd << ": " << o.out;
  }
  auto top = run({"--help"});
  EXPECT_EQ(top.exit_code, 0);
  for (const std::string cmd : {"run", "validate", "nodes", "plugins"}) EXPECT_TRUE(contains(top.out, "  " + cmd)) << top.out;
}

TEST_F(CliTest, UnknownCommandAndBadOptionsAreUsageErrors) {
  auto o = run({"frobnicate"});
  EXPECT_EQ(o.exit_code, 2);
  EXPECT_TRUE(contains(o.err, "unknown command 'frobnicate'")) << o.err;
  auto missing = run({"run", "--config", "x.yaml"});
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_TRUE(contains(missing.err, "missing required option(s): --tree")) << missing.err;
  auto unknown = run({"validate", "--config", "x.yaml", "--colour"});
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_TRUE(contains(unknown.err, "unknown option '--colour'")) << unknown.err;
}

TEST_F(CliTest, ValidateListsEveryErrorWithFileAndLine) {
  const std::string config = write("bad.yaml",
                                   "robot: {type: fixture, params: {max_speed_mps: 50}}\n"
                                   "camera: {type: nosuchcamera}\n"
                                   "detector: {type: grid_l2, params: {cell_pix: 8}}\n"
                                   "run: {rate_hz: -2}\n"
                                   "plugin_path: [" VISNAV_TEST_FIXTURE_PLUGIN_DIR "]\nnodes: [fixture_nodes]\n");
  const std::string tree = write("bad.xml", R"(<root BTCPP_format="4">
  <BehaviorTree ID="Main">
    <Sequence>
      <FixtureDrive speed_mps="fast" distance_m="1"/>
      <Teleport/>
    </Sequence>
  </BehaviorTree>
</root>
)");
  auto o = run({"validate", "--config", config, "--tree", tree});
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_TRUE(contains(o.err, config + ":4: key 'rate_hz'")) << o.err;
  // The tree is validated too (against the nodes plugins on the config's plugin_path).
  EXPECT_TRUE(contains(o.err, tree + ":4")) << o.err;
  EXPECT_TRUE(contains(o.err, tree + ":5")) << o.err;
  EXPECT_TRUE(contains(o.err, "Teleport")) << o.err;

  // With the run block fixed, the plugin params are checked against their declared docs.
  write("bad.yaml",
        "robot: {type: fixture, params: {max_speed_mps: 50}}\n"
        "camera: {type: nosuchcamera}\n"
        "detector: {type: grid_l2, params: {cell_pix: 8}}\n"
        "plugin_path: [" VISNAV_TEST_FIXTURE_PLUGIN_DIR "]\nnodes: [fixture_nodes]\n");
  auto p = run({"validate", "--config", config, "--tree", tree});
  EXPECT_EQ(p.exit_code, 1);
  EXPECT_TRUE(contains(p.err, config + ":1: key 'max_speed_mps' in robot.params: value 50 is out of range [0, 10]")) << p.err;
  EXPECT_TRUE(contains(p.err, config + ":2: camera: no camera plugin provides type 'nosuchcamera'")) << p.err;
  EXPECT_TRUE(contains(p.err, config + ":3: unknown key 'cell_pix' in detector.params")) << p.err;
  EXPECT_TRUE(contains(p.err, tree + ":4")) << p.err;  // speed_mps="fast" is not a double
}

TEST_F(CliTest, ValidateReportsYamlSyntaxErrors) {
  const std::string config = write("broken.yaml", "robot: {type: fixture\ncamera: {type: fixture}\n");
  auto o = run({"validate", "--config", config});
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_TRUE(contains(o.err, config + ":")) << o.err;
  EXPECT_TRUE(contains(o.err, "YAML syntax error")) << o.err;
}

TEST_F(CliTest, ValidateAcceptsAGoodSetupAndAppliesSet) {
  const std::string config = good_config();
  const std::string tree = drive_tree("1.0");
  auto o = run({"validate", "--config", config, "--tree", tree});
  EXPECT_EQ(o.exit_code, 0) << o.err;
  EXPECT_TRUE(contains(o.out, "are valid")) << o.out;
  auto bad = run({"validate", "--config", config, "--tree", tree, "--set", "detector.params.cell_px=1000"});
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_TRUE(contains(bad.err, "--set detector.params.cell_px=1000: key 'cell_px' in detector.params: value 1000 is out of range"))
      << bad.err;
}

TEST_F(CliTest, RunFinishesAMissionWithSuccess) {
  auto o = run({"run", "--config", good_config(), "--tree", drive_tree("1.0"), "--trace", path("trace.jsonl")});
  EXPECT_EQ(o.exit_code, 0) << o.err;
  EXPECT_TRUE(contains(o.out, "visnav run: success after")) << o.out;
  EXPECT_TRUE(contains(read_file(path("trace.jsonl")), "FixtureDrive"));
}

TEST_F(CliTest, RunExitsOneOnFailureAndOnInvalidTree) {
  const std::string failing = write("fail.xml", R"(<root BTCPP_format="4"><BehaviorTree ID="M"><AlwaysFailure/></BehaviorTree></root>)");
  auto o = run({"run", "--config", good_config(), "--tree", failing});
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_TRUE(contains(o.out, "failure")) << o.out;
  EXPECT_TRUE(contains(o.err, "FAILURE")) << o.err;

  const std::string invalid = write("invalid.xml", R"(<root BTCPP_format="4"><BehaviorTree ID="M">
<Nope/></BehaviorTree></root>)");
  auto i = run({"run", "--config", good_config(), "--tree", invalid});
  EXPECT_EQ(i.exit_code, 1);
  EXPECT_TRUE(contains(i.err, "nothing was run")) << i.err;
  EXPECT_TRUE(contains(i.err, invalid + ":2")) << i.err;
}

TEST_F(CliTest, RunRejectsABadOverride) {
  auto o = run({"run", "--config", good_config(), "--tree", drive_tree("1.0"), "--set", "run.rate_hz=fast"});
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_TRUE(contains(o.err, "--set run.rate_hz=fast: key 'rate_hz': 'fast' is not a number")) << o.err;
}

TEST_F(CliTest, RunStopsOnStaleOdometryWithExitThree) {
  auto o = run({"run", "--config", good_config("{odometry_freeze_after_s: 1.0}"), "--tree", drive_tree("100")});
  EXPECT_EQ(o.exit_code, 3);
  EXPECT_TRUE(contains(o.err, "stale odometry")) << o.err;
}

TEST_F(CliTest, SigintHaltsTheTreeStopsTheRobotAndExits130) {
  const std::string config =
      write("rt.yaml", "robot: {type: fixture, params: {simulated: false, command_log_file: " + path("cmd.txt") +
                           "}}\n"
                           "camera: {type: fixture, params: {frame_period_s: 0.02}}\n"
                           "run: {tick: rate, rate_hz: 20}\n"
                           "plugin_path: [" VISNAV_TEST_FIXTURE_PLUGIN_DIR "]\nnodes: [fixture_nodes]\n");
  const pid_t pid = spawn({"run", "--config", config, "--tree", drive_tree("1000")});
  // Wait until the robot has been commanded to move, then interrupt.
  for (int i = 0; i < 200 && read_file(path("cmd.txt")).empty(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_EQ(kill(pid, SIGINT), 0);
  auto o = wait(pid);
  EXPECT_EQ(o.exit_code, 130) << o.err;
  EXPECT_TRUE(contains(o.err, "halted")) << o.err;  // the RUNNING FixtureDrive got its halt callback
  EXPECT_TRUE(contains(o.out, "interrupted")) << o.out;
  const std::string commands = read_file(path("cmd.txt"));
  ASSERT_FALSE(commands.empty());
  EXPECT_TRUE(contains(commands, " 0.500000 0.000000")) << commands;  // it was moving
  const std::string last = commands.substr(commands.rfind('\n', commands.size() - 2) + 1);
  EXPECT_TRUE(contains(last, " 0.000000 0.000000")) << last;  // and was stopped
}

TEST_F(CliTest, PluginsListsKindTypesAbiAndPath) {
  auto o = run({"plugins"}, {fixture_env()});
  EXPECT_EQ(o.exit_code, 0) << o.err;
  std::string listed = "robot  fixture_robot 1.0  (ABI ";
  listed += std::to_string(visnav::kPluginAbiVersion);
  listed += ")  " VISNAV_TEST_FIXTURE_PLUGIN_DIR "/libvisnav_fixture_robot.so";
  EXPECT_TRUE(contains(o.out, listed)) << o.out;
  EXPECT_TRUE(contains(o.out, "type grid_l2")) << o.out;
  EXPECT_TRUE(contains(o.out, "command visnav fixture-hello")) << o.out;
  EXPECT_TRUE(contains(o.out, "node FixtureDrive")) << o.out;
  EXPECT_FALSE(contains(o.out, "max_speed_mps")) << o.out;
  auto p = run({"plugins", "--params"}, {fixture_env()});
  EXPECT_TRUE(contains(p.out, "max_speed_mps : double = 2  [0, 10]")) << p.out;
}

TEST_F(CliTest, PluginsShowsLibrariesThatCouldNotBeUsed) {
  auto o = run({"plugins", "--plugin-path", std::string(VISNAV_TEST_FIXTURE_PLUGIN_DIR) + "/broken"});
  EXPECT_EQ(o.exit_code, 0) << o.err;
  EXPECT_TRUE(contains(o.out, "not used:")) << o.out;
  EXPECT_TRUE(contains(o.out, "libvisnav_fixture_wrong_abi.so: ")) << o.out;
  EXPECT_TRUE(contains(o.out, "entry symbol 'visnav_plugin_entry' not found")) << o.out;
}

TEST_F(CliTest, NodesListsPluginNodesWithPortsAndWritesTheModel) {
  auto o = run({"nodes", "--no-builtin"}, {fixture_env()});
  EXPECT_EQ(o.exit_code, 0) << o.err;
  EXPECT_TRUE(contains(o.out, "FixtureDrive  (Action)")) << o.out;
  EXPECT_TRUE(contains(o.out, "in distance_m : double (required)")) << o.out;
  EXPECT_TRUE(contains(o.out, "in speed_mps : double = 0.5")) << o.out;
  EXPECT_FALSE(contains(o.out, "Sequence")) << o.out;
  // A port's check beyond its type is listed with it (the range a literal must lie in).
  auto b = run({"nodes"}, {fixture_env()});
  EXPECT_TRUE(contains(b.out, "in num_cycles : int (required)  [-1, 2147483647]")) << b.out;
  auto x = run({"nodes", "--xml", "--output", path("model.xml")}, {fixture_env()});
  EXPECT_EQ(x.exit_code, 0) << x.err;
  const std::string model = read_file(path("model.xml"));
  EXPECT_TRUE(contains(model, "<TreeNodesModel>")) << model;
  EXPECT_TRUE(contains(model, "ID=\"FixtureDrive\"")) << model;
  EXPECT_TRUE(contains(model, "ID=\"Sequence\"")) << model;
}

TEST_F(CliTest, PluginCommandsAreDispatched) {
  auto o = run({"fixture-hello", "a", "b"}, {fixture_env()});
  EXPECT_EQ(o.exit_code, 0) << o.err;
  EXPECT_TRUE(contains(o.out, "hello from fixture-hello: a b")) << o.out;
  auto f = run({"fixture-hello", "fail"}, {fixture_env()});
  EXPECT_EQ(f.exit_code, 3);
  auto help = run({"--help"}, {fixture_env()});
  EXPECT_TRUE(contains(help.out, "fixture-hello")) << help.out;
}
