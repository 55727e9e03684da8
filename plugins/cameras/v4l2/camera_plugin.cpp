// The `camera_v4l2` plugin: camera type `v4l2` (docs/cameras.md).
//
// Creation (never hangs longer than open_timeout_s):
//  1. the device path is checked without blocking: missing → "v4l2 device '/dev/video0' does not
//     exist (no V4L2 device ...)", not a character device, no permission (open(O_NONBLOCK)), not a
//     V4L2 device (VIDIOC_QUERYCAP fails), not a capture device — each an error naming the path;
//  2. cv::VideoCapture(path, CAP_V4L2) is opened on a helper thread; if it does not finish within
//     open_timeout_s the error says so (the helper thread is left to finish on its own and owns
//     everything it touches);
//  3. resolution, frame rate and pixel format are requested; what the device granted is logged;
//  4. exposure/gain are set through V4L2 controls (V4L2_CID_EXPOSURE_AUTO, _EXPOSURE_ABSOLUTE,
//     V4L2_CID_GAIN) where the device has them; otherwise a warning names the missing control.
// Capture: a thread reads frames continuously and keeps the newest one (stamped with the run
// clock at capture); grab(timeout_s) waits at most timeout_s for a frame newer than the last one
// returned. A read failure (unplugged camera) makes grab() return an error naming the device.
// Adaptive exposure (exposure_mode adaptive): after each frame the AdaptiveExposure controller
// (exposure.hpp) moves the exposure towards target_brightness; the capture thread applies it.
// Thread-safety: grab() from one thread; the capture thread only touches the shared slot under
// its mutex.
#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <future>
#include <mutex>
#include <thread>

#include <opencv2/videoio.hpp>

#include "visnav/camera_mount.hpp"
#include "visnav/plugin.hpp"
#include "visnav/recorded/exposure.hpp"
#include "visnav/recorded/image_pipeline.hpp"

namespace {

using namespace visnav;
using namespace visnav::recorded;

struct V4l2Params : ImageOptions, CameraMountOptions {  // + the image pipeline keys (add_image_fields) and the mount
  std::string device = "/dev/video0";
  int width_px = 640;
  int height_px = 480;
  double frame_rate_hz = 30.0;
  std::string pixel_format;  // "" = driver default, else a FOURCC like MJPG or YUYV
  std::string exposure_mode = "auto";
  int exposure = 0;          // device units (V4L2 exposure_time_absolute: 100 µs); 0 = leave
  int gain = -1;             // device units; -1 = leave
  double target_brightness = 110.0;
  double brightness_tolerance = 8.0;
  double exposure_control_gain = 0.6;
  int min_exposure = 1;
  int max_exposure = 2000;
  double open_timeout_s = 5.0;

