// Shared helpers of the file/device camera tests: a host over the real loader, params from YAML
// text, a scratch folder, and small image/run writers.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "visnav/config.hpp"
#include "visnav/loader.hpp"
#include "visnav/runtime_host.hpp"

namespace visnav::testing {

namespace fs = std::filesystem;

/// A loader over the build's plugin folder, a quiet logger and a manual run clock.
struct LoaderHost {
  PluginLoader loader{std::vector<std::string>{VISNAV_TEST_PLUGIN_DIR}};
  StderrLogger logger{LogLevel::warn};
  ManualClock clock{0.0};
  RuntimeHost host{loader, logger, clock};
  LoaderHost() { (void)loader.scan(); }
};

/// Params node from YAML text; locations read "test.yaml:<line>".
inline ConfigNode yaml(const std::string& text) {
  auto node = parse_yaml_string(text, "test.yaml");
  EXPECT_TRUE(node.ok()) << (node.ok() ? "" : node.error().message);
  return node.ok() ? *node : ConfigNode{};
}

/// A fresh, empty folder under the test binary dir, named after the running test.
inline std::string scratch(const std::string& tag = "") {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  fs::path dir = fs::path(VISNAV_TEST_BINARY_DIR) / "test_scratch" / (std::string(info->test_suite_name()) + "_" + info->name() + tag);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

/// A textured test image whose content depends on `seed` (so frames are distinguishable).
inline cv::Mat test_image(int seed, int w = 64, int h = 48, bool grey = false) {
  cv::Mat img(h, w, CV_8UC3);
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c)
      img.at<cv::Vec3b>(r, c) = cv::Vec3b(static_cast<unsigned char>((c * 4 + seed * 10) % 256),
                                          static_cast<unsigned char>((r * 5 + seed * 3) % 256),
                                          static_cast<unsigned char>((seed * 37) % 256));
  if (grey) cv::cvtColor(img, img, cv::COLOR_BGR2GRAY);
  return img;
}

inline void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  out << text;
}

/// A recorded run with `n` frames at t = 0.1·(i+1), odometry at 50 Hz moving at 0.5 m/s.
inline void write_run(const std::string& dir, int n) {
  fs::create_directories(fs::path(dir) / "frames");
  std::string frames = "index,t_s,sequence,file\n";
  for (int i = 0; i < n; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "frames/%06d.png", i);
    cv::imwrite((fs::path(dir) / name).string(), test_image(i));
    frames += std::to_string(i) + "," + std::to_string(0.1 * (i + 1)) + "," + std::to_string(i + 1) + "," + name + "\n";
  }
  write_text((fs::path(dir) / "frames.csv").string(), frames);
  std::string odo = "t_s,x_m,y_m,heading_rad,distance_m,linear_mps,angular_radps\n";
  for (int k = 0; k <= n * 5 + 5; ++k) {
    const double t = 0.02 * k;
    odo += std::to_string(t) + "," + std::to_string(0.5 * t) + ",0,0," + std::to_string(0.5 * t) + ",0.5,0\n";
  }
  write_text((fs::path(dir) / "odometry.csv").string(), odo);
  write_text((fs::path(dir) / "run.yaml").string(), "format: visnav-recorded-run\nversion: 1\n");
}

}  // namespace visnav::testing
