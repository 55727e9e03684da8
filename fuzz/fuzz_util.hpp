// Helpers shared by the libFuzzer targets: a bounded cursor over the fuzzer's bytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

namespace visnav::fuzz {

class Bytes {
 public:
  Bytes(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  template <typename T>
  T take() {
    T v{};
    if (size_ - pos_ >= sizeof(T)) {
      std::memcpy(&v, data_ + pos_, sizeof(T));
      pos_ += sizeof(T);
    } else {
      pos_ = size_;
    }
    return v;
  }
  /// Up to `max` bytes as a string, length taken from the input.
  std::string take_string(std::size_t max) {
    const std::size_t n = std::min<std::size_t>(take<std::uint16_t>(), std::min(max, size_ - pos_));
    std::string s(reinterpret_cast<const char*>(data_ + pos_), n);
    pos_ += n;
    return s;
  }
  std::string_view rest() const { return {reinterpret_cast<const char*>(data_ + pos_), size_ - pos_}; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

/// Splits at the first '\n': (first line, everything after it).
inline std::pair<std::string_view, std::string_view> split_first_line(std::string_view text) {
  const auto nl = text.find('\n');
  if (nl == std::string_view::npos) return {text, {}};
  return {text.substr(0, nl), text.substr(nl + 1)};
}

}  // namespace visnav::fuzz
