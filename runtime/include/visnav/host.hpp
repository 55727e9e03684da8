// visnav SDK — services the runtime offers to plugins.
//
// Every factory, node registrar and plugin command receives a HostServices&.
// Lifetime: valid for as long as any object the plugin created lives.
// Thread-safety: `log()` and `clock()` may be called from any thread; the run
// accessors (`frame_bus()`, `robot()`, ...) only from the tick thread.
#pragma once

#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "visnav/config_node.hpp"
#include "visnav/devices.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav {

enum class LogLevel { debug, info, warn, error };

class Logger {
 public:
  virtual ~Logger() = default;
  virtual void log(LogLevel level, std::string_view component, std::string_view message) = 0;
  void info(std::string_view c, std::string_view m) { log(LogLevel::info, c, m); }
  void warn(std::string_view c, std::string_view m) { log(LogLevel::warn, c, m); }
  void error(std::string_view c, std::string_view m) { log(LogLevel::error, c, m); }
};

/// Time source of a run: wall time for real robots, simulated time in simulation.
class Clock {
 public:
  virtual ~Clock() = default;
  [[nodiscard]] virtual double now_s() const = 0;
};

/// Latest timestamped sensor values. Sensor callbacks write, the tick thread reads.
/// Thread-safe; copies are cheap (cv::Mat is reference counted).
class FrameBus {
 public:
  void publish_frame(Frame frame) {
    std::lock_guard lock(mutex_);
    frame_ = std::move(frame);
  }
  void publish_odometry(const Odometry& odometry) {
    std::lock_guard lock(mutex_);
    odometry_ = odometry;
  }
  [[nodiscard]] std::optional<Frame> latest_frame() const {
    std::lock_guard lock(mutex_);
    return frame_;
  }
  [[nodiscard]] std::optional<Odometry> latest_odometry() const {
    std::lock_guard lock(mutex_);
    return odometry_;
  }

 private:
  mutable std::mutex mutex_;
  std::optional<Frame> frame_;
  std::optional<Odometry> odometry_;
};

/// What a primitive saw in the frame a NavStatus is about, for the live view (`visnav run
/// --view`, docs/live_view.md). Image coordinates in px of that frame (u right, v down).
/// Non-owning: the spans and the mask belong to the primitive and are valid only during the
/// Telemetry::publish() call that carries them; a sink that keeps them copies them.
struct NavOverlay {
  std::span<const cv::Point2f> matched_px;    ///< current-frame features that voted (feature primitives)
  std::span<const cv::Point2f> reference_px;  ///< where each was taught (same order; may be empty)
  std::span<const std::uint8_t> inlier;       ///< 1 = inside the winning heading bin (same order; may be empty)
  std::span<const int> histogram;             ///< heading-histogram votes per bin (may be empty)
  double histogram_bin_px = 0.0;              ///< bin width; bin i is centred on (i - size/2) * bin px
  double offset_px = 0.0;                     ///< the chosen offset (current minus taught, + = right)
  cv::Mat path_mask;                          ///< CV_8UC1, frame size, 255 = path (path following); may be empty
  std::span<const cv::Point2f> path_middle_px;  ///< the path's centre line, one point per row (may be empty)
};

/// Per-tick navigation status, published as JSON lines and on the DDS telemetry topic.
struct NavStatus {
  std::string node_path;      ///< behaviour-tree path of the active primitive
  std::string map_node;       ///< current map node name (empty if none)
  std::string edge;           ///< current map edge id (empty if none)
  double distance_m = 0.0;    ///< distance travelled along the edge
  int matches = 0;
  int inliers = 0;
  double offset_px = 0.0;     ///< horizontal image offset estimate
  Twist command;              ///< command sent this tick
  double confidence = 0.0;    ///< window-mean confidence of the primitive, [0, 1] (nav_health.hpp)
  double blind_m = 0.0;       ///< odometric distance since the route was last seen
  std::string status;         ///< short human-readable state ("replaying", "path lost", ...)
  /// What the primitive saw (NavOverlay), or nullptr; valid only during publish().
  const NavOverlay* overlay = nullptr;
};

class Telemetry {
 public:
  virtual ~Telemetry() = default;
  virtual void publish(const NavStatus& status) = 0;
};

class MapStore;  // visnav/map.hpp

/// Services of the host runtime.
class HostServices {
 public:
  virtual ~HostServices() = default;

  virtual Logger& logger() = 0;
  virtual const Clock& clock() = 0;

  /// Creates a detector of a registered type (e.g. "orb") from its params block.
  virtual Result<std::unique_ptr<Detector>> create_detector(std::string_view type, const ConfigNode& params) = 0;

  // --- Valid during `visnav run` (nullptr otherwise, e.g. while listing nodes). ---
  virtual FrameBus* frame_bus() { return nullptr; }
  virtual Robot* robot() { return nullptr; }
  virtual Telemetry* telemetry() { return nullptr; }
  /// The detector currently selected in config; swapped by live reload between ticks.
  virtual Detector* active_detector() { return nullptr; }
  /// The map named by `--map`, or nullptr.
  virtual MapStore* map() { return nullptr; }
  /// The active camera's mount (valid during `visnav run`); an error naming the camera config
  /// keys to add when the camera declares none, or when not running (code `missing` both ways).
  /// Ask when needed rather than once: a live reload may change the camera's params.
  virtual Result<CameraMount> camera_mount() { return fail(ErrorCode::missing, "no camera mount: not running"); }
};

}  // namespace visnav
