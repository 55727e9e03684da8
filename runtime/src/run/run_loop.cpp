// The tick loop: lock-step / per-frame / fixed-rate ticking, safety checks, stop requests,
// mission control (pause / resume / abort / swap_detector from the DDS control topic).
#include <csignal>
#include <cstdio>
#include <exception>
#include <numbers>
#include <optional>
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

namespace {

/// One run of a tree (see runner.hpp): each method is one step of a loop iteration. `finish`
/// is the only way out; it halts the tree, stops the robot and fills the report.
class TickLoop {
 public:
  TickLoop(Session& session, bt::Tree& tree, const RunOptions& options)
      : session_(session),
        tree_(tree),
        options_(options),
        log_(session.logger()),
        robot_(session.robot()),
        clock_(session.clock()),
        stop_(options.stop_requested != nullptr ? *options.stop_requested : signal_flag()),
        lockstep_(session.lockstep()),
        control_(session.control()) {}

  RunReport run();

 private:
  RunReport finish(RunOutcome outcome, std::string reason);
  void halt_everything();
  /// Applies the pending control requests; an abort ends the run (returned).
  std::optional<RunReport> handle_control();
  /// Waits for this iteration's deadline (fixed rate in real time; paused lock-step).
  void pace(double period_s);
  /// Steps the simulation, grabs a frame and reads odometry onto the frame bus; a failure ends
  /// the run (returned).
  std::optional<RunReport> acquire(double period_s);
  std::optional<RunReport> read_odometry();
  /// Safety: the data problem that holds the tree ("" when none; `starting_up` when there is no
  /// data yet and nothing holds the tree: skip this iteration), or the end of the run.
  std::optional<RunReport> check_data(double now_s, std::string& data_problem, bool& starting_up);
  void publish_paused();
  /// Ticks once; the end of the run when the tree finished, threw or the caller stopped it.
  std::optional<RunReport> tick(double now_s, double period_s);

  Session& session_;
  bt::Tree& tree_;
  const RunOptions& options_;
  Logger& log_;
  GuardedRobot& robot_;
  const Clock& clock_;
  const std::atomic<int>& stop_;
  const bool lockstep_;
  dds::ControlSubscriber* control_;
  WallClock wall_;
  RunReport report_;

