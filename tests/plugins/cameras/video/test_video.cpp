// The `video` camera (plugins/cameras/video) through the real loader.
#include <gtest/gtest.h>

#include <chrono>

#include <opencv2/videoio.hpp>

#include "camera_test_support.hpp"
#include "error_expect.hpp"

using namespace visnav::testing;

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;

namespace {

/// Writes `n` frames at `fps` as MJPG/AVI; returns the path or "" if this OpenCV cannot write it.
std::string write_video(const std::string& dir, int n, double fps) {
  const std::string path = dir + "/clip.avi";
  cv::VideoWriter w(path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, cv::Size(64, 48));
  if (!w.isOpened()) return "";
  for (int i = 0; i < n; ++i) {
    cv::Mat img = test_image(i);
    cv::rectangle(img, cv::Rect(4 * i, 10, 8, 8), cv::Scalar(255, 255, 255), cv::FILLED);
    w.write(img);
  }
  return path;
}

}  // namespace

TEST(VideoCamera, FastPacingReadsEveryFrameThenEnds) {
  const std::string dir = scratch();
  const std::string path = write_video(dir, 12, 20.0);
  if (path.empty()) GTEST_SKIP() << "OpenCV cannot write MJPG/AVI here";
  LoaderHost h;
  auto cam = h.loader.create<visnav::Camera>("video", yaml("file: " + path + "\npacing: fast\nresize_width_px: 32\n"), h.host);
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  for (int i = 0; i < 12; ++i) {
    auto f = (*cam)->grab(0.0);
    ASSERT_TRUE(f.ok()) << f.error().message;
    ASSERT_TRUE(f->has_value()) << i;
    EXPECT_EQ((*f)->image.size(), cv::Size(32, 24));
    EXPECT_EQ((*f)->sequence, static_cast<std::uint64_t>(i));
  }
  auto end = (*cam)->grab(0.0);
  EXPECT_TRUE(fails_with(end, ErrorCode::missing, At{path, 0, "file"}));
  EXPECT_NE(end.error().message.find("after 12 frames"), std::string::npos) << end.error().message;  // how far it got
}

TEST(VideoCamera, RealtimePacingFollowsTheFileRateAndClockPacingTheRunClock) {
  const std::string dir = scratch();
  const std::string path = write_video(dir, 6, 20.0);
  if (path.empty()) GTEST_SKIP() << "OpenCV cannot write MJPG/AVI here";
  LoaderHost h;
  auto cam = h.loader.create<visnav::Camera>("video", yaml("file: " + path + "\n"), h.host);  // realtime default
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  const auto start = std::chrono::steady_clock::now();
  int got = 0;
  while (got < 6) {
    auto f = (*cam)->grab(0.5);
    ASSERT_TRUE(f.ok()) << f.error().message;
    if (f->has_value()) ++got;
  }
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_GT(took, 0.2);  // 5 intervals of 50 ms
  EXPECT_LT(took, 2.0);  // generous: CI shares 2 cores

  auto clocked = h.loader.create<visnav::Camera>("video", yaml("file: " + path + "\npacing: clock\n"), h.host);
  ASSERT_TRUE(clocked.ok()) << clocked.error().message;
  h.clock.set(0.12);  // frames at 0, 0.05, 0.10 are due: the newest is delivered
  auto f = (*clocked)->grab(0.0);
  ASSERT_TRUE(f.ok() && f->has_value());
  EXPECT_NEAR((*f)->timestamp_s, 0.10, 1e-6);
  EXPECT_FALSE((*clocked)->grab(0.0)->has_value());
}

TEST(VideoCamera, MissingOrUnreadableFilesAreClearErrors) {
  LoaderHost h;
  auto missing = h.loader.create<visnav::Camera>("video", yaml("file: /no/such/clip.mp4\n"), h.host);
  EXPECT_TRUE(fails_with(missing, ErrorCode::not_found, At{"/no/such/clip.mp4", 0, "file"}));
  const std::string dir = scratch();
  write_text(dir + "/garbage.mp4", std::string(4096, 'x'));
  auto garbage = h.loader.create<visnav::Camera>("video", yaml("file: " + dir + "/garbage.mp4\n"), h.host);
  EXPECT_TRUE(fails_with(garbage, ErrorCode::parse_error, At{"garbage.mp4", 0, "file"}));
  auto folder = h.loader.create<visnav::Camera>("video", yaml("file: " + dir + "\n"), h.host);
  EXPECT_TRUE(fails_with(folder, ErrorCode::invalid_value, At{dir, 0, "file"}));
}
