// visnav SDK — interfaces implemented by robot, camera and detector plugins.
//
// Ownership: the runtime owns every plugin object (std::unique_ptr) and destroys it
// before unloading the library that made it.
// Thread-safety: unless a method says otherwise, the runtime calls a plugin object
// from one thread at a time (the tick thread). Plugins that receive data on their own
// threads (drivers, DDS callbacks) must make `latest_odometry()`/`grab()` thread-safe.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include "visnav/config_node.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav {

/// Root of every object a plugin factory makes.
class PluginObject {
 public:
  virtual ~PluginObject() = default;

  /// Applies changed parameters without recreating the object (live config reload).
  /// `params` is the full new `params:` block. Objects that cannot reconfigure return
  /// an error; the runtime then keeps the old object and logs the reason.
  virtual Status reconfigure(const ConfigNode& params) {
    (void)params;
    return fail("this plugin does not support live reconfiguration");
  }
};

/// Hooks only a simulated robot offers. Evaluation code (experiments, tests) reads
/// ground truth here; navigation code must never call `ground_truth_pose()`.
/// A contact of a simulated robot's body with an obstacle (walls, fences, tree trunks, posts).
struct SimCollision {
  double time_s = 0.0;      ///< simulated time of the first contact
  Pose2D pose_world;        ///< true pose at the contact (the robot is stopped there)
  std::string obstacle;     ///< name of the world object hit
};

class SimulationControl {
 public:
  virtual ~SimulationControl() = default;
  /// Advances the simulation by dt_s seconds of simulated time (lock-step mode).
  virtual Status step(double dt_s) = 0;
  /// Current simulated time, s.
  [[nodiscard]] virtual double time_s() const = 0;
  /// True pose in the world frame.
  [[nodiscard]] virtual Pose2D ground_truth_pose() const = 0;
  /// Teleports the robot (world frame); odometry keeps integrating from its current value.
  virtual Status set_ground_truth_pose(const Pose2D& pose_world) = 0;
  /// Every collision since the robot was created, oldest first (evaluation only; the
  /// navigation never sees it). Default: a simulator without collision detection.
  [[nodiscard]] virtual std::vector<SimCollision> collisions() const { return {}; }
};

/// A mobile base: takes velocity commands, reports odometry.
class Robot : public PluginObject {
 public:
  /// Commands a velocity; the robot holds it until the next command or its own
  /// command watchdog expires. Errors mean the command could not be delivered.
  virtual Status send_command(const Twist& command) = 0;
  /// Newest odometry reading, or nullopt if none has arrived yet.
  [[nodiscard]] virtual std::optional<Odometry> latest_odometry() = 0;
  /// Brings the robot to a stop (default: a zero command).
  virtual Status stop() { return send_command(Twist{}); }
  /// Non-null for simulated robots; the pointer lives as long as the robot.
  virtual SimulationControl* simulation() { return nullptr; }
};

/// Where the camera sits on the robot and what it sees: a pinhole with a centred principal point.
/// Robot frame: x forward, y left, z up; the lens is at (forward_m, lateral_m, height_m) and looks
/// along the robot's heading, tilted down by pitch_down_deg. A camera declares it in its config's
/// `params:` (camera_mount.hpp); nodes read it through HostServices::camera_mount().
struct CameraMount {
  double hfov_deg = 0.0;        ///< horizontal field of view, (1, 179) deg
  double height_m = 0.0;        ///< lens height above the ground, > 0
  double pitch_down_deg = 0.0;  ///< downward tilt of the optical axis, (-89, 89) deg
  double forward_m = 0.0;       ///< lens ahead of the robot origin
  double lateral_m = 0.0;       ///< lens left of the robot origin
  /// ok(), or an out_of_range error naming the bad field and its value
  /// ("camera mount: hfov_deg 0 is out of range (1, 179)", where.key = "hfov_deg").
  [[nodiscard]] Status validate() const;
};

/// A source of images.
class Camera : public PluginObject {
 public:
  /// The mount declared in this camera's config, or nullopt when the config declares none.
  /// A returned mount is valid (CameraMount::validate()). Default: none.
  [[nodiscard]] virtual std::optional<CameraMount> mount() const { return std::nullopt; }

  /// Waits at most `timeout_s` for a frame newer than the previous one returned.
  /// Returns nullopt on timeout, an error when the source failed or ended
  /// (message names the device/file). Simulated cameras render immediately.
  virtual Result<std::optional<Frame>> grab(double timeout_s) = 0;
};

/// Norm to compare descriptors with.
enum class DescriptorNorm { hamming, l2 };

/// Keypoints with descriptors (one row per keypoint, CV_8U for binary, CV_32F for float).
struct Features {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  DescriptorNorm norm = DescriptorNorm::hamming;

  void clear() { keypoints.clear(); descriptors.release(); }
};

/// Keypoint detector + descriptor extractor.
class Detector : public PluginObject {
 public:
  /// Detects and describes features in `image` (grey CV_8UC1 or BGR CV_8UC3),
  /// reusing `out`'s buffers. An empty or unusable image is an error, not a crash;
  /// an image without features yields an empty `out` and ok().
  virtual Status detect(const cv::Mat& image, Features& out) = 0;
  [[nodiscard]] virtual DescriptorNorm norm() const = 0;
};

}  // namespace visnav
