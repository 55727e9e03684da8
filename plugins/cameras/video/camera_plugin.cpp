// The `camera_video` plugin: camera type `video` (docs/cameras.md).
//
// Decodes `file` with cv::VideoCapture (CAP_ANY: FFmpeg, then GStreamer). Frame times: the
// container's presentation time (CAP_PROP_POS_MSEC) when it increases, else index / frame rate
// (`frame_rate_hz`, or the file's CAP_PROP_FPS, or 25). Pacing (pacing.hpp): fast (next frame
// per grab), realtime (at the recorded spacing; overdue frames are decoded and skipped), clock
// (when the run clock reaches the frame time). End of file: grab() returns an error
// "<file>: end of video after N frames" (or starts again with `loop`).
// Errors at creation: missing file, a file videoio cannot open, a file without a first frame —
// each naming the file. Decoding happens in grab() on the caller's thread.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <thread>

#include <opencv2/videoio.hpp>

#include "visnav/camera_mount.hpp"
#include "visnav/plugin.hpp"
#include "visnav/recorded/image_pipeline.hpp"
#include "visnav/recorded/pacing.hpp"

namespace {

using namespace visnav;
using namespace visnav::recorded;
namespace fs = std::filesystem;

struct VideoParams : ImageOptions, CameraMountOptions {  // + the image pipeline keys (add_image_fields) and the mount
  std::string file;
  std::string pacing = "realtime";
  double frame_rate_hz = 0.0;
  bool loop = false;

  [[nodiscard]] Status validate() const {
    if (file.empty()) return Error{"key 'file' is required (the video file)", ErrorCode::missing, {{}, 0, "file"}};
    VISNAV_TRY(CameraMountOptions::validate());
    return ImageOptions::validate();
  }
  static const ParamSchema<VideoParams>& schema() {
    static const auto s = [] {
      ParamSchema<VideoParams> p;
      p.field("file", &VideoParams::file, "video file OpenCV videoio can read (relative to the config file's folder)")
          .field("pacing", &VideoParams::pacing, "realtime: at the video's own timing; fast: next frame per grab; clock: by the run clock")
          .one_of({"realtime", "fast", "clock"})
          .field("frame_rate_hz", &VideoParams::frame_rate_hz, "frame times i / rate, Hz; 0 = the file's timestamps / fps").range(0, 10000)
          .field("loop", &VideoParams::loop, "start again at the end of the file instead of ending");
      add_image_fields(p);
      add_camera_mount_fields(p);
      return p;
    }();
    return s;
  }
};

class VideoCamera final : public Camera {
 public:
  using Params = VideoParams;

  static Result<std::unique_ptr<VideoCamera>> create(const ConfigNode& node, HostServices& host) {
    VISNAV_ASSIGN(Params p, Params::schema().parse(node));
    const std::string base = config_folder(node.where().file);
    std::unique_ptr<VideoCamera> cam(new VideoCamera(p, host.clock()));
    cam->path_ = resolve_path(p.file, base);
    std::error_code ec;
    if (!fs::exists(cam->path_, ec)) return fail(ErrorCode::not_found, {cam->path_, 0, "file"}, "no such file");
    if (!fs::is_regular_file(cam->path_, ec)) return fail(ErrorCode::invalid_value, {cam->path_, 0, "file"}, "not a regular file");
    VISNAV_ASSIGN(cam->pipeline_, ImagePipeline::create(p, base));
    VISNAV_TRY(cam->open());
    // A file that opens but yields no frame (truncated, not a video) is rejected now, not at the first tick.
    VISNAV_TRY(cam->decode_next());
    if (!cam->peek_)
      return fail(ErrorCode::parse_error, {cam->path_, 0, "file"}, "no frame could be decoded (empty, truncated or not a video)");
    host.logger().info("camera_video", cam->path_ + ": " + std::to_string(cam->fps_) + " fps, pacing " + p.pacing);
    return cam;
  }

  [[nodiscard]] std::optional<CameraMount> mount() const override { return params_.mount(); }

