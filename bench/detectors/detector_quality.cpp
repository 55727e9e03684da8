// detector_quality — quality figures of the detectors on real photographs (python3-skimage), to
// compare before and after a change of a detector's implementation (docs/detectors.md).
//
//   detector_quality [--dump FILE] [--types star_brief,orb,...]
//
// 1. STAR repeatability (StarDetector core, 500 strongest keypoints per image): image B is a
//    crop of the same photo as A shifted by a known horizontal amount, optionally with changed
//    brightness/contrast or added noise. A keypoint of A inside the common part is repeated when
//    B has a keypoint within 1.5 px of its expected position; repeatability = repeated / min(kept
//    in the common part of A, of B), capped at 1. Averaged over 5 photos × 6 shifts per condition.
// 2. Alignment (every type via the core factory + feature_replay HeadingEstimator, defaults):
//    the crops and shifts of tests/plugins/primitives/feature_replay test_heading (offset must be
//    −shift ± 3 px), plain and with contrast ×1.35 / brightness −25; reports the mean and max
//    |error|, failures (> 3 px or not valid) and mean inliers.
// --dump writes every STAR keypoint (x y size response octave class) of a fixed set of images
// and thresholds, so two builds can be compared for bit-identical output (diff the files).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "visnav/detectors/detector_types.hpp"
#include "visnav/detectors/star.hpp"
#include "visnav/feature_replay/heading.hpp"