  [[nodiscard]] Status validate() const {
    if (device.empty()) return Error{"key 'device' is required (e.g. /dev/video0)", ErrorCode::missing, {{}, 0, "device"}};
    if (!pixel_format.empty() && pixel_format.size() != 4) return fail(ErrorCode::invalid_value, {{}, 0, "pixel_format"}, "a FOURCC of 4 characters (MJPG, YUYV), got '" + pixel_format + "'");
    if (min_exposure > max_exposure) return fail(ErrorCode::inconsistent, {{}, 0, "min_exposure"}, "must not exceed max_exposure");
    VISNAV_TRY(CameraMountOptions::validate());
    return ImageOptions::validate();
  }
  static const ParamSchema<V4l2Params>& schema() {
    static const auto s = [] {
      ParamSchema<V4l2Params> p;
      p.field("device", &V4l2Params::device, "V4L2 device path")
          .field("width_px", &V4l2Params::width_px, "requested image width, px (the device may grant another)").range(16, 8192)
          .field("height_px", &V4l2Params::height_px, "requested image height, px").range(16, 8192)
          .field("frame_rate_hz", &V4l2Params::frame_rate_hz, "requested frame rate, Hz").range(0.1, 1000)
          .field("pixel_format", &V4l2Params::pixel_format, "FOURCC (MJPG, YUYV, ...); '' = driver default")
          .field("exposure_mode", &V4l2Params::exposure_mode,
                 "auto: the camera's auto exposure; manual: fixed `exposure`; adaptive: visnav aims at target_brightness")
          .one_of({"auto", "manual", "adaptive"})
          .field("exposure", &V4l2Params::exposure, "manual exposure / adaptive start, device units (exposure_time_absolute: 100 us); 0 = leave").range(0, 1000000)
          .field("gain", &V4l2Params::gain, "sensor gain, device units; -1 = leave").range(-1, 100000)
          .field("target_brightness", &V4l2Params::target_brightness, "adaptive: mean grey level to aim at, 0..255").range(1, 254)
          .field("brightness_tolerance", &V4l2Params::brightness_tolerance, "adaptive: dead band around the target, grey levels").range(0, 100)
          .field("exposure_control_gain", &V4l2Params::exposure_control_gain, "adaptive: exponent of the correction per frame (1 = one step)").range(0.05, 1)
          .field("min_exposure", &V4l2Params::min_exposure, "adaptive: lowest exposure, device units").range(1, 1000000)
          .field("max_exposure", &V4l2Params::max_exposure, "adaptive: highest exposure, device units").range(1, 1000000)
          .field("open_timeout_s", &V4l2Params::open_timeout_s, "give up opening the device after this long, s").range(0.1, 60);
      add_image_fields(p);
      add_camera_mount_fields(p);
      return p;
    }();
    return s;
  }
};

std::string errno_text(int err) { return std::strerror(err); }

/// Non-blocking checks of the device node (step 1 of the file comment).
Status probe_device(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT)
      return fail(ErrorCode::not_found, {path, 0, "device"}, "v4l2 device does not exist (no V4L2 device found at that path; is the camera connected and its driver loaded?)");
    return fail(ErrorCode::io, {path, 0, "device"}, errno_text(errno));
  }
  if (!S_ISCHR(st.st_mode)) return fail(ErrorCode::invalid_value, {path, 0, "device"}, "not a character device (not a V4L2 device node)");
  const int fd = ::open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return fail(ErrorCode::io, {path, 0, "device"}, "cannot be opened: " + errno_text(errno));
  v4l2_capability cap {};
  const int rc = ::ioctl(fd, VIDIOC_QUERYCAP, &cap);
  const int err = errno;
  ::close(fd);
  if (rc != 0) return fail(ErrorCode::invalid_value, {path, 0, "device"}, "not a V4L2 device (VIDIOC_QUERYCAP: " + errno_text(err) + ")");
  const std::uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (!(caps & (V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_VIDEO_CAPTURE_MPLANE)))
    return fail(ErrorCode::invalid_value, {path, 0, "device"}, std::string("(") + reinterpret_cast<const char*>(cap.card) + ") is not a video capture device");
  return ok();
}

/// V4L2 controls on their own file descriptor.
class Controls {
 public:
  explicit Controls(const std::string& path) : fd_(::open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC)) {}
  ~Controls() {
    if (fd_ >= 0) ::close(fd_);
  }
  Controls(const Controls&) = delete;
  Controls& operator=(const Controls&) = delete;
  /// Sets a control, clamped to its range; error when the device lacks it.
  Result<int> set(std::uint32_t id, int value, const char* name) {
    if (fd_ < 0) return fail(std::string("control '") + name + "': device not open");
    v4l2_queryctrl q {};
    q.id = id;
    if (::ioctl(fd_, VIDIOC_QUERYCTRL, &q) != 0 || (q.flags & V4L2_CTRL_FLAG_DISABLED))
      return fail(std::string("the device has no control '") + name + "'");
    value = std::clamp(value, q.minimum, q.maximum);
    v4l2_control c {};
    c.id = id;
    c.value = value;
    if (::ioctl(fd_, VIDIOC_S_CTRL, &c) != 0) return fail(std::string("setting control '") + name + "' failed: " + errno_text(errno));
    return value;
  }

 private:
  int fd_;
};

