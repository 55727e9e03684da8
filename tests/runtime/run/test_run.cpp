// Session + tick loop on the fixture robot/camera/detector/nodes plugins.
#include <csignal>

#include "error_expect.hpp"
#include "run_test_util.hpp"

using namespace visnav;
using visnav::test::CaptureLogger;
using visnav::test::contains;
using visnav::test::TempDir;

namespace {

struct Mission {
  TempDir dir;
  CaptureLogger log;
  std::unique_ptr<Session> session;

  /// Creates the session; fails the test (and returns false) on error.
  bool start(const std::string& config, const std::string& tree_xml = visnav::test::drive_tree(1.0)) {
    session = visnav::test::start_fixture_session(dir, config, tree_xml, &log);
    return session != nullptr;
  }
  RunReport run(RunOptions options = {}) {
    std::atomic<int> no_signal{0};
    if (options.stop_requested == nullptr) options.stop_requested = &no_signal;
    return visnav::test::run_tree_file(*session, dir.file("tree.xml"), options);
  }
};

}  // namespace

using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST(Run, SimulatedMissionRunsToSuccessInLockStep) {
  Mission m;
  ASSERT_TRUE(m.start(visnav::test::fixture_config()));
  EXPECT_TRUE(m.session->lockstep());
  const RunReport r = m.run();
  EXPECT_EQ(r.outcome, RunOutcome::success) << r.reason;
  EXPECT_EQ(r.exit_code, 0);
  // 1 m at 0.5 m/s with 0.1 s steps: the drive ends on the tick after 2 s of simulated time.
  EXPECT_GE(r.ticks, 20u);
  EXPECT_LE(r.ticks, 23u);
  EXPECT_NEAR(r.run_time_s, 0.1 * static_cast<double>(r.ticks), 1e-6);
  EXPECT_LT(r.wall_time_s, 1.0);  // lock-step runs as fast as possible
  auto odo = m.session->robot().latest_odometry();
  ASSERT_TRUE(odo);
  EXPECT_GE(odo->distance_m, 1.0);
  EXPECT_LT(odo->distance_m, 1.2);
  EXPECT_EQ(m.session->robot().last_command().linear_mps, 0.0);
}

TEST(Run, HostServicesAreWiredForNodes) {
  Mission m;
  ASSERT_TRUE(m.start(visnav::test::fixture_config()));
  RuntimeHost& host = m.session->host();
  EXPECT_EQ(host.robot(), &m.session->robot());
  EXPECT_EQ(host.frame_bus(), &m.session->frame_bus());
  EXPECT_EQ(host.active_detector(), m.session->detector());
  EXPECT_EQ(host.map(), nullptr);
  EXPECT_EQ(&host.clock(), &m.session->clock());
  RunOptions o;
  double last_t = -1.0;
  o.after_tick = [&](const TickInfo& t) {
    EXPECT_GT(t.t_s, last_t);  // simulated clock advances by one period per tick
    last_t = t.t_s;
    return true;
  };
  EXPECT_EQ(m.run(o).outcome, RunOutcome::success);
  EXPECT_TRUE(m.session->frame_bus().latest_frame().has_value());
  EXPECT_NEAR(m.session->clock().now_s(), last_t, 1e-9);
}

