// visnav simulator — pinhole renderer of a World.
//
// Camera model: pinhole, square pixels, no distortion. fx = fy = (width/2) / tan(hfov/2),
// principal point at the image centre cx = (width-1)/2, cy = (height-1)/2; pixel (u, v) has
// its centre at integer coordinates, u right, v down. The camera frame is OpenCV's
// (x right, y down, z forward). The camera is mounted on the robot at (forward_m, lateral_m
// (left positive), height_m) in the robot frame, looking along the robot's +x, tilted down
// by pitch_down_deg, with zero roll (the renderer relies on zero roll: every image row maps
// to a straight line on the ground at constant depth).
//
// Rendering: sky gradient and ground are ray-cast row by row (per row one ray-plane
// intersection, then the ground point is linear in u); ground regions come from the world's
// rasterised region map; walls are rasterised as convex polygons with perspective-correct
// texturing and an inverse-depth buffer; obstacle tops (World::caps) likewise, into the same
// buffer, when the camera is above them. Textures are mip-mapped, nearest-texel lookup.
// Optional label render: LabelClass per pixel (CV_8UC1) and object ids (CV_16UC1: 0 sky,
// 1..R ground region index+1, 0x7FFF default ground, 0x8000 + wall index for walls; an
// obstacle's top carries the id of the obstacle's first wall).
//
// Ownership/threads: a Renderer holds a shared_ptr to its World and its own scratch buffers;
// render() reuses them and the caller's output Mats (no allocation once sizes are stable).
// One Renderer must not be used from two threads at once; separate Renderers may share a World.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/matx.hpp>
#include <opencv2/core/types.hpp>

#include "visnav/result.hpp"
#include "visnav/types.hpp"
#include "visnav_sim/world.hpp"

namespace visnav::sim {

struct CameraModel {
  int width_px = 320;
  int height_px = 240;
  double hfov_deg = 60.0;
  double height_m = 0.5;         ///< mount height above the ground
  double pitch_down_deg = 5.0;   ///< downward tilt of the optical axis
  double forward_m = 0.0;        ///< mount offset forward of the robot origin
  double lateral_m = 0.0;        ///< mount offset to the left of the robot origin
  double max_range_m = 300.0;    ///< ground farther than this is drawn in the horizon colour; <= 1000
                                 ///< (texel coordinates stay in int range for worlds within ±10 km)

  [[nodiscard]] double fx() const;
  [[nodiscard]] double cx() const { return (width_px - 1) * 0.5; }
  [[nodiscard]] double cy() const { return (height_px - 1) * 0.5; }
  [[nodiscard]] Status validate() const;
};

/// Camera pose in the world: x_world = R_world_cam * x_cam + position_world.
struct CameraPose {
  cv::Matx33d R_world_cam;
  cv::Vec3d position_world;
};

/// Camera pose for a robot pose (world frame).
[[nodiscard]] CameraPose camera_pose(const CameraModel& model, const Pose2D& robot_pose_world);
/// Pixel of a world point, or nullopt if it is behind the camera (z_cam <= 1 mm).
/// The point may fall outside the image.
[[nodiscard]] std::optional<cv::Point2d> project(const CameraModel& model, const CameraPose& pose,
                                                 const cv::Vec3d& point_world);

/// World-fixed shadow stripes on the ground (e.g. shadows of a row of trees).
struct ShadowBands {
  double strength = 0.0;     ///< 0 = off; 1 = black shadows
  double period_m = 4.0;     ///< stripe period
  double width_m = 1.5;      ///< shadow width per period
  double direction_deg = 30.0;  ///< stripe normal direction (world)
};

struct RenderOptions {
  std::string season;        ///< "" = base textures; else textures' seasonal swaps apply
  ShadowBands shadows;
};

class Renderer {
 public:
  /// `world` must be non-null; `model` must validate().
  Renderer(std::shared_ptr<const World> world, CameraModel model, RenderOptions options = {});

  /// Renders the view from `robot_pose_world` into `bgr` (CV_8UC3, (re)allocated only if the
  /// size/type differs). `labels` (CV_8UC1 LabelClass) and `object_ids` (CV_16UC1) are
  /// filled when non-null. `time_s` (simulated seconds since the run started) places the
  /// world's moving obstacles (World::movers); static worlds look the same at any time.
  void render(const Pose2D& robot_pose_world, cv::Mat& bgr, cv::Mat* labels = nullptr,
              cv::Mat* object_ids = nullptr, double time_s = 0.0);

  [[nodiscard]] const CameraModel& model() const { return model_; }
  [[nodiscard]] const World& world() const { return *world_; }
  [[nodiscard]] const std::shared_ptr<const World>& world_ptr() const { return world_; }
  [[nodiscard]] const RenderOptions& options() const { return options_; }
  /// Where the moving obstacles are: by default their blind motion (MovingObstacle::offset_at);
  /// the sim camera of a run passes its robot's RobotCore::mover_offset so that yielding
  /// walkers are drawn where the robot's collision check has them. Empty = the default.
  using MoverOffsets = std::function<cv::Point2d(int mover, double time_s)>;
  void set_mover_offsets(MoverOffsets offsets) { mover_offsets_ = std::move(offsets); }

 private:
  template <bool kLabels, bool kShadows>
  void render_ground(const CameraPose& pose, cv::Mat& bgr, cv::Mat* labels, cv::Mat* ids);
  template <bool kLabels>
  void render_walls(const CameraPose& pose, cv::Mat& bgr, cv::Mat* labels, cv::Mat* ids, double time_s);
  template <bool kLabels>
  void render_caps(const CameraPose& pose, cv::Mat& bgr, cv::Mat* labels, cv::Mat* ids, double time_s);

  std::shared_ptr<const World> world_;
  MoverOffsets mover_offsets_;
  CameraModel model_;
  RenderOptions options_;
  std::vector<const Texture*> texture_for_id_;  // after the seasonal swap
  std::vector<const Texture*> region_texture_;  // index 0: default ground; r: regions[r-1]
  std::vector<std::uint8_t> region_label_;
  std::vector<float> inv_depth_;                // per pixel, walls and obstacle tops
  std::vector<cv::Vec3b> sky_row_;
  std::vector<std::uint8_t> shadow_lut_;        // 256 entries per shadow period, factor*255
  std::vector<std::uint16_t> fog_lut_;          // fog weight*256 per 0.25 m of depth
};

/// Binary mask (CV_8UC1, 255 where the label equals `label`).
void label_mask(const cv::Mat& labels, LabelClass label, cv::Mat& mask);
/// Colour visualisation of a label image.
void colorize_labels(const cv::Mat& labels, cv::Mat& bgr);

}  // namespace visnav::sim
