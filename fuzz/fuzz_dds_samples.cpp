// libFuzzer target: what arrives from the network — sensor_msgs Image / CompressedImage through
// the dds camera's decoder, nav_msgs Odometry through the dds robot's tracker and the run loop's
// plausibility check, and control requests through validation and log escaping. The first byte
// chooses the message. Invariants: a decoded image respects the limits; log_safe output has no
// control characters and is bounded.
#include <cstdint>
#include <cstdlib>

#include "fuzz_util.hpp"
#include "image_decoder.hpp"
#include "odometry_tracker.hpp"
#include "run/odometry_check.hpp"
#include "visnav/dds.hpp"

namespace dds = visnav::dds;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  visnav::fuzz::Bytes in(data, size);
  const auto which = in.take<std::uint8_t>() % 4;
  visnav::camera_dds::ImageLimits limits;
  limits.max_width_px = 640;
  limits.max_height_px = 480;
  limits.max_compressed_bytes = 1 << 20;
  visnav::camera_dds::ImageDecoder decoder(limits);
  if (which == 0) {
    dds::msg::Image m;
    m.height = in.take<std::uint16_t>();
    m.width = in.take<std::uint16_t>();
    m.step = in.take<std::uint16_t>();
    m.is_bigendian = in.take<std::uint8_t>();
    m.encoding = in.take_string(16);
    const auto rest = in.rest();
    m.data.assign(rest.begin(), rest.end());
    if (auto img = decoder.decode(m); img && (img->cols > 640 || img->rows > 480)) std::abort();
  } else if (which == 1) {
    dds::msg::CompressedImage m;
    m.format = in.take_string(32);
    const auto rest = in.rest();
    m.data.assign(rest.begin(), rest.end());
    if (auto img = decoder.decode(m); img && (img->cols > 640 || img->rows > 480)) std::abort();
  } else if (which == 2) {
    visnav::robot_dds::OdometryTracker tracker;
    visnav::OdometryPlausibility plausibility({3.0, 0.5});
    for (int i = 0; i < 8; ++i) {
      dds::msg::Odometry o;
      o.pose.pose.position = {in.take<double>(), in.take<double>(), in.take<double>()};
      o.pose.pose.orientation = {in.take<double>(), in.take<double>(), in.take<double>(), in.take<double>()};
      o.twist.twist.linear.x = in.take<double>();
      o.twist.twist.angular.z = in.take<double>();
      if (auto odo = tracker.update(o, in.take<double>())) (void)plausibility.check(*odo);
    }
  } else {
    const auto command = static_cast<dds::msg::ControlCommand>(in.take<std::uint8_t>() % 5);
    const std::string arg(in.rest());
    (void)dds::valid_control_argument(command, arg);
    const std::string shown = dds::log_safe(arg);
    if (shown.size() > 64 * 4 + 32) std::abort();
    for (char c : shown)
      if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7f) std::abort();
  }
  return 0;
}
