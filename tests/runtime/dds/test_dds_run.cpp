// DDS telemetry and mission control wired into the run loop (the `dds:` config block):
// `run_tree` on the simulated fixture robot publishes every NavStatus on DDS (and into the
// JSON-lines file), and obeys pause / resume / abort / swap_detector from the control topic.
// Loopback only, a random domain id and a unique partition per test.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <thread>

#include "dds_test_util.hpp"
#include "error_expect.hpp"
#include "run_test_util.hpp"
#include "visnav/dds.hpp"
#include "visnav/runner.hpp"

namespace dds = visnav::dds;
using dds::testing::eventually;
using visnav::test::CaptureLogger;
using visnav::test::contains;
using visnav::test::TempDir;
using namespace visnav;

namespace {

/// Endpoints of one test: loopback, random domain, unique partition.
dds::TelemetryParams test_endpoints() {
  dds::testing::use_loopback();
  dds::TelemetryParams p;
  p.domain_id = dds::testing::random_domain_id();
  p.partition = dds::testing::unique_partition("visnav_run");
  return p;
}

std::string dds_block(const dds::TelemetryParams& p, const std::string& extra = "") {
  return "dds:\n  domain_id: " + std::to_string(p.domain_id) + "\n  partition: " + p.partition + "\n" + extra;
}

/// Collects telemetry samples on its own thread.
class TelemetryCollector {
 public:
  explicit TelemetryCollector(const dds::TelemetryParams& p) {
    auto participant = dds::Participant::create(p.domain_id);
    EXPECT_TRUE(participant.ok()) << participant.error().message;
    if (!participant) return;
    dds::Qos qos = dds::Qos::ros_default();
    qos.history_depth = 0;  // keep-all: the lock-step runs publish fast
    auto sub = dds::Subscription<dds::msg::Telemetry>::create(
        *participant, {p.telemetry_topic, qos, p.partition}, [this](dds::msg::Telemetry&& t, const dds::SampleInfo&) {
          std::lock_guard lock(mutex_);
          samples_.push_back(std::move(t));
        });
    EXPECT_TRUE(sub.ok()) << sub.error().message;
    if (sub) sub_ = std::move(*sub);
  }
  [[nodiscard]] std::vector<dds::msg::Telemetry> samples() {
    std::lock_guard lock(mutex_);
    return samples_;
  }
  [[nodiscard]] std::size_t count(const std::string& status) {
    std::lock_guard lock(mutex_);
    std::size_t n = 0;
    for (const auto& s : samples_) n += s.status == status ? 1 : 0;
    return n;
  }
  [[nodiscard]] std::size_t size() {
    std::lock_guard lock(mutex_);
    return samples_.size();
  }

 private:
  std::mutex mutex_;
  std::vector<dds::msg::Telemetry> samples_;
  std::unique_ptr<dds::Subscription<dds::msg::Telemetry>> sub_;
};

struct DdsMission {
  TempDir dir;
  CaptureLogger log;
  dds::TelemetryParams endpoints = test_endpoints();
  std::unique_ptr<Session> session;
  std::atomic<int> no_signal{0};