  std::unique_ptr<bt::TraceWriter> trace_;
  const bt::TreeNode* last_failed_ = nullptr;  // the last leaf that failed, for a FAILURE's reason
  std::uint64_t observer_ = 0;
  std::string error_at_start_;
  double start_s_ = 0.0;
  std::optional<double> last_frame_s_;
  std::optional<double> last_odometry_s_;
  bool new_frame_ = false;
  std::optional<OdometryPlausibility> plausibility_;  // (re)made when its limits change (live reload)
  OdometryLimits plausibility_limits_{-1.0, -1.0};
  std::uint64_t late_odometry_ = 0;
  std::chrono::steady_clock::time_point next_deadline_ = std::chrono::steady_clock::now();
  // Mission control (see runner.hpp): paused = robot held at zero, tree not ticked.
  std::uint64_t control_rejected_at_start_ = 0;
  bool paused_ = false;
  double paused_since_s_ = 0.0;
  bool after_resume_ = false;  // data must be fresh again within startup_timeout_s of resumed_at_s_
  double resumed_at_s_ = 0.0;
  bool hold_logged_ = false;   // "stale data while holding" logged once per hold
};

RunReport TickLoop::run() {
  const std::string trace_file = options_.trace_file.empty() ? session_.config().run.trace_file : options_.trace_file;
  if (!trace_file.empty()) {
    auto attached = bt::TraceWriter::attach(tree_, trace_file);
    if (!attached) {
      report_.outcome = RunOutcome::error;
      report_.reason = attached.error().message;
      return report_;
    }
    trace_ = std::move(attached).value();
  }
  observer_ = tree_.add_observer([this](double, const bt::TreeNode& node, bt::NodeStatus, bt::NodeStatus to) {
    if (to == bt::NodeStatus::failure && node.children().empty()) last_failed_ = &node;
  });
  error_at_start_ = tree_.last_error();
  start_s_ = clock_.now_s();
  control_rejected_at_start_ = control_ != nullptr ? control_->rejected() : 0;

  for (;;) {
    if (stop_.load() != 0) {
      log_.warn("run", std::string("stop requested (signal ") + std::to_string(stop_.load()) + "), halting the tree");
      return finish(RunOutcome::interrupted, "interrupted by signal " + std::to_string(stop_.load()));
    }
    if (auto end = handle_control()) return std::move(*end);
    session_.poll_config_reload();
    const RunSettings& rs = session_.config().run;
    const double period_s = 1.0 / rs.rate_hz;
    if ((!lockstep_ && rs.tick == "rate") || (lockstep_ && paused_)) {
      pace(period_s);
      if (stop_.load() != 0) continue;
    }
    if (auto end = acquire(period_s)) return std::move(*end);
    const double now_s = clock_.now_s();
    std::string data_problem;
    bool starting_up = false;
    if (auto end = check_data(now_s, data_problem, starting_up)) return std::move(*end);
    if (starting_up) continue;
    if (rs.max_duration_s > 0.0 && now_s - start_s_ >= rs.max_duration_s)
      return finish(RunOutcome::failure, "max_duration_s = " + fmt_s(rs.max_duration_s) + " s reached");
    if (paused_) {
      publish_paused();
      continue;
    }
    if (!data_problem.empty()) continue;  // holding after a resume until the data is fresh
    if (!lockstep_ && rs.tick == "frame" && !new_frame_) continue;
    if (auto end = tick(now_s, period_s)) return std::move(*end);
  }
}

void TickLoop::halt_everything() {
  try {
    if (tree_.status() == bt::NodeStatus::running) tree_.halt();
    // After an exception the root may not be RUNNING while nodes below it are: halt those
    // too, deepest first, so every RUNNING node gets its halt callback.
    std::vector<bt::TreeNode*> running;
    tree_.visit([&running](bt::TreeNode& n) {
      if (n.status() == bt::NodeStatus::running) running.push_back(&n);
    });
    for (auto it = running.rbegin(); it != running.rend(); ++it) (*it)->halt_node();
  } catch (const std::exception& e) {
    log_.error("run", std::string("halting the tree threw: ") + e.what());
  } catch (...) {
    log_.error("run", "halting the tree threw");
  }
}

RunReport TickLoop::finish(RunOutcome outcome, std::string reason) {
  halt_everything();
  tree_.remove_observer(observer_);
  if (paused_) report_.paused_s += clock_.now_s() - paused_since_s_;
  if (control_ != nullptr) report_.control_rejected += control_->rejected() - control_rejected_at_start_;
  if (outcome == RunOutcome::safety_stop) robot_.latch(reason);
  if (auto st = robot_.stop(); !st) log_.error("run", "could not stop the robot: " + st.error().message);
  report_.outcome = outcome;
  report_.reason = std::move(reason);
  switch (outcome) {
    case RunOutcome::success: report_.exit_code = 0; break;
    case RunOutcome::stopped: report_.exit_code = 0; break;
    case RunOutcome::failure: report_.exit_code = 1; break;
    case RunOutcome::error: report_.exit_code = 1; break;
    case RunOutcome::safety_stop: report_.exit_code = 3; break;
    case RunOutcome::interrupted: report_.exit_code = 128 + (stop_.load() != 0 ? stop_.load() : SIGINT); break;
  }
  report_.run_time_s = clock_.now_s() - start_s_;
  report_.wall_time_s = wall_.now_s();
  if (trace_) trace_->flush();
  const std::string summary = std::string("run ended: ") + to_string(outcome) + " after " +
                              std::to_string(report_.ticks) + " ticks, " + fmt_s(report_.run_time_s) + " s" +
                              (report_.overruns > 0 ? ", " + std::to_string(report_.overruns) + " overruns" : "") +
                              (report_.reason.empty() ? "" : ": " + report_.reason);
  if (outcome == RunOutcome::success || outcome == RunOutcome::stopped)
    log_.info("run", summary);
  else
    log_.error("run", summary);
  // A simulated robot's true end pose: what a teach-and-repeat run is judged by (the navigation
  // never sees it; odometry is the robot's own, with its error models).
  if (SimulationControl* sim = robot_.simulation(); sim != nullptr) {
    const Pose2D truth = sim->ground_truth_pose();
    log_.info("run", "simulated ground truth at the end: x=" + fmt_s(truth.x_m) + " y=" + fmt_s(truth.y_m) +
                         " heading=" + fmt_s(truth.heading_rad * 180.0 / std::numbers::pi) + " deg");
  }
  return report_;
}

std::optional<RunReport> TickLoop::handle_control() {
  if (control_ == nullptr) return std::nullopt;
  for (dds::ControlRequest& request : control_->take_pending()) {
    switch (request.command) {
      case dds::msg::ControlCommand::pause:
        if (paused_) {
          log_.info("run", "control: pause while paused, ignored");
          break;
        }
        paused_ = true;
        paused_since_s_ = clock_.now_s();
        hold_logged_ = false;
        ++report_.pauses;
        ++report_.control_applied;
        if (auto st = robot_.stop(); !st) log_.error("run", "could not stop the robot: " + st.error().message);
        log_.warn("run", "paused by the control topic: robot stopped, tree not ticked (resume to continue)");
        break;
      case dds::msg::ControlCommand::resume:
        if (!paused_) {
          log_.info("run", "control: resume while not paused, ignored");
          break;
        }
        paused_ = false;
        report_.paused_s += clock_.now_s() - paused_since_s_;
        after_resume_ = true;
        resumed_at_s_ = clock_.now_s();
        hold_logged_ = false;
        ++report_.control_applied;
        log_.info("run", "resumed by the control topic after " + fmt_s(clock_.now_s() - paused_since_s_) + " s paused");
        break;
      case dds::msg::ControlCommand::abort:
        ++report_.control_applied;
        log_.warn("run", "abort requested on the control topic, halting the tree");
        return finish(RunOutcome::interrupted, "aborted by control topic");
      case dds::msg::ControlCommand::swap_detector: {
        const std::string old_type = session_.config().detector ? session_.config().detector->type : "none";
        if (auto st = session_.swap_detector(request.argument); st) {
          ++report_.control_applied;
        } else {
          ++report_.control_rejected;
          log_.warn("run", "control: swap_detector rejected, keeping detector '" + old_type + "': " + st.error().message);
        }
        break;
      }
    }
  }
  return std::nullopt;
}

// In short slices, so a stop request is seen quickly even at low rates.
void TickLoop::pace(double period_s) {
  const auto now = std::chrono::steady_clock::now();
  if (next_deadline_ < now) next_deadline_ = now;  // behind: do not try to catch up
  while (std::chrono::steady_clock::now() < next_deadline_ && stop_.load() == 0)
    std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(
        next_deadline_ - std::chrono::steady_clock::now(), std::chrono::milliseconds(50)));
  if (stop_.load() != 0) return;
  next_deadline_ += std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(period_s));
}