  Result<std::optional<Frame>> grab(double timeout_s) override {
    const double deadline = wall_now_s() + std::max(0.0, timeout_s);
    for (;;) {
      if (!peek_ && pacer_.pacing() == Pacing::clock && clock_->now_s() <= last_t_s_ + 1e-9)
        return std::optional<Frame>{};  // ends when the next frame would be due
      if (!peek_) {
        if (!params_.loop) return fail(ErrorCode::missing, {path_, 0, "file"}, "end of video after " + std::to_string(decoded_) + " frames");
        VISNAV_TRY(restart());
        if (!peek_) return fail(ErrorCode::parse_error, {path_, 0, "file"}, "no frame after restarting");
      }
      times_.assign(1, peek_->t_s);
      auto due = pacer_.due(times_, 0, wall_now_s(), clock_->now_s());
      if (!due) {
        if (pacer_.pacing() != Pacing::realtime) return std::optional<Frame>{};
        const double wait = std::min(pacer_.wait_s(times_, 0, wall_now_s()), deadline - wall_now_s());
        if (wait <= 0.0) return std::optional<Frame>{};
        std::this_thread::sleep_for(std::chrono::duration<double>(std::min(wait, 0.05)));
        continue;
      }
      Pending current = std::move(*peek_);
      peek_.reset();
      const double stamp = pacer_.stamp(times_, 0, clock_->now_s());
      VISNAV_TRY(decode_next());
      if (pacer_.pacing() != Pacing::fast && peek_) {
        // Skip overdue frames: deliver only the newest one that is due.
        times_.assign(1, peek_->t_s);
        if (pacer_.due(times_, 0, wall_now_s(), clock_->now_s())) continue;
      }
      Frame frame;
      if (auto st = pipeline_.apply(current.image, frame.image); !st)
        return fail(st.error().code, {path_, 0, "file"}, "frame " + std::to_string(current.index) + ": " + st.error().message);
      frame.timestamp_s = stamp;
      frame.sequence = sequence_++;
      return std::optional<Frame>(std::move(frame));
    }
  }

 private:
  struct Pending {
    cv::Mat image;
    double t_s = 0.0;
    std::uint64_t index = 0;
  };

  VideoCamera(Params p, const Clock& clock) : params_(std::move(p)), pacer_(parse_pacing(params_.pacing)), clock_(&clock) {}

  double wall_now_s() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start_).count(); }

  Status open() {
    try {
      capture_.open(path_, cv::CAP_ANY);
    } catch (const cv::Exception& e) {
      return fail(ErrorCode::io, {path_, 0, "file"}, std::string("cannot be opened: ") + e.what());
    }
    if (!capture_.isOpened())
      return fail(ErrorCode::parse_error, {path_, 0, "file"}, "OpenCV videoio cannot open it (unreadable, unsupported codec or not a video)");
    fps_ = params_.frame_rate_hz > 0.0 ? params_.frame_rate_hz : capture_.get(cv::CAP_PROP_FPS);
    if (!(fps_ > 0.0 && fps_ < 10000.0)) fps_ = 25.0;
    return ok();
  }

  Status restart() {
    capture_.release();
    time_offset_s_ = last_t_s_ + 1.0 / fps_;
    file_index_ = 0;
    VISNAV_TRY(open());
    return decode_next();
  }

  /// Decodes the next frame into peek_ (nullopt at the end of the file).
  Status decode_next() {
    cv::Mat image;
    bool got = false;
    try {
      got = capture_.read(image);
    } catch (const cv::Exception& e) {
      return fail(ErrorCode::parse_error, {path_, 0, "file"}, "frame " + std::to_string(decoded_) + ": decoding failed: " + e.what());
    }
    if (!got || image.empty()) {
      peek_.reset();
      return ok();
    }
    double t = static_cast<double>(file_index_) / fps_;
    if (params_.frame_rate_hz <= 0.0) {
      const double pos_s = capture_.get(cv::CAP_PROP_POS_MSEC) * 1e-3;
      if (std::isfinite(pos_s) && pos_s > 0.0 && (file_index_ == 0 || pos_s + time_offset_s_ > last_t_s_)) t = pos_s;
    }
    t += time_offset_s_;
    if (decoded_ > 0 && t <= last_t_s_) t = last_t_s_ + 1.0 / fps_;  // keep times increasing
    last_t_s_ = t;
    peek_ = Pending{std::move(image), t, decoded_};
    ++decoded_;
    ++file_index_;
    return ok();
  }

  Params params_;
  FramePacer pacer_;
  const Clock* clock_;
  std::string path_;
  cv::VideoCapture capture_;
  ImagePipeline pipeline_;
  double fps_ = 25.0;
  std::optional<Pending> peek_;
  std::vector<double> times_;
  std::uint64_t decoded_ = 0;
  std::uint64_t file_index_ = 0;
  std::uint64_t sequence_ = 0;
  double last_t_s_ = 0.0;
  double time_offset_s_ = 0.0;
  std::chrono::steady_clock::time_point wall_start_ = std::chrono::steady_clock::now();
};

const TypeEntry kTypes[] = {make_type<VideoCamera>("video", "frames of a video file (OpenCV videoio), real-time or as fast as possible")};

}  // namespace

VISNAV_PLUGIN({.name = "camera_video",
               .version = "0.1.0",
               .description = "video file as a camera",
               .types = kTypes})
