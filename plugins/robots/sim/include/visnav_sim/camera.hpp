// visnav simulator — the `sim` camera: renders the world from a simulated robot's pose at
// its current simulated time, then applies appearance changes and faults.
//
// Per grab (lock-step: the runtime has just called SimulationControl::step):
//  1. faults: with probability drop_probability the frame is dropped (grab returns nullopt);
//     but when more than 1.5 frame periods of simulated time passed since the last grab (the
//     robot's compute froze, SimulationControl::step jumped), the camera kept capturing
//     meanwhile: a drop then loses only the newest frame and the one a period earlier is
//     delivered (captured a period before t; the period is 1/frame_rate_hz, or with
//     frame_rate_hz 0 the usual time between grabs); with probability freeze_probability the previous image is returned again (new
//     timestamp and sequence, same pixels).
//  2. render at the robot's true pose at (t - latency_s) (RobotCore::pose_at); the frame's
//     timestamp is that capture time t - latency_s.
//  3. appearance: motion blur (horizontal box blur of |ω|·exposure·fx pixels plus a vertical
//     one for forward motion), gain/offset, per-channel colour gains, auto-exposure flicker
//     (the image is scaled by e^x, x an Ornstein-Uhlenbeck process of stationary std
//     exposure_jitter and time constant exposure_time_constant_s, advanced per rendered frame
//     by simulated time), Gaussian sensor noise; shadow bands and the season are applied by
//     the renderer.
// Random draws come from one generator seeded with `seed`: the same params, world and robot
// motion give bit-identical frames.
// frame_rate_hz > 0 limits frames to that rate of simulated time (grab returns nullopt when
// no frame is due); 0 renders one frame per grab.
//
// Ownership: each returned Frame owns its pixels (buffers are recycled from a small pool
// only once no returned Frame refers to them any more).
// Thread-safety: one thread at a time (as devices.hpp states).
#pragma once

#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "visnav/devices.hpp"
#include "visnav/host.hpp"
#include "visnav/params.hpp"
#include "visnav_sim/render.hpp"
#include "visnav_sim/robot.hpp"

namespace visnav::sim {

struct CameraParams {
  std::string world;   ///< world file/name; "" = the robot's world
  int width_px = 320;
  int height_px = 240;
  double hfov_deg = 60.0;
  double mount_height_m = 0.5;
  double mount_pitch_down_deg = 5.0;
  double mount_forward_m = 0.0;
  double mount_lateral_m = 0.0;
  double max_range_m = 300.0;
  bool grey = false;              ///< deliver CV_8UC1 instead of BGR
  double frame_rate_hz = 0.0;
  // appearance
  double gain = 1.0;
  double offset = 0.0;            ///< added to every channel (0..255 scale)
  std::vector<double> color_gain_bgr{1.0, 1.0, 1.0};
  double shadow_strength = 0.0;
  double shadow_period_m = 4.0;
  double shadow_width_m = 1.5;
  double shadow_direction_deg = 30.0;
  std::string season;             ///< "" = base textures
  double noise_std = 0.0;         ///< Gaussian sensor noise, grey levels
  double exposure_jitter = 0.0;   ///< std of log brightness of the auto-exposure flicker; 0 = off
  double exposure_time_constant_s = 2.0;
  double motion_blur_exposure_s = 0.0;  ///< 0 = no motion blur
  // faults
  double drop_probability = 0.0;
  double freeze_probability = 0.0;
  double latency_s = 0.0;
  int seed = 1;

  [[nodiscard]] Status validate() const;
  static const ParamSchema<CameraParams>& schema();
  [[nodiscard]] CameraModel model() const;
  [[nodiscard]] RenderOptions render_options() const;
  /// The mount these params render from (hfov_deg, mount_*): what HostServices::camera_mount()
  /// reports during a simulated run, so the navigation sees the camera the renderer uses.
  [[nodiscard]] CameraMount mount() const;
};

/// Appearance + fault pipeline around a Renderer, bound to one RobotCore.
class CameraCore {
 public:
  CameraCore(CameraParams params, std::shared_ptr<RobotCore> robot, std::shared_ptr<const World> world);
  /// Renders the next frame (see the file comment); nullopt for dropped/not-due frames.
  std::optional<Frame> grab();
  /// Renders the label image for the pose the last frame was rendered from (CV_8UC1 LabelClass).
  void last_labels(cv::Mat& labels);
  [[nodiscard]] const CameraParams& params() const { return params_; }
  [[nodiscard]] Renderer& renderer() { return renderer_; }
  [[nodiscard]] Pose2D last_pose() const { return last_pose_; }