  bool start(const std::string& config, const std::string& tree_xml) {
    session = visnav::test::start_fixture_session(dir, config, tree_xml, &log);
    return session != nullptr;
  }
  /// Fixture robot/camera/detector + the dds block of this test's endpoints.
  bool start_default(const std::string& tree_xml, const std::string& run = "{}", const std::string& dds_extra = "") {
    return start(visnav::test::fixture_config("{}", "{}", run) + dds_block(endpoints, dds_extra), tree_xml);
  }
  RunReport run(RunOptions options = {}) {
    if (options.stop_requested == nullptr) options.stop_requested = &no_signal;
    return visnav::test::run_tree_file(*session, dir.file("tree.xml"), options);
  }
  std::unique_ptr<dds::ControlPublisher> publisher() {
    auto p = dds::ControlPublisher::create(endpoints);
    EXPECT_TRUE(p.ok()) << p.error().message;
    if (!p) return nullptr;
    EXPECT_TRUE((*p)->wait_for_subscribers(1, 10.0)) << "the session's control subscriber was not matched";
    return std::move(*p);
  }
};

// --- config --------------------------------------------------------------------------------

Result<RunConfig> parse(const std::string& yaml) {
  VISNAV_ASSIGN(ConfigNode root, parse_yaml_string(yaml, "c.yaml"));
  return parse_run_config(root, "c.yaml");
}

TEST(DdsRunConfig, BlockIsParsedWithDefaults) {
  const std::string base = "robot: {type: sim}\ncamera: {type: sim}\n";
  auto none = parse(base);
  ASSERT_TRUE(none.ok()) << none.error().message;
  EXPECT_FALSE(none->dds.enabled);

  auto empty = parse(base + "dds:\n");
  ASSERT_TRUE(empty.ok()) << empty.error().message;
  EXPECT_TRUE(empty->dds.enabled);
  EXPECT_TRUE(empty->dds.telemetry);
  EXPECT_TRUE(empty->dds.control);
  EXPECT_EQ(empty->dds.endpoints.domain_id, 0);
  EXPECT_EQ(empty->dds.endpoints.telemetry_topic, "rt/visnav/telemetry");
  EXPECT_EQ(empty->dds.endpoints.control_topic, "rt/visnav/control");

  auto full = parse(base +
                    "dds:\n  domain_id: 42\n  partition: robot7\n  telemetry_topic: rt/a\n  control_topic: rt/b\n"
                    "  control: false\n");
  ASSERT_TRUE(full.ok()) << full.error().message;
  EXPECT_TRUE(full->dds.enabled);
  EXPECT_FALSE(full->dds.control);
  EXPECT_EQ(full->dds.endpoints.domain_id, 42);
  EXPECT_EQ(full->dds.endpoints.partition, "robot7");
  EXPECT_EQ(full->dds.endpoints.telemetry_topic, "rt/a");
  EXPECT_EQ(full->dds.endpoints.control_topic, "rt/b");

  auto off = parse(base + "dds: {enabled: false, domain_id: 3}\n");
  ASSERT_TRUE(off.ok()) << off.error().message;
  EXPECT_FALSE(off->dds.enabled);
}

TEST(DdsRunConfig, ErrorsNameFileLineAndKey) {
  using visnav::test::At;
  using visnav::test::fails_with;
  const std::string base = "robot: {type: sim}\ncamera: {type: sim}\n";
  EXPECT_TRUE(fails_with(parse(base + "dds:\n  domain_id: 1\n  domian: 2\n"), ErrorCode::unknown_key,
                         At{"c.yaml", 5, "dds.domian"}));
  EXPECT_TRUE(fails_with(parse(base + "dds:\n  domain_id: 300\n"), ErrorCode::out_of_range,
                         At{"c.yaml", 4, "dds.domain_id"}));
  EXPECT_TRUE(fails_with(parse(base + "dds:\n  enabled: maybe\n"), ErrorCode::invalid_value,
                         At{"c.yaml", 4, "dds.enabled"}));
  // Two topics fine alone, equal together: the second one is where the clash is seen.
  EXPECT_TRUE(fails_with(parse(base + "dds:\n  telemetry_topic: rt/x\n  control_topic: rt/x\n"),
                         ErrorCode::inconsistent, At{"c.yaml", 5, "dds.control_topic"}));
  EXPECT_TRUE(fails_with(parse(base + "dds: 5\n"), ErrorCode::invalid_value, At{"c.yaml", 3, "dds"}));
}

TEST(DdsRunConfig, ChangingTheBlockWhileRunningNeedsARestart) {
  DdsMission m;
  ASSERT_TRUE(m.start_default(visnav::test::drive_tree(1.0)));
  ASSERT_NE(m.session->dds_telemetry(), nullptr);
  ASSERT_NE(m.session->control(), nullptr);
  m.dir.write("c.yaml", visnav::test::fixture_config() + dds_block(m.endpoints, "  control: false\n"));
  auto reloaded = m.session->reload_config();
  ASSERT_FALSE(reloaded.ok());
  EXPECT_TRUE(visnav::test::fails_with(reloaded, ErrorCode::inconsistent, visnav::test::At{"c.yaml", 0, "dds"}));
  EXPECT_TRUE(m.session->config().dds.control);
}

// --- telemetry -----------------------------------------------------------------------------

TEST(DdsRun, EveryTickIsPublishedOnDdsAndInTheTelemetryFile) {
  DdsMission m;
  const std::string jsonl = m.dir.file("telemetry.jsonl");
  ASSERT_TRUE(m.start_default(visnav::test::drive_tree(1.0), "{telemetry_file: " + jsonl + "}", "  control: false\n"));
  ASSERT_NE(m.session->dds_telemetry(), nullptr);
  EXPECT_EQ(m.session->control(), nullptr);
  TelemetryCollector collector(m.endpoints);
  ASSERT_TRUE(eventually([&] { return m.session->dds_telemetry()->matched_readers() == 1; }, 10.0));

  const RunReport r = m.run();
  ASSERT_EQ(r.outcome, RunOutcome::success) << r.reason;
  const std::uint64_t published = m.session->telemetry_published();
  EXPECT_GE(published, r.ticks);  // one per tick at least (FixtureDrive publishes its own)
  EXPECT_EQ(m.session->dds_telemetry()->published(), published);
  ASSERT_TRUE(eventually([&] { return collector.size() >= published; }, 10.0))
      << collector.size() << " of " << published << " samples received";
  const auto samples = collector.samples();
  ASSERT_EQ(samples.size(), published);
  std::size_t driving = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    EXPECT_EQ(samples[i].sequence_number, i + 1);
    if (samples[i].status == "driving") {
      ++driving;
      EXPECT_DOUBLE_EQ(samples[i].linear_mps, 0.5);
      EXPECT_TRUE(contains(samples[i].node_path, "FixtureDrive")) << samples[i].node_path;
    }
  }
  EXPECT_GE(driving, 18u);  // 1 m at 0.5 m/s in 0.1 s steps
  EXPECT_EQ(samples.back().status, "SUCCESS");  // the runtime's line for the final tick
  EXPECT_GT(samples.back().header.stamp.sec, 1600000000);  // wall time, like ROS 2

