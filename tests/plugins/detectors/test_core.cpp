// Unit tests of the detector core: CenSurE/STAR, BRIEF, adaptive threshold.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <opencv2/imgproc.hpp>

#include "test_support.hpp"
#include "visnav/detectors/adaptive_threshold.hpp"
#include "visnav/detectors/brief.hpp"
#include "visnav/detectors/star.hpp"

namespace visnav::detectors {
namespace {

using testing::median;
using testing::photo;

struct Blob {
  cv::Point center;
  int radius;
  bool bright;
};

cv::Mat blob_image(const std::vector<Blob>& blobs, int w = 640, int h = 480) {
  cv::Mat img(h, w, CV_8UC1, cv::Scalar(110));
  for (const auto& b : blobs) cv::circle(img, b.center, b.radius, cv::Scalar(b.bright ? 230 : 10), cv::FILLED, cv::LINE_8);
  return img;
}

const cv::KeyPoint* nearest(const std::vector<cv::KeyPoint>& kps, cv::Point2f p, double* dist) {
  const cv::KeyPoint* best = nullptr;
  double bd = 1e9;
  for (const auto& kp : kps) {
    const double d = cv::norm(kp.pt - p);
    if (d < bd) {
      bd = d;
      best = &kp;
    }
  }
  *dist = bd;
  return best;
}

TEST(Star, FindsBrightAndDarkBlobsAtTheirCentres) {
  std::vector<Blob> blobs;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 4; ++j) blobs.push_back({{70 + i * 95, 70 + j * 110}, 4, (i + j) % 2 == 0});
  const cv::Mat img = blob_image(blobs);
  StarDetector star;
  std::vector<cv::KeyPoint> kps;
  star.detect(img, kps);
  for (const auto& b : blobs) {
    double d = 0;
    const cv::KeyPoint* kp = nearest(kps, cv::Point2f(b.center), &d);
    ASSERT_NE(kp, nullptr);
    EXPECT_LE(d, 1.0) << "blob at " << b.center;
    EXPECT_EQ(kp->class_id, b.bright ? 1 : -1) << "blob at " << b.center;
    EXPECT_GT(kp->response, 30.0F);
  }
  // Nothing away from the blobs: every keypoint belongs to one (ring artefacts included).
  for (const auto& kp : kps) {
    double d = 1e9;
    for (const auto& b : blobs) d = std::min(d, cv::norm(kp.pt - cv::Point2f(b.center)));
    EXPECT_LE(d, 10.0) << "stray keypoint at " << kp.pt;
  }
  EXPECT_LE(kps.size(), blobs.size() * 2);
}

TEST(Star, ScaleFollowsBlobSize) {
  const std::vector<int> radii = {2, 4, 7, 11};
  std::vector<Blob> blobs;
  for (std::size_t i = 0; i < radii.size(); ++i) blobs.push_back({{100 + static_cast<int>(i) * 140, 240}, radii[i], true});
  const cv::Mat img = blob_image(blobs);
  StarDetector star;
  std::vector<cv::KeyPoint> kps;
  star.detect(img, kps);
  float previous = 0;
  for (const auto& b : blobs) {
    double d = 0;
    const cv::KeyPoint* kp = nearest(kps, cv::Point2f(b.center), &d);
    ASSERT_NE(kp, nullptr);
    EXPECT_LE(d, 1.0) << "radius " << b.radius;
    EXPECT_GT(kp->size, previous) << "radius " << b.radius;
    // Inner filter radius (size = 4·inner + 1) within a factor 2 of the blob radius.
    const double inner = (kp->size - 1) / 4.0;
    EXPECT_GE(inner, b.radius / 2.0) << "radius " << b.radius;
    EXPECT_LE(inner, b.radius * 2.0) << "radius " << b.radius;
    previous = kp->size;
  }
}

TEST(Star, UniformAndTinyImagesGiveNothing) {
  StarDetector star;
  std::vector<cv::KeyPoint> kps{cv::KeyPoint(1, 1, 1)};
  star.detect(cv::Mat(480, 640, CV_8UC1, cv::Scalar(77)), kps);
  EXPECT_TRUE(kps.empty());
  for (int side : {1, 2, 5, 7, 8, 20}) {
    cv::Mat tiny(side, side, CV_8UC1);
    cv::randu(tiny, 0, 255);
    star.detect(tiny, kps);
    for (const auto& kp : kps) {
      EXPECT_GE(kp.pt.x, 0);
      EXPECT_LT(kp.pt.x, side);
    }
  }
  star.detect(cv::Mat(), kps);
  EXPECT_TRUE(kps.empty());
}

TEST(Star, SuppressesLines) {
  cv::Mat img(480, 640, CV_8UC1, cv::Scalar(100));
  cv::line(img, {100, 240}, {540, 240}, cv::Scalar(220), 3);
  cv::line(img, {320, 60}, {320, 200}, cv::Scalar(10), 5);
  StarDetector star;
  std::vector<cv::KeyPoint> kps;
  star.detect(img, kps);
  EXPECT_FALSE(kps.empty());
  // Only the line ends may respond, never the middle stretches.
  for (const auto& kp : kps) {
    const bool near_end = cv::norm(kp.pt - cv::Point2f(100, 240)) < 25 || cv::norm(kp.pt - cv::Point2f(540, 240)) < 25 ||
                          cv::norm(kp.pt - cv::Point2f(320, 60)) < 25 || cv::norm(kp.pt - cv::Point2f(320, 200)) < 25;
    EXPECT_TRUE(near_end) << "keypoint on a line at " << kp.pt;
  }
}

TEST(Star, LineSuppressionRemovesNoiseMaximaAlongLines) {
  // Noise breaks the response plateau along a line into many local maxima; the Harris-type
  // ratio test must reject almost all of them.
  cv::Mat img(480, 640, CV_8UC1, cv::Scalar(100));
  cv::line(img, {60, 240}, {580, 240}, cv::Scalar(220), 3);
  cv::line(img, {100, 60}, {500, 420}, cv::Scalar(10), 4);
  cv::Mat noise(img.size(), CV_16S);
  cv::RNG rng(42);
  rng.fill(noise, cv::RNG::NORMAL, 0, 6);
  cv::Mat noisy;
  cv::add(img, noise, noisy, cv::noArray(), CV_8U);
  StarParams off;
  off.line_threshold_projected = 1000;
  off.line_threshold_binarized = 1000;
  StarDetector without(off);
  StarDetector with;
  std::vector<cv::KeyPoint> k_without;
  std::vector<cv::KeyPoint> k_with;
  without.detect(noisy, k_without);
  with.detect(noisy, k_with);
  EXPECT_GT(k_without.size(), 60U);
  EXPECT_LT(k_with.size() * 4, k_without.size()) << k_with.size() << " vs " << k_without.size();
}

TEST(Star, ThresholdControlsCountOnAPhoto) {
  cv::Mat bgr = photo("motorcycle_left.png");
  if (bgr.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  StarParams p;
  std::vector<std::size_t> counts;
  for (double t : {60.0, 30.0, 15.0, 8.0}) {
    p.response_threshold = t;
    StarDetector star(p);
    std::vector<cv::KeyPoint> kps;
    star.detect(grey, kps);
    counts.push_back(kps.size());
  }
  EXPECT_LT(counts[0], counts[1]);
  EXPECT_LT(counts[1], counts[2]);
  EXPECT_LT(counts[2], counts[3]);
  EXPECT_GT(counts[3], 300U);
}

TEST(Star, IntegralMatchesOpenCv) {
  cv::Mat img(97, 131, CV_8UC1);
  cv::randu(img, 0, 256);
  StarDetector star;
  std::vector<cv::KeyPoint> kps;
  star.detect(img, kps);
  cv::Mat ref;
  cv::integral(img, ref, CV_32S);
  EXPECT_EQ(cv::norm(star.integral(), ref, cv::NORM_INF), 0.0);
}

// A direct, unoptimised restatement of the filter of star.hpp: star sums from per-row
// prefix sums (no slanted tables), per-pixel scale selection, a plain NMS window scan and the
// line test. The optimised detector must return exactly the same keypoints.
std::vector<cv::KeyPoint> reference_star(const cv::Mat& img, const StarParams& p) {
  const int w = img.cols, h = img.rows;
  cv::Mat prefix(h, w + 1, CV_32S, cv::Scalar(0));  // prefix(y, x + 1) = sum of row y up to x
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) prefix.at<int>(y, x + 1) = prefix.at<int>(y, x) + img.at<std::uint8_t>(y, x);
  auto row_sum = [&](int y, int x0, int x1) { return prefix.at<int>(y, x1 + 1) - prefix.at<int>(y, x0); };
  struct R {
    int n, r;
    double area;
  };
  auto radius = [](int n) {
    const int r = static_cast<int>(std::lround(n * std::sqrt(2.0)));
    return R{n, r, (2.0 * n + 1) * (2.0 * n + 1) + 2.0 * r * r + 2.0 * r + 1.0};
  };
  auto star_sum = [&](const R& rad, int x, int y) {
    int sum = 0;
    for (int dy = -rad.n; dy <= rad.n; ++dy) sum += row_sum(y + dy, x - rad.n, x + rad.n);
    for (int dy = -rad.r; dy <= rad.r; ++dy) {
      const int half = rad.r - std::abs(dy);
      sum += row_sum(y + dy, x - half, x + half);
    }
    return sum;
  };
  struct Sc {
    R in, out;
    float wi, wr;
    int margin;
  };
  std::vector<Sc> scales;
  for (int inner : {1, 2, 3, 4, 6, 8, 11, 16, 23, 32}) {
    if (4 * inner + 1 > p.max_size_px) break;
    const R a = radius(inner), b = radius(2 * inner);
    scales.push_back({a, b, static_cast<float>(1.0 / a.area), static_cast<float>(1.0 / (b.area - a.area)),
                      std::max(b.n, b.r)});
  }
  cv::Mat resp(h, w, CV_32F, cv::Scalar(0));
  cv::Mat scale(h, w, CV_8U, cv::Scalar(0));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (std::size_t i = 0; i < scales.size(); ++i) {
        const Sc& s = scales[i];
        if (x < s.margin || y < s.margin || x >= w - s.margin || y >= h - s.margin) continue;
        const float fin = static_cast<float>(star_sum(s.in, x, y));
        const float v = fin * s.wi - (static_cast<float>(star_sum(s.out, x, y)) - fin) * s.wr;
        if (std::fabs(v) > std::fabs(resp.at<float>(y, x))) {
          resp.at<float>(y, x) = v;
          scale.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(i);
        }
      }
  auto is_line = [&](int x, int y, int sc) {
    const int delta = std::max(1, 2 * scales[static_cast<std::size_t>(sc)].in.n / 4), rad = 4 * delta;
    double lxx = 0, lyy = 0, lxy = 0;
    int bxx = 0, byy = 0, bxy = 0;
    for (int sy = y - rad; sy <= y + rad; sy += delta)
      for (int sx = x - rad; sx <= x + rad; sx += delta) {
        if (sy < 1 || sy > h - 2 || sx < 1 || sx > w - 2) continue;
        const double lx = resp.at<float>(sy, sx + 1) - resp.at<float>(sy, sx - 1);
        const double ly = resp.at<float>(sy + 1, sx) - resp.at<float>(sy - 1, sx);
        lxx += lx * lx;
        lyy += ly * ly;
        lxy += lx * ly;
        auto same = [&](int yy, int xx) { return int(scale.at<std::uint8_t>(yy, xx) == sc); };
        const int bx = same(sy, sx + 1) - same(sy, sx - 1), by = same(sy + 1, sx) - same(sy - 1, sx);
        bxx += bx * bx;
        byy += by * by;
        bxy += bx * by;
      }
    const double tr = lxx + lyy, trb = bxx + byy;
    return (tr > 0 && tr * tr >= p.line_threshold_projected * (lxx * lyy - lxy * lxy)) ||
           (trb > 0 && trb * trb >= p.line_threshold_binarized * (double(bxx) * byy - double(bxy) * bxy));
  };
  std::vector<cv::KeyPoint> out;
  const int k = p.suppress_nonmax_size_px / 2, edge = std::max(k, p.border_px);
  for (int y = edge; y < h - edge; ++y)
    for (int x = edge; x < w - edge; ++x) {
      const float v = resp.at<float>(y, x);
      if (!(std::fabs(v) > p.response_threshold)) continue;
      bool extremum = true;
      for (int dy = -k; dy <= k; ++dy)
        for (int dx = -k; dx <= k; ++dx) {
          if (dx == 0 && dy == 0) continue;
          const float nv = resp.at<float>(y + dy, x + dx);
          const bool earlier = dy < 0 || (dy == 0 && dx < 0);
          if (v > 0 ? (nv > v || (earlier && nv == v)) : (nv < v || (earlier && nv == v))) extremum = false;
        }
      const int sc = scale.at<std::uint8_t>(y, x);
      if (!extremum || is_line(x, y, sc)) continue;
      out.emplace_back(static_cast<float>(x), static_cast<float>(y), static_cast<float>(4 * scales[sc].in.n + 1), -1.0F,
                       std::fabs(v), sc, v > 0 ? 1 : -1);
    }
  return out;
}

TEST(Star, OptimisedDetectorMatchesTheDirectDefinitionExactly) {
  // Odd sizes (vector tails), borders where only some scales fit, 7 and all 10 scales, plateaus
  // (ties in the NMS) from a quantised image, and a real photo when available.
  cv::Mat noise(157, 243, CV_8UC1);
  cv::RNG rng(5);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat smooth;
  cv::GaussianBlur(noise, smooth, cv::Size(0, 0), 2.5);
  cv::normalize(smooth, smooth, 0, 255, cv::NORM_MINMAX);
  cv::Mat quantised = smooth / 40 * 40;
  std::vector<cv::Mat> images = {smooth, quantised};
  const cv::Mat bgr = photo("motorcycle_left.png");
  if (!bgr.empty()) {
    cv::Mat grey;
    cv::cvtColor(bgr(cv::Rect(300, 150, 211, 190)), grey, cv::COLOR_BGR2GRAY);
    images.push_back(grey);
  }
  for (int max_size : {45, 129, 13}) {
    for (double threshold : {3.0, 12.0}) {
      StarParams p;
      p.max_size_px = max_size;
      p.response_threshold = threshold;
      p.border_px = max_size == 13 ? 9 : 0;
      StarDetector star(p);
      for (std::size_t i = 0; i < images.size(); ++i) {
        std::vector<cv::KeyPoint> got;
        star.detect(images[i], got);
        const auto want = reference_star(images[i], p);
        ASSERT_EQ(got.size(), want.size()) << "image " << i << " max_size " << max_size << " threshold " << threshold;
        for (std::size_t j = 0; j < got.size(); ++j) {
          EXPECT_EQ(got[j].pt, want[j].pt) << j;
          EXPECT_EQ(got[j].response, want[j].response) << j;
          EXPECT_EQ(got[j].octave, want[j].octave) << j;
          EXPECT_EQ(got[j].size, want[j].size) << j;
          EXPECT_EQ(got[j].class_id, want[j].class_id) << j;
        }
        if (max_size == 45 && threshold == 3.0) {
          EXPECT_GT(got.size(), 20U) << "image " << i;
        }
      }
    }
  }
}

// ------------------------------------------------------------------------------------ BRIEF

TEST(Brief, PatternIsFixedAndInsideThePatch) {
  const auto a = BriefExtractor::make_pattern(48);
  const auto b = BriefExtractor::make_pattern(48);
  ASSERT_EQ(a.size(), 256U);
  double sum_sq = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].x1, b[i].x1);
    EXPECT_EQ(a[i].y2, b[i].y2);
    EXPECT_LE(a[i].x1 * a[i].x1 + a[i].y1 * a[i].y1, 23 * 23);
    EXPECT_LE(a[i].x2 * a[i].x2 + a[i].y2 * a[i].y2, 23 * 23);
    sum_sq += a[i].x1 * a[i].x1 + a[i].y1 * a[i].y1;
  }
  // Isotropic Gaussian σ = S/5 = 9.6 px (slightly less after truncation to the disc).
  const double sigma = std::sqrt(sum_sq / (2.0 * a.size()));
  EXPECT_GT(sigma, 7.5);
  EXPECT_LT(sigma, 10.5);
}

