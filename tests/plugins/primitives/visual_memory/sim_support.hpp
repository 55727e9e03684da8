// Shared by the visual-memory tests on simulator frames: the straight15m world (gravel path
// along +x, brick wall left, fence right, trees, a facade ahead) rendered by visnav_sim's
// pinhole camera (320×240, 60° hfov, 0.5 m high, 5° down), and a memory taught by driving
// straight along the path's centre line.
#pragma once

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "visnav/visual_memory/teacher.hpp"
#include "visnav_sim/render.hpp"
#include "visnav_sim/world.hpp"

namespace vm_test {

inline std::shared_ptr<const visnav::sim::World> straight_world() {
  auto world = visnav::sim::load_world_cached(std::string(VISNAV_TEST_SOURCE_DIR) + "/config/worlds/straight15m.yaml");
  EXPECT_TRUE(world.ok()) << world.error().message;
  return world.ok() ? *world : nullptr;
}

/// Teaches x = 0 … length_m along y = 0 (heading 0) in steps of step_m, ideal odometry.
inline visnav::visual_memory::VisualMemory teach_straight(double length_m, double step_m = 0.05,
                                                         visnav::visual_memory::TeachParams params = {}) {
  visnav::sim::Renderer renderer(straight_world(), visnav::sim::CameraModel{});
  auto teacher = visnav::visual_memory::MemoryTeacher::create(params);
  EXPECT_TRUE(teacher.ok());
  cv::Mat bgr;
  for (double x = 0.0; x <= length_m + 1e-9; x += step_m) {
    visnav::Pose2D pose{x, 0.0, 0.0};
    renderer.render(pose, bgr);
    visnav::Odometry odom;
    odom.pose = pose;
    odom.distance_m = x;
    auto r = teacher->add_frame(bgr, odom, x);
    EXPECT_TRUE(r.ok());
  }
  auto memory = teacher->finish();
  EXPECT_TRUE(memory.ok());
  return memory.ok() ? std::move(*memory) : visnav::visual_memory::VisualMemory{};
}

}  // namespace vm_test
