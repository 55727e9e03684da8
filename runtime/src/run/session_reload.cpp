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
  if (next.run.view_port != now.run.view_port) keys.push_back("run.view_port");
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

Session::LiveReload::LiveReload(Parts parts, std::vector<std::string> overrides)
    : p_(parts), overrides_(std::move(overrides)) {
  (void)restamp();
  next_poll_wall_s_ = p_.wall_clock.now_s() + p_.config.run.reload_poll_s;
}

bool Session::LiveReload::restamp() {
  const std::string& file = p_.config.file;
  if (file.empty()) return false;
  std::error_code ec;
  const auto t = fs::last_write_time(file, ec);
  if (ec) return false;  // e.g. mid-rename by an editor; try again next poll
  const auto size = fs::file_size(file, ec);
  if (ec) return false;
  const auto mtime_ns =
      static_cast<std::int64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count());
  if (mtime_ns == file_mtime_ns_ && size == file_size_) return false;
  file_mtime_ns_ = mtime_ns;
  file_size_ = size;
  return true;
}

bool Session::LiveReload::poll(bool force) {
  if (p_.config.file.empty()) return false;
  if (!force) {
    if (p_.config.run.reload_poll_s <= 0.0) return false;
    const double now = p_.wall_clock.now_s();
    if (now < next_poll_wall_s_) return false;
    next_poll_wall_s_ = now + p_.config.run.reload_poll_s;
  }
  if (!restamp()) return false;
  auto applied = reload();
  return applied && *applied;
}

Error Session::LiveReload::reject(Error why) {
  ++rejected_;
  p_.logger.error("config", "reload of " + p_.config.file + " rejected, keeping the running config: " + why.message);
  return why;
}

Result<bool> Session::LiveReload::reload() {
  RunConfig& config = p_.config;
  auto loaded = load_run_config(config.file, overrides_);
  if (!loaded) return reject(loaded.error());
  RunConfig next = std::move(loaded).value();
  if (const std::string keys = restart_keys(next, config); !keys.empty())
  {
    // The key is the first setting that changed ("robot" for robot.type/plugin); the message lists them all.
    std::string first = keys.substr(0, keys.find(','));
    if (first.find('/') != std::string::npos) first = first.substr(0, first.find('.'));
    return reject(Error{config.file + ": changing " + keys + " needs a restart", ErrorCode::inconsistent,
                        {config.file, 0, first}});
  }

  // A new detector is created before anything is applied, so a failing factory rejects the
  // whole reload.
  bool detector_changed = false;
  auto new_detector = detector_for(next, detector_changed);
  if (!new_detector) return reject(new_detector.error());

  bool changed = apply_device_params(next);
  if (detector_changed) {
    install_detector(p_.host, p_.detector, std::move(new_detector).value());
    p_.logger.info("config", next.detector ? "active detector is now '" + next.detector->type + "'" : "detector removed");
    changed = true;
  } else if (next.detector && !same_config(next.detector->params, config.detector->params)) {
    changed = true;
  }

  if (next.run.log_level != config.run.log_level && p_.own_logger != nullptr) {
    if (auto level = parse_log_level(next.run.log_level)) p_.own_logger->set_level(*level);
  }
  if (run_settings_changed(next.run, config.run)) {
    p_.logger.info("config", "run settings updated");
    changed = true;
  }

  config = std::move(next);
  (void)restamp();
  ++applied_;
  if (!changed) p_.logger.info("config", config.file + " changed but the effective config is the same");
  return changed;
}

// The detector `next` asks for: a new one when its type/plugin changed (or it appeared), or
// when the active one cannot take the new params in place; nullptr with `changed` false when
// the active one stays (its params, if changed, already applied).
Result<PluginPtr<Detector>> Session::LiveReload::detector_for(const RunConfig& next, bool& changed) {
  const RunConfig& config = p_.config;
  changed = false;
  if (next.detector.has_value() != config.detector.has_value() ||
      (next.detector && !same_identity(*next.detector, *config.detector))) {
    changed = true;
    if (!next.detector) return PluginPtr<Detector>{};
    auto made = p_.loader.create<Detector>(next.detector->type, next.detector->params, p_.host, next.detector->plugin);
    if (!made) return spec_error(made.error(), "detector", *next.detector);
    return std::move(made).value();
  }
  if (!next.detector || same_config(next.detector->params, config.detector->params)) return PluginPtr<Detector>{};
  PluginPtr<Detector> replacement;
  if (auto st = p_.detector->reconfigure(next.detector->params); !st) {
    // Cannot reconfigure in place: build a fresh one with the new params and swap.
    auto made = p_.loader.create<Detector>(next.detector->type, next.detector->params, p_.host, next.detector->plugin);
    if (!made)
      return Error{"detector '" + next.detector->type + "': reconfigure failed (" + st.error().message +
                       ") and a new one could not be created (" + made.error().message + ")",
                   made.error().code, spec_error(made.error(), "detector", *next.detector).where};
    replacement = std::move(made).value();
    changed = true;
  }
  p_.logger.info("config", "detector '" + next.detector->type + "' params updated");
  return replacement;
}

// Robot and camera params: reconfigured in place; one that refuses keeps its old params (logged)
// and the rest still applies.
bool Session::LiveReload::apply_device_params(RunConfig& next) {
  RunConfig& config = p_.config;
  bool changed = false;
  auto reconfigure = [&](const char* section, PluginObject& object, PluginSpec& current, const PluginSpec& wanted) {
    if (same_config(current.params, wanted.params)) return;
    auto st = object.reconfigure(wanted.params);
    if (!st) {
      p_.logger.error("config", std::string(section) + " '" + current.type + "' kept its old params: " + st.error().message);
      return;
    }
    p_.logger.info("config", std::string(section) + " '" + current.type + "' params updated");
    current = wanted;
    changed = true;
  };
  reconfigure("robot", p_.robot, config.robot, next.robot);
  reconfigure("camera", p_.camera, config.camera, next.camera);
  next.robot = config.robot;
  next.camera = config.camera;
  return changed;
}

}  // namespace visnav
