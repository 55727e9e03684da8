// BRIEF descriptor — see brief.hpp for the contract.
#include "visnav/detectors/brief.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <numbers>
#include <string>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "output_buffer.hpp"

namespace visnav::detectors {

namespace {

// SplitMix64: tiny, portable, fully specified generator (the pattern must not depend on the
// standard library's distributions, which differ between implementations).
struct SplitMix64 {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }
  double uniform() { return (static_cast<double>(next() >> 11) + 0.5) * (1.0 / 9007199254740992.0); }  // (0, 1)
};

constexpr std::uint64_t kPatternSeed = 0x0B41EF256CA10DE5ULL;

}  // namespace

Status BriefParams::validate() const {
  if (patch_size_px < 16 || patch_size_px > 96)
    return fail("patch_size_px " + std::to_string(patch_size_px) + " is out of range [16, 96]");
  if (kernel_size_px < 1 || kernel_size_px > 15 || kernel_size_px % 2 == 0)
    return fail("kernel_size_px " + std::to_string(kernel_size_px) + " must be odd in [1, 15]");
  return ok();
}

std::vector<BriefTest> BriefExtractor::make_pattern(int patch_size_px) {
  const int radius = patch_size_px / 2 - 1;
  const double sigma = patch_size_px / 5.0;
  SplitMix64 rng{kPatternSeed ^ static_cast<std::uint64_t>(patch_size_px)};
  // Box–Muller, one pair of normals per draw.
  auto sample_point = [&](int& x, int& y) {
    for (;;) {
      const double u1 = rng.uniform();
      const double u2 = rng.uniform();
      const double mag = sigma * std::sqrt(-2.0 * std::log(u1));
      x = static_cast<int>(std::lround(mag * std::cos(2.0 * std::numbers::pi * u2)));
      y = static_cast<int>(std::lround(mag * std::sin(2.0 * std::numbers::pi * u2)));
      if (x * x + y * y <= radius * radius) return;
    }
  };
  std::vector<BriefTest> pattern;
  pattern.reserve(kBits);
  while (static_cast<int>(pattern.size()) < kBits) {
    BriefTest t{};
    sample_point(t.x1, t.y1);
    sample_point(t.x2, t.y2);
    if (t.x1 == t.x2 && t.y1 == t.y2) continue;  // a test against itself carries no information
    pattern.push_back(t);
  }
  return pattern;
}

BriefExtractor::BriefExtractor(const BriefParams& params) : params_(params) {
  assert(params.validate().ok());
  pattern_ = make_pattern(params_.patch_size_px);
}

Status BriefExtractor::set_params(const BriefParams& params) {
  VISNAV_TRY(params.validate());
  const bool rebuild = params.patch_size_px != params_.patch_size_px || params.kernel_size_px != params_.kernel_size_px;
  params_ = params;
  if (rebuild) {
    pattern_ = make_pattern(params_.patch_size_px);
    offsets_stride_ = -1;
    disc_half_width_.clear();
  }
  return ok();
}

Status BriefExtractor::validate_pattern(const std::vector<BriefTest>& pattern, int patch_size_px) {
  if (pattern.size() != static_cast<std::size_t>(kBits))
    return fail("a comparison pattern needs exactly " + std::to_string(kBits) + " pairs, got " +
                std::to_string(pattern.size()));
  const int radius = patch_size_px / 2 - 1;
  for (std::size_t i = 0; i < pattern.size(); ++i) {
    const BriefTest& t = pattern[i];
    for (const auto& [x, y] : {std::pair{t.x1, t.y1}, std::pair{t.x2, t.y2}})
      if (x * x + y * y > radius * radius)
        return fail("pair " + std::to_string(i) + ": point (" + std::to_string(x) + ", " + std::to_string(y) +
                    ") is outside the patch disc of radius " + std::to_string(radius) + " px (patch_size_px " +
                    std::to_string(patch_size_px) + ")");
    if (t.x1 == t.x2 && t.y1 == t.y2)
      return fail("pair " + std::to_string(i) + " compares point (" + std::to_string(t.x1) + ", " +
                  std::to_string(t.y1) + ") with itself");
  }
  return ok();
}

Status BriefExtractor::set_pattern(std::vector<BriefTest> pattern) {
  if (pattern.empty()) pattern = make_pattern(params_.patch_size_px);
  VISNAV_TRY(validate_pattern(pattern, params_.patch_size_px));
  pattern_ = std::move(pattern);
  offsets_stride_ = -1;  // the offset tables are built from the pattern
  return ok();
}

int BriefExtractor::border_px() const { return params_.patch_size_px / 2 - 1 + params_.kernel_size_px / 2; }

void BriefExtractor::rebuild_offsets(int stride) {
  const int h = params_.kernel_size_px / 2;
  offsets_.resize(static_cast<std::size_t>(kOrientationBins) * kBits * 8);
  for (int bin = 0; bin < kOrientationBins; ++bin) {
    const double angle = 2.0 * std::numbers::pi * bin / kOrientationBins;
    const double c = std::cos(angle);
    const double s = std::sin(angle);
    auto box = [&](int px, int py, std::int32_t* o) {
      const int rx = static_cast<int>(std::lround(px * c - py * s));
      const int ry = static_cast<int>(std::lround(px * s + py * c));
      o[0] = (ry + h + 1) * stride + rx + h + 1;
      o[1] = (ry - h) * stride + rx + h + 1;
      o[2] = (ry + h + 1) * stride + rx - h;
      o[3] = (ry - h) * stride + rx - h;
    };
    std::int32_t* o = offsets_.data() + static_cast<std::size_t>(bin) * kBits * 8;
    for (int i = 0; i < kBits; ++i, o += 8) {
      const BriefTest& t = pattern_[static_cast<std::size_t>(i)];
      box(t.x1, t.y1, o);
      box(t.x2, t.y2, o + 4);
    }
  }
  offsets_stride_ = stride;
}