std::optional<RunReport> TickLoop::acquire(double period_s) {
  const RunSettings& rs = session_.config().run;
  new_frame_ = false;
  if (lockstep_) {
    if (auto st = robot_.simulation()->step(period_s); !st)
      return finish(RunOutcome::safety_stop, "simulation step failed: " + st.error().message);
  }
  double wait_s = 0.0;
  if (!lockstep_ && rs.tick == "frame") wait_s = std::min(0.05, rs.max_frame_age_s);
  auto grabbed = session_.camera().grab(wait_s);
  if (!grabbed) return finish(RunOutcome::safety_stop, "camera failed: " + grabbed.error().message);
  if (grabbed->has_value()) {  // grab() only returns frames newer than the previous one
    last_frame_s_ = (**grabbed).timestamp_s;
    session_.frame_bus().publish_frame(std::move(**grabbed));
    new_frame_ = true;
  }
  return read_odometry();
}

std::optional<RunReport> TickLoop::read_odometry() {
  auto odo = robot_.latest_odometry();
  if (!odo) return std::nullopt;
  const RunSettings& rs = session_.config().run;
  if (rs.odometry_max_speed_mps != plausibility_limits_.max_speed_mps ||
      rs.odometry_jump_slack_m != plausibility_limits_.slack_m) {
    plausibility_limits_ = OdometryLimits{rs.odometry_max_speed_mps, rs.odometry_jump_slack_m};
    plausibility_.emplace(plausibility_limits_);  // restarts from this reading
  }
  // An implausible reading never reaches the tree (issue 17: spoofed odometry). A late
  // (reordered) one is dropped: the stale-odometry check stops the robot if nothing newer comes.
  if (auto why = plausibility_->check(*odo)) {
    if (!plausibility_->last_was_late()) return finish(RunOutcome::safety_stop, "implausible odometry: " + *why);
    if (++late_odometry_ <= 3 || late_odometry_ % 100 == 0)
      log_.warn("run", "dropped a late odometry reading (" + *why + "); " + std::to_string(late_odometry_) + " so far");
    return std::nullopt;
  }
  last_odometry_s_ = odo->timestamp_s;
  session_.frame_bus().publish_odometry(*odo);
  return std::nullopt;
}

