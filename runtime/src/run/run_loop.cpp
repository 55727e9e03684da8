// The tick loop: lock-step / per-frame / fixed-rate ticking, safety checks, stop requests,
// mission control (pause / resume / abort / swap_detector from the DDS control topic).
#include <csignal>
#include <cstdio>
#include <exception>
#include <thread>
#include <vector>

#include "run/odometry_check.hpp"
#include "visnav/runner.hpp"

namespace visnav {

namespace {

std::atomic<int> g_signal{0};

extern "C" void visnav_on_signal(int signal_number) {
  if (g_signal.load() != 0) {
    // Second signal: the user insists; fall back to the default action.
    std::signal(signal_number, SIG_DFL);
    std::raise(signal_number);
    return;
  }
  g_signal.store(signal_number);
}

std::string fmt_s(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", v);
  return buf;
}

/// Path of the deepest RUNNING node (for the default telemetry line), or the root's path.
std::string active_path(const bt::Tree& tree) {
  std::string path = tree.root().path();
  tree.visit([&](bt::TreeNode& n) {
    if (n.status() == bt::NodeStatus::running) path = n.path();
  });
  return path;
}

}  // namespace

const char* to_string(RunOutcome outcome) {
  switch (outcome) {
    case RunOutcome::success: return "success";
    case RunOutcome::failure: return "failure";
    case RunOutcome::safety_stop: return "safety stop";
    case RunOutcome::interrupted: return "interrupted";
    case RunOutcome::stopped: return "stopped";
    case RunOutcome::error: return "error";
  }
  return "?";
}

std::atomic<int>& signal_flag() { return g_signal; }

void install_signal_handlers() {
  struct sigaction action {};
  action.sa_handler = &visnav_on_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = 0;  // no SA_RESTART: blocking waits return early
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

RunReport run_tree(Session& session, bt::Tree& tree, const RunOptions& options) {
  RunReport report;
  Logger& log = session.logger();
  GuardedRobot& robot = session.robot();
  Camera& camera = session.camera();
  FrameBus& bus = session.frame_bus();
  const Clock& clock = session.clock();
  const std::atomic<int>& stop = options.stop_requested != nullptr ? *options.stop_requested : signal_flag();
  const bool lockstep = session.lockstep();
  SimulationControl* sim = robot.simulation();
  WallClock wall;

  std::unique_ptr<bt::TraceWriter> trace;
  const std::string trace_file = options.trace_file.empty() ? session.config().run.trace_file : options.trace_file;
  if (!trace_file.empty()) {
    auto attached = bt::TraceWriter::attach(tree, trace_file);
    if (!attached) {
      report.outcome = RunOutcome::error;
      report.reason = attached.error().message;
      return report;
    }
    trace = std::move(attached).value();
  }

  // Remember the last leaf that failed, so a FAILURE outcome can say where.
  const bt::TreeNode* last_failed = nullptr;
  const std::uint64_t observer = tree.add_observer(
      [&last_failed](double, const bt::TreeNode& node, bt::NodeStatus, bt::NodeStatus to) {
        if (to == bt::NodeStatus::failure && node.children().empty()) last_failed = &node;
      });

  const std::string error_at_start = tree.last_error();
  const double start_s = clock.now_s();
  std::optional<double> last_frame_s;
  std::optional<double> last_odometry_s;
  std::optional<OdometryPlausibility> plausibility;  // (re)made when its limits change (live reload)
  OdometryLimits plausibility_limits{-1.0, -1.0};
  std::uint64_t late_odometry = 0;
  auto next_deadline = std::chrono::steady_clock::now();

  // Mission control (see runner.hpp): paused = robot held at zero, tree not ticked.
  dds::ControlSubscriber* control = session.control();
  const std::uint64_t control_rejected_at_start = control != nullptr ? control->rejected() : 0;
  bool paused = false;
  double paused_since_s = 0.0;
  bool after_resume = false;  // data must be fresh again within startup_timeout_s of resumed_at_s
  double resumed_at_s = 0.0;
  bool hold_logged = false;   // "stale data while holding" logged once per hold

  auto finish = [&](RunOutcome outcome, std::string reason) -> RunReport {
    try {
      if (tree.status() == bt::NodeStatus::running) tree.halt();
      // After an exception the root may not be RUNNING while nodes below it are: halt those
      // too, deepest first, so every RUNNING node gets its halt callback.
      std::vector<bt::TreeNode*> running;
      tree.visit([&running](bt::TreeNode& n) {
        if (n.status() == bt::NodeStatus::running) running.push_back(&n);
      });
      for (auto it = running.rbegin(); it != running.rend(); ++it) (*it)->halt_node();
    } catch (const std::exception& e) {
      log.error("run", std::string("halting the tree threw: ") + e.what());
    } catch (...) {
      log.error("run", "halting the tree threw");
    }
    tree.remove_observer(observer);
    if (paused) report.paused_s += clock.now_s() - paused_since_s;
    if (control != nullptr) report.control_rejected += control->rejected() - control_rejected_at_start;
    if (outcome == RunOutcome::safety_stop) robot.latch(reason);
    if (auto st = robot.stop(); !st) log.error("run", "could not stop the robot: " + st.error().message);
    report.outcome = outcome;
    report.reason = std::move(reason);
    switch (outcome) {
      case RunOutcome::success: report.exit_code = 0; break;
      case RunOutcome::stopped: report.exit_code = 0; break;
      case RunOutcome::failure: report.exit_code = 1; break;
      case RunOutcome::error: report.exit_code = 1; break;
      case RunOutcome::safety_stop: report.exit_code = 3; break;
      case RunOutcome::interrupted: report.exit_code = 128 + (stop.load() != 0 ? stop.load() : SIGINT); break;
    }
    report.run_time_s = clock.now_s() - start_s;
    report.wall_time_s = wall.now_s();
    if (trace) trace->flush();
    const std::string summary = std::string("run ended: ") + to_string(outcome) + " after " +
                                std::to_string(report.ticks) + " ticks, " + fmt_s(report.run_time_s) + " s" +
                                (report.overruns > 0 ? ", " + std::to_string(report.overruns) + " overruns" : "") +
                                (report.reason.empty() ? "" : ": " + report.reason);
    if (outcome == RunOutcome::success || outcome == RunOutcome::stopped)
      log.info("run", summary);
    else
      log.error("run", summary);
    return report;
  };

  for (;;) {
    if (stop.load() != 0) {
      log.warn("run", std::string("stop requested (signal ") + std::to_string(stop.load()) + "), halting the tree");
      return finish(RunOutcome::interrupted, "interrupted by signal " + std::to_string(stop.load()));
    }
    if (control != nullptr) {
      for (dds::ControlRequest& request : control->take_pending()) {
        switch (request.command) {
          case dds::msg::ControlCommand::pause:
            if (paused) {
              log.info("run", "control: pause while paused, ignored");
              break;
            }
            paused = true;
            paused_since_s = clock.now_s();
            hold_logged = false;
            ++report.pauses;
            ++report.control_applied;
            if (auto st = robot.stop(); !st) log.error("run", "could not stop the robot: " + st.error().message);
            log.warn("run", "paused by the control topic: robot stopped, tree not ticked (resume to continue)");
            break;
          case dds::msg::ControlCommand::resume:
            if (!paused) {
              log.info("run", "control: resume while not paused, ignored");
              break;
            }
            paused = false;
            report.paused_s += clock.now_s() - paused_since_s;
            after_resume = true;
            resumed_at_s = clock.now_s();
            hold_logged = false;
            ++report.control_applied;
            log.info("run", "resumed by the control topic after " + fmt_s(clock.now_s() - paused_since_s) + " s paused");
            break;
          case dds::msg::ControlCommand::abort:
            ++report.control_applied;
            log.warn("run", "abort requested on the control topic, halting the tree");
            return finish(RunOutcome::interrupted, "aborted by control topic");
          case dds::msg::ControlCommand::swap_detector: {
            const std::string old_type = session.config().detector ? session.config().detector->type : "none";
            if (auto st = session.swap_detector(request.argument); st) {
              ++report.control_applied;
            } else {
              ++report.control_rejected;
              log.warn("run", "control: swap_detector rejected, keeping detector '" + old_type + "': " + st.error().message);
            }
            break;
          }
        }
      }
    }
    session.poll_config_reload();
    const RunSettings& rs = session.config().run;
    const double period_s = 1.0 / rs.rate_hz;

    // --- pace (fixed rate, real time; and a paused lock-step simulation): wait for this
    // tick's deadline, in short slices so a stop request is seen quickly even at low rates ---
    if ((!lockstep && rs.tick == "rate") || (lockstep && paused)) {
      const auto now = std::chrono::steady_clock::now();
      if (next_deadline < now) next_deadline = now;  // behind: do not try to catch up
      while (std::chrono::steady_clock::now() < next_deadline && stop.load() == 0)
        std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(
            next_deadline - std::chrono::steady_clock::now(), std::chrono::milliseconds(50)));
      if (stop.load() != 0) continue;
      next_deadline += std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(period_s));
    }

    // --- acquire ---
    bool new_frame = false;
    if (lockstep) {
      if (auto st = sim->step(period_s); !st) return finish(RunOutcome::safety_stop, "simulation step failed: " + st.error().message);
    }
    {
      double wait_s = 0.0;
      if (!lockstep && rs.tick == "frame") wait_s = std::min(0.05, rs.max_frame_age_s);
      auto grabbed = camera.grab(wait_s);
      if (!grabbed) return finish(RunOutcome::safety_stop, "camera failed: " + grabbed.error().message);
      if (grabbed->has_value()) {  // grab() only returns frames newer than the previous one
        last_frame_s = (**grabbed).timestamp_s;
        bus.publish_frame(std::move(**grabbed));
        new_frame = true;
      }
    }
    if (auto odo = robot.latest_odometry()) {
      if (rs.odometry_max_speed_mps != plausibility_limits.max_speed_mps ||
          rs.odometry_jump_slack_m != plausibility_limits.slack_m) {
        plausibility_limits = OdometryLimits{rs.odometry_max_speed_mps, rs.odometry_jump_slack_m};
        plausibility.emplace(plausibility_limits);  // restarts from this reading
      }
      // An implausible reading never reaches the tree (issue 17: spoofed odometry). A late
      // (reordered) one is dropped: the stale-odometry check stops the robot if nothing newer comes.
      if (auto why = plausibility->check(*odo)) {
        if (!plausibility->last_was_late()) return finish(RunOutcome::safety_stop, "implausible odometry: " + *why);
        if (++late_odometry <= 3 || late_odometry % 100 == 0)
          log.warn("run", "dropped a late odometry reading (" + *why + "); " + std::to_string(late_odometry) + " so far");
      } else {
        last_odometry_s = odo->timestamp_s;
        bus.publish_odometry(*odo);
      }
    }

    // --- safety ---
    // While paused (robot held at zero) and within startup_timeout_s after a resume, stale or
    // missing data holds the tree instead of ending the run.
    const double now_s = clock.now_s();
    if (after_resume && now_s - resumed_at_s > rs.startup_timeout_s) after_resume = false;
    const bool holding = paused || after_resume;
    std::string data_problem;
    if (!last_frame_s || !last_odometry_s) {
      if (now_s - start_s > rs.startup_timeout_s && !holding) {
        return finish(RunOutcome::safety_stop, std::string("no ") + (!last_frame_s ? "camera frame" : "odometry") +
                                                   " within startup_timeout_s = " + fmt_s(rs.startup_timeout_s) + " s");
      }
      data_problem = std::string("no ") + (!last_frame_s ? "camera frame" : "odometry") + " yet";
    } else if (now_s - *last_frame_s > rs.max_frame_age_s) {
      data_problem = "stale camera data: newest frame is " + fmt_s(now_s - *last_frame_s) +
                     " s old (max_frame_age_s = " + fmt_s(rs.max_frame_age_s) + ")";
    } else if (now_s - *last_odometry_s > rs.max_odometry_age_s) {
      data_problem = "stale odometry: newest reading is " + fmt_s(now_s - *last_odometry_s) +
                     " s old (max_odometry_age_s = " + fmt_s(rs.max_odometry_age_s) + ")";
    }
    if (!data_problem.empty() && !holding) {
      if (!last_frame_s || !last_odometry_s) continue;  // still starting up
      return finish(RunOutcome::safety_stop, data_problem);
    }
    if (!data_problem.empty() && !hold_logged) {
      log.warn("run", data_problem + (paused ? " while paused" : " after resume") +
                          "; the tree is ticked again only with fresh data");
      hold_logged = true;
    }
    if (data_problem.empty() && after_resume && !paused) {
      after_resume = false;  // fresh data after a resume: normal checks from now on
      hold_logged = false;
    }
    if (rs.max_duration_s > 0.0 && now_s - start_s >= rs.max_duration_s)
      return finish(RunOutcome::failure, "max_duration_s = " + fmt_s(rs.max_duration_s) + " s reached");
    if (paused) {
      // Keep-alive zero (robots with a cmd_vel timeout) and a "paused" status for monitors.
      if (auto st = robot.stop(); !st) log.error("run", "could not stop the robot: " + st.error().message);
      if (Telemetry* t = session.host().telemetry(); t != nullptr) {
        NavStatus s;
        s.node_path = active_path(tree);
        s.status = "paused";
        t->publish(s);
      }
      continue;
    }
    if (!data_problem.empty()) continue;  // holding after a resume until the data is fresh
    if (!lockstep && rs.tick == "frame" && !new_frame) continue;

    // --- tick ---
    const std::uint64_t published_before = session.telemetry_published();
    const double tick_start = wall.now_s();
    bt::NodeStatus status = bt::NodeStatus::idle;
    try {
      status = tree.tick_once();
    } catch (const std::exception& e) {
      // A node broke the no-exceptions rule: stop the robot rather than let it drive on.
      return finish(RunOutcome::error, std::string("a node threw an exception during tick ") +
                                           std::to_string(report.ticks + 1) + ": " + e.what());
    } catch (...) {
      return finish(RunOutcome::error, "a node threw a non-standard exception during tick " +
                                           std::to_string(report.ticks + 1));
    }
    const double tick_s = wall.now_s() - tick_start;
    ++report.ticks;
    if (tick_s > period_s) {
      ++report.overruns;
      const std::string msg = "tick " + std::to_string(report.ticks) + " took " + fmt_s(tick_s * 1e3) +
                              " ms, over its period of " + fmt_s(period_s * 1e3) + " ms";
      if (!lockstep && (report.overruns <= 10 || report.overruns % 100 == 0))
        log.warn("run", msg + (report.overruns == 10 ? " (logging every 100th from now)" : ""));
      else
        log.log(LogLevel::debug, "run", msg);
    }
    if (Telemetry* t = session.host().telemetry(); t != nullptr && session.telemetry_published() == published_before) {
      NavStatus s;
      s.node_path = active_path(tree);
      s.command = robot.last_command();
      s.status = bt::to_string(status);
      t->publish(s);
    }
    if (options.after_tick) {
      TickInfo info{report.ticks, now_s, status, tick_s};
      if (!options.after_tick(info)) return finish(RunOutcome::stopped, "stopped by the caller");
    }
    if (status == bt::NodeStatus::success) return finish(RunOutcome::success, "");
    if (status == bt::NodeStatus::failure) {
      if (!tree.last_error().empty() && tree.last_error() != error_at_start) {
        // tick_once() caught an exception from a node and already halted the tree.
        return finish(RunOutcome::error, "a node threw during tick " + std::to_string(report.ticks) + ": " +
                                             tree.last_error());
      }
      std::string why = "the tree returned FAILURE";
      if (last_failed != nullptr)
        why += " (last failed leaf: " + last_failed->path() + " at " + last_failed->where().str() + ")";
      return finish(RunOutcome::failure, why);
    }
  }
}

}  // namespace visnav