  // The same statuses went to the JSON-lines file (fan-out).
  const std::string text = visnav::test::read_file(jsonl);
  EXPECT_EQ(static_cast<std::uint64_t>(std::count(text.begin(), text.end(), '\n')), published);
  EXPECT_TRUE(contains(text, "\"status\":\"driving\"")) << text;
}

// --- mission control -----------------------------------------------------------------------

TEST(DdsRun, PauseStopsTheRobotAndResumeContinuesWithoutHaltingTheTree) {
  DdsMission m;
  ASSERT_TRUE(m.start_default(visnav::test::drive_tree(3.0)));
  TelemetryCollector collector(m.endpoints);
  auto control = m.publisher();
  ASSERT_NE(control, nullptr);
  ASSERT_TRUE(eventually([&] { return m.session->dds_telemetry()->matched_readers() == 1; }, 10.0));

  // Once the run is paused (seen in the telemetry), wait for a few paused iterations, then resume.
  std::atomic<bool> resumed{false};
  std::thread operator_thread([&] {
    if (!eventually([&] { return collector.count("paused") >= 4; }, 20.0)) return;
    (void)control->send(dds::msg::ControlCommand::resume);
    resumed = true;
  });

  struct TickRecord {
    double t_s;
    double distance_m;
    double linear_mps;
  };
  std::vector<TickRecord> ticks;
  bool sent = false;
  RunOptions o;
  o.after_tick = [&](const TickInfo& t) {
    auto odo = m.session->robot().latest_odometry();
    ticks.push_back({t.t_s, odo ? odo->distance_m : -1.0, odo ? odo->twist.linear_mps : -1.0});
    if (t.tick == 5 && !sent) {
      sent = true;
      EXPECT_TRUE(control->send(dds::msg::ControlCommand::pause).ok());
    }
    // A lock-step run of this short tree can end before a loaded machine delivers the DDS sample:
    // until the pause shows in the telemetry, give delivery up to 50 ms per tick (2 s in all).
    if (sent && t.tick < 45 && collector.count("paused") == 0)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    return true;
  };
  const RunReport r = m.run(o);
  operator_thread.join();
  ASSERT_TRUE(resumed.load()) << "the run never reported 'paused' on the telemetry topic\n" << m.log.all();
  EXPECT_EQ(r.outcome, RunOutcome::success) << r.reason << "\n" << m.log.all();
  EXPECT_EQ(r.pauses, 1u);
  EXPECT_EQ(r.control_applied, 2u);
  EXPECT_EQ(r.control_rejected, 0u);
  EXPECT_GE(r.paused_s, 0.3);  // >= 4 paused iterations of 0.1 s (paced in real time)
  EXPECT_TRUE(m.log.saw("paused by the control topic")) << m.log.all();
  EXPECT_TRUE(m.log.saw("resumed by the control topic")) << m.log.all();
  EXPECT_FALSE(m.log.saw("halted")) << "pause must not halt the tree\n" << m.log.all();

  // The pause is the one gap in the tick times; the robot did not move during it.
  std::size_t gap = 0;
  for (std::size_t i = 1; i < ticks.size(); ++i)
    if (ticks[i].t_s - ticks[i - 1].t_s > 0.25) {
      EXPECT_EQ(gap, 0u) << "more than one gap";
      gap = i;
    }
  ASSERT_GT(gap, 0u) << "no pause visible in the tick times";
  const double pause_s = ticks[gap].t_s - ticks[gap - 1].t_s;
  const double moved_m = ticks[gap].distance_m - ticks[gap - 1].distance_m;
  std::printf("[ measured ] paused %.2f s (run clock); the robot moved %.3f m meanwhile (0.5 m/s without the pause: %.2f m)\n",
              pause_s, moved_m, 0.5 * pause_s);
  EXPECT_LE(moved_m, 0.051) << "at most the one step before the pause took effect";
  EXPECT_DOUBLE_EQ(ticks[gap].linear_mps, 0.0) << "the robot stood still when the run resumed";
  // Paused telemetry carries a zero command.
  for (const auto& s : collector.samples())
    if (s.status == "paused") {
      EXPECT_EQ(s.linear_mps, 0.0);
      EXPECT_EQ(s.angular_radps, 0.0);
    }
  // ... and afterwards the drive continued to its end.
  auto odo = m.session->robot().latest_odometry();
  ASSERT_TRUE(odo);
  EXPECT_GE(odo->distance_m, 3.0);
  EXPECT_LT(odo->distance_m, 3.2);
}

