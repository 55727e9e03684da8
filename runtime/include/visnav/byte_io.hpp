// visnav SDK — little-endian byte writer/reader for binary payload bodies (the feature payload
// codecs and the feature primitive's experiences file use it; plugins may too).
// The reader never reads past the end: every getter returns false once the input is exhausted,
// and the caller turns that into an Error. Header-only; no state beyond the buffer it is given.
// Thread-safety: one Writer/Reader per thread.
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <type_traits>
#include <vector>

namespace visnav::byte_io {

static_assert(std::endian::native == std::endian::little, "payload code assumes a little-endian host");

class Writer {
 public:
  explicit Writer(std::vector<std::uint8_t>& out) : out_(out) {}
  template <typename T>
  void put(T value) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes(&value, sizeof(T));
  }
  // resize + memcpy rather than vector::insert of a pointer range: GCC 12 at -O3 reports a false
  // -Wstringop-overflow for the inlined insert in this library.
  void bytes(const void* data, std::size_t n) {
    if (n == 0) return;
    const std::size_t at = out_.size();
    out_.resize(at + n);
    std::memcpy(out_.data() + at, data, n);
  }

 private:
  std::vector<std::uint8_t>& out_;
};

class Reader {
 public:
  explicit Reader(std::span<const std::uint8_t> in) : in_(in) {}
  template <typename T>
  bool get(T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    if (remaining() < sizeof(T)) return false;
    std::memcpy(&value, in_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return true;
  }
  bool bytes(void* data, std::size_t n) {
    if (remaining() < n) return false;
    if (n > 0) std::memcpy(data, in_.data() + pos_, n);
    pos_ += n;
    return true;
  }
  [[nodiscard]] std::size_t remaining() const { return in_.size() - pos_; }
  [[nodiscard]] std::size_t position() const { return pos_; }

 private:
  std::span<const std::uint8_t> in_;
  std::size_t pos_ = 0;
};

/// Image coordinate in fixed point (1/8 px) in an int16: range [-4096, 4095.875] px.
inline std::int16_t to_fixed_px(float v) {
  const float s = std::round(v * 8.0f);
  if (!(s > -32768.0f)) return -32768;
  if (s > 32767.0f) return 32767;
  return static_cast<std::int16_t>(s);
}
inline float from_fixed_px(std::int16_t v) { return static_cast<float>(v) / 8.0f; }

/// Descriptor element kinds in the payloads.
enum class DescKind : std::uint8_t { binary = 0, float32 = 1 };

}  // namespace visnav::byte_io
