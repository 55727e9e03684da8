// Session live reload: re-read the config file between ticks and apply what can change live
// (plugin params, the detector, run settings); reject what needs a restart.
#include <chrono>
#include <filesystem>
#include <system_error>

#include "run/session_parts.hpp"
#include "visnav/runner.hpp"

namespace visnav {

namespace fs = std::filesystem;

namespace {

bool same_identity(const PluginSpec& a, const PluginSpec& b) { return a.type == b.type && a.plugin == b.plugin; }

bool same_dds(const DdsSettings& a, const DdsSettings& b) {
  return a.enabled == b.enabled && a.telemetry == b.telemetry && a.control == b.control &&
         a.endpoints.domain_id == b.endpoints.domain_id && a.endpoints.partition == b.endpoints.partition &&
         a.endpoints.telemetry_topic == b.endpoints.telemetry_topic && a.endpoints.control_topic == b.endpoints.control_topic;
}

/// The changed settings that need a restart, comma-separated; empty: none.
std::string restart_keys(const RunConfig& next, const RunConfig& now) {
  std::vector<std::string> keys;
  if (!same_identity(next.robot, now.robot)) keys.push_back("robot.type/plugin");
  if (!same_identity(next.camera, now.camera)) keys.push_back("camera.type/plugin");
  if (next.nodes != now.nodes) keys.push_back("nodes");
  if (next.plugin_path != now.plugin_path) keys.push_back("plugin_path");
  if (next.run.tick != now.run.tick) keys.push_back("run.tick");
  if (next.run.lockstep != now.run.lockstep) keys.push_back("run.lockstep");
  if (next.run.trace_file != now.run.trace_file) keys.push_back("run.trace_file");
  if (next.run.telemetry_file != now.run.telemetry_file) keys.push_back("run.telemetry_file");
  if (!same_dds(next.dds, now.dds)) keys.push_back("dds");
  std::string out;
  for (const auto& k : keys) out += (out.empty() ? "" : ", ") + k;
  return out;
}

/// The run settings that take effect live.
bool run_settings_changed(const RunSettings& a, const RunSettings& b) {
  return a.rate_hz != b.rate_hz || a.max_frame_age_s != b.max_frame_age_s || a.max_odometry_age_s != b.max_odometry_age_s ||
         a.startup_timeout_s != b.startup_timeout_s || a.max_duration_s != b.max_duration_s ||
         a.log_level != b.log_level || a.reload_poll_s != b.reload_poll_s;
}

}  // namespace

bool Session::ReloadState::restamp(const std::string& file) {
  if (file.empty()) return false;
  std::error_code ec;
  const auto t = fs::last_write_time(file, ec);
  if (ec) return false;
  const auto size = fs::file_size(file, ec);
  if (ec) return false;
  const auto mtime_ns =
      static_cast<std::int64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count());
  if (mtime_ns == file_mtime_ns && size == file_size) return false;
  file_mtime_ns = mtime_ns;
  file_size = size;
  return true;
}

bool Session::poll_config_reload(bool force) {
  if (config_.file.empty()) return false;
  if (!force) {
    if (config_.run.reload_poll_s <= 0.0) return false;
    const double now = wall_clock_.now_s();
    if (now < reload_->next_poll_wall_s) return false;
    reload_->next_poll_wall_s = now + config_.run.reload_poll_s;
  }
  if (!reload_->restamp(config_.file)) return false;
  auto applied = reload_config();
  return applied && *applied;
}

Error Session::reject_reload(const std::string& why) {
  ++reload_->rejected;
  logger_->error("config", "reload of " + config_.file + " rejected, keeping the running config: " + why);
  return fail(why);
}

Result<bool> Session::reload_config() {
  auto loaded = load_run_config(config_.file, reload_->overrides);
  if (!loaded) return reject_reload(loaded.error().message);
  RunConfig next = std::move(loaded).value();
  if (const std::string keys = restart_keys(next, config_); !keys.empty())
    return reject_reload("changing " + keys + " needs a restart");

  // A new detector is created before anything is applied, so a failing factory rejects the
  // whole reload.
  bool detector_changed = false;
  auto new_detector = detector_for(next, detector_changed);
  if (!new_detector) return reject_reload(new_detector.error().message);

  bool changed = apply_device_params(next);
  if (detector_changed) {
    install_detector(std::move(new_detector).value());
    logger_->info("config", next.detector ? "active detector is now '" + next.detector->type + "'" : "detector removed");
    changed = true;
  } else if (next.detector && !same_config(next.detector->params, config_.detector->params)) {
    changed = true;
  }

  if (next.run.log_level != config_.run.log_level && own_logger_) {
    if (auto level = parse_log_level(next.run.log_level)) own_logger_->set_level(*level);
  }
  if (run_settings_changed(next.run, config_.run)) {
    logger_->info("config", "run settings updated");
    changed = true;
  }

  config_ = std::move(next);
  (void)reload_->restamp(config_.file);
  ++reload_->applied;
  if (!changed) logger_->info("config", config_.file + " changed but the effective config is the same");
  return changed;
}

// The detector `next` asks for: a new one when its type/plugin changed (or it appeared), or
// when the active one cannot take the new params in place; nullptr with `changed` false when
// the active one stays (its params, if changed, already applied).
Result<PluginPtr<Detector>> Session::detector_for(const RunConfig& next, bool& changed) {
  changed = false;
  if (next.detector.has_value() != config_.detector.has_value() ||
      (next.detector && !same_identity(*next.detector, *config_.detector))) {
    changed = true;
    if (!next.detector) return PluginPtr<Detector>{};
    auto made = loader_.create<Detector>(next.detector->type, next.detector->params, *host_, next.detector->plugin);
    if (!made) return made.error().with_context(spec_label("detector", *next.detector));
    return std::move(made).value();
  }
  if (!next.detector || same_config(next.detector->params, config_.detector->params)) return PluginPtr<Detector>{};
  PluginPtr<Detector> replacement;
  if (auto st = detector_->reconfigure(next.detector->params); !st) {
    // Cannot reconfigure in place: build a fresh one with the new params and swap.
    auto made = loader_.create<Detector>(next.detector->type, next.detector->params, *host_, next.detector->plugin);
    if (!made)
      return fail("detector '" + next.detector->type + "': reconfigure failed (" + st.error().message +
                  ") and a new one could not be created (" + made.error().message + ")");
    replacement = std::move(made).value();
    changed = true;
  }
  logger_->info("config", "detector '" + next.detector->type + "' params updated");
  return replacement;
}

// Robot and camera params: reconfigured in place; one that refuses keeps its old params (logged)
// and the rest still applies. `next` is left holding what was actually applied.
bool Session::apply_device_params(RunConfig& next) {
  bool changed = false;
  auto reconfigure = [&](const char* section, PluginObject& object, PluginSpec& current, const PluginSpec& wanted) {
    if (same_config(current.params, wanted.params)) return;
    auto st = object.reconfigure(wanted.params);
    if (!st) {
      logger_->error("config", std::string(section) + " '" + current.type + "' kept its old params: " + st.error().message);
      return;
    }
    logger_->info("config", std::string(section) + " '" + current.type + "' params updated");
    current = wanted;
    changed = true;
  };
  reconfigure("robot", *robot_, config_.robot, next.robot);
  reconfigure("camera", *camera_, config_.camera, next.camera);
  next.robot = config_.robot;
  next.camera = config_.camera;
  return changed;
}

}  // namespace visnav