TEST(DdsRun, AbortHaltsTheTreeAndStopsTheRobot) {
  DdsMission m;
  ASSERT_TRUE(m.start_default(visnav::test::drive_tree(1000.0)));
  auto control = m.publisher();
  ASSERT_NE(control, nullptr);
  std::uint64_t sent_at = 0;
  RunOptions o;
  o.after_tick = [&](const TickInfo& t) {
    if (t.tick == 3) {
      sent_at = t.tick;
      EXPECT_TRUE(control->send(dds::msg::ControlCommand::abort).ok());
      std::this_thread::sleep_for(std::chrono::milliseconds(200));  // delivered before the next tick
    }
    return true;
  };
  const RunReport r = m.run(o);
  EXPECT_EQ(r.outcome, RunOutcome::interrupted) << r.reason;
  EXPECT_EQ(r.exit_code, 130);
  EXPECT_EQ(r.reason, "aborted by control topic");
  EXPECT_EQ(r.control_applied, 1u);
  EXPECT_EQ(sent_at, 3u);
  EXPECT_LE(r.ticks, 4u);
  EXPECT_TRUE(m.log.saw("halted")) << m.log.all();  // FixtureDrive's halt callback ran
  EXPECT_EQ(m.session->robot().last_command().linear_mps, 0.0);
  EXPECT_FALSE(m.session->robot().latched());  // not a safety stop
}

