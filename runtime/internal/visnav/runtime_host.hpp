// visnav runtime — the host side of HostServices: stderr logger, wall/simulated clocks,
// JSON-lines telemetry, and RuntimeHost, the HostServices the runtime hands to plugins.
//
// Ownership: RuntimeHost borrows everything it is given (loader, logger, clock, robot,
// camera, frame bus, telemetry, detector, map); the owner (normally visnav::Session) keeps them
// alive for as long as the host is used and any object created through it lives.
// Thread-safety: StderrLogger and the clocks are thread-safe; RuntimeHost's setters and run
// accessors are for the tick thread only (as HostServices states).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdio>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "visnav/devices.hpp"
#include "visnav/host.hpp"
#include "visnav/loader.hpp"
#include "visnav/result.hpp"

namespace visnav {

/// Parses "debug", "info", "warn", "error".
[[nodiscard]] Result<LogLevel> parse_log_level(std::string_view text);
[[nodiscard]] const char* to_string(LogLevel level);

/// Logs "visnav [W] component: message" lines to stderr (or a given FILE*), one write per line.
/// Messages below `min_level` are dropped. Thread-safe.
class StderrLogger final : public Logger {
 public:
  explicit StderrLogger(LogLevel min_level = LogLevel::info, std::FILE* out = stderr);
  void log(LogLevel level, std::string_view component, std::string_view message) override;
  void set_level(LogLevel level) { min_level_.store(level); }
  [[nodiscard]] LogLevel level() const { return min_level_.load(); }

 private:
  std::atomic<LogLevel> min_level_;
  std::FILE* out_;
  std::mutex mutex_;
};

/// Seconds since construction on std::chrono::steady_clock. Thread-safe.
class WallClock final : public Clock {
 public:
  WallClock() : start_(std::chrono::steady_clock::now()) {}
  [[nodiscard]] double now_s() const override {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  std::chrono::steady_clock::time_point start_;
};

/// Simulated time of a SimulationControl (borrowed; must outlive the clock).
class SimulationClock final : public Clock {
 public:
  explicit SimulationClock(const SimulationControl& simulation) : simulation_(&simulation) {}
  [[nodiscard]] double now_s() const override { return simulation_->time_s(); }

 private:
  const SimulationControl* simulation_;
};

/// A clock that only moves when told to (tests, tools). Thread-safe.
class ManualClock final : public Clock {
 public:
  explicit ManualClock(double start_s = 0.0) : now_s_(start_s) {}
  [[nodiscard]] double now_s() const override { return now_s_.load(); }
  void set(double t_s) { now_s_.store(t_s); }
  void advance(double dt_s) { now_s_.store(now_s_.load() + dt_s); }

 private:
  std::atomic<double> now_s_;
};

/// Writes each NavStatus as one JSON object per line:
///   {"t_s":1.2,"node_path":"...","map_node":"...","edge":"...","distance_m":0.5,"matches":10,
///    "inliers":8,"offset_px":-3.1,"linear_mps":0.3,"angular_radps":0.01,"status":"replaying"}
/// `t_s` comes from the given clock. Flushes every line (a killed run keeps its telemetry).
class JsonLinesTelemetry final : public Telemetry {
 public:
  /// Opens (truncates) `path`. Error names the path and the OS reason.
  static Result<std::unique_ptr<JsonLinesTelemetry>> open(const std::string& path, const Clock& clock);
  ~JsonLinesTelemetry() override;
  JsonLinesTelemetry(const JsonLinesTelemetry&) = delete;
  JsonLinesTelemetry& operator=(const JsonLinesTelemetry&) = delete;

  void publish(const NavStatus& status) override;
  /// Number of publish() calls so far.
  [[nodiscard]] std::uint64_t published() const { return published_; }

 private:
  JsonLinesTelemetry(std::FILE* file, const Clock& clock) : file_(file), clock_(&clock) {}
  std::FILE* file_;
  const Clock* clock_;
  std::uint64_t published_ = 0;
};

/// Forwards every NavStatus to several sinks in order (e.g. the JSON-lines file and DDS) and
/// counts the calls. The sinks are borrowed and must outlive the fan-out. Used from the tick
/// thread only (like every Telemetry).
class FanOutTelemetry final : public Telemetry {
 public:
  FanOutTelemetry() = default;
  /// Adds a sink (nullptr is ignored).
  void add(Telemetry* sink) {
    if (sink != nullptr) sinks_.push_back(sink);
  }
  /// Removes every occurrence of `sink`.
  void remove(Telemetry* sink) { std::erase(sinks_, sink); }
  void publish(const NavStatus& status) override {
    ++published_;
    for (Telemetry* sink : sinks_) sink->publish(status);
  }
  /// Number of publish() calls so far.
  [[nodiscard]] std::uint64_t published() const { return published_; }
  [[nodiscard]] std::size_t sinks() const { return sinks_.size(); }

 private:
  std::vector<Telemetry*> sinks_;
  std::uint64_t published_ = 0;
};

/// Escapes `text` for a JSON string literal (without the quotes).
[[nodiscard]] std::string json_escape(std::string_view text);

/// The HostServices implementation. Everything is borrowed (see the file comment).
class RuntimeHost final : public HostServices {
 public:
  RuntimeHost(PluginLoader& loader, Logger& logger, const Clock& clock);

  Logger& logger() override { return *logger_; }
  const Clock& clock() override { return *clock_; }
  /// Creates a detector through the loader. The returned object must be destroyed before
  /// the loader (plain unique_ptr; the library stays loaded as long as the loader lives).
  Result<std::unique_ptr<Detector>> create_detector(std::string_view type, const ConfigNode& params) override;

  FrameBus* frame_bus() override { return frame_bus_; }
  Robot* robot() override { return robot_; }
  Telemetry* telemetry() override { return telemetry_; }
  Detector* active_detector() override { return detector_; }
  MapStore* map() override { return map_; }
  /// The mount of the camera given to set_camera(); without a camera: "no camera mount: not
  /// running"; a camera that declares none: "camera 'v4l2' (config.yaml:12) declares no mount:
  /// add hfov_deg, mount_height_m, mount_pitch_down_deg to camera.params" (code `missing`).
  Result<CameraMount> camera_mount() override;

  void set_clock(const Clock& clock) { clock_ = &clock; }
  void set_frame_bus(FrameBus* bus) { frame_bus_ = bus; }
  void set_robot(Robot* robot) { robot_ = robot; }
  void set_telemetry(Telemetry* telemetry) { telemetry_ = telemetry; }
  void set_active_detector(Detector* detector) { detector_ = detector; }
  void set_map(MapStore* map) { map_ = map; }
  /// The run's camera (borrowed; nullptr: none) and how errors name it: its type and where its
  /// config is, e.g. "camera 'v4l2' (config.yaml:12)".
  void set_camera(Camera* camera, std::string described) {
    camera_ = camera;
    camera_described_ = std::move(described);
  }
  [[nodiscard]] PluginLoader& loader() { return *loader_; }

 private:
  PluginLoader* loader_;
  Logger* logger_;
  const Clock* clock_;
  FrameBus* frame_bus_ = nullptr;
  Robot* robot_ = nullptr;
  Telemetry* telemetry_ = nullptr;
  Detector* detector_ = nullptr;
  MapStore* map_ = nullptr;
  Camera* camera_ = nullptr;
  std::string camera_described_;
};

}  // namespace visnav
