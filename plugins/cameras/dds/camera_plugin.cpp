// The `dds` camera: frames from a ROS 2 image topic over Cyclone DDS.
//   transport raw:        sensor_msgs/Image (rgb8, bgr8, mono8) on `topic` (default rt/camera/image_raw)
//   transport compressed: sensor_msgs/CompressedImage (jpeg, png) on `topic`
//                         (default rt/camera/image_raw/compressed)
// Samples are validated and decoded on the subscription thread (ImageDecoder) and the newest
// frame is kept in a latest-value slot; `grab()` (tick thread) waits on that slot. Rejected
// samples (malformed, oversized, unknown encoding, undecodable) and writers of the wrong type
// are dropped, counted and reported with rate-limited warnings; nothing on the wire can crash
// the camera. Frame timestamps are the run-clock arrival time (`timestamp: receive`) or the
// header stamp mapped onto the run clock (`timestamp: header`).
#include <algorithm>
#include <atomic>
#include <memory>

#include "image_decoder.hpp"
#include "visnav/camera_mount.hpp"
#include "visnav/dds.hpp"
#include "visnav/plugin.hpp"

namespace visnav::camera_dds {
namespace {

struct DdsCameraParams : CameraMountOptions {  // + the camera mount keys (add_camera_mount_fields)
  int domain_id = 0;
  std::string partition;
  std::string transport = "raw";
  std::string topic;  // empty: rt/camera/image_raw (raw) or rt/camera/image_raw/compressed
  std::string reliability = "best_effort";
  int history_depth = 1;
  int max_width_px = 4096;
  int max_height_px = 4096;
  int max_compressed_bytes = 32 << 20;
  std::string timestamp = "receive";

  [[nodiscard]] std::string resolved_topic() const {
    if (!topic.empty()) return topic;
    return transport == "compressed" ? "rt/camera/image_raw/compressed" : "rt/camera/image_raw";
  }
  [[nodiscard]] Status validate() const { return CameraMountOptions::validate(); }
  static const ParamSchema<DdsCameraParams>& schema() {
    static const auto s = [] {
      ParamSchema<DdsCameraParams> p;
      p.field("domain_id", &DdsCameraParams::domain_id, "DDS domain id (ROS_DOMAIN_ID of the camera)").range(0, 232)
        .field("partition", &DdsCameraParams::partition, "DDS partition; empty = default (what ROS 2 uses)")
        .field("transport", &DdsCameraParams::transport, "raw: sensor_msgs/Image; compressed: sensor_msgs/CompressedImage").one_of({"raw", "compressed"})
        .field("topic", &DdsCameraParams::topic, "DDS topic; empty = rt/camera/image_raw (raw) or rt/camera/image_raw/compressed")
        .field("reliability", &DdsCameraParams::reliability, "QoS reliability of the reader (best_effort matches every publisher)").one_of({"best_effort", "reliable"})
        .field("history_depth", &DdsCameraParams::history_depth, "keep-last depth of the reader").range(1, 100)
        .field("max_width_px", &DdsCameraParams::max_width_px, "larger images are dropped").range(1, 65535)
        .field("max_height_px", &DdsCameraParams::max_height_px, "larger images are dropped").range(1, 65535)
        .field("max_compressed_bytes", &DdsCameraParams::max_compressed_bytes, "larger compressed images are dropped").range(1, 1 << 30)
        .field("timestamp", &DdsCameraParams::timestamp, "frame time: arrival on the run clock, or the header stamp mapped onto it").one_of({"receive", "header"});
      add_camera_mount_fields(p);
      return p;
    }();
    return s;
  }
};

class DdsCamera final : public Camera {
 public:
  using Params = DdsCameraParams;

  static Result<std::unique_ptr<DdsCamera>> create(const ConfigNode& node, HostServices& host) {
    VISNAV_ASSIGN(Params params, Params::schema().parse(node));
    auto camera = std::unique_ptr<DdsCamera>(new DdsCamera(params, host));
    VISNAV_TRY(camera->connect());
    return camera;
  }

  ~DdsCamera() override {
    raw_.reset();
    compressed_.reset();
  }

  [[nodiscard]] std::optional<CameraMount> mount() const override { return params_.mount(); }