TEST(Run, FailingTreeExitsOneAndNamesTheFailedLeaf) {
  Mission m;
  ASSERT_TRUE(m.start(visnav::test::fixture_config(),
                      R"(<root BTCPP_format="4"><BehaviorTree ID="Main">
<Sequence>
  <FixtureHasFrame/>
  <AlwaysFailure name="give_up"/>
</Sequence></BehaviorTree></root>)"));
  const RunReport r = m.run();
  EXPECT_EQ(r.outcome, RunOutcome::failure);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_TRUE(contains(r.reason, "FAILURE")) << r.reason;
  EXPECT_TRUE(contains(r.reason, "give_up")) << r.reason;
  EXPECT_TRUE(contains(r.reason, "tree.xml:4")) << r.reason;
}

TEST(Run, StaleOdometryStopsTheRobotAndHaltsTheTree) {
  Mission m;
  ASSERT_TRUE(m.start(visnav::test::fixture_config("{odometry_freeze_after_s: 1.0}", "{}", "{max_odometry_age_s: 0.5}"),
                      visnav::test::drive_tree(100.0)));
  const RunReport r = m.run();
  EXPECT_EQ(r.outcome, RunOutcome::safety_stop);
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_TRUE(contains(r.reason, "stale odometry")) << r.reason;
  EXPECT_TRUE(contains(r.reason, "max_odometry_age_s = 0.500")) << r.reason;
  EXPECT_NEAR(r.run_time_s, 1.6, 0.15);
  EXPECT_EQ(m.session->robot().last_command().linear_mps, 0.0);
  EXPECT_TRUE(m.session->robot().latched());
  EXPECT_TRUE(m.log.saw("halted")) << m.log.all();  // FixtureDrive's halt callback ran
  EXPECT_TRUE(m.log.saw("E run: run ended: safety stop")) << m.log.all();
  // After a safety stop the robot refuses motion.
  EXPECT_FALSE(m.session->robot().send_command({0.3, 0.0}));
}

TEST(Run, StaleCameraStopsTheRobot) {
  Mission m;
  ASSERT_TRUE(m.start(visnav::test::fixture_config("{}", "{freeze_after_s: 0.5}", "{max_frame_age_s: 0.3}"),
                      visnav::test::drive_tree(100.0)));
  const RunReport r = m.run();
  EXPECT_EQ(r.outcome, RunOutcome::safety_stop);
  EXPECT_TRUE(contains(r.reason, "stale camera data")) << r.reason;
  EXPECT_EQ(m.session->robot().last_command().linear_mps, 0.0);
}

TEST(Run, CameraFailureIsASafetyStop) {
  Mission m;
  ASSERT_TRUE(m.start(visnav::test::fixture_config("{}", "{end_after_frames: 5}"), visnav::test::drive_tree(100.0)));
  const RunReport r = m.run();
  EXPECT_EQ(r.outcome, RunOutcome::safety_stop);
  EXPECT_TRUE(contains(r.reason, "camera failed: fixture camera: source ended after 5 frames")) << r.reason;
  EXPECT_EQ(r.ticks, 5u);
}

TEST(Run, StopRequestHaltsRunningNodesAndCommandsZero) {
  Mission m;
  ASSERT_TRUE(m.start(visnav::test::fixture_config("{command_log_file: " + m.dir.file("commands.txt") + "}"),
                      visnav::test::drive_tree(100.0)));
  std::atomic<int> flag{0};
  RunOptions o;
  o.stop_requested = &flag;
  o.after_tick = [&](const TickInfo& t) {
    if (t.tick == 5) flag.store(SIGINT);
    return true;
  };
  const RunReport r = m.run(o);
  EXPECT_EQ(r.outcome, RunOutcome::interrupted);
  EXPECT_EQ(r.exit_code, 130);
  EXPECT_EQ(r.ticks, 5u);
  EXPECT_TRUE(m.log.saw("halted")) << m.log.all();
  EXPECT_EQ(m.session->robot().last_command().linear_mps, 0.0);
  const std::string commands = visnav::test::read_file(m.dir.file("commands.txt"));
  ASSERT_FALSE(commands.empty());
  const std::string last = commands.substr(commands.rfind('\n', commands.size() - 2) + 1);
  EXPECT_TRUE(contains(last, " 0.000000 0.000000")) << last;
}

TEST(Run, AfterTickCanEndTheRun) {
  Mission m;
  ASSERT_TRUE(m.start(visnav::test::fixture_config(), visnav::test::drive_tree(100.0)));
  RunOptions o;
  o.after_tick = [](const TickInfo& t) { return t.tick < 7; };
  const RunReport r = m.run(o);
  EXPECT_EQ(r.outcome, RunOutcome::stopped);
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(r.ticks, 7u);
}

TEST(Run, MaxDurationEndsTheRunWithFailure) {
  Mission m;
  ASSERT_TRUE(m.start(visnav::test::fixture_config("{}", "{}", "{max_duration_s: 1.0}"), visnav::test::drive_tree(100.0)));
  const RunReport r = m.run();
  EXPECT_EQ(r.outcome, RunOutcome::failure);
  EXPECT_TRUE(contains(r.reason, "max_duration_s")) << r.reason;
  EXPECT_NEAR(r.run_time_s, 1.0, 0.11);
}

TEST(Run, InvalidTreeIsRejectedBeforeAnythingRuns) {
  Mission m;
  ASSERT_TRUE(m.start(visnav::test::fixture_config(), R"(<root BTCPP_format="4"><BehaviorTree ID="Main">
<Sequence>
  <FixtureDrive speed_mps="0.3"/>
  <NoSuchNode/>
</Sequence></BehaviorTree></root>)"));
  auto tree = m.session->load_tree(m.dir.file("tree.xml"));
  ASSERT_FALSE(tree);
  EXPECT_TRUE(contains(tree.error().message, "tree.xml:3")) << tree.error().message;  // missing distance_m
  EXPECT_TRUE(contains(tree.error().message, "tree.xml:4")) << tree.error().message;  // unknown node
  EXPECT_EQ(m.session->robot().commands_sent(), 0u);
}

TEST(Run, WritesTraceAndTelemetry) {
  Mission m;
  const std::string telemetry = m.dir.file("telemetry.jsonl");
  ASSERT_TRUE(m.start(visnav::test::fixture_config("{}", "{}", "{telemetry_file: " + telemetry + "}")));
  RunOptions o;
  o.trace_file = m.dir.file("trace.jsonl");
  const RunReport r = m.run(o);
  ASSERT_EQ(r.outcome, RunOutcome::success);
  const std::string trace = visnav::test::read_file(o.trace_file);
  EXPECT_TRUE(contains(trace, "FixtureDrive")) << trace;
  EXPECT_TRUE(contains(trace, "RUNNING")) << trace;
  const std::string tel = visnav::test::read_file(telemetry);
  EXPECT_TRUE(contains(tel, "\"status\":\"driving\"")) << tel;
  EXPECT_TRUE(contains(tel, "\"linear_mps\":0.5000")) << tel;
  // One line per tick: nodes published while driving, the runtime filled in the others.
  EXPECT_EQ(static_cast<std::uint64_t>(std::count(tel.begin(), tel.end(), '\n')), r.ticks);
}

TEST(Run, AnAddedTelemetrySinkGetsOneStatusPerTickAndNoneAfterRemoval) {
  // The live view and a recording are sinks added beside the config's (here: none). Each tick
  // gives one status: the node's own while it publishes, else the runtime's.
  struct Counter final : Telemetry {
    std::uint64_t count = 0;
    void publish(const NavStatus&) override { ++count; }
  } counter;
  Mission m;
  ASSERT_TRUE(m.start(visnav::test::fixture_config()));
  EXPECT_EQ(m.session->host().telemetry(), nullptr);  // nobody listens: primitives build no status
  m.session->add_telemetry_sink(&counter);
  EXPECT_NE(m.session->host().telemetry(), nullptr);
  const RunReport r = m.run();
  ASSERT_EQ(r.outcome, RunOutcome::success) << r.reason;
  EXPECT_EQ(counter.count, r.ticks);
  m.session->remove_telemetry_sink(&counter);
  EXPECT_EQ(m.session->host().telemetry(), nullptr);
}

TEST(Run, RealTimeFixedRateMode) {
  Mission m;
  ASSERT_TRUE(m.start(visnav::test::fixture_config("{simulated: false}", "{frame_period_s: 0.01}",
                                                   "{tick: rate, rate_hz: 50}"),
                      visnav::test::drive_tree(0.1, 1.0)));
  EXPECT_FALSE(m.session->lockstep());
  const RunReport r = m.run();
  EXPECT_EQ(r.outcome, RunOutcome::success) << r.reason;
  EXPECT_GE(r.wall_time_s, 0.08);  // 0.1 m at 1 m/s in real time
  EXPECT_LT(r.wall_time_s, 2.0);
  EXPECT_GE(r.ticks, 5u);
}

TEST(Run, RealTimePerFrameMode) {
  Mission m;
  ASSERT_TRUE(m.start(visnav::test::fixture_config("{simulated: false}", "{frame_period_s: 0.02}", "{tick: frame}"),
                      visnav::test::drive_tree(0.1, 1.0)));
  const RunReport r = m.run();
  EXPECT_EQ(r.outcome, RunOutcome::success) << r.reason;
  // One tick per frame: about 0.1 s / 0.02 s, never more than the frames produced.
  EXPECT_GE(r.ticks, 4u);
  EXPECT_LE(r.ticks, static_cast<std::uint64_t>(r.wall_time_s / 0.02) + 2);
}

TEST(Run, OverrunsAreDetected) {
  Mission m;
  ASSERT_TRUE(m.start(visnav::test::fixture_config("{}", "{width_px: 2048, height_px: 2048, square_px: 6}", "{rate_hz: 1000}",
                                                   "grid_hamming", "{cell_px: 4}"),
                      R"(<root BTCPP_format="4"><BehaviorTree ID="Main"><FixtureDetect/></BehaviorTree></root>)"));
  const RunReport r = m.run();
  EXPECT_EQ(r.outcome, RunOutcome::success) << r.reason;
  EXPECT_EQ(r.ticks, 1u);
  EXPECT_EQ(r.overruns, 1u);  // detecting 2048x2048 in 4 px cells takes longer than 1 ms
}

TEST(Run, LockstepOnNeedsASimulatedRobot) {
  TempDir dir;
  CaptureLogger log;
  auto s = visnav::test::fixture_session(
      dir.write("c.yaml", visnav::test::fixture_config("{simulated: false}", "{}", "{lockstep: on}")), &log);
  ASSERT_FALSE(s);
  EXPECT_TRUE(fails_with(s, ErrorCode::inconsistent, At{"c.yaml", 0, "run.lockstep"}));
}

TEST(Run, UnknownPluginTypeNamesSectionAndLocation) {
  TempDir dir;
  CaptureLogger log;
  auto s = visnav::test::fixture_session(dir.write("c.yaml", "robot: {type: fixture}\ncamera: {type: lidar}\n"), &log);
  ASSERT_FALSE(s);
  EXPECT_TRUE(fails_with(s, ErrorCode::not_found, At{"c.yaml", 2, "camera.type"}));
}

TEST(Run, PluginParamErrorNamesFileAndLine) {
  TempDir dir;
  CaptureLogger log;
  auto s = visnav::test::fixture_session(
      dir.write("c.yaml", "robot: {type: fixture}\ncamera:\n  type: fixture\n  params:\n    width_px: 5\n"), &log);
  ASSERT_FALSE(s);
  EXPECT_TRUE(fails_with(s, ErrorCode::out_of_range, At{"c.yaml", 5, "camera.params.width_px"}));
}

TEST(Run, NodesSelectionLoadsOnlyTheNamedPlugins) {
  {
    Mission m;
    ASSERT_TRUE(m.start(visnav::test::fixture_config() + "nodes: [fixture_nodes]\n"));
    EXPECT_NE(m.session->registry().find("FixtureDrive"), nullptr);
  }
  {
    Mission m;
    ASSERT_TRUE(m.start(visnav::test::fixture_config() + "nodes: []\n"));
    EXPECT_EQ(m.session->registry().find("FixtureDrive"), nullptr);
    EXPECT_NE(m.session->registry().find("Sequence"), nullptr);
  }
  TempDir dir;
  CaptureLogger log;
  auto s = visnav::test::fixture_session(dir.write("c.yaml", visnav::test::fixture_config() + "nodes: [nodes_missing]\n"), &log);
  ASSERT_FALSE(s);
  EXPECT_TRUE(fails_with(s, ErrorCode::not_found, key_only("nodes")));
  // Content: the places searched are listed, so a user can see why.
  EXPECT_TRUE(contains(s.error().message, "not found; tried:")) << s.error().message;
}

TEST(Run, MapOptionOpensOrCreatesTheMap) {
  TempDir dir;
  CaptureLogger log;
  auto config = load_run_config(dir.write("c.yaml", visnav::test::fixture_config()));
  ASSERT_TRUE(config);
  SessionOptions o = visnav::test::fixture_options(&log);
  o.map_path = dir.file("new_map");
  auto s = Session::create(std::move(config).value(), o);
  ASSERT_TRUE(s) << s.error().message;
  ASSERT_NE((*s)->map(), nullptr);
  EXPECT_EQ((*s)->host().map(), (*s)->map());
  EXPECT_TRUE(std::filesystem::exists(dir.file("new_map")));
}

TEST(Run, ANodeThrowingStopsTheRobot) {
  Mission m;
  ASSERT_TRUE(m.start(visnav::test::fixture_config(), R"(<root BTCPP_format="4"><BehaviorTree ID="Main">
<Parallel success_count="2" failure_count="1">
  <FixtureDrive distance_m="100"/>
  <Sequence><FixtureHasFrame/><FixtureThrow/></Sequence>
</Parallel></BehaviorTree></root>)"));
  const RunReport r = m.run();
  EXPECT_EQ(r.outcome, RunOutcome::error);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_TRUE(contains(r.reason, "a node threw during tick 1: ")) << r.reason;
  EXPECT_TRUE(contains(r.reason, "fixture node exploded")) << r.reason;
  EXPECT_EQ(m.session->robot().last_command().linear_mps, 0.0);
  // FixtureDrive was RUNNING and got halted before the run ended.
  EXPECT_GE(m.log.index_of("halted"), 0) << m.log.all();
  EXPECT_LT(m.log.index_of("halted"), m.log.index_of("run ended")) << m.log.all();
}

TEST(Run, ASessionCanRunSeveralTrees) {
  Mission m;
  ASSERT_TRUE(m.start(visnav::test::fixture_config(), visnav::test::drive_tree(0.5)));
  const RunReport first = m.run();
  ASSERT_EQ(first.outcome, RunOutcome::success) << first.reason;
  const double after_first = m.session->robot().latest_odometry()->distance_m;
  const RunReport second = m.run();
  ASSERT_EQ(second.outcome, RunOutcome::success) << second.reason;
  EXPECT_NEAR(m.session->robot().latest_odometry()->distance_m - after_first, 0.5, 0.06);
}

TEST(GuardedRobot, RecordsCommandsAndRefusesMotionOnceLatched) {
  TempDir dir;
  CaptureLogger log;
  auto s = visnav::test::fixture_session(dir.write("c.yaml", visnav::test::fixture_config()), &log);
  ASSERT_TRUE(s) << s.error().message;
  GuardedRobot& robot = (*s)->robot();
  ASSERT_TRUE(robot.send_command({0.4, 0.1}));
  EXPECT_EQ(robot.last_command().linear_mps, 0.4);
  robot.latch("test");
  auto refused = robot.send_command({0.4, 0.0});
  ASSERT_FALSE(refused);
  EXPECT_TRUE(contains(refused.error().message, "robot stopped by the runtime (test)"));  // content: the stop's reason
  EXPECT_EQ(robot.last_command().linear_mps, 0.0);
  EXPECT_TRUE(robot.send_command({}));  // zero is always allowed
  robot.unlatch();
  EXPECT_TRUE(robot.send_command({0.4, 0.0}));
}
