// The live view's overlays (runtime/src/view/overlay.cpp): a NavOverlay copied past publish(),
// turned into foxglove.ImageAnnotations (matched features, match lines, heading histogram,
// offset line, path outline and centre line) and drawn into a frame.
#include <gtest/gtest.h>

#include <regex>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "view/overlay.hpp"

using namespace visnav;
using namespace visnav::view;

namespace {

/// The BGR pixel OpenCV draws for an RGB colour given in [0, 1].
cv::Vec3b bgr(double r, double g, double b) {
  return {cv::saturate_cast<std::uint8_t>(b * 255.0), cv::saturate_cast<std::uint8_t>(g * 255.0),
          cv::saturate_cast<std::uint8_t>(r * 255.0)};
}

int count(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

TEST(ViewOverlay, FeatureOverlayBecomesPointsLinesAndHistogramBars) {
  const std::vector<cv::Point2f> matched{{100, 50}, {120, 60}, {30, 70}};
  const std::vector<cv::Point2f> taught{{90, 50}, {110, 60}, {60, 70}};
  const std::vector<std::uint8_t> inlier{1, 1, 0};
  std::vector<int> histogram(41, 0);
  histogram[20] = 1;  // offset 0
  histogram[21] = 4;  // offset +20 px: the peak
  NavOverlay o;
  o.matched_px = matched;
  o.reference_px = taught;
  o.inlier = inlier;
  o.histogram = histogram;
  o.histogram_bin_px = 20.0;
  o.offset_px = 10.0;
  OverlayCopy copy;
  copy.copy_from(o);
  // The copy outlives the primitive's buffers.
  const std::string json = annotations_json(copy, {320, 240}, 12.5);
  EXPECT_EQ(count(json, "\"type\":1,"), 1) << json;  // the matched features
  EXPECT_EQ(count(json, "\"type\":4,"), 2) << json;  // match lines, histogram bars
  EXPECT_EQ(count(json, "\"type\":3,"), 1) << json;  // the offset line
  EXPECT_NE(json.find("\"timestamp\":{\"sec\":12,\"nsec\":500000000}"), std::string::npos) << json;
  EXPECT_NE(json.find("matches 3, inliers 2, offset 10 px"), std::string::npos) << json;
  // Per-point colours: two inliers (green) and one outlier (red).
  EXPECT_NE(json.find("\"outline_colors\":[{\"r\":0.1,\"g\":0.9,\"b\":0.1,\"a\":1},{\"r\":0.1,\"g\":0.9,\"b\":0.1,\"a\":1},"
                      "{\"r\":0.9,\"g\":0.1,\"b\":0.1,\"a\":1}]"),
            std::string::npos)
      << json;
  // Histogram bars at image centre + bin offset, the peak a quarter of the image high.
  EXPECT_NE(json.find("{\"x\":180,\"y\":239},{\"x\":180,\"y\":179}"), std::string::npos) << json;
  EXPECT_NE(json.find("{\"x\":160,\"y\":239},{\"x\":160,\"y\":224}"), std::string::npos) << json;

  cv::Mat frame(240, 320, CV_8UC3, cv::Scalar(0, 0, 0));
  draw_overlay(frame, copy);
  EXPECT_EQ(frame.at<cv::Vec3b>(50, 100), bgr(0.1, 0.9, 0.1));  // inlier dot, green
  EXPECT_EQ(frame.at<cv::Vec3b>(70, 30), bgr(0.9, 0.1, 0.1));   // outlier dot, red
  EXPECT_EQ(frame.at<cv::Vec3b>(120, 170), bgr(1.0, 0.1, 1.0));  // offset line at 160 + 10
  EXPECT_EQ(frame.at<cv::Vec3b>(200, 180), bgr(1.0, 1.0, 1.0));  // the peak bar, white
  EXPECT_EQ(frame.at<cv::Vec3b>(10, 300), cv::Vec3b(0, 0, 0));  // untouched elsewhere

  copy.clear();
  EXPECT_EQ(annotations_json(copy, {320, 240}, 1.0), "{\"circles\":[],\"points\":[],\"texts\":[]}");
  cv::Mat blank(240, 320, CV_8UC3, cv::Scalar(0, 0, 0));
  draw_overlay(blank, copy);
  EXPECT_EQ(cv::countNonZero(blank.reshape(1)), 0);
}

TEST(ViewOverlay, PathMaskBecomesAnOutlineCentreLineAndAGreenTint) {
  cv::Mat mask(120, 160, CV_8UC1, cv::Scalar(0));
  cv::rectangle(mask, cv::Rect(60, 60, 40, 60), cv::Scalar(255), cv::FILLED);
  std::vector<cv::Point2f> middle;
  for (int v = 60; v < 120; ++v) middle.emplace_back(80.0F, static_cast<float>(v));
  NavOverlay o;
  o.path_mask = mask;
  o.path_middle_px = middle;
  o.offset_px = 0.0;
  OverlayCopy copy;
  copy.copy_from(o);
  mask.setTo(0);  // the follower reuses its buffer: the copy must not change
  EXPECT_EQ(cv::countNonZero(copy.path_mask), 40 * 60);
  const std::string json = annotations_json(copy, {160, 120}, 0.0);
  EXPECT_EQ(count(json, "\"type\":2,"), 1) << json;  // the outline
  // Centre line and offset line.
  EXPECT_EQ(count(json, "\"type\":3,"), 2) << json;
  // The outline is the rectangle's four corners.
  const std::regex loop("\"type\":2,\"points\":\\[(\\{[^}]*\\},?){4}\\]");
  EXPECT_TRUE(std::regex_search(json, loop)) << json;
  EXPECT_NE(json.find("path offset 0 px"), std::string::npos) << json;

  cv::Mat frame(120, 160, CV_8UC3, cv::Scalar(100, 100, 100));
  draw_overlay(frame, copy);
  const cv::Vec3b inside = frame.at<cv::Vec3b>(90, 70);
  const cv::Vec3b outside = frame.at<cv::Vec3b>(20, 20);
  EXPECT_EQ(outside, cv::Vec3b(100, 100, 100));
  EXPECT_GT(inside[1], 130);  // tinted green
  EXPECT_LT(inside[0], 100);
}

}  // namespace
