#include "image_decoder.hpp"

#include <cstring>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace visnav::camera_dds {

const char* to_string(DropReason reason) {
  switch (reason) {
    case DropReason::malformed: return "malformed";
    case DropReason::oversized: return "oversized";
    case DropReason::unknown_encoding: return "unknown encoding";
    case DropReason::undecodable: return "undecodable";
  }
  return "?";
}

std::optional<cv::Mat> ImageDecoder::reject(DropReason reason, std::string message, Rejection* out) {
  switch (reason) {
    case DropReason::malformed: ++counts_.malformed; break;
    case DropReason::oversized: ++counts_.oversized; break;
    case DropReason::unknown_encoding: ++counts_.unknown_encoding; break;
    case DropReason::undecodable: ++counts_.undecodable; break;
  }
  if (out != nullptr) *out = Rejection{reason, std::move(message)};
  return std::nullopt;
}

std::optional<cv::Mat> ImageDecoder::decode(const dds::msg::Image& image, Rejection* rejection) {
  int channels = 0;
  bool swap_rb = false;
  if (image.encoding == "bgr8") channels = 3;
  else if (image.encoding == "rgb8") { channels = 3; swap_rb = true; }
  else if (image.encoding == "mono8") channels = 1;
  else return reject(DropReason::unknown_encoding, "unsupported image encoding '" + image.encoding + "' (supported: rgb8, bgr8, mono8)", rejection);

  const auto w = static_cast<std::uint64_t>(image.width);
  const auto h = static_cast<std::uint64_t>(image.height);
  if (w == 0 || h == 0)
    return reject(DropReason::malformed, "image has zero size (" + std::to_string(w) + "x" + std::to_string(h) + ")", rejection);
  if (w > static_cast<std::uint64_t>(limits_.max_width_px) || h > static_cast<std::uint64_t>(limits_.max_height_px))
    return reject(DropReason::oversized,
                  "image " + std::to_string(w) + "x" + std::to_string(h) + " exceeds the limit " +
                      std::to_string(limits_.max_width_px) + "x" + std::to_string(limits_.max_height_px),
                  rejection);
  const std::uint64_t row_bytes = w * static_cast<std::uint64_t>(channels);
  if (image.step < row_bytes)
    return reject(DropReason::malformed,
                  "step " + std::to_string(image.step) + " < width*channels " + std::to_string(row_bytes), rejection);
  const std::uint64_t expected = static_cast<std::uint64_t>(image.step) * h;
  if (image.data.size() != expected)
    return reject(DropReason::malformed,
                  "data size " + std::to_string(image.data.size()) + " != step*height " + std::to_string(expected), rejection);

  // Wrap without copying (the Mat header honours `step`), then produce a fresh, packed buffer.
  const cv::Mat view(static_cast<int>(h), static_cast<int>(w), channels == 3 ? CV_8UC3 : CV_8UC1,
                     const_cast<std::uint8_t*>(image.data.data()), static_cast<std::size_t>(image.step));
  cv::Mat out;
  if (swap_rb) cv::cvtColor(view, out, cv::COLOR_RGB2BGR);
  else out = view.clone();
  return out;
}

std::optional<cv::Mat> ImageDecoder::decode(const dds::msg::CompressedImage& image, Rejection* rejection) {
  std::string format = image.format;
  for (char& c : format) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const bool jpeg = format.find("jpeg") != std::string::npos || format.find("jpg") != std::string::npos;
  const bool png = format.find("png") != std::string::npos;
  if (!jpeg && !png)
    return reject(DropReason::unknown_encoding, "unsupported compressed format '" + image.format + "' (supported: jpeg, png)", rejection);
  if (image.data.empty()) return reject(DropReason::malformed, "compressed image without data", rejection);
  if (image.data.size() > limits_.max_compressed_bytes)
    return reject(DropReason::oversized,
                  "compressed image of " + std::to_string(image.data.size()) + " bytes exceeds the limit " +
                      std::to_string(limits_.max_compressed_bytes),
                  rejection);
  const auto size = peek_compressed_size(image.data.data(), image.data.size());
  if (!size) return reject(DropReason::undecodable, "no PNG or JPEG header in a '" + image.format + "' image", rejection);
  if (size->width <= 0 || size->height <= 0 || size->width > limits_.max_width_px || size->height > limits_.max_height_px)
    return reject(DropReason::oversized,
                  "compressed image " + std::to_string(size->width) + "x" + std::to_string(size->height) +
                      " exceeds the limit " + std::to_string(limits_.max_width_px) + "x" +
                      std::to_string(limits_.max_height_px),
                  rejection);
  cv::Mat decoded;
  try {
    const cv::Mat buffer(1, static_cast<int>(image.data.size()), CV_8UC1, const_cast<std::uint8_t*>(image.data.data()));
    decoded = cv::imdecode(buffer, cv::IMREAD_ANYCOLOR);  // 8-bit, grey stays grey, colour -> BGR
  } catch (const cv::Exception& e) {
    return reject(DropReason::undecodable, std::string("decoding failed: ") + e.what(), rejection);
  }
  if (decoded.empty()) return reject(DropReason::undecodable, "'" + image.format + "' data does not decode", rejection);
  if (decoded.type() != CV_8UC1 && decoded.type() != CV_8UC3)
    return reject(DropReason::undecodable, "'" + image.format + "' decoded to an unsupported pixel type", rejection);
  return decoded;
}

namespace {
std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
}
std::uint32_t be16(const std::uint8_t* p) { return (std::uint32_t{p[0]} << 8) | std::uint32_t{p[1]}; }
}  // namespace

std::optional<cv::Size> peek_compressed_size(const std::uint8_t* data, std::size_t size) {
  static const std::uint8_t kPng[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
  if (size >= 24 && std::memcmp(data, kPng, 8) == 0 && std::memcmp(data + 12, "IHDR", 4) == 0) {
    const std::uint32_t w = be32(data + 16);
    const std::uint32_t h = be32(data + 20);
    if (w > 0x7fffffffu || h > 0x7fffffffu) return cv::Size(-1, -1);
    return cv::Size(static_cast<int>(w), static_cast<int>(h));
  }
  if (size >= 4 && data[0] == 0xFF && data[1] == 0xD8) {
    std::size_t i = 2;
    while (i + 4 <= size) {
      if (data[i] != 0xFF) return std::nullopt;
      const std::uint8_t marker = data[i + 1];
      if (marker == 0xFF) { ++i; continue; }  // fill byte
      if (marker == 0xD8 || marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) { i += 2; continue; }
      const std::uint32_t length = be16(data + i + 2);
      if (length < 2) return std::nullopt;
      const bool sof = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
      if (sof) {
        if (i + 9 > size) return std::nullopt;
        return cv::Size(static_cast<int>(be16(data + i + 7)), static_cast<int>(be16(data + i + 5)));
      }
      i += 2 + length;
    }
  }
  return std::nullopt;
}

}  // namespace visnav::camera_dds
