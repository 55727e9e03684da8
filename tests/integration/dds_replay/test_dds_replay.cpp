// Issue 7 "must show", end to end on loopback: a route taught in the simulator is replayed by
// `visnav run` (robot `dds`, camera `dds`, ReplayFeatureEdge) driving `visnav simd` (the
// simulated robot and camera as their own process) over Cyclone DDS.
//
//  * Teach (once per binary, in this process): ScriptedOperator + TeachRoute + TeachFeatureEdge
//    (style segment, ORB, 320×240) drive 3 m along the gravel path of config/worlds/straight6m
//    in lock-step; the taught end is the simulator's ground truth when the teach run ends.
//  * Replay: simd and `visnav run` as two processes, real time (tick: rate, 10 Hz, lenient
//    staleness limits for a loaded machine). Mid-route the test pauses the mission over the
//    control topic (the robot must stand still), resumes it, and the run must exit 0 (tree
//    SUCCESS = route replayed to the end). simd's ground truth (rt/visnav/sim/ground_truth)
//    must end near the taught end; the run's telemetry must arrive on DDS.
//  * Kill: SIGKILL of `visnav run` during the replay stops the robot in simd within 300 ms
//    (simd's cmd_vel watchdog; measured with an odometry subscriber here).
//
// CYCLONEDDS_URI = loopback_config_xml() (inherited by the children), a random domain id and a
// unique partition per test, so parallel ctest runs do not interfere.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <thread>

#include "child_process.hpp"
#include "dds_test_util.hpp"
#include "visnav/dds.hpp"
#include "visnav/map.hpp"
#include "visnav/runner.hpp"

namespace dds = visnav::dds;
namespace fs = std::filesystem;
using dds::testing::ChildProcess;
using dds::testing::eventually;
using dds::testing::slurp;
using SteadyClock = std::chrono::steady_clock;

namespace {

const std::string kSource = VISNAV_TEST_SOURCE_DIR;
constexpr const char* kCamera = "{width_px: 320, height_px: 240, hfov_deg: 60}";
constexpr double kTaughtLength_m = 3.0;

/// The route taught once for the whole binary.
struct Taught {
  fs::path dir;
  std::string map;
  std::string goal_node;
  std::string edge_id;
  visnav::Pose2D end;  ///< ground truth when the teach run ended
  double teach_wall_s = 0.0;
  std::string error;   ///< non-empty when teaching failed
};

Taught& taught() {
  static Taught t;
  return t;
}

void teach_once() {
  Taught& t = taught();
  t.dir = fs::path(VISNAV_TEST_BINARY_DIR) / "tests" / "integration" / "dds_replay" / ("taught_" + std::to_string(::getpid()));
  fs::remove_all(t.dir);
  fs::create_directories(t.dir);
  t.map = (t.dir / "map").string();
  std::ofstream(t.dir / "teach.yaml") << "robot: {type: sim, params: {world: straight6m}}\n"
                                      << "camera: {type: sim, params: " << kCamera << "}\n"
                                      << "detector: {type: orb, params: {target_keypoints: 300}}\n"
                                      << "nodes: [feature_replay, navigation, sim_operator, relocalisation]\n"
                                      << "run: {tick: frame, rate_hz: 10, lockstep: on, log_level: warn, reload_poll_s: 0}\n";
  std::ofstream(t.dir / "route.yaml") << "route:\n  name: straight3m\n  world: straight6m\n  start: [0, 0, 0]\n"
                                      << "  waypoints:\n    - {at: [0, 0], kind: feature}\n    - {at: ["
                                      << kTaughtLength_m << ", 0]}\n";
  auto config = visnav::load_run_config((t.dir / "teach.yaml").string());
  if (!config) {
    t.error = config.error().message;
    return;
  }
  visnav::SessionOptions options;
  options.use_default_plugin_path = false;
  options.extra_plugin_dirs = {VISNAV_TEST_PLUGIN_DIR};
  options.map_path = t.map;
  auto session = visnav::Session::create(std::move(*config), options);
  if (!session) {
    t.error = session.error().message;
    return;
  }
  {
    auto tree = (*session)->load_tree(kSource + "/trees/teach_feature_edge.xml");
    if (!tree) {
      t.error = tree.error().message;
      return;
    }
    tree->blackboard().set("route_file", (t.dir / "route.yaml").string());
    tree->blackboard().set("style", std::string("segment"));
    tree->blackboard().set("force_kind", std::string("feature_segment"));
    tree->blackboard().set("close_loop", false);
    std::atomic<int> no_signal{0};
    visnav::RunOptions run;
    run.stop_requested = &no_signal;
    const visnav::RunReport report = visnav::run_tree(**session, *tree, run);
    t.teach_wall_s = report.wall_time_s;
    if (report.outcome != visnav::RunOutcome::success) {
      t.error = std::string("teach run: ") + visnav::to_string(report.outcome) + ": " + report.reason;
      return;
    }
  }
  t.end = (*session)->robot().simulation()->ground_truth_pose();
  const visnav::MapStore& map = *(*session)->map();
  if (map.edges().size() != 1 || map.edges().front().kind != "feature_segment") {
    t.error = "expected one feature_segment edge, got " + std::to_string(map.edges().size());
    return;
  }
  t.goal_node = map.edges().front().to;
  t.edge_id = map.edges().front().id;
  std::printf("taught edge %s: start -> %s, %.2f m, ends at (%.3f, %.3f), %.1f s wall\n", t.edge_id.c_str(),
              t.goal_node.c_str(), map.edges().front().length_m, t.end.x_m, t.end.y_m, t.teach_wall_s);
}

struct PoseSample {
  SteadyClock::time_point received;
  double x_m = 0.0;
  double y_m = 0.0;
  double linear_mps = 0.0;
  double angular_radps = 0.0;
};

class DdsReplay : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { teach_once(); }
  static void TearDownTestSuite() {
    std::error_code ec;
    if (!::testing::UnitTest::GetInstance()->Failed()) fs::remove_all(taught().dir, ec);
  }