class V4l2Camera final : public Camera {
 public:
  using Params = V4l2Params;

  static Result<std::unique_ptr<V4l2Camera>> create(const ConfigNode& node, HostServices& host) {
    VISNAV_ASSIGN(Params p, Params::schema().parse(node));
    const std::string base = config_folder(node.where().file);
    VISNAV_TRY(probe_device(p.device));
    VISNAV_ASSIGN(ImagePipeline pipeline, ImagePipeline::create(p, base));

    // Open on a helper thread so a wedged driver cannot hang the runtime.
    auto shared = std::make_shared<cv::VideoCapture>();
    auto opened = std::async(std::launch::async, [shared, p]() -> bool {
      try {
        if (!shared->open(p.device, cv::CAP_V4L2)) return false;
        if (!p.pixel_format.empty())
          shared->set(cv::CAP_PROP_FOURCC, cv::VideoWriter::fourcc(p.pixel_format[0], p.pixel_format[1], p.pixel_format[2], p.pixel_format[3]));
        shared->set(cv::CAP_PROP_FRAME_WIDTH, p.width_px);
        shared->set(cv::CAP_PROP_FRAME_HEIGHT, p.height_px);
        shared->set(cv::CAP_PROP_FPS, p.frame_rate_hz);
        return shared->isOpened();
      } catch (...) {
        return false;
      }
    });
    if (opened.wait_for(std::chrono::duration<double>(p.open_timeout_s)) != std::future_status::ready) {
      // Leave the helper running detached: hand the future to a thread that waits it out.
      std::thread([f = std::move(opened)]() mutable { f.wait(); }).detach();
      return fail(ErrorCode::io, {p.device, 0, "device"}, "did not open within open_timeout_s = " + std::to_string(p.open_timeout_s) + " s");
    }
    if (!opened.get()) return fail(ErrorCode::io, {p.device, 0, "device"}, "OpenCV's V4L2 backend could not open it (busy or unsupported format?)");

    std::unique_ptr<V4l2Camera> cam(new V4l2Camera(p, host, std::move(pipeline), std::move(shared)));
    cam->configure_controls();
    const int w = static_cast<int>(cam->capture_->get(cv::CAP_PROP_FRAME_WIDTH));
    const int h = static_cast<int>(cam->capture_->get(cv::CAP_PROP_FRAME_HEIGHT));
    const double fps = cam->capture_->get(cv::CAP_PROP_FPS);
    host.logger().info("camera_v4l2", p.device + ": " + std::to_string(w) + "x" + std::to_string(h) + " at " +
                                          std::to_string(fps) + " Hz (asked " + std::to_string(p.width_px) + "x" +
                                          std::to_string(p.height_px) + " at " + std::to_string(p.frame_rate_hz) + " Hz), exposure " +
                                          p.exposure_mode);
    cam->thread_ = std::thread([c = cam.get()] { c->capture_loop(); });
    return cam;
  }

  ~V4l2Camera() override {
    running_.store(false);
    if (thread_.joinable()) thread_.join();
  }
  V4l2Camera(const V4l2Camera&) = delete;
  V4l2Camera& operator=(const V4l2Camera&) = delete;

  [[nodiscard]] std::optional<CameraMount> mount() const override { return params_.mount(); }

