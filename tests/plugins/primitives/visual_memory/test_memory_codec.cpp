// The visual-memory payload: a taught memory survives encode/decode exactly, and a body that
// does not decode (truncated, wrong magic, a damaged image, non-finite numbers) is an error with
// ErrorCode::parse_error, never a crash.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "visnav/map.hpp"
#include "visnav/visual_memory/memory.hpp"

namespace vm = visnav::visual_memory;

namespace {

vm::VisualMemory small_memory() {
  vm::VisualMemory m;
  m.width_px = 64;
  m.height_px = 48;
  m.focal_px = 55.4;
  for (int k = 0; k < 3; ++k) {
    vm::Reference r;
    r.distance_m = 1.5 * k;
    r.heading_rad = 0.1 * k;
    r.t_from_prev_m = cv::Vec3d(0.01 * k, 0.0, -1.5);
    r.image = cv::Mat(48, 64, CV_8UC1);
    cv::randu(r.image, 0, 255);
    for (int j = 0; j < 4; ++j) {
      r.ids.push_back(10 * k + j);
      r.points_px.emplace_back(5.0f + j, 7.5f + k);
      r.has_3d.push_back(static_cast<std::uint8_t>(j % 2));
      r.points3d_m.emplace_back(0.1f * j, -0.2f, 2.0f + j);
    }
    m.references.push_back(r);
  }
  return m;
}

}  // namespace

TEST(VisualMemoryCodec, RoundTripsEveryField) {
  const vm::VisualMemory m = small_memory();
  const auto body = m.encode();
  auto back = vm::VisualMemory::decode(body);
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->references.size(), 3u);
  EXPECT_EQ(back->width_px, 64);
  EXPECT_DOUBLE_EQ(back->focal_px, 55.4);
  for (std::size_t k = 0; k < 3; ++k) {
    const auto& a = m.references[k];
    const auto& b = back->references[k];
    EXPECT_DOUBLE_EQ(a.distance_m, b.distance_m);
    EXPECT_DOUBLE_EQ(a.t_from_prev_m[2], b.t_from_prev_m[2]);
    EXPECT_EQ(cv::norm(a.image, b.image, cv::NORM_INF), 0.0);
    EXPECT_EQ(a.ids, b.ids);
    EXPECT_EQ(a.has_3d, b.has_3d);
    for (std::size_t j = 0; j < a.ids.size(); ++j) {
      EXPECT_EQ(a.points_px[j], b.points_px[j]);
      EXPECT_EQ(a.points3d_m[j], b.points3d_m[j]);
    }
  }
}

TEST(VisualMemoryCodec, EveryTruncationIsAParseErrorOrShortRead) {
  const auto body = small_memory().encode();
  for (std::size_t n = 0; n < body.size(); n += 97) {
    auto r = vm::VisualMemory::decode(std::span<const std::uint8_t>(body.data(), n));
    EXPECT_FALSE(r.ok()) << "truncated at " << n;
  }
}

TEST(VisualMemoryCodec, ForeignMagicDamagedImageAndNonFiniteNumbersAreRejected) {
  auto body = small_memory().encode();
  {
    auto bad = body;
    bad[0] ^= 0xFF;
    auto r = vm::VisualMemory::decode(bad);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, visnav::ErrorCode::parse_error);
  }
  {
    // first reference: header 4+4+4+8+4, then 2+9+3 doubles, then the PNG block length (8 bytes)
    const std::size_t png_at = 24 + 14 * 8 + 8;
    auto bad = body;
    for (std::size_t i = png_at; i < png_at + 16; ++i) bad[i] = 0;  // PNG signature and IHDR gone
    auto r = vm::VisualMemory::decode(bad);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, visnav::ErrorCode::parse_error);
  }
  {
    auto m = small_memory();
    m.references[1].distance_m = std::numeric_limits<double>::quiet_NaN();
    auto r = vm::VisualMemory::decode(m.encode());
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, visnav::ErrorCode::parse_error);
  }
  {
    auto m = small_memory();
    m.references[2].points3d_m[1].z = -1.0f;  // a 3D point behind its reference camera
    auto r = vm::VisualMemory::decode(m.encode());
    ASSERT_FALSE(r.ok());
  }
  {
    auto bad = body;
    bad.push_back(0);
    EXPECT_FALSE(vm::VisualMemory::decode(bad).ok());
  }
}