// While paused (robot held at zero) and within startup_timeout_s after a resume, stale or
// missing data holds the tree instead of ending the run.
std::optional<RunReport> TickLoop::check_data(double now_s, std::string& data_problem, bool& starting_up) {
  const RunSettings& rs = session_.config().run;
  if (after_resume_ && now_s - resumed_at_s_ > rs.startup_timeout_s) after_resume_ = false;
  const bool holding = paused_ || after_resume_;
  const bool starting = !last_frame_s_ || !last_odometry_s_;
  if (starting) {
    const std::string missing = !last_frame_s_ ? "camera frame" : "odometry";
    if (now_s - start_s_ > rs.startup_timeout_s && !holding)
      return finish(RunOutcome::safety_stop,
                    "no " + missing + " within startup_timeout_s = " + fmt_s(rs.startup_timeout_s) + " s");
    data_problem = "no " + missing + " yet";
  } else if (now_s - *last_frame_s_ > rs.max_frame_age_s) {
    data_problem = "stale camera data: newest frame is " + fmt_s(now_s - *last_frame_s_) +
                   " s old (max_frame_age_s = " + fmt_s(rs.max_frame_age_s) + ")";
  } else if (now_s - *last_odometry_s_ > rs.max_odometry_age_s) {
    data_problem = "stale odometry: newest reading is " + fmt_s(now_s - *last_odometry_s_) +
                   " s old (max_odometry_age_s = " + fmt_s(rs.max_odometry_age_s) + ")";
  }
  if (!data_problem.empty() && !holding) {
    starting_up = starting;
    if (starting) return std::nullopt;
    return finish(RunOutcome::safety_stop, data_problem);
  }
  if (!data_problem.empty() && !hold_logged_) {
    log_.warn("run", data_problem + (paused_ ? " while paused" : " after resume") +
                         "; the tree is ticked again only with fresh data");
    hold_logged_ = true;
  }
  if (data_problem.empty() && after_resume_ && !paused_) {
    after_resume_ = false;  // fresh data after a resume: normal checks from now on
    hold_logged_ = false;
  }
  return std::nullopt;
}

// Keep-alive zero (robots with a cmd_vel timeout) and a "paused" status for monitors.
void TickLoop::publish_paused() {
  if (auto st = robot_.stop(); !st) log_.error("run", "could not stop the robot: " + st.error().message);
  if (Telemetry* t = session_.host().telemetry(); t != nullptr) {
    NavStatus s;
    s.node_path = active_path(tree_);
    s.status = "paused";
    t->publish(s);
  }
}

std::optional<RunReport> TickLoop::tick(double now_s, double period_s) {
  const std::uint64_t published_before = session_.telemetry_published();
  const double tick_start = wall_.now_s();
  bt::NodeStatus status = bt::NodeStatus::idle;
  try {
    status = tree_.tick_once();
  } catch (const std::exception& e) {
    // A node broke the no-exceptions rule: stop the robot rather than let it drive on.
    return finish(RunOutcome::error, std::string("a node threw an exception during tick ") +
                                         std::to_string(report_.ticks + 1) + ": " + e.what());
  } catch (...) {
    return finish(RunOutcome::error, "a node threw a non-standard exception during tick " + std::to_string(report_.ticks + 1));
  }
  const double tick_s = wall_.now_s() - tick_start;
  ++report_.ticks;
  if (tick_s > period_s) {
    ++report_.overruns;
    const std::string msg = "tick " + std::to_string(report_.ticks) + " took " + fmt_s(tick_s * 1e3) +
                            " ms, over its period of " + fmt_s(period_s * 1e3) + " ms";
    if (!lockstep_ && (report_.overruns <= 10 || report_.overruns % 100 == 0))
      log_.warn("run", msg + (report_.overruns == 10 ? " (logging every 100th from now)" : ""));
    else
      log_.log(LogLevel::debug, "run", msg);
  }
  if (Telemetry* t = session_.host().telemetry(); t != nullptr && session_.telemetry_published() == published_before) {
    NavStatus s;
    s.node_path = active_path(tree_);
    s.command = robot_.last_command();
    s.status = bt::to_string(status);
    t->publish(s);
  }
  if (options_.after_tick && !options_.after_tick(TickInfo{report_.ticks, now_s, status, tick_s}))
    return finish(RunOutcome::stopped, "stopped by the caller");
  if (status == bt::NodeStatus::success) return finish(RunOutcome::success, "");
  if (status != bt::NodeStatus::failure) return std::nullopt;
  if (!tree_.last_error().empty() && tree_.last_error() != error_at_start_) {
    // tick_once() caught an exception from a node and already halted the tree.
    return finish(RunOutcome::error, "a node threw during tick " + std::to_string(report_.ticks) + ": " + tree_.last_error());
  }
  std::string why = "the tree returned FAILURE";
  if (last_failed_ != nullptr)
    why += " (last failed leaf: " + last_failed_->path() + " at " + last_failed_->where().str() + ")";
  return finish(RunOutcome::failure, why);
}

}  // namespace

RunReport run_tree(Session& session, bt::Tree& tree, const RunOptions& options) {
  return TickLoop(session, tree, options).run();
}

}  // namespace visnav
