// The `camera_image_folder` plugin: camera type `image_folder` (docs/cameras.md).
//
// Lists the images of `folder` in natural name order, attaches times from `timestamps_file`
// (or timestamps.csv / timestamps.txt in the folder, or i / frame_rate_hz) and delivers them
// with the chosen pacing through the common image pipeline. Errors at creation: missing folder,
// a folder with no images, a bad timestamps file (file:line); at grab: an unreadable image
// (named), end of the sequence.
#include "visnav/camera_mount.hpp"
#include "visnav/plugin.hpp"
#include "visnav/recorded/image_list_camera.hpp"

namespace {

using namespace visnav;
using namespace visnav::recorded;

struct ImageFolderParams : ImageOptions, CameraMountOptions {  // + the image pipeline keys (add_image_fields) and the mount
  std::string folder;
  std::string timestamps_file;
  double frame_rate_hz = 10.0;
  std::string pacing = "fast";
  bool loop = false;

  [[nodiscard]] Status validate() const {
    if (folder.empty()) return fail("key 'folder' is required (the image folder)");
    VISNAV_TRY(CameraMountOptions::validate());
    return ImageOptions::validate();
  }
  static const ParamSchema<ImageFolderParams>& schema() {
    static const auto s = [] {
      ParamSchema<ImageFolderParams> p;
      p.field("folder", &ImageFolderParams::folder, "folder of images (relative to the config file's folder)")
          .field("timestamps_file", &ImageFolderParams::timestamps_file,
                 "per-image times: CSV (file,t_s) or text (one time per line); '' = timestamps.csv/.txt in the folder if present")
          .field("frame_rate_hz", &ImageFolderParams::frame_rate_hz, "frame times i / rate when there is no timestamps file, Hz").range(0.001, 10000)
          .field("pacing", &ImageFolderParams::pacing, "fast: next image per grab; realtime: at the recorded spacing; clock: when the run clock reaches its time")
          .one_of({"fast", "realtime", "clock"})
          .field("loop", &ImageFolderParams::loop, "start again after the last image instead of ending");
      add_image_fields(p);
      add_camera_mount_fields(p);
      return p;
    }();
    return s;
  }
};

class ImageFolderCamera final : public ImageListCamera {
 public:
  using Params = ImageFolderParams;
  using ImageListCamera::ImageListCamera;

  static Result<std::unique_ptr<ImageFolderCamera>> create(const ConfigNode& node, HostServices& host) {
    VISNAV_ASSIGN(Params p, Params::schema().parse(node));
    const std::string base = config_folder(node.where().file);
    const std::string folder = resolve_path(p.folder, base);
    VISNAV_ASSIGN(FrameList list, list_image_folder(folder, resolve_path(p.timestamps_file, base), p.frame_rate_hz));
    VISNAV_ASSIGN(ImagePipeline pipeline, ImagePipeline::create(p, base));
    host.logger().info("camera_image_folder", folder + ": " + std::to_string(list.frames.size()) + " images, pacing " + p.pacing);
    auto cam = std::make_unique<ImageFolderCamera>(std::move(list), parse_pacing(p.pacing), std::move(pipeline), host.clock(), p.loop);
    cam->set_mount(p.mount());
    return cam;
  }
};

const TypeEntry kTypes[] = {
    make_type<ImageFolderCamera>("image_folder", "sorted images of a folder, optional per-image timestamps")};

}  // namespace

VISNAV_PLUGIN({.name = "camera_image_folder",
               .version = "0.1.0",
               .description = "images of a folder as a camera",
               .types = kTypes})