  void SetUp() override {
    ASSERT_TRUE(taught().error.empty()) << "teaching failed: " << taught().error;
    dds::testing::use_loopback();  // inherited by both children
    domain_ = dds::testing::random_domain_id();
    partition_ = dds::testing::unique_partition("visnav_e2e");
    dir_ = fs::path(VISNAV_TEST_BINARY_DIR) / "tests" / "integration" / "dds_replay" / partition_;
    fs::create_directories(dir_);
    // Each test replays its own copy of the map (a replay may write statistics).
    fs::copy(taught().map, dir_ / "map", fs::copy_options::recursive);
    const std::string ids = "domain_id: " + std::to_string(domain_) + ", partition: " + partition_;
    std::ofstream(dir_ / "replay.yaml")
        << "robot: {type: dds, params: {" << ids << "}}\n"
        << "camera: {type: dds, params: {" << ids << "}}\n"
        << "detector: {type: orb, params: {target_keypoints: 300}}\n"
        << "nodes: [feature_replay, navigation]\n"
        << "run: {tick: rate, rate_hz: 10, max_frame_age_s: 1.0, max_odometry_age_s: 1.0, startup_timeout_s: 20,"
        << " log_level: info, reload_poll_s: 0}\n"
        << "dds: {" << ids << "}\n";

    auto p = dds::Participant::create(domain_);
    ASSERT_TRUE(p.ok()) << p.error().message;
    participant_.emplace(*p);
    auto odom = dds::Subscription<dds::msg::Odometry>::create(
        *participant_, {"rt/odom", dds::Qos::ros_default(), partition_},
        [this](dds::msg::Odometry&& o, const dds::SampleInfo&) { store(odom_, o); });
    ASSERT_TRUE(odom.ok()) << odom.error().message;
    odom_sub_ = std::move(*odom);
    auto truth = dds::Subscription<dds::msg::Odometry>::create(
        *participant_, {"rt/visnav/sim/ground_truth", dds::Qos::sensor_data(), partition_},
        [this](dds::msg::Odometry&& o, const dds::SampleInfo&) { store(truth_, o); });
    ASSERT_TRUE(truth.ok()) << truth.error().message;
    truth_sub_ = std::move(*truth);
    dds::Qos keep_all = dds::Qos::ros_default();
    keep_all.history_depth = 0;
    auto telemetry = dds::Subscription<dds::msg::Telemetry>::create(
        *participant_, {"rt/visnav/telemetry", keep_all, partition_}, [this](dds::msg::Telemetry&& t, const dds::SampleInfo&) {
          std::lock_guard lock(mutex_);
          telemetry_.push_back(std::move(t));
        });
    ASSERT_TRUE(telemetry.ok()) << telemetry.error().message;
    telemetry_sub_ = std::move(*telemetry);
  }

  void TearDown() override {
    odom_sub_.reset();
    truth_sub_.reset();
    telemetry_sub_.reset();
    if (!HasFailure()) {  // keep the logs of failed runs
      std::error_code ec;
      fs::remove_all(dir_, ec);
    }
  }

