// The `camera_recorded` plugin: camera type `recorded` (docs/recorded_runs.md).
//
// Reads RUN/frames.csv and delivers the recorded images with their recorded timestamps and
// sequence numbers. Default pacing `clock`: a frame is delivered once the run clock reaches its
// time — with the `recorded` robot (lock-step, its step() moves the clock to the next frame time)
// every tick gets exactly the next recorded frame, so a mission sees what the live run saw.
#include "visnav/camera_mount.hpp"
#include "visnav/plugin.hpp"
#include "visnav/recorded/image_list_camera.hpp"

namespace {

using namespace visnav;
using namespace visnav::recorded;

struct RecordedCameraParams : ImageOptions, CameraMountOptions {  // + the image pipeline keys (add_image_fields), normally off:
                                                                  // recorded frames are already processed;
                                                                  // + the camera mount keys
  std::string run_dir;
  std::string pacing = "clock";

  [[nodiscard]] Status validate() const {
    if (run_dir.empty()) return fail("key 'run_dir' is required (the recorded-run folder)");
    VISNAV_TRY(CameraMountOptions::validate());
    return ImageOptions::validate();
  }
  static const ParamSchema<RecordedCameraParams>& schema() {
    static const auto s = [] {
      ParamSchema<RecordedCameraParams> p;
      p.field("run_dir", &RecordedCameraParams::run_dir, "recorded-run folder (written by `visnav record`)")
          .field("pacing", &RecordedCameraParams::pacing,
                 "clock: when the run clock reaches the frame time (with the recorded robot); fast; realtime")
          .one_of({"clock", "fast", "realtime"});
      add_image_fields(p);
      add_camera_mount_fields(p);
      return p;
    }();
    return s;
  }
};

class RecordedCamera final : public ImageListCamera {
 public:
  using Params = RecordedCameraParams;
  using ImageListCamera::ImageListCamera;

  static Result<std::unique_ptr<RecordedCamera>> create(const ConfigNode& node, HostServices& host) {
    VISNAV_ASSIGN(Params p, Params::schema().parse(node));
    const std::string base = config_folder(node.where().file);
    const std::string dir = resolve_path(p.run_dir, base);
    VISNAV_ASSIGN(FrameList list, read_run_frames(dir));
    VISNAV_ASSIGN(ImagePipeline pipeline, ImagePipeline::create(p, base));
    host.logger().info("camera_recorded", dir + ": " + std::to_string(list.frames.size()) + " frames, pacing " + p.pacing);
    auto cam = std::make_unique<RecordedCamera>(std::move(list), parse_pacing(p.pacing), std::move(pipeline), host.clock(), false);
    cam->set_mount(p.mount());
    return cam;
  }
};

const TypeEntry kTypes[] = {make_type<RecordedCamera>("recorded", "frames of a recorded run (visnav record)")};

}  // namespace

VISNAV_PLUGIN({.name = "camera_recorded",
               .version = "0.1.0",
               .description = "recorded-run frames as a camera",
               .types = kTypes})
