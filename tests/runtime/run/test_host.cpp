// Host services: logger levels, telemetry JSON lines, clocks, create_detector.
#include <csignal>
#include <cstdio>
#include <thread>

#include "error_expect.hpp"
#include "run_test_util.hpp"

using namespace visnav;
using visnav::test::contains;
using visnav::test::TempDir;

TEST(Host, LoggerDropsMessagesBelowItsLevel) {
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  StderrLogger logger(LogLevel::warn, f);
  logger.info("run", "hidden");
  logger.warn("run", "shown");
  logger.set_level(LogLevel::debug);
  logger.log(LogLevel::debug, "bt", "now visible");
  std::rewind(f);
  char buf[256] = {};
  const std::size_t n = std::fread(buf, 1, sizeof buf - 1, f);
  std::fclose(f);
  const std::string text(buf, n);
  EXPECT_EQ(text, "visnav [W] run: shown\nvisnav [D] bt: now visible\n");
  EXPECT_TRUE(parse_log_level("warning"));
  EXPECT_FALSE(parse_log_level("loud"));
}

TEST(Host, TelemetryWritesOneEscapedJsonLinePerStatus) {
  TempDir dir;
  ManualClock clock(1.5);
  {
    auto t = JsonLinesTelemetry::open(dir.file("t.jsonl"), clock);
    ASSERT_TRUE(t) << t.error().message;
    NavStatus s;
    s.node_path = "Main/\"quoted\"\\path";
    s.edge = "e1";
    s.matches = 42;
    s.command = {0.25, -0.5};
    s.confidence = 0.75;
    s.blind_m = 1.25;
    s.status = "line\nbreak";
    (*t)->publish(s);
    clock.advance(0.5);
    (*t)->publish(NavStatus{});
    EXPECT_EQ((*t)->published(), 2u);
  }
  const std::string text = visnav::test::read_file(dir.file("t.jsonl"));
  EXPECT_TRUE(contains(text, "{\"t_s\":1.5000,\"node_path\":\"Main/\\\"quoted\\\"\\\\path\",\"map_node\":\"\",\"edge\":\"e1\""))
      << text;
  EXPECT_TRUE(contains(text, "\"matches\":42,")) << text;
  EXPECT_TRUE(contains(text, "\"linear_mps\":0.2500,\"angular_radps\":-0.5000,\"confidence\":0.750,\"blind_m\":1.250,"
                             "\"status\":\"line\\nbreak\"}\n")) << text;
  EXPECT_TRUE(contains(text, "{\"t_s\":2.0000,")) << text;
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 2);
}

TEST(Host, TelemetryFileThatCannotBeOpenedIsAnError) {
  ManualClock clock;
  auto t = JsonLinesTelemetry::open("/nonexistent/dir/t.jsonl", clock);
  ASSERT_FALSE(t);
  EXPECT_TRUE(visnav::test::fails_with(t, ErrorCode::io, visnav::test::At{"/nonexistent/dir/t.jsonl"}));
}

TEST(Host, CreateDetectorGoesThroughTheLoader) {
  TempDir dir;
  visnav::test::CaptureLogger log;
  auto s = visnav::test::fixture_session(dir.write("c.yaml", visnav::test::fixture_config()), &log);
  ASSERT_TRUE(s) << s.error().message;
  HostServices& host = (*s)->host();
  auto d = host.create_detector("grid_l2", ConfigNode{});
  ASSERT_TRUE(d) << d.error().message;
  EXPECT_EQ((*d)->norm(), DescriptorNorm::l2);
  auto missing = host.create_detector("sift9000", ConfigNode{});
  ASSERT_FALSE(missing);
  EXPECT_TRUE(visnav::test::fails_with(missing, ErrorCode::not_found));
}

TEST(Host, SimulationClockFollowsTheSimulation) {
  TempDir dir;
  visnav::test::CaptureLogger log;
  auto s = visnav::test::fixture_session(dir.write("c.yaml", visnav::test::fixture_config()), &log);
  ASSERT_TRUE(s) << s.error().message;
  SimulationControl* sim = (*s)->robot().simulation();
  ASSERT_NE(sim, nullptr);
  const double before = (*s)->clock().now_s();
  ASSERT_TRUE(sim->step(0.25));
  EXPECT_DOUBLE_EQ((*s)->clock().now_s(), before + 0.25);
}

TEST(Host, StopRequestIsSeenQuicklyAtLowTickRates) {
  TempDir dir;
  visnav::test::CaptureLogger log;
  auto s = visnav::test::fixture_session(
      dir.write("c.yaml", visnav::test::fixture_config("{simulated: false}", "{frame_period_s: 0.01}",
                                                       "{tick: rate, rate_hz: 0.2, max_frame_age_s: 60, max_odometry_age_s: 60}")),
      &log);
  ASSERT_TRUE(s) << s.error().message;
  dir.write("tree.xml", visnav::test::drive_tree(100.0));
  auto tree = (*s)->load_tree(dir.file("tree.xml"));
  ASSERT_TRUE(tree) << tree.error().message;
  std::atomic<int> flag{0};
  std::thread stopper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(150));
    flag.store(SIGTERM);
  });
  RunOptions o;
  o.stop_requested = &flag;
  const RunReport r = run_tree(**s, *tree, o);
  stopper.join();
  EXPECT_EQ(r.outcome, RunOutcome::interrupted);
  EXPECT_EQ(r.exit_code, 128 + SIGTERM);
  EXPECT_EQ(r.ticks, 1u);           // the first tick happens at once, the next one is 5 s away
  EXPECT_LT(r.wall_time_s, 1.0);    // but the stop is seen within a slice
}