  Result<std::optional<Frame>> grab(double timeout_s) override {
    auto newer = frames_.wait_newer(seen_version_, timeout_s);
    if (!newer) return std::optional<Frame>{};
    seen_version_ = newer->second;
    return std::optional<Frame>{std::move(newer->first)};
  }

 private:
  DdsCamera(Params params, HostServices& host)
      : params_(std::move(params)), host_(&host),
        decoder_(ImageLimits{params_.max_width_px, params_.max_height_px,
                             static_cast<std::size_t>(params_.max_compressed_bytes)}) {}

  template <typename M>
  void on_sample(const M& sample, const dds::SampleInfo& info) {
    Rejection why;
    auto image = decoder_.decode(sample, &why);
    if (!image) {
      if (limiter_.allow(info.receive_time_s)) {
        const auto& c = decoder_.counts();
        host_->logger().warn("dds.camera", "topic '" + topic_ + "': dropped a " + to_string(why.reason) + " sample: " +
                                               why.message + " (dropped so far: " + std::to_string(c.total()) +
                                               " = malformed " + std::to_string(c.malformed) + ", oversized " +
                                               std::to_string(c.oversized) + ", unknown encoding " +
                                               std::to_string(c.unknown_encoding) + ", undecodable " +
                                               std::to_string(c.undecodable) + ")");
      }
      return;
    }
    const double run_now_s = host_->clock().now_s();
    Frame frame;
    frame.timestamp_s = use_header_stamp_
                            ? run_now_s - std::max(0.0, info.receive_time_s - sample.header.stamp.seconds())
                            : run_now_s;
    frame.sequence = ++sequence_;
    frame.image = std::move(*image);
    frames_.put(std::move(frame));
  }

  Status connect() {
    topic_ = params_.resolved_topic();
    use_header_stamp_ = params_.timestamp == "header";
    VISNAV_ASSIGN(auto participant, dds::Participant::create(params_.domain_id));
    VISNAV_ASSIGN(auto reliability, dds::parse_reliability(params_.reliability));
    const dds::EndpointOptions options{topic_, dds::Qos{reliability, dds::Durability::volatile_data, params_.history_depth, 0.0},
                                       params_.partition};
    auto on_warning = [this](const std::string& message) { host_->logger().warn("dds.camera", message); };
    if (params_.transport == "compressed") {
      VISNAV_ASSIGN(compressed_, dds::Subscription<dds::msg::CompressedImage>::create(
                                     participant, options,
                                     [this](dds::msg::CompressedImage&& m, const dds::SampleInfo& i) { on_sample(m, i); },
                                     on_warning));
    } else {
      VISNAV_ASSIGN(raw_, dds::Subscription<dds::msg::Image>::create(
                              participant, options, [this](dds::msg::Image&& m, const dds::SampleInfo& i) { on_sample(m, i); },
                              on_warning));
    }
    host_->logger().info("dds.camera", "domain " + std::to_string(params_.domain_id) + ": " + params_.transport +
                                           " images from '" + topic_ + "'");
    return ok();
  }

  Params params_;
  HostServices* host_;
  std::string topic_;
  bool use_header_stamp_ = false;
  ImageDecoder decoder_;        // subscription thread only
  std::uint64_t sequence_ = 0;  // subscription thread only
  dds::WarningLimiter limiter_{1.0};
  dds::LatestSlot<Frame> frames_;
  std::uint64_t seen_version_ = 0;  // tick thread only
  std::unique_ptr<dds::Subscription<dds::msg::Image>> raw_;
  std::unique_ptr<dds::Subscription<dds::msg::CompressedImage>> compressed_;
};

const TypeEntry kTypes[] = {
    make_type<DdsCamera>("dds", "Camera over Cyclone DDS: sensor_msgs/Image (rgb8, bgr8, mono8) or CompressedImage (jpeg, png)")};

}  // namespace
}  // namespace visnav::camera_dds

VISNAV_PLUGIN({.name = "camera_dds",
               .version = "1.0",
               .description = "Cyclone DDS camera (ROS 2 Image / CompressedImage)",
               .types = ::visnav::camera_dds::kTypes})