TEST(DdsRun, SwapDetectorReplacesTheActiveDetectorBetweenTicks) {
  DdsMission m;
  ASSERT_TRUE(m.start_default(visnav::test::drive_tree(1000.0)));
  ASSERT_NE(m.session->detector(), nullptr);
  EXPECT_EQ(m.session->detector()->norm(), DescriptorNorm::hamming);
  auto control = m.publisher();
  ASSERT_NE(control, nullptr);
  std::uint64_t swapped_at = 0;
  RunOptions o;
  o.after_tick = [&](const TickInfo& t) {
    if (t.tick == 3) {
      EXPECT_TRUE(control->send(dds::msg::ControlCommand::swap_detector, "grid_l2").ok());
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
    if (m.session->detector()->norm() == DescriptorNorm::l2) {
      swapped_at = t.tick;
      return false;
    }
    return t.tick < 200;
  };
  const RunReport r = m.run(o);
  EXPECT_EQ(r.outcome, RunOutcome::stopped) << r.reason;
  EXPECT_EQ(swapped_at, 4u);
  ASSERT_TRUE(m.session->config().detector.has_value());
  EXPECT_EQ(m.session->config().detector->type, "grid_l2");
  EXPECT_EQ(m.session->host().active_detector(), m.session->detector());
  EXPECT_EQ(r.control_applied, 1u);
  EXPECT_EQ(r.control_rejected, 0u);
  EXPECT_TRUE(m.log.saw("active detector is now 'grid_l2'")) << m.log.all();
}

TEST(DdsRun, BadControlRequestsAreRejectedAndCounted) {
  DdsMission m;
  ASSERT_TRUE(m.start_default(visnav::test::drive_tree(1000.0)));
  Detector* before = m.session->detector();
  // One raw writer, so the four requests arrive in order: unknown code, swap without a type,
  // swap to a type no plugin provides, abort.
  auto participant = dds::Participant::create(m.endpoints.domain_id);
  ASSERT_TRUE(participant.ok());
  auto writer = dds::Writer<dds::msg::Control>::create(
      *participant, {m.endpoints.control_topic, dds::Qos{dds::Reliability::reliable, dds::Durability::volatile_data, 32, 0.0},
                     m.endpoints.partition});
  ASSERT_TRUE(writer.ok()) << writer.error().message;
  ASSERT_TRUE(writer->wait_for_readers(1, 10.0));
  auto send = [&](std::uint8_t code, const std::string& argument) {
    dds::msg::Control c;
    c.command = code;
    c.argument = argument;
    EXPECT_TRUE(writer->write(c).ok());
  };
  RunOptions o;
  o.after_tick = [&](const TickInfo& t) {
    if (t.tick == 3) {
      send(9, "");
      send(4, "");
      send(4, "no_such_detector");
      send(3, "");
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
    }
    return true;
  };
  const RunReport r = m.run(o);
  EXPECT_EQ(r.outcome, RunOutcome::interrupted) << r.reason;
  EXPECT_EQ(r.reason, "aborted by control topic");
  EXPECT_EQ(r.control_rejected, 3u) << m.log.all();
  EXPECT_EQ(r.control_applied, 1u);
  EXPECT_EQ(m.session->control()->rejected(), 2u);  // the two malformed ones, dropped by the subscriber
  EXPECT_EQ(m.session->detector(), before) << "the old detector is kept";
  EXPECT_EQ(m.session->config().detector->type, "grid_hamming");
  EXPECT_TRUE(m.log.saw("unknown command code 9")) << m.log.all();
  // (the second malformed request is only counted: warnings are limited to one per second)
  EXPECT_TRUE(m.log.saw("swap_detector rejected, keeping detector 'grid_hamming'")) << m.log.all();
  EXPECT_TRUE(m.log.saw("no_such_detector")) << m.log.all();
}

TEST(DdsRun, StaleDataWhilePausedHoldsInsteadOfStopping) {
  // Odometry freezes at 1.0 s (run clock); paused before that, the run neither ticks nor
  // safety-stops while paused; after the resume the data is still stale, so once
  // startup_timeout_s has passed since the resume the run ends with a safety stop.
  DdsMission m;
  ASSERT_TRUE(m.start(visnav::test::fixture_config("{odometry_freeze_after_s: 1.0}", "{}",
                                                   "{max_odometry_age_s: 0.3, startup_timeout_s: 0.5}") +
                          dds_block(m.endpoints),
                      visnav::test::drive_tree(1000.0)));
  TelemetryCollector collector(m.endpoints);
  auto control = m.publisher();
  ASSERT_NE(control, nullptr);
  ASSERT_TRUE(eventually([&] { return m.session->dds_telemetry()->matched_readers() == 1; }, 10.0));
  std::thread operator_thread([&] {
    // Paused for ~1.5 s of run time: well past the freeze + max_odometry_age_s.
    if (!eventually([&] { return collector.count("paused") >= 15; }, 20.0)) return;
    (void)control->send(dds::msg::ControlCommand::resume);
  });
  RunOptions o;
  o.after_tick = [&](const TickInfo& t) {
    if (t.tick == 3) {
      EXPECT_TRUE(control->send(dds::msg::ControlCommand::pause).ok());
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
    return true;
  };
  const RunReport r = m.run(o);
  operator_thread.join();
  EXPECT_EQ(r.outcome, RunOutcome::safety_stop) << r.reason << "\n" << m.log.all();
  EXPECT_TRUE(contains(r.reason, "stale odometry")) << r.reason;
  EXPECT_EQ(r.ticks, 3u) << "no tick while paused or while holding after the resume";
  EXPECT_EQ(r.pauses, 1u);
  EXPECT_GE(r.paused_s, 1.4);
  EXPECT_TRUE(m.log.saw("stale odometry")) << m.log.all();
  EXPECT_TRUE(m.log.saw("while paused")) << m.log.all();
  EXPECT_EQ(m.session->robot().last_command().linear_mps, 0.0);
}

}  // namespace