  void store(std::vector<PoseSample>& into, const dds::msg::Odometry& o) {
    std::lock_guard lock(mutex_);
    into.push_back(PoseSample{SteadyClock::now(), o.pose.pose.position.x, o.pose.pose.position.y,
                              o.twist.twist.linear.x, o.twist.twist.angular.z});
  }
  std::optional<PoseSample> last(const std::vector<PoseSample>& of) {
    std::lock_guard lock(mutex_);
    if (of.empty()) return std::nullopt;
    return of.back();
  }
  std::vector<PoseSample> since(const std::vector<PoseSample>& of, SteadyClock::time_point t) {
    std::lock_guard lock(mutex_);
    std::vector<PoseSample> out;
    for (const auto& s : of)
      if (s.received >= t) out.push_back(s);
    return out;
  }
  std::vector<dds::msg::Telemetry> telemetry() {
    std::lock_guard lock(mutex_);
    return telemetry_;
  }
  std::string logs() { return "--- run.log\n" + slurp(dir_ / "run.log") + "--- simd.log\n" + slurp(dir_ / "simd.log"); }

  std::unique_ptr<ChildProcess> start_simd() {
    auto c = std::make_unique<ChildProcess>(
        std::vector<std::string>{VISNAV_TEST_CLI, "simd", "--world", "straight6m", "--domain", std::to_string(domain_),
                                 "--partition", partition_, "--duration", "120", "--camera-rate", "15",
                                 "--camera-param", "width_px=320", "--camera-param", "height_px=240",
                                 "--camera-param", "hfov_deg=60"},
        (dir_ / "simd.log").string());
    EXPECT_TRUE(c->started());
    EXPECT_TRUE(c->wait_for_output("simd: ready", 20.0)) << slurp(dir_ / "simd.log");
    return c;
  }
  std::unique_ptr<ChildProcess> start_replay() {
    auto c = std::make_unique<ChildProcess>(
        std::vector<std::string>{VISNAV_TEST_CLI, "run", "--config", (dir_ / "replay.yaml").string(), "--map",
                                 (dir_ / "map").string(), "--tree", kSource + "/trees/replay_feature_edge.xml",
                                 "--bb", "start=start", "--bb", "goal=" + taught().goal_node, "--bb", "loops=1",
                                 "--bb", "laps=1", "--bb", "speed_mps=0.5"},
        (dir_ / "run.log").string());
    EXPECT_TRUE(c->started());
    return c;
  }

  int domain_ = 0;
  std::string partition_;
  fs::path dir_;
  std::optional<dds::Participant> participant_;
  std::unique_ptr<dds::Subscription<dds::msg::Odometry>> odom_sub_;
  std::unique_ptr<dds::Subscription<dds::msg::Odometry>> truth_sub_;
  std::unique_ptr<dds::Subscription<dds::msg::Telemetry>> telemetry_sub_;
  std::mutex mutex_;
  std::vector<PoseSample> odom_;
  std::vector<PoseSample> truth_;
  std::vector<dds::msg::Telemetry> telemetry_;
};

