// Shared helpers for the detector tests: real photos from python3-skimage and matching.
#pragma once

#include <algorithm>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "visnav/detectors/brief.hpp"
#include "visnav/devices.hpp"

namespace visnav::detectors::testing {

inline const char* kSkimageData = "/usr/lib/python3/dist-packages/skimage/data/";

/// A real photo (BGR), or an empty Mat when python3-skimage is not installed.
inline cv::Mat photo(const std::string& name) { return cv::imread(std::string(kSkimageData) + name, cv::IMREAD_COLOR); }

/// The 640×480 window at (x0, y0) of motorcycle_left.png (741×500), BGR.
inline cv::Mat motorcycle_window(int x0, int y0) {
  cv::Mat m = photo("motorcycle_left.png");
  if (m.empty()) return m;
  return m(cv::Rect(x0, y0, 640, 480)).clone();
}

inline double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

struct Match {
  int a;
  int b;
};

/// Brute-force nearest neighbour of each row of `a` in `b` with Lowe's ratio test.
inline std::vector<Match> ratio_matches(const Features& a, const Features& b, double ratio) {
  std::vector<Match> out;
  for (int i = 0; i < a.descriptors.rows; ++i) {
    double best = 1e30;
    double second = 1e30;
    int best_j = -1;
    for (int j = 0; j < b.descriptors.rows; ++j) {
      double d = 0;
      if (a.norm == DescriptorNorm::hamming)
        d = hamming_distance(a.descriptors.ptr<std::uint8_t>(i), b.descriptors.ptr<std::uint8_t>(j),
                             a.descriptors.cols);
      else
        d = cv::norm(a.descriptors.row(i), b.descriptors.row(j), cv::NORM_L2);
      if (d < best) {
        second = best;
        best = d;
        best_j = j;
      } else if (d < second) {
        second = d;
      }
    }
    if (best_j >= 0 && best < ratio * second) out.push_back({i, best_j});
  }
  return out;
}

}  // namespace visnav::detectors::testing
