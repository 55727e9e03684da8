// Internal: the parts of a Session that have one job each besides building it — the telemetry
// and control links, the detector slot, and live reload. Shared by session.cpp (building,
// detector swap) and session_reload.cpp (live reload).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "visnav/runner.hpp"

namespace visnav {

/// "detector 'orb' (plugin detectors_opencv) at config.yaml:7": the context of a plugin error.
inline std::string spec_label(const char* section, const PluginSpec& spec) {
  return std::string(section) + " '" + spec.type + "'" + (spec.plugin.empty() ? "" : " (plugin " + spec.plugin + ")") +
         " at " + spec.where.str();
}

/// A plugin's creation error in the context of its config section: the message gains
/// spec_label(); the location becomes the config's. An error that names a params key (from the
/// plugin's schema) is keyed `section.params.key`; one with no location (an unknown type, a
/// library that would not load) is keyed `section.type` at the section's line.
inline Error spec_error(const Error& e, const char* section, const PluginSpec& spec) {
  Error out = e.with_context(spec_label(section, spec));
  if (!out.where.key.empty()) {
    out.where.key = std::string(section) + ".params." + out.where.key;
    if (out.where.file.empty()) out.where.file = spec.where.file;
  } else if (out.where.empty()) {
    out.where = ErrorLocation{spec.where.file, spec.where.line, std::string(section) + ".type"};
  }
  return out;
}

/// Telemetry sinks behind one fan-out (the host's telemetry when it has a sink) and the DDS
/// control subscriber. Member order is destruction order in reverse: control first, file last.
struct Session::Links {
  std::unique_ptr<JsonLinesTelemetry> file;  ///< run.telemetry_file
  std::unique_ptr<dds::DdsTelemetry> dds;    ///< dds: telemetry
  FanOutTelemetry fan_out;
  std::unique_ptr<dds::ControlSubscriber> control;  ///< dds: control
};

/// Makes `next` the active detector: published to the host first, then the old one is destroyed
/// (between ticks). The one way the session's detector changes (build, swap, reload).
inline void install_detector(RuntimeHost& host, PluginPtr<Detector>& slot, PluginPtr<Detector> next) {
  host.set_active_detector(next.get());
  slot = std::move(next);
}

/// Live reload of the config file (see Session::reload_config): re-reads it with the session's
/// overrides and applies what may change live to the parts it borrows from the session.
class Session::LiveReload {
 public:
  /// What a reload may read and change; all owned by the session, which outlives this.
  struct Parts {
    RunConfig& config;
    Logger& logger;
    StderrLogger* own_logger;  ///< nullptr when the logger is borrowed (its level is not ours)
    PluginLoader& loader;
    RuntimeHost& host;
    PluginObject& robot;
    PluginObject& camera;
    PluginPtr<Detector>& detector;
    const Clock& wall_clock;
  };
  LiveReload(Parts parts, std::vector<std::string> overrides);

  /// Session::poll_config_reload.
  bool poll(bool force);
  /// Session::reload_config.
  Result<bool> reload();
  [[nodiscard]] int applied() const { return applied_; }
  [[nodiscard]] int rejected() const { return rejected_; }

 private:
  Error reject(Error why);
  /// A new detector when `next` needs one (`changed`), else nullptr (params applied in place).
  Result<PluginPtr<Detector>> detector_for(const RunConfig& next, bool& changed);
  /// Robot and camera params, in place; `next` is left holding what was applied.
  bool apply_device_params(RunConfig& next);
  /// Reads the file's stamp (mtime, size); true when it changed since the last call.
  bool restamp();

  Parts p_;
  std::vector<std::string> overrides_;  ///< the --set list the session was loaded with
  double next_poll_wall_s_ = 0.0;
  std::int64_t file_mtime_ns_ = 0;
  std::uintmax_t file_size_ = 0;
  int applied_ = 0;
  int rejected_ = 0;
};

}  // namespace visnav