struct PhotoFeatures {
  cv::Mat grey;
  std::vector<cv::KeyPoint> kps;
};

PhotoFeatures photo_keypoints() {
  PhotoFeatures out;
  cv::Mat bgr = testing::motorcycle_window(50, 10);
  if (bgr.empty()) return out;
  cv::cvtColor(bgr, out.grey, cv::COLOR_BGR2GRAY);
  StarParams sp;
  sp.response_threshold = 12;
  StarDetector star(sp);
  star.detect(out.grey, out.kps);
  return out;
}

TEST(Brief, DeterministicAndBorderAware) {
  PhotoFeatures pf = photo_keypoints();
  if (pf.grey.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  pf.kps.emplace_back(3.0F, 3.0F, 7.0F);
  pf.kps.emplace_back(639.0F, 240.0F, 7.0F);
  BriefExtractor e1;
  BriefExtractor e2;
  auto k1 = pf.kps;
  auto k2 = pf.kps;
  cv::Mat d1;
  cv::Mat d2;
  e1.compute(pf.grey, k1, d1);
  e2.compute(pf.grey, k2, d2);
  ASSERT_EQ(d1.cols, 32);
  ASSERT_EQ(d1.type(), CV_8U);
  ASSERT_EQ(static_cast<int>(k1.size()), d1.rows);
  EXPECT_EQ(cv::norm(d1, d2, cv::NORM_HAMMING), 0.0);
  EXPECT_LT(k1.size(), pf.kps.size());
  for (const auto& kp : k1) {
    EXPECT_GE(kp.pt.x, e1.border_px());
    EXPECT_LT(kp.pt.x, 640 - e1.border_px());
  }
  // Reusing the star integral gives the same bits.
  auto k3 = pf.kps;
  cv::Mat d3;
  cv::Mat sum;
  cv::integral(pf.grey, sum, CV_32S);
  e1.compute(pf.grey, k3, d3, sum);
  EXPECT_EQ(cv::norm(d1, d3, cv::NORM_HAMMING), 0.0);
}

TEST(Brief, SmallDistanceUnderPhotometricChangeLargeForOtherPatches) {
  PhotoFeatures pf = photo_keypoints();
  if (pf.grey.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  cv::Mat changed;
  pf.grey.convertTo(changed, CV_8U, 0.7, 35);  // contrast × 0.7, brightness + 35
  cv::Mat noise(changed.size(), CV_16S);
  cv::randn(noise, 0, 3);
  cv::Mat noisy;
  cv::add(changed, noise, noisy, cv::noArray(), CV_8U);
  BriefExtractor brief;
  auto ka = pf.kps;
  cv::Mat da;
  brief.compute(pf.grey, ka, da);
  auto kb = ka;
  cv::Mat db;
  brief.compute(noisy, kb, db);
  ASSERT_EQ(ka.size(), kb.size());
  ASSERT_GT(ka.size(), 100U);
  std::vector<double> same;
  std::vector<double> other;
  for (int i = 0; i < da.rows; ++i) {
    same.push_back(hamming_distance(da.ptr<std::uint8_t>(i), db.ptr<std::uint8_t>(i), 32));
    const int j = (i * 7 + da.rows / 2) % da.rows;
    if (cv::norm(ka[static_cast<std::size_t>(i)].pt - ka[static_cast<std::size_t>(j)].pt) > 48)
      other.push_back(hamming_distance(da.ptr<std::uint8_t>(i), da.ptr<std::uint8_t>(j), 32));
  }
  EXPECT_LT(median(same), 25.0);
  EXPECT_GT(median(other), 85.0);
}

TEST(Brief, OrientedIsRotationInvariantUprightIsNot) {
  PhotoFeatures pf = photo_keypoints();
  if (pf.grey.empty()) GTEST_SKIP() << "python3-skimage photos not installed";
  cv::Mat rotated;
  cv::rotate(pf.grey, rotated, cv::ROTATE_90_CLOCKWISE);  // (x, y) → (h−1−y, x)
  const int h = pf.grey.rows;
  auto rotate_kps = [h](std::vector<cv::KeyPoint> kps) {
    for (auto& kp : kps) kp.pt = cv::Point2f(static_cast<float>(h - 1) - kp.pt.y, kp.pt.x);
    return kps;
  };
  for (bool upright : {false, true}) {
    BriefParams bp;
    bp.upright = upright;
    BriefExtractor brief(bp);
    auto ka = pf.kps;
    cv::Mat da;
    brief.compute(pf.grey, ka, da);
    auto kb = rotate_kps(ka);
    cv::Mat db;
    brief.compute(rotated, kb, db);
    ASSERT_EQ(ka.size(), kb.size());
    std::vector<double> dist;
    for (int i = 0; i < da.rows; ++i) dist.push_back(hamming_distance(da.ptr<std::uint8_t>(i), db.ptr<std::uint8_t>(i), 32));
    if (upright) {
      EXPECT_GT(median(dist), 80.0);
    } else {
      EXPECT_LT(median(dist), 45.0);
      std::vector<double> dangle;
      for (std::size_t i = 0; i < ka.size(); ++i) {
        double d = kb[i].angle - ka[i].angle - 90.0;
        d = std::remainder(d, 360.0);
        dangle.push_back(std::abs(d));
      }
      EXPECT_LT(median(dangle), 6.0);
    }
  }
}

TEST(Brief, HammingDistance) {
  std::uint8_t a[32] = {};
  std::uint8_t b[32] = {};
  EXPECT_EQ(hamming_distance(a, b, 32), 0);
  b[0] = 0xFF;
  b[31] = 0x01;
  b[9] = 0x10;
  EXPECT_EQ(hamming_distance(a, b, 32), 10);
  EXPECT_EQ(hamming_distance(a, b, 3), 8);
}

// -------------------------------------------------------------------------- adaptive threshold

TEST(AdaptiveThreshold, ConvergesOnAPowerLawWithinAFewFrames) {
  for (double alpha : {0.7, 1.5, 3.0}) {
    for (double start : {2.0, 200.0}) {
      AdaptiveThresholdParams p;
      p.target_keypoints = 500;
      p.initial_threshold = start;
      p.min_threshold = 0.5;
      p.max_threshold = 1000;
      AdaptiveThreshold at(p);
      auto count = [alpha](double t) { return static_cast<int>(600.0 * std::pow(t / 20.0, -alpha)); };
      int frames = 0;
      while (std::abs(count(at.threshold()) - at.aim()) > 0.15 * at.aim() && frames < 20) {
        at.update(count(at.threshold()));
        ++frames;
      }
      EXPECT_LE(frames, 8) << "alpha " << alpha << " start " << start;
    }
  }
}

TEST(AdaptiveThreshold, ClampsAndStepsDownOnEmptyFrames) {
  AdaptiveThresholdParams p;
  p.initial_threshold = 10;
  p.min_threshold = 4;
  p.max_threshold = 12;
  p.max_step_ratio = 2;
  AdaptiveThreshold at(p);
  at.update(0);
  EXPECT_DOUBLE_EQ(at.threshold(), 5.0);
  at.update(0);
  EXPECT_DOUBLE_EQ(at.threshold(), 4.0);
  // A sudden scene change: the recent "too few at 5" bracket only delays the climb briefly.
  int frames = 0;
  while (at.threshold() < 12.0 && frames < 10) {
    at.update(100000);
    ++frames;
  }
  EXPECT_DOUBLE_EQ(at.threshold(), 12.0);
  EXPECT_LE(frames, 6);
  p.enabled = false;
  at.reconfigure(p);
  at.update(0);
  EXPECT_DOUBLE_EQ(at.threshold(), 10.0);
  p.min_threshold = 20;
  EXPECT_FALSE(p.validate().ok());
}

}  // namespace
}  // namespace visnav::detectors
