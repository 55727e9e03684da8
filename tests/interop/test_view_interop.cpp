// The live view (`visnav run`, here started by the config key run.view_port) against the
// independent @foxglove/ws-protocol client (npm): a route is taught in the simulator, then during
// its replay, paced at twice real time by --view-speed 2, a client that never reads sits on every
// channel and another client connects and disconnects 10 times; then the ws-protocol client
// subscribes to every advertised channel, every message must decode, the per-tick channels must
// arrive at the tick rate, and the feature overlay (/camera/annotations) must carry the replay's
// matched features. The run must still finish normally.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>

#include "interop_util.hpp"

extern char** environ;
namespace fs = std::filesystem;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Connects, upgrades, subscribes to channels 1..n and never reads again.
int stuck_client(int port, int channels) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  const int size = 4096;
  (void)::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &size, sizeof size);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) return fd;
  const std::string req = "GET / HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                          "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n";
  (void)::send(fd, req.data(), req.size(), 0);
  std::string subs;
  for (int i = 1; i <= channels; ++i) {
    if (i > 1) subs += ',';
    subs += "{\"id\":" + std::to_string(i) + ",\"channelId\":" + std::to_string(i) + "}";
  }
  const std::string text = "{\"op\":\"subscribe\",\"subscriptions\":[" + subs + "]}";
  std::string f{static_cast<char>(0x81), static_cast<char>(0x80 | 126), static_cast<char>(text.size() >> 8),
                static_cast<char>(text.size() & 0xFF), 0, 0, 0, 0};  // zero mask: payload as is
  f += text;
  (void)::send(fd, f.data(), f.size(), 0);
  return fd;
}

double json_number(const std::string& json, const std::string& topic, const std::string& key) {
  const auto at = json.find("\"" + topic + "\":{");
  if (at == std::string::npos) return -1;
  std::smatch m;
  const std::string rest = json.substr(at);
  if (!std::regex_search(rest, m, std::regex("\"" + key + "\":([-0-9.e]+)"))) return -1;
  return std::stod(m[1].str());
}