TEST_F(DdsReplay, TwoProcessesReplayTheTaughtRouteToTheEndWithPauseAndResume) {
  const auto wall_start = SteadyClock::now();
  auto simd = start_simd();
  ASSERT_TRUE(eventually([&] { return last(truth_).has_value(); }, 10.0)) << "no ground truth from simd\n" << logs();
  const PoseSample start = *last(truth_);
  EXPECT_LT(std::hypot(start.x_m, start.y_m), 0.01) << "simd starts at the world's start";

  auto run = start_replay();
  auto control = dds::ControlPublisher::create(dds::TelemetryParams{domain_, partition_, "rt/visnav/telemetry",
                                                                    "rt/visnav/control"});
  ASSERT_TRUE(control.ok()) << control.error().message;

  // Pause a third of the way along: the robot in simd must come to a standstill and stay there.
  ASSERT_TRUE(eventually([&] {
    auto t = last(truth_);
    return (t && t->x_m > 1.0) || run->exited();
  }, 40.0)) << "the replay never got 1 m along the route\n" << logs();
  ASSERT_FALSE(run->exited()) << logs();
  ASSERT_TRUE((*control)->wait_for_subscribers(1, 5.0));
  ASSERT_TRUE((*control)->send(dds::msg::ControlCommand::pause).ok());
  const auto paused_at = SteadyClock::now();
  std::optional<double> standstill_ms;
  ASSERT_TRUE(eventually([&] {
    for (const auto& s : since(odom_, paused_at))
      if (std::fabs(s.linear_mps) < 1e-3 && std::fabs(s.angular_radps) < 1e-3) {
        standstill_ms = std::chrono::duration<double, std::milli>(s.received - paused_at).count();
        return true;
      }
    return false;
  }, 5.0)) << "the robot did not stop after the pause request\n" << logs();
  const PoseSample held = *last(truth_);
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  const PoseSample after_hold = *last(truth_);
  const double crept_m = std::hypot(after_hold.x_m - held.x_m, after_hold.y_m - held.y_m);
  EXPECT_LT(crept_m, 0.005) << "the robot moved while paused";
  EXPECT_FALSE(run->exited()) << "a pause must not end the run\n" << logs();
  std::size_t paused_samples = 0;
  for (const auto& t : telemetry()) paused_samples += t.status == "paused" ? 1 : 0;
  EXPECT_GE(paused_samples, 5u) << "the paused run reports its state";
  ASSERT_TRUE((*control)->send(dds::msg::ControlCommand::resume).ok());

  // Tree SUCCESS = the route was replayed to its end node.
  const int code = run->wait(60.0);
  const double wall_s = std::chrono::duration<double>(SteadyClock::now() - wall_start).count();
  ASSERT_EQ(code, 0) << logs();
  EXPECT_TRUE(run->wait_for_output("visnav run: success", 1.0)) << run->output();
  EXPECT_TRUE(run->wait_for_output("2 control requests applied, 0 rejected", 0.1)) << run->output();

  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // the robot settles (stop, watchdog)
  const PoseSample end = *last(truth_);
  EXPECT_LT(std::fabs(end.linear_mps), 1e-3) << "the robot stands at the end";
  const visnav::Pose2D& goal = taught().end;
  const double end_error_m = std::hypot(end.x_m - goal.x_m, end.y_m - goal.y_m);
  std::printf("[ measured ] replay over DDS ended at (%.3f, %.3f), taught end (%.3f, %.3f): end error %.3f m "
              "(along %.3f m, across %.3f m); paused robot at standstill %.0f ms after the request, crept %.4f m in 1 s; "
              "simd + run wall time %.1f s\n",
              end.x_m, end.y_m, goal.x_m, goal.y_m, end_error_m, end.x_m - goal.x_m, end.y_m - goal.y_m, *standstill_ms,
              crept_m, wall_s);
  RecordProperty("end_error_mm", static_cast<int>(std::lround(end_error_m * 1000.0)));
  EXPECT_LT(end_error_m, 0.25) << logs();

  // The run's telemetry reached this process over DDS: the replay of the taught edge with matches.
  const auto samples = telemetry();
  std::size_t replaying = 0;
  for (const auto& t : samples)
    if (t.edge == taught().edge_id && t.inliers > 0) ++replaying;
  EXPECT_GT(replaying, 20u) << samples.size() << " telemetry samples";

  simd->signal(SIGTERM);
  EXPECT_EQ(simd->wait(10.0), 0) << slurp(dir_ / "simd.log");
}

TEST_F(DdsReplay, RobotStopsWithin300msWhenTheReplayingRuntimeIsKilled) {
  auto simd = start_simd();
  ASSERT_TRUE(eventually([&] { return last(odom_).has_value(); }, 10.0)) << "no odometry from simd\n" << logs();
  auto run = start_replay();
  ASSERT_TRUE(eventually([&] {
    auto o = last(truth_);
    return (o && o->x_m > 0.8 && o->linear_mps > 0.3) || run->exited();
  }, 40.0)) << "the replay never got going\n" << logs();
  ASSERT_FALSE(run->exited()) << logs();

  run->signal(SIGKILL);
  const auto killed = SteadyClock::now();
  ASSERT_EQ(run->wait(5.0), 128 + SIGKILL);
  std::optional<double> stop_ms;
  ASSERT_TRUE(eventually([&] {
    for (const auto& s : since(odom_, killed))
      if (std::fabs(s.linear_mps) < 1e-3 && std::fabs(s.angular_radps) < 1e-3) {
        stop_ms = std::chrono::duration<double, std::milli>(s.received - killed).count();
        return true;
      }
    return false;
  }, 5.0)) << "the robot did not stop after the runtime was killed\n" << logs();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_LT(std::fabs(last(odom_)->linear_mps), 1e-3) << "stays stopped";
  std::printf("[ measured ] robot in simd stopped %.0f ms after SIGKILL of the replaying visnav run (limit 300 ms)\n",
              *stop_ms);
  RecordProperty("stop_after_kill_ms", static_cast<int>(std::lround(*stop_ms)));
  EXPECT_LT(*stop_ms, 300.0);
  EXPECT_NE(slurp(dir_ / "simd.log").find("watchdog: no cmd_vel"), std::string::npos);
  simd->signal(SIGTERM);
  EXPECT_EQ(simd->wait(10.0), 0) << slurp(dir_ / "simd.log");
}

}  // namespace