namespace {

namespace d = visnav::detectors;
namespace fr = visnav::feature_replay;

const char* kData = "/usr/lib/python3/dist-packages/skimage/data/";

cv::Mat load_grey(const std::string& name) { return cv::imread(std::string(kData) + name, cv::IMREAD_GRAYSCALE); }

struct Crop {
  const char* image;
  int x0, y0, w, h;
};

// The crops of test_heading (KnownShiftsWithinThreePixels).
const Crop kCrops[] = {{"camera.png", 60, 80, 360, 300},
                       {"astronaut.png", 60, 60, 360, 320},
                       {"coffee.png", 80, 40, 400, 300},
                       {"chelsea.png", 60, 20, 320, 260},
                       {"motorcycle_left.png", 120, 80, 480, 360}};
const int kShifts[] = {-57, -23, -8, 5, 17, 44};

enum class Change { none, photometric, dark_low_contrast, noise };

cv::Mat changed(const cv::Mat& b, Change c) {
  cv::Mat out;
  switch (c) {
    case Change::none: return b.clone();
    case Change::photometric: b.convertTo(out, -1, 1.35, -25.0); return out;
    case Change::dark_low_contrast: b.convertTo(out, -1, 0.6, 10.0); return out;
    case Change::noise: {
      cv::Mat noise(b.size(), CV_16S);
      cv::RNG rng(7);
      rng.fill(noise, cv::RNG::NORMAL, 0, 4);
      cv::add(b, noise, out, cv::noArray(), CV_8U);
      return out;
    }
  }
  return out;
}

const char* change_name(Change c) {
  switch (c) {
    case Change::none: return "shift only";
    case Change::photometric: return "contrast x1.35, brightness -25";
    case Change::dark_low_contrast: return "contrast x0.6, brightness +10";
    case Change::noise: return "Gaussian noise sigma 4";
  }
  return "";
}

// The n strongest STAR keypoints; the threshold is lowered until at least n are found.
std::vector<cv::KeyPoint> strongest_star(const cv::Mat& grey, int n) {
  d::StarParams p;
  p.response_threshold = 4.0;
  d::StarDetector star(p);
  std::vector<cv::KeyPoint> kps;
  star.detect(grey, kps);
  if (static_cast<int>(kps.size()) > n) {
    std::stable_sort(kps.begin(), kps.end(), [](const cv::KeyPoint& a, const cv::KeyPoint& b) { return a.response > b.response; });
    kps.resize(static_cast<std::size_t>(n));
  }
  return kps;
}

// Repeatability of A's keypoints in B, where scene point x in A is at x − shift in B.
double repeatability(const std::vector<cv::KeyPoint>& a, const std::vector<cv::KeyPoint>& b, int shift, int w, int h,
                     int margin) {
  auto inside = [&](cv::Point2f p) { return p.x >= margin && p.x < w - margin && p.y >= margin && p.y < h - margin; };
  int na = 0, nb = 0, rep = 0;
  for (const auto& kb : b)
    if (inside(kb.pt + cv::Point2f(static_cast<float>(shift), 0))) ++nb;
  for (const auto& ka : a) {
    const cv::Point2f expected = ka.pt - cv::Point2f(static_cast<float>(shift), 0);
    if (!inside(expected)) continue;
    ++na;
    for (const auto& kb : b)
      if (cv::norm(kb.pt - expected) <= 1.5) {
        ++rep;
        break;
      }
  }
  const int denom = std::min(na, nb);
  return denom > 0 ? std::min(1.0, static_cast<double>(rep) / denom) : 0.0;
}

void star_repeatability() {
  std::printf("STAR repeatability (500 strongest, 1.5 px tolerance, mean over photos x shifts %s):\n", "-57..44 px");
  for (Change c : {Change::none, Change::photometric, Change::dark_low_contrast, Change::noise}) {
    double sum = 0.0;
    double worst = 1.0;
    int n = 0;
    for (const auto& crop : kCrops) {
      const cv::Mat img = load_grey(crop.image);
      if (img.empty()) continue;
      const cv::Mat a = img(cv::Rect(crop.x0, crop.y0, crop.w, crop.h)).clone();
      const auto ka = strongest_star(a, 500);
      for (int shift : kShifts) {
        const cv::Mat b = changed(img(cv::Rect(crop.x0 + shift, crop.y0, crop.w, crop.h)), c);
        const auto kb = strongest_star(b, 500);
        const double r = repeatability(ka, kb, shift, crop.w, crop.h, 24);
        sum += r;
        worst = std::min(worst, r);
        ++n;
      }
    }
    if (n > 0) std::printf("  %-32s mean %.3f  worst %.3f  (%d pairs)\n", change_name(c), sum / n, worst, n);
  }
}

void alignment(const std::string& type) {
  double sum_err = 0.0, max_err = 0.0, sum_inl = 0.0;
  int n = 0, failures = 0;
  for (const auto& crop : kCrops) {
    const cv::Mat img = load_grey(crop.image);
    if (img.empty()) continue;
    for (int shift : {-57, -23, -8, 0, 5, 17, 44}) {
      for (Change c : {Change::none, Change::photometric}) {
        const cv::Mat a = img(cv::Rect(crop.x0, crop.y0, crop.w, crop.h)).clone();
        const cv::Mat b = changed(img(cv::Rect(crop.x0 + shift, crop.y0, crop.w, crop.h)), c);
        auto det = d::create_detector(type, d::make_params({{"target_keypoints", "500"}}));
        if (!det) {
          std::printf("  %s: %s\n", type.c_str(), det.error().message.c_str());
          return;
        }
        visnav::Features fa, fb;
        for (int i = 0; i < 3; ++i) (void)(*det)->detect(a, fa);
        (void)(*det)->detect(b, fb);
        fr::HeadingEstimator est;
        auto e = est.estimate(fa, fb, static_cast<double>(crop.w));
        const double err = e.ok() ? std::abs(e->offset_px + shift) : 1e9;
        if (!e.ok() || !e->valid || err > 3.0) ++failures;
        if (e.ok()) {
          sum_err += std::min(err, 100.0);
          max_err = std::max(max_err, err);
          sum_inl += e->inliers;
        }
        ++n;
      }
    }
  }
  if (n > 0)
    std::printf("  %-12s mean |err| %.2f px  max %.2f px  failures %d/%d  mean inliers %.0f\n", type.c_str(), sum_err / n,
                max_err, failures, n, sum_inl / n);
}

void dump(const std::string& path) {
  std::ofstream out(path);
  for (const char* name : {"camera.png", "astronaut.png", "coffee.png", "chelsea.png", "motorcycle_left.png",
                           "motorcycle_right.png", "brick.png", "page.png", "text.png", "rocket.jpg"}) {
    const cv::Mat img = load_grey(name);
    if (img.empty()) continue;
    for (double t : {4.0, 12.0, 30.0, 60.0}) {
      d::StarParams p;
      p.response_threshold = t;
      d::StarDetector star(p);
      std::vector<cv::KeyPoint> kps;
      star.detect(img, kps);
      out << name << " threshold " << t << " count " << kps.size() << "\n";
      char line[160];
      for (const auto& k : kps) {
        std::snprintf(line, sizeof line, "%g %g %g %.9g %d %d\n", k.pt.x, k.pt.y, k.size, k.response, k.octave, k.class_id);
        out << line;
      }
    }
  }
  std::printf("keypoints written to %s\n", path.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> types = d::detector_type_names();
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--dump") == 0 && i + 1 < argc) {
      dump(argv[++i]);
      return 0;
    }
    if (std::strcmp(argv[i], "--types") == 0 && i + 1 < argc) {
      types.clear();
      std::stringstream ss(argv[++i]);
      for (std::string t; std::getline(ss, t, ',');) types.push_back(t);
    }
  }
  if (load_grey("camera.png").empty()) {
    std::printf("python3-skimage photos not installed\n");
    return 0;
  }
  star_repeatability();
  std::printf("Alignment on the test_heading crops (7 shifts x {plain, photometric}), HeadingEstimator defaults:\n");
  for (const auto& t : types) alignment(t);
  return 0;
}
