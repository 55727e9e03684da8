// camera_dds core: validates and decodes sensor_msgs/Image and sensor_msgs/CompressedImage
// samples into visnav frames (BGR CV_8UC3 or grey CV_8UC1, always a fresh buffer).
//
// Raw images: encodings rgb8, bgr8, mono8; `step` >= width * channels and
// data.size() == step * height exactly (the ROS contract) or the sample is malformed.
// Compressed images: `format` must name jpeg/jpg or png (as image_transport writes it, e.g.
// "bgr8; jpeg compressed bgr8"); the width/height are read from the PNG IHDR / JPEG SOF header
// and checked against the limits *before* decoding (no decompression bombs).
// Every rejected sample is counted by reason. Never throws on bad input.
// Thread-safety: not thread-safe; one decoder per stream. `counts()` copies are plain values.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include <opencv2/core/mat.hpp>

#include "visnav/dds.hpp"
#include "visnav/result.hpp"

namespace visnav::camera_dds {

struct ImageLimits {
  int max_width_px = 4096;
  int max_height_px = 4096;
  std::size_t max_compressed_bytes = 32u << 20;
};

enum class DropReason { malformed, oversized, unknown_encoding, undecodable };
[[nodiscard]] const char* to_string(DropReason reason);

struct DropCounts {
  std::uint64_t malformed = 0;         ///< sizes inconsistent (data != step*height, step too small, zero size)
  std::uint64_t oversized = 0;         ///< width/height/bytes above the limits
  std::uint64_t unknown_encoding = 0;  ///< encoding / format not supported
  std::uint64_t undecodable = 0;       ///< compressed data that does not decode
  [[nodiscard]] std::uint64_t total() const { return malformed + oversized + unknown_encoding + undecodable; }
};

/// A rejected sample: why, and a message naming the offending field and value.
struct Rejection {
  DropReason reason = DropReason::malformed;
  std::string message;
};

class ImageDecoder {
 public:
  explicit ImageDecoder(ImageLimits limits = {}) : limits_(limits) {}

  /// Decoded image, or nullopt with `rejection` filled (and the count incremented).
  [[nodiscard]] std::optional<cv::Mat> decode(const dds::msg::Image& image, Rejection* rejection = nullptr);
  [[nodiscard]] std::optional<cv::Mat> decode(const dds::msg::CompressedImage& image, Rejection* rejection = nullptr);

  [[nodiscard]] const DropCounts& counts() const { return counts_; }
  [[nodiscard]] const ImageLimits& limits() const { return limits_; }

 private:
  std::optional<cv::Mat> reject(DropReason reason, std::string message, Rejection* out);
  ImageLimits limits_;
  DropCounts counts_;
};

/// Width and height from a PNG IHDR or a JPEG SOFn header; nullopt if neither is found.
[[nodiscard]] std::optional<cv::Size> peek_compressed_size(const std::uint8_t* data, std::size_t size);


}  // namespace visnav::camera_dds
