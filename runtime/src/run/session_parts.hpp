// Internal: the parts of a Session that have one job each besides building it — the telemetry
// and control links, and the live-reload state. Shared by session.cpp (building) and
// session_reload.cpp (live reload).
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

/// Telemetry sinks behind one fan-out (the host's telemetry when it has a sink) and the DDS
/// control subscriber. Member order is destruction order in reverse: control first, file last.
struct Session::Links {
  std::unique_ptr<JsonLinesTelemetry> file;  ///< run.telemetry_file
  std::unique_ptr<dds::DdsTelemetry> dds;    ///< dds: telemetry
  FanOutTelemetry fan_out;
  std::unique_ptr<dds::ControlSubscriber> control;  ///< dds: control
};

/// Live reload: what the config file is re-read with, when it is looked at next, what it
/// looked like last, and how reloads went.
struct Session::ReloadState {
  std::vector<std::string> overrides;  ///< the --set list the session was loaded with
  double next_poll_wall_s = 0.0;
  std::int64_t file_mtime_ns = 0;
  std::uintmax_t file_size = 0;
  int applied = 0;
  int rejected = 0;

  /// Reads the stamp (mtime, size) of `file`; true when it differs from the remembered one,
  /// which it then becomes. An unreadable file (mid-rename by an editor) is "unchanged".
  bool restamp(const std::string& file);
};

}  // namespace visnav
