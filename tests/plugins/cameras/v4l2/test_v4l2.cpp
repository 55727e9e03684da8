// The `v4l2` camera (plugins/cameras/v4l2) through the real loader.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <chrono>
#include <cstring>

#include "camera_test_support.hpp"
#include "error_expect.hpp"

using namespace visnav::testing;

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

/// The first /dev/video* capture node whose driver is vivid, or "".
std::string find_vivid() {
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator("/dev", ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("video", 0) != 0) continue;
    const int fd = ::open(e.path().c_str(), O_RDWR | O_NONBLOCK);
    if (fd < 0) continue;
    v4l2_capability cap {};
    const bool ok = ::ioctl(fd, VIDIOC_QUERYCAP, &cap) == 0;
    ::close(fd);
    const std::uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
    if (ok && std::strcmp(reinterpret_cast<const char*>(cap.driver), "vivid") == 0 && (caps & V4L2_CAP_VIDEO_CAPTURE))
      return e.path().string();
  }
  return "";
}

}  // namespace

TEST(V4l2Camera, MissingDeviceIsAClearErrorWithoutHanging) {
  LoaderHost h;
  const auto start = std::chrono::steady_clock::now();
  auto cam = h.loader.create<visnav::Camera>("v4l2", yaml("device: /dev/video_visnav_test_absent\n"), h.host);
  EXPECT_LT(seconds_since(start), 1.0);
  EXPECT_TRUE(fails_with(cam, ErrorCode::not_found, At{"/dev/video_visnav_test_absent", 0, "device"}));
}

TEST(V4l2Camera, NonV4l2PathsAreRefused) {
  LoaderHost h;
  auto null_dev = h.loader.create<visnav::Camera>("v4l2", yaml("device: /dev/null\n"), h.host);
  EXPECT_TRUE(fails_with(null_dev, ErrorCode::invalid_value, At{"/dev/null", 0, "device"}));
  const std::string dir = scratch();
  write_text(dir + "/fake_video0", "x");
  auto file = h.loader.create<visnav::Camera>("v4l2", yaml("device: " + dir + "/fake_video0\n"), h.host);
  EXPECT_TRUE(fails_with(file, ErrorCode::invalid_value, At{"fake_video0", 0, "device"}));
  auto bad = h.loader.create<visnav::Camera>("v4l2", yaml("device: /dev/video0\npixel_format: MJPEG\n"), h.host);
  EXPECT_TRUE(fails_with(bad, ErrorCode::invalid_value, At{"test.yaml", 2, "pixel_format"}));
}

TEST(V4l2Camera, VividVirtualDeviceDeliversFrames) {
  const std::string device = find_vivid();
  if (device.empty())
    GTEST_SKIP() << "no vivid device (/dev/video* with driver 'vivid'): load it with `modprobe vivid` "
                    "(not possible in this sandbox: no kernel modules)";
  LoaderHost h;
  auto cam = h.loader.create<visnav::Camera>(
      "v4l2", yaml("device: " + device + "\nwidth_px: 320\nheight_px: 240\nexposure_mode: adaptive\n"), h.host);
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  int frames = 0;
  const auto start = std::chrono::steady_clock::now();
  std::uint64_t last = 0;
  while (frames < 5 && seconds_since(start) < 5.0) {
    auto f = (*cam)->grab(1.0);
    ASSERT_TRUE(f.ok()) << f.error().message;
    if (!f->has_value()) continue;
    EXPECT_GT((*f)->sequence, last);
    last = (*f)->sequence;
    EXPECT_FALSE((*f)->image.empty());
    ++frames;
  }
  EXPECT_EQ(frames, 5);
}