TEST(ViewInterop, FoxgloveWsProtocolClientReceivesEveryChannelDuringARun) {
  if (!visnav::interop::have_node()) GTEST_SKIP() << "node/npm not found: the @foxglove/ws-protocol test needs Node.js";
  const std::string why = visnav::interop::ensure_npm_packages("@foxglove/ws-protocol");
  ASSERT_TRUE(why.empty()) << why;
  const fs::path dir = fs::temp_directory_path() / ("visnav_view_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string src = VISNAV_TEST_SOURCE_DIR;
  std::ofstream(dir / "config.yaml")
      << "robot:\n  type: sim\n  params: {world: straight6m}\n"
         "camera:\n  type: sim\n  params: {width_px: 160, height_px: 120, hfov_deg: 60}\n"
         "detector:\n  type: orb\n  params: {target_keypoints: 200}\n"
         "nodes: [feature_replay, navigation, sim_operator, relocalisation]\n"
         "run:\n  tick: frame\n  rate_hz: 10\n  lockstep: on\n  log_level: warn\n  reload_poll_s: 0\n";
  std::ofstream(dir / "route.yaml")
      << "route:\n  name: s\n  world: straight6m\n  start: [0, 0, 0]\n"
         "  waypoints:\n    - {at: [0, 0], kind: feature}\n    - {at: [5, 0]}\n";
  // Teach the route first (no view, as fast as lock-step goes).
  std::string teach_out;
  ASSERT_EQ(visnav::interop::run_shell(
                std::string("'") + VISNAV_TEST_CLI + "' run --config " + (dir / "config.yaml").string() + " --map " +
                    (dir / "map").string() + " --create --tree " + src + "/trees/teach_feature_edge.xml --bb route_file=" +
                    (dir / "route.yaml").string() + " --bb style=segment --bb force_kind=feature_segment --bb close_loop=false",
                teach_out),
            0)
      << teach_out;
  // The view's port from the config key (a free port: bound, read back, released).
  int view_port = 0;
  {
    const int s = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    ASSERT_EQ(::bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    ASSERT_EQ(::getsockname(s, reinterpret_cast<sockaddr*>(&a), &len), 0);
    view_port = ntohs(a.sin_port);
    ::close(s);
  }
  const std::vector<std::string> args{VISNAV_TEST_CLI, "run", "--config", (dir / "config.yaml").string(), "--map",
                                      (dir / "map").string(), "--tree", src + "/trees/replay_feature_edge.xml",
                                      "--bb", "start=start", "--bb", "goal=n1", "--bb", "loops=1", "--bb", "laps=1",
                                      "--bb", "speed_mps=0.5", "--set", "run.view_port=" + std::to_string(view_port),
                                      "--view-speed", "2"};
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  const std::string log = (dir / "run.log").string();
  posix_spawn_file_actions_addopen(&fa, STDERR_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  std::vector<char*> argv;
  for (const auto& s : args) argv.push_back(const_cast<char*>(s.c_str()));
  argv.push_back(nullptr);
  pid_t pid = -1;
  ASSERT_EQ(posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&fa);

  int port = -1;
  for (int i = 0; i < 200 && port < 0; ++i) {
    std::smatch m;
    const std::string text = slurp(log);
    if (std::regex_search(text, m, std::regex("ws://localhost:([0-9]+)"))) port = std::stoi(m[1].str());
    else std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (port < 0) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, nullptr, 0);
    FAIL() << "no live view port announced:\n" << slurp(log);
  }
  EXPECT_EQ(port, view_port);
  const int stuck = stuck_client(port, 7);
  std::string out;
  const int rc = visnav::interop::run_shell("cd " + visnav::interop::shell_quote(visnav::interop::kInteropDir.string()) +
                                                " && node view_client.mjs " + std::to_string(port) + " 3 10",
                                            out);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ::close(stuck);
  ASSERT_EQ(rc, 0) << out;
  std::printf("view client: %s\n", out.c_str());
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << slurp(log);
  EXPECT_NE(out.find("\"errors\":[]"), std::string::npos) << out;
  for (const char* topic : {"/camera", "/robot/pose", "/bt", "/map", "/telemetry", "/camera/annotations", "/camera/overlay"}) {
    SCOPED_TRACE(topic);
    EXPECT_EQ(json_number(out, topic, "bad"), 0) << out;  // every message decoded
  }
  EXPECT_NE(out.find("\"schema\":\"foxglove.CompressedImage\""), std::string::npos) << out;
  EXPECT_NE(out.find("\"schema\":\"foxglove.SceneUpdate\""), std::string::npos) << out;
  // The per-tick channels at the tick rate: 10 Hz of simulated time at twice real time.
  for (const char* topic : {"/camera", "/robot/pose", "/bt", "/camera/annotations", "/camera/overlay"}) {
    SCOPED_TRACE(topic);
    const double rate = json_number(out, topic, "rate_hz");
    EXPECT_GT(rate, 14.0) << out;
    EXPECT_LT(rate, 26.0) << out;
  }
  EXPECT_GE(json_number(out, "/map", "count"), 1) << out;
  // The replay's matched features are drawn over the camera image.
  EXPECT_NE(out.find("\"schema\":\"foxglove.ImageAnnotations\""), std::string::npos) << out;
  EXPECT_GE(json_number(out, "/camera/annotations", "features_max"), 10) << out;
  EXPECT_NE(out.find("\"keys\":[\"circles\",\"points\",\"texts\"]"), std::string::npos) << out;
  EXPECT_NE(out.find("\"keys\":[\"data\",\"format\",\"frame_id\",\"timestamp\"]"), std::string::npos) << out;
  fs::remove_all(dir);
}

}  // namespace