  Result<std::optional<Frame>> grab(double timeout_s) override {
    std::unique_lock lock(mutex_);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                                   std::chrono::duration<double>(std::max(0.0, timeout_s)));
    cv_.wait_until(lock, deadline, [&] { return !error_.empty() || (latest_ && latest_->sequence > returned_); });
    if (latest_ && latest_->sequence > returned_) {
      returned_ = latest_->sequence;
      return std::optional<Frame>(*latest_);
    }
    if (!error_.empty()) return fail(error_);
    return std::optional<Frame>{};
  }

 private:
  V4l2Camera(Params p, HostServices& host, ImagePipeline pipeline, std::shared_ptr<cv::VideoCapture> capture)
      : params_(std::move(p)), host_(&host), pipeline_(std::move(pipeline)), capture_(std::move(capture)),
        controls_(params_.device),
        exposure_(ExposureControlParams{params_.target_brightness, params_.brightness_tolerance, params_.exposure_control_gain, 2.0,
                                        static_cast<double>(params_.min_exposure), static_cast<double>(params_.max_exposure)},
                  params_.exposure > 0 ? params_.exposure : (params_.min_exposure + params_.max_exposure) / 4.0) {}

  void configure_controls() {
    Logger& log = host_->logger();
    if (params_.gain >= 0)
      if (auto r = controls_.set(V4L2_CID_GAIN, params_.gain, "gain"); !r) log.warn("camera_v4l2", params_.device + ": " + r.error().message);
    if (params_.exposure_mode == "auto") {
      if (auto r = controls_.set(V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_APERTURE_PRIORITY, "auto_exposure"); !r)
        (void)controls_.set(V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_AUTO, "auto_exposure");
      return;
    }
    if (auto r = controls_.set(V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_MANUAL, "auto_exposure"); !r)
      log.warn("camera_v4l2", params_.device + ": " + r.error().message + "; manual/adaptive exposure may have no effect");
    const int start = static_cast<int>(exposure_.exposure());
    if (params_.exposure_mode == "manual" && params_.exposure == 0) return;
    auto r = controls_.set(V4L2_CID_EXPOSURE_ABSOLUTE, params_.exposure_mode == "manual" ? params_.exposure : start, "exposure_time_absolute");
    if (!r) {
      log.warn("camera_v4l2", params_.device + ": " + r.error().message + "; exposure stays as the device chooses");
      exposure_supported_ = false;
    }
  }

  void capture_loop() {
    cv::Mat raw;
    std::uint64_t sequence = 0;
    while (running_.load()) {
      bool got = false;
      try {
        got = capture_->read(raw);
      } catch (const cv::Exception& e) {
        set_error("v4l2 device '" + params_.device + "': read failed: " + e.what());
        return;
      }
      if (!running_.load()) return;
      if (!got || raw.empty()) {
        set_error("v4l2 device '" + params_.device + "': no frame (device unplugged or stream stopped)");
        return;
      }
      Frame frame;
      frame.timestamp_s = host_->clock().now_s();
      frame.sequence = ++sequence;
      if (auto st = pipeline_.apply(raw, frame.image); !st) {
        set_error("v4l2 device '" + params_.device + "': " + st.error().message);
        return;
      }
      if (params_.exposure_mode == "adaptive" && exposure_supported_) {
        const double before = exposure_.exposure();
        const double after = exposure_.update(AdaptiveExposure::mean_brightness(raw));
        if (static_cast<int>(after) != static_cast<int>(before))
          (void)controls_.set(V4L2_CID_EXPOSURE_ABSOLUTE, static_cast<int>(after), "exposure_time_absolute");
      }
      {
        std::lock_guard lock(mutex_);
        latest_ = std::move(frame);
      }
      cv_.notify_all();
    }
  }

  void set_error(std::string message) {
    {
      std::lock_guard lock(mutex_);
      error_ = std::move(message);
    }
    cv_.notify_all();
  }

  Params params_;
  HostServices* host_;
  ImagePipeline pipeline_;
  std::shared_ptr<cv::VideoCapture> capture_;
  Controls controls_;
  AdaptiveExposure exposure_;
  bool exposure_supported_ = true;
  std::atomic<bool> running_{true};
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::optional<Frame> latest_;
  std::string error_;
  std::uint64_t returned_ = 0;
};

const TypeEntry kTypes[] = {make_type<V4l2Camera>("v4l2", "V4L2 (USB) camera by device path, with adaptive exposure")};

}  // namespace

VISNAV_PLUGIN({.name = "camera_v4l2",
               .version = "0.1.0",
               .description = "V4L2 camera",
               .types = kTypes})