float BriefExtractor::centroid_angle_deg(const cv::Mat& grey, int x, int y) const {
  const int radius = params_.patch_size_px / 2 - 1;
  std::int64_t m10 = 0;
  std::int64_t m01 = 0;
  for (int dy = -radius; dy <= radius; ++dy) {
    const int half = disc_half_width_[static_cast<std::size_t>(dy + radius)];
    const std::uint8_t* row = grey.ptr<std::uint8_t>(y + dy) + x;
    std::int64_t row_sum = 0;
    std::int64_t row_moment = 0;
    for (int dx = -half; dx <= half; ++dx) {
      row_sum += row[dx];
      row_moment += static_cast<std::int64_t>(dx) * row[dx];
    }
    m10 += row_moment;
    m01 += static_cast<std::int64_t>(dy) * row_sum;
  }
  if (m10 == 0 && m01 == 0) return 0.0F;
  double deg = std::atan2(static_cast<double>(m01), static_cast<double>(m10)) * 180.0 / std::numbers::pi;
  if (deg < 0.0) deg += 360.0;
  if (deg >= 360.0) deg -= 360.0;
  return static_cast<float>(deg);
}

void BriefExtractor::compute(const cv::Mat& grey, std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors,
                             const cv::Mat& integral) {
  assert(grey.empty() || grey.type() == CV_8UC1);
  const int border = border_px();
  const int w = grey.cols;
  const int h = grey.rows;
  // Drop keypoints whose patch does not fit (keeps the order of the others).
  std::erase_if(keypoints, [&](const cv::KeyPoint& kp) {
    const long xi = std::lround(kp.pt.x);
    const long yi = std::lround(kp.pt.y);
    return xi < border || yi < border || xi >= w - border || yi >= h - border;
  });
  const int n = static_cast<int>(keypoints.size());
  prepare_output(descriptors, n, kBytes, CV_8U);
  if (n == 0) return;

  const cv::Mat* sum = &integral;
  if (integral.rows != h + 1 || integral.cols != w + 1 || integral.type() != CV_32S) {
    cv::integral(grey, own_integral_, CV_32S);
    sum = &own_integral_;
  }
  const int stride = static_cast<int>(sum->step1());
  if (stride != offsets_stride_) rebuild_offsets(stride);
  if (!params_.upright && disc_half_width_.empty()) {
    const int radius = params_.patch_size_px / 2 - 1;
    for (int dy = -radius; dy <= radius; ++dy)
      disc_half_width_.push_back(static_cast<int>(std::floor(std::sqrt(double(radius * radius - dy * dy)))));
  }

  const auto* table = reinterpret_cast<const std::uint32_t*>(sum->ptr<std::int32_t>(0));
  for (int i = 0; i < n; ++i) {
    cv::KeyPoint& kp = keypoints[static_cast<std::size_t>(i)];
    const int xi = static_cast<int>(std::lround(kp.pt.x));
    const int yi = static_cast<int>(std::lround(kp.pt.y));
    int bin = 0;
    if (!params_.upright) {
      kp.angle = centroid_angle_deg(grey, xi, yi);
      bin = static_cast<int>(std::lround(kp.angle * kOrientationBins / 360.0)) % kOrientationBins;
    }
    const std::uint32_t* base = table + static_cast<std::ptrdiff_t>(yi) * stride + xi;
    const std::int32_t* o = offsets_.data() + static_cast<std::size_t>(bin) * kBits * 8;
    std::uint8_t* d = descriptors.ptr<std::uint8_t>(i);
    for (int byte = 0; byte < kBytes; ++byte) {
      unsigned v = 0;
      for (int bit = 0; bit < 8; ++bit, o += 8) {
        const auto a = static_cast<std::int32_t>(base[o[0]] - base[o[1]] - base[o[2]] + base[o[3]]);
        const auto b = static_cast<std::int32_t>(base[o[4]] - base[o[5]] - base[o[6]] + base[o[7]]);
        v |= static_cast<unsigned>(a < b) << bit;
      }
      d[byte] = static_cast<std::uint8_t>(v);
    }
  }
}

int hamming_distance(const std::uint8_t* a, const std::uint8_t* b, int bytes) {
  int distance = 0;
  int i = 0;
  for (; i + 8 <= bytes; i += 8) {
    std::uint64_t x = 0;
    std::uint64_t y = 0;
    std::memcpy(&x, a + i, 8);
    std::memcpy(&y, b + i, 8);
    distance += __builtin_popcountll(x ^ y);
  }
  for (; i < bytes; ++i) distance += __builtin_popcount(static_cast<unsigned>(a[i] ^ b[i]));
  return distance;
}

}  // namespace visnav::detectors
