// The `sim` camera: renderer + appearance changes + faults, bound to a RobotCore.
#include "visnav_sim/camera.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>


namespace visnav::sim {

Status CameraParams::validate() const {
  VISNAV_TRY(model().validate());
  VISNAV_TRY(mount().validate());  // the schema's ranges lie inside the mount's; kept in step here
  if (color_gain_bgr.size() != 3)
    return fail("key 'color_gain_bgr': expected 3 values b;g;r, got " + std::to_string(color_gain_bgr.size()));
  for (double g : color_gain_bgr)
    if (!(g >= 0.0 && g <= 4.0)) return fail("key 'color_gain_bgr': values must be in [0, 4]");
  if (shadow_width_m >= shadow_period_m) return fail("key 'shadow_width_m': must be smaller than shadow_period_m");
  return ok();
}

const ParamSchema<CameraParams>& CameraParams::schema() {
  static const auto s =
      ParamSchema<CameraParams>{}
          .field("world", &CameraParams::world, "world file or name; empty = the robot's world")
          .field("width_px", &CameraParams::width_px, "image width, px").range(8, 8192)
          .field("height_px", &CameraParams::height_px, "image height, px").range(8, 8192)
          .field("hfov_deg", &CameraParams::hfov_deg, "horizontal field of view, deg").range(5, 170)
          .field("mount_height_m", &CameraParams::mount_height_m, "camera height above the ground, m").range(0.02, 20)
          .field("mount_pitch_down_deg", &CameraParams::mount_pitch_down_deg, "downward tilt of the optical axis, deg").range(-60, 60)
          .field("mount_forward_m", &CameraParams::mount_forward_m, "mount offset forward of the robot origin, m").range(-5, 5)
          .field("mount_lateral_m", &CameraParams::mount_lateral_m, "mount offset left of the robot origin, m").range(-5, 5)
          .field("max_range_m", &CameraParams::max_range_m, "ground beyond this distance is drawn as horizon, m").range(2, 1000)
          .field("grey", &CameraParams::grey, "deliver 8-bit grey frames instead of BGR")
          .field("frame_rate_hz", &CameraParams::frame_rate_hz, "frames per second of simulated time; 0 = one per grab").range(0, 1000)
          .field("gain", &CameraParams::gain, "illumination gain").range(0, 8)
          .field("offset", &CameraParams::offset, "illumination offset, grey levels").range(-255, 255)
          .field("color_gain_bgr", &CameraParams::color_gain_bgr, "per-channel colour gains b;g;r (colour shift)")
          .field("shadow_strength", &CameraParams::shadow_strength, "darkness of world-fixed shadow bands on the ground, 0 = off").range(0, 1)
          .field("shadow_period_m", &CameraParams::shadow_period_m, "shadow band period, m").range(0.1, 1000)
          .field("shadow_width_m", &CameraParams::shadow_width_m, "shadow band width, m").range(0.01, 1000)
          .field("shadow_direction_deg", &CameraParams::shadow_direction_deg, "direction of the band normal in the world, deg").range(-360, 360)
          .field("season", &CameraParams::season, "texture season (world textures' `seasons:`); empty = base")
          .field("noise_std", &CameraParams::noise_std, "Gaussian sensor noise std, grey levels").range(0, 100)
          .field("exposure_jitter", &CameraParams::exposure_jitter, "auto-exposure flicker: std of the log image brightness; 0 = off").range(0, 1)
          .field("exposure_time_constant_s", &CameraParams::exposure_time_constant_s, "auto-exposure flicker time constant, s").range(0.01, 1000)
          .field("motion_blur_exposure_s", &CameraParams::motion_blur_exposure_s, "exposure time for motion blur, s; 0 = off").range(0, 1)
          .field("drop_probability", &CameraParams::drop_probability, "probability that a frame is dropped").range(0, 1)
          .field("freeze_probability", &CameraParams::freeze_probability, "probability that the previous image is repeated").range(0, 1)
          .field("latency_s", &CameraParams::latency_s, "frames show the world this long ago, s").range(0, 10)
          .field("seed", &CameraParams::seed, "seed of faults and noise").range(0, 2147483647);
  return s;
}

CameraModel CameraParams::model() const {
  CameraModel m;
  m.width_px = width_px;
  m.height_px = height_px;
  m.hfov_deg = hfov_deg;
  m.height_m = mount_height_m;
  m.pitch_down_deg = mount_pitch_down_deg;
  m.forward_m = mount_forward_m;
  m.lateral_m = mount_lateral_m;
  m.max_range_m = max_range_m;
  return m;
}

CameraMount CameraParams::mount() const {
  CameraMount m;
  m.hfov_deg = hfov_deg;
  m.height_m = mount_height_m;
  m.pitch_down_deg = mount_pitch_down_deg;
  m.forward_m = mount_forward_m;
  m.lateral_m = mount_lateral_m;
  return m;
}

RenderOptions CameraParams::render_options() const {
  RenderOptions o;
  o.season = season;
  o.shadows.strength = shadow_strength;
  o.shadows.period_m = shadow_period_m;
  o.shadows.width_m = shadow_width_m;
  o.shadows.direction_deg = shadow_direction_deg;
  return o;
}

CameraCore::CameraCore(CameraParams params, std::shared_ptr<RobotCore> robot, std::shared_ptr<const World> world)
    : params_(std::move(params)),
      robot_(std::move(robot)),
      renderer_(std::move(world), params_.model(), params_.render_options()),
      rng_(static_cast<std::uint64_t>(params_.seed) * 0x9E3779B97F4A7C15ULL + 1) {
  const bool tone = params_.gain != 1.0 || params_.offset != 0.0 || params_.color_gain_bgr[0] != 1.0 ||
                    params_.color_gain_bgr[1] != 1.0 || params_.color_gain_bgr[2] != 1.0;
  // Moving obstacles where the robot's collision check has them (yielding walkers, movers.hpp).
  if (robot_) {
    const World* shown = &renderer_.world();
    renderer_.set_mover_offsets([robot = robot_.get(), shown](int mover, double time_s) {
      return robot->mover_offset(shown, mover, time_s);
    });
  }
  if (tone) {
    tone_lut_.create(1, 256, CV_8UC3);
    for (int i = 0; i < 256; ++i)
      for (int c = 0; c < 3; ++c)
        tone_lut_.at<cv::Vec3b>(0, i)[c] =
            cv::saturate_cast<unsigned char>(i * params_.gain * params_.color_gain_bgr[static_cast<size_t>(c)] + params_.offset);
  }
}

cv::Mat CameraCore::take_buffer(int type) {
  const cv::Size size(params_.width_px, params_.height_px);
  for (auto& m : pool_)
    if (m.u != nullptr && m.u->refcount == 1 && m.type() == type && m.size() == size) return m;
  cv::Mat fresh(size, type);
  if (pool_.size() < 8) pool_.push_back(fresh);
  return fresh;
}

void CameraCore::apply_appearance(cv::Mat& bgr, const Twist& twist) {
  if (params_.motion_blur_exposure_s > 0.0) {
    const double f = params_.model().fx();
    const int kh = static_cast<int>(std::lround(std::abs(twist.angular_radps) * params_.motion_blur_exposure_s * f));
    const int kv = static_cast<int>(std::lround(std::abs(twist.linear_mps) * params_.motion_blur_exposure_s * f / 4.0));
    if (kh > 1 || kv > 1) cv::blur(bgr, bgr, cv::Size(std::max(1, kh), std::max(1, kv)));
  }
  if (!tone_lut_.empty()) cv::LUT(bgr, tone_lut_, bgr);
  if (params_.exposure_jitter > 0.0) {
    const double brightness = std::exp(exposure_log_);
    bgr.convertTo(bgr, -1, brightness, 0.0);
  }
  if (params_.noise_std > 0.0) {
    cv::RNG rng(rng_());
    noise_buffer_.create(bgr.size(), CV_16SC3);
    rng.fill(noise_buffer_, cv::RNG::NORMAL, 0.0, params_.noise_std);
    cv::add(bgr, noise_buffer_, bgr, cv::noArray(), CV_8U);
  }
}

std::optional<Frame> CameraCore::grab() {
  const double now = robot_->time_s();
  double capture_s = now;
  double period = 0.0;  // frame period: the rate's, or with one frame per grab the grabs' cadence
  if (params_.frame_rate_hz > 0.0) {
    if (now + 1e-9 < next_frame_s_) return std::nullopt;
    period = 1.0 / params_.frame_rate_hz;
    while (next_frame_s_ <= now + 1e-9) next_frame_s_ += period;
  } else {
    period = grab_interval_s_;
  }
  // The caller stalled (a compute freeze) for frames the camera kept capturing meanwhile.
  const bool frames_missed = last_grab_s_ >= 0.0 && period > 0.0 && now - last_grab_s_ > 1.5 * period;
  if (last_grab_s_ >= 0.0 && !frames_missed && now > last_grab_s_) grab_interval_s_ = now - last_grab_s_;
  last_grab_s_ = now;
  // fixed number of draws per grab keeps the random stream independent of the outcomes
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const double drop_draw = uni(rng_);
  const double freeze_draw = uni(rng_);
  const std::uint64_t noise_seed = rng_();
  const std::uint64_t sequence = sequence_++;
  if (drop_draw < params_.drop_probability) {
    if (!frames_missed) return std::nullopt;
    capture_s = now - period;  // the newest frame is lost, the one before it is not
  }

  Frame frame;
  frame.sequence = sequence;
  frame.timestamp_s = std::max(0.0, capture_s - params_.latency_s);
  if (have_last_ && freeze_draw < params_.freeze_probability) {
    frame.image = last_image_;
    return frame;
  }
  if (params_.exposure_jitter > 0.0) {
    // Exact OU step over the simulated time since the last rendered frame; the draw comes from
    // the frame's noise seed so the random stream stays one fixed draw count per grab.
    std::mt19937_64 exposure_rng(noise_seed ^ 0x5DEECE66DULL);
    std::normal_distribution<double> unit(0.0, 1.0);
    if (exposure_time_s_ < 0.0) {
      exposure_log_ = params_.exposure_jitter * unit(exposure_rng);
    } else {
      const double decay = std::exp(-std::max(0.0, now - exposure_time_s_) / params_.exposure_time_constant_s);
      exposure_log_ = exposure_log_ * decay + params_.exposure_jitter * std::sqrt(1.0 - decay * decay) * unit(exposure_rng);
    }
    exposure_time_s_ = now;
  }
  const Pose2D pose =
      params_.latency_s > 0.0 || capture_s < now ? robot_->pose_at(frame.timestamp_s) : robot_->ground_truth();
  cv::Mat out = take_buffer(params_.grey ? CV_8UC1 : CV_8UC3);
  cv::Mat& target = params_.grey ? render_buffer_ : out;
  renderer_.render(pose, target, nullptr, nullptr, frame.timestamp_s);  // moving obstacles where they were then
  std::mt19937_64 saved = rng_;
  rng_.seed(noise_seed);
  apply_appearance(target, robot_->true_twist());
  rng_ = saved;
  if (params_.grey) cv::cvtColor(render_buffer_, out, cv::COLOR_BGR2GRAY);
  last_image_ = out;
  last_pose_ = pose;
  last_time_s_ = frame.timestamp_s;
  have_last_ = true;
  frame.image = out;
  return frame;
}

void CameraCore::last_labels(cv::Mat& labels) {
  cv::Mat scratch;
  renderer_.render(last_pose_, scratch, &labels, nullptr, last_time_s_);
}

// ---------------------------------------------------------------------------------------

Status SimCamera::bind() {
  if (core_) return ok();
  std::shared_ptr<RobotCore> robot = robot_;
  if (!robot) {
    Robot* run_robot = host_ != nullptr ? host_->robot() : nullptr;
    if (run_robot == nullptr)
      return fail(ErrorCode::not_found, "sim camera: the run has no robot yet (the sim camera renders a `sim` robot's world)");
    // The host's robot may wrap the plugin's (the run's command guard); its simulation interface
    // is the sim robot itself.
    auto* sim_robot = dynamic_cast<SimRobot*>(run_robot->simulation());
    if (sim_robot == nullptr)
      return fail(ErrorCode::inconsistent, "sim camera: the run's robot is not a `sim` robot (the sim camera can only ride on one)");
    robot = sim_robot->core();
  }
  std::shared_ptr<const World> world = robot->world();
  if (!params_.world.empty()) {
    auto path = resolve_world_path(params_.world, relative_to_);
    if (!path) return path.error().with_context("sim camera: key 'world'");
    VISNAV_ASSIGN(world, load_world_cached(*path));
  }
  if (world == nullptr) return fail("sim camera: neither the camera nor the robot names a world (set 'world')");
  robot_ = robot;
  core_ = std::make_unique<CameraCore>(params_, std::move(robot), std::move(world));
  return ok();
}

Result<std::unique_ptr<SimCamera>> SimCamera::make(const CameraParams& params, std::shared_ptr<RobotCore> robot,
                                                   HostServices* host, const std::string& relative_to) {
  VISNAV_TRY(params.validate());
  std::unique_ptr<SimCamera> cam(new SimCamera(params, relative_to, std::move(robot), host));
  if (!params.world.empty()) {  // report a bad world now rather than at the first grab
    auto path = resolve_world_path(params.world, relative_to);
    if (!path) return path.error().with_context("key 'world'");
    VISNAV_TRY(load_world_cached(*path));
  }
  if (cam->robot_ || (host != nullptr && host->robot() != nullptr)) VISNAV_TRY(cam->bind());
  return cam;
}

Result<std::unique_ptr<SimCamera>> SimCamera::create(const CameraParams& params, std::shared_ptr<RobotCore> robot,
                                                     const std::string& relative_to) {
  if (!robot) return fail("sim camera: no robot to ride on");
  return make(params, std::move(robot), nullptr, relative_to);
}

std::vector<Error> SimCamera::check_params(const ConfigNode& params) {
  std::vector<Error> problems = CameraParams::schema().problems(params);
  if (!problems.empty()) return problems;
  auto p = CameraParams::schema().parse(params);
  if (p && !p->world.empty())
    if (auto st = check_world_file(p->world, params); !st) problems.push_back(std::move(st).error());
  return problems;
}

Result<std::unique_ptr<SimCamera>> SimCamera::create(const ConfigNode& params, HostServices& host) {
  if (auto problems = check_params(params); !problems.empty()) return std::move(problems.front());
  VISNAV_ASSIGN(CameraParams p, CameraParams::schema().parse(params));
  auto made = make(p, nullptr, &host, params.where().file);
  if (!made) return made.error().with_context(params.where().str());
  host.logger().info("sim camera", std::to_string(p.width_px) + "x" + std::to_string(p.height_px) + " hfov " +
                                       std::to_string(p.hfov_deg) + " deg" +
                                       ((*made)->core_ ? "" : " (robot not created yet; bound at the first grab)"));
  return made;
}

Result<std::optional<Frame>> SimCamera::grab(double timeout_s) {
  (void)timeout_s;  // simulated frames are rendered immediately
  VISNAV_TRY(bind());
  return core_->grab();
}

Status SimCamera::reconfigure(const ConfigNode& params) {
  VISNAV_ASSIGN(CameraParams p, CameraParams::schema().parse(params));
  VISNAV_TRY(p.validate());
  // Another world may be shown from now on (a replay in a changed or a wrong world); the robot
  // keeps driving (and colliding) in its own.
  std::shared_ptr<const World> world;
  if (p.world != params_.world && !p.world.empty()) {
    auto path = resolve_world_path(p.world, relative_to_);
    if (!path) return path.error().with_context("sim camera: key 'world'");
    VISNAV_ASSIGN(world, load_world_cached(*path));
  }
  const bool back_to_robot_world = p.world.empty() && !params_.world.empty();
  params_ = p;
  if (core_) {
    // Without a world of its own the camera shows the robot's, which may have changed (obstacles
    // placed for a replay).
    if (!world) world = back_to_robot_world || p.world.empty() ? robot_->world() : core_->renderer().world_ptr();
    if (world == nullptr) return fail("sim camera: no world to render");
    core_ = std::make_unique<CameraCore>(params_, robot_, world);
  }
  return ok();
}

}  // namespace visnav::sim
