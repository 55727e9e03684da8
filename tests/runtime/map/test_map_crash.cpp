// Crash safety: a teaching process killed with SIGKILL at an arbitrary moment leaves a map that
// opens with every edge whose add_edge() returned, and that validates.
#include <signal.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <set>
#include <thread>

#include "map_test_util.hpp"

namespace visnav {
namespace {

using test::edge;
using test::make_body;
using test::node;
using test::TempDir;

constexpr std::size_t kBodyBytes = 256 * 1024;

/// Child: teaches edges n<i> -> n<i+1> forever, reporting each completed edge index on `fd`.
[[noreturn]] void teach_forever(const std::string& dir, int fd) {
  auto map = MapStore::open(dir);
  if (!map) ::_exit(3);
  int i = static_cast<int>(map->edges().size());
  for (;; ++i) {
    const std::string to = test::numbered("n", i + 1);
    // A previous session may have been killed between adding this node and its edge.
    if (map->find_node(to) == nullptr && !map->add_node(node(to))) ::_exit(4);
    EdgeRecord e = edge(test::numbered("n", i), to, i % 2 == 0 ? "feature_segment" : "path_following", 1.0 + i, 0.1 * i,
                        test::numbered("e", i));
    e.statistics["index"] = i;
    if (!map->add_edge(e, make_body(kBodyBytes, static_cast<std::uint32_t>(i)))) ::_exit(5);
    const std::int32_t done = i;
    if (::write(fd, &done, sizeof done) != sizeof done) ::_exit(6);
  }
}

TEST(MapCrashSafety, SigkillDuringTeachKeepsEveryCompletedEdge) {
  TempDir tmp;
  const std::string dir = tmp / "teach";
  {
    auto map = MapStore::create(dir, "crash");
    ASSERT_TRUE(map);
    ASSERT_TRUE(map->add_node(node("n0")));
  }
  std::set<int> completed;
  // Several teach sessions into the same map, each killed at a different moment.
  const int kill_after[] = {3, 6, 4};
  const int extra_delay_us[] = {0, 700, 2300};
  for (int round = 0; round < 3; ++round) {
    int fds[2];
    ASSERT_EQ(::pipe(fds), 0);
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      ::close(fds[0]);
      teach_forever(dir, fds[1]);
    }
    ::close(fds[1]);
    int reported = 0;
    std::int32_t index = 0;
    while (reported < kill_after[round] && ::read(fds[0], &index, sizeof index) == sizeof index) {
      completed.insert(index);
      ++reported;
    }
    std::this_thread::sleep_for(std::chrono::microseconds(extra_delay_us[round]));
    ::kill(child, SIGKILL);
    // Edges that completed between the last read and the kill were reported too.
    while (::read(fds[0], &index, sizeof index) == sizeof index) completed.insert(index);
    ::close(fds[0]);
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFSIGNALED(status)) << "child exited early with status " << WEXITSTATUS(status);
    ASSERT_EQ(reported, kill_after[round]) << "child stopped reporting";

    auto map = MapStore::open(dir);
    ASSERT_TRUE(map) << "round " << round << ": " << map.error().message;
    for (int i : completed) {
      const auto* e = map->find_edge(test::numbered("e", i));
      ASSERT_NE(e, nullptr) << "round " << round << ": completed edge e" << i << " lost";
      EXPECT_EQ(e->statistics.at("index"), i);
    }
    // At most one edge beyond the reported ones (killed between the graph write and the report).
    EXPECT_LE(map->edges().size(), completed.size() + 1);
    const auto problems = map->validate();
    EXPECT_TRUE(problems.empty()) << "round " << round << ": " << problems.front();
    for (const auto& e : map->edges()) {
      auto body = map->read_payload(e.id);
      ASSERT_TRUE(body) << body.error().message;
      EXPECT_EQ(*body, make_body(kBodyBytes, static_cast<std::uint32_t>(e.statistics.at("index"))));
    }
    // Whatever was left behind is a temporary or unreferenced file, never an edge.
    for (const auto& f : map->leftover_files()) {
      const std::string name = std::filesystem::path(f).filename().string();
      const bool temp = name.front() == '.' && name.find(".tmp.") != std::string::npos;
      const bool orphan = name.size() > 4 && !map->find_edge(name.substr(0, name.size() - 4));
      EXPECT_TRUE(temp || orphan) << f;
    }
    // The next session continues from the last complete edge.
    for (const auto& e : map->edges()) completed.insert(static_cast<int>(e.statistics.at("index")));
  }
  const auto [status, out] = test::run(std::string(VISNAV_TEST_CLI) + " map validate " + dir + " --no-plugins");  // synthetic bodies
  EXPECT_EQ(status, 0) << out;
  EXPECT_GE(completed.size(), 13u);
}

}  // namespace
}  // namespace visnav