 private:
  cv::Mat take_buffer(int type);
  void apply_appearance(cv::Mat& bgr, const Twist& twist);

  CameraParams params_;
  std::shared_ptr<RobotCore> robot_;
  Renderer renderer_;
  std::mt19937_64 rng_;
  std::uint64_t sequence_ = 0;
  double next_frame_s_ = 0.0;
  double last_grab_s_ = -1.0;     // simulated time of the last grab that was due (< 0: none yet)
  double grab_interval_s_ = 0.0;  // frame_rate_hz 0: the usual time between grabs (0: unknown)
  cv::Mat render_buffer_;
  cv::Mat blur_buffer_;
  cv::Mat noise_buffer_;
  cv::Mat tone_lut_;  // gain/offset/colour gains; empty when they are neutral
  std::vector<cv::Mat> pool_;
  cv::Mat last_image_;
  double exposure_log_ = 0.0;       // OU state of the auto-exposure flicker
  double exposure_time_s_ = -1.0;   // simulated time of its last update (< 0: not started)
  Pose2D last_pose_;
  double last_time_s_ = 0.0;  // capture time of the last rendered frame (moving obstacles)
  bool have_last_ = false;
};

/// The `sim` camera plugin object. It rides on the run's robot, which must be a `sim` robot:
/// created through the plugin it finds that robot through HostServices::robot() (at creation
/// when the host already has it, else at the first grab, so config order does not matter); made
/// in-process it is given the robot's core. No process-wide state: two runs in one process each
/// render their own robot.
class SimCamera final : public Camera {
 public:
  using Params = CameraParams;
  /// Every problem create() would find in a params block, without building anything: the
  /// schema, validate() and the `world` file (resolved against the block's file, opened and
  /// parsed; errors at the key 'world'). create() runs the same checks first.
  static std::vector<Error> check_params(const ConfigNode& params);
  /// The plugin factory: rides on `host.robot()`. `host` must outlive the camera (HostServices
  /// contract).
  static Result<std::unique_ptr<SimCamera>> create(const ConfigNode& params, HostServices& host);
  /// In-process use (tools, tests): rides on `robot` (shared; kept alive by the camera).
  static Result<std::unique_ptr<SimCamera>> create(const CameraParams& params, std::shared_ptr<RobotCore> robot,
                                                   const std::string& relative_to = {});
  Result<std::optional<Frame>> grab(double timeout_s) override;
  Status reconfigure(const ConfigNode& params) override;
  /// Always declared: the params' mount (CameraParams::mount(); defaults when not given).
  [[nodiscard]] std::optional<CameraMount> mount() const override { return params_.mount(); }
  /// The bound core, or nullptr before the robot was found.
  [[nodiscard]] CameraCore* core() { return core_.get(); }

 private:
  SimCamera(CameraParams params, std::string relative_to, std::shared_ptr<RobotCore> robot, HostServices* host)
      : params_(std::move(params)), relative_to_(std::move(relative_to)), robot_(std::move(robot)), host_(host) {}
  static Result<std::unique_ptr<SimCamera>> make(const CameraParams& params, std::shared_ptr<RobotCore> robot,
                                                 HostServices* host, const std::string& relative_to);
  Status bind();
  CameraParams params_;
  std::string relative_to_;
  std::shared_ptr<RobotCore> robot_;  // set at bind() (or given)
  HostServices* host_ = nullptr;      // plugin-made cameras only; outlives the camera
  std::unique_ptr<CameraCore> core_;
};

}  // namespace visnav::sim
