// PNG plot of the offset along the route (evaluate.hpp, write_plot).
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "visnav/evaluation/evaluate.hpp"

namespace visnav::evaluation {

Status write_plot(const std::vector<FrameEvaluation>& rows, const std::string& path, const std::string& title) {
  constexpr int kW = 1000;
  constexpr int kH = 420;
  constexpr int kLeft = 70;
  constexpr int kRight = 20;
  constexpr int kTop = 40;
  constexpr int kBottom = 50;
  cv::Mat img(kH, kW, CV_8UC3, cv::Scalar(255, 255, 255));
  double d_max = 1e-6;
  double off_max = 20.0;
  for (const auto& r : rows) {
    d_max = std::max(d_max, r.run_distance_m);
    off_max = std::max(off_max, std::abs(r.estimate.offset_px));
  }
  off_max = std::ceil(off_max / 20.0) * 20.0;
  auto px = [&](double d, double off) {
    const double x = kLeft + (kW - kLeft - kRight) * (d / d_max);
    const double y = kTop + (kH - kTop - kBottom) * (0.5 - off / (2.0 * off_max));
    return cv::Point(static_cast<int>(std::lround(x)), static_cast<int>(std::lround(y)));
  };
  const cv::Scalar grey(200, 200, 200);
  const cv::Scalar black(0, 0, 0);
  // grid: zero line, +-off_max, edge boundaries
  cv::line(img, px(0, 0), px(d_max, 0), cv::Scalar(120, 120, 120), 1);
  cv::rectangle(img, px(0, off_max), px(d_max, -off_max), black, 1);
  std::string last_edge;
  for (const auto& r : rows) {
    if (r.edge != last_edge && !last_edge.empty()) {
      cv::line(img, px(r.run_distance_m, off_max), px(r.run_distance_m, -off_max), grey, 1);
      cv::putText(img, r.edge, px(r.run_distance_m, off_max) + cv::Point(3, 14), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(90, 90, 90), 1);
    }
    last_edge = r.edge;
  }
  char buf[64];
  for (double v : {-off_max, -off_max / 2, 0.0, off_max / 2, off_max}) {
    std::snprintf(buf, sizeof buf, "%+.0f", v);
    cv::putText(img, buf, px(0, v) + cv::Point(-55, 4), cv::FONT_HERSHEY_SIMPLEX, 0.4, black, 1);
  }
  for (int i = 0; i <= 5; ++i) {
    const double d = d_max * i / 5.0;
    std::snprintf(buf, sizeof buf, "%.1f", d);
    cv::putText(img, buf, px(d, -off_max) + cv::Point(-10, 18), cv::FONT_HERSHEY_SIMPLEX, 0.4, black, 1);
  }
  cv::putText(img, "route distance [m]", cv::Point(kW / 2 - 60, kH - 8), cv::FONT_HERSHEY_SIMPLEX, 0.5, black, 1);
  cv::putText(img, "offset [px]", cv::Point(5, kTop - 12), cv::FONT_HERSHEY_SIMPLEX, 0.5, black, 1);
  cv::putText(img, title, cv::Point(kLeft + 100, kTop - 12), cv::FONT_HERSHEY_SIMPLEX, 0.5, black, 1);
  // points: valid filled blue, not valid hollow red; connect valid ones
  cv::Point prev;
  bool have_prev = false;
  for (const auto& r : rows) {
    const cv::Point p = px(r.run_distance_m, r.estimate.offset_px);
    if (r.estimate.valid) {
      if (have_prev) cv::line(img, prev, p, cv::Scalar(230, 160, 120), 1, cv::LINE_AA);
      cv::circle(img, p, 3, cv::Scalar(200, 80, 0), cv::FILLED, cv::LINE_AA);
      prev = p;
      have_prev = true;
    } else {
      cv::circle(img, p, 3, cv::Scalar(40, 40, 220), 1, cv::LINE_AA);
    }
  }
  bool written = false;
  try {
    written = cv::imwrite(path, img);
  } catch (const cv::Exception& e) {
    return fail(path + ": " + e.what());
  }
  if (!written) return fail(path + ": cannot write the plot");
  return ok();
}

}  // namespace visnav::evaluation
