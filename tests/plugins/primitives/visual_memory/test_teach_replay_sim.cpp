// Teaching and open-loop replay on simulator frames (straight15m): references are made by
// feature loss with metric relative poses; replaying the taught poses switches through every
// reference and stops at the goal; a view rotated or shifted off the path steers back; a
// frame that is not the taught size is a per-frame status.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "sim_support.hpp"
#include "visnav/visual_memory/follower.hpp"

namespace vm = visnav::visual_memory;
namespace sim = visnav::sim;

TEST(VisualMemoryTeach, MakesReferencesWithMetricGeometryAlongAStraightPath) {
  const vm::VisualMemory m = vm_test::teach_straight(8.0);
  ASSERT_GE(m.references.size(), 3u);
  std::printf("8 m taught: %zu references\n", m.references.size());
  for (std::size_t k = 1; k < m.references.size(); ++k) {
    const auto& r = m.references[k];
    const double spacing = r.distance_m - m.references[k - 1].distance_m;
    EXPECT_GT(spacing, 0.0);
    EXPECT_LE(spacing, vm::TeachParams{}.max_reference_spacing_m + 0.06);
    // straight drive: the relative pose is forward by the odometric spacing, no rotation
    EXPECT_NEAR(cv::norm(r.t_from_prev_m), spacing, 1e-6) << "reference " << k;
    const cv::Vec3d c = -(r.R_from_prev.t() * r.t_from_prev_m);  // this camera in the previous frame
    EXPECT_GT(c[2], 0.9 * spacing) << "reference " << k;
    EXPECT_LT(std::abs(std::atan2(r.R_from_prev(0, 2), r.R_from_prev(2, 2))), 0.03) << "reference " << k;
    EXPECT_GT(r.count_3d(), 20) << "reference " << k;
    std::printf("  ref %zu at %.2f m: %zu features, %d with 3D\n", k, r.distance_m, r.ids.size(), r.count_3d());
  }
}

TEST(VisualMemoryTeach, TriangulatedDepthsMatchTheRenderedScene) {
  // Depth check against the world: a point's triangulated position, mapped through the
  // reference's known camera pose, must lie near the camera ray at the true (rendered) depth.
  // The ground is the plane z_world = 0: for ground features the world height must be ~0.
  const vm::VisualMemory m = vm_test::teach_straight(6.0);
  const sim::CameraModel cam;
  int ground = 0, close = 0;
  for (std::size_t k = 1; k < m.references.size(); ++k) {
    const auto& r = m.references[k];
    const sim::CameraPose pose = sim::camera_pose(cam, visnav::Pose2D{r.distance_m, 0.0, 0.0});
    for (std::size_t j = 0; j < r.ids.size(); ++j) {
      if (!r.has_3d[j]) continue;
      const cv::Vec3d pc(r.points3d_m[j].x, r.points3d_m[j].y, r.points3d_m[j].z);
      const cv::Vec3d pw = pose.R_world_cam * pc + pose.position_world;
      // below the horizon and near: the ground
      if (r.points_px[j].y > cam.cy() + 40 && pc[2] < 8.0) {
        ++ground;
        if (std::abs(pw[2]) < 0.1) ++close;
      }
    }
  }
  std::printf("ground features with 3D: %d, within 0.1 m of the ground plane: %d\n", ground, close);
  ASSERT_GT(ground, 20);
  EXPECT_GT(close, 0.8 * ground);
}

namespace {

struct ReplayRun {
  int switches = 0;
  bool goal = false;
  int last_target = 0;
  int steps = 0;
};

ReplayRun replay_open_loop(vm::MemoryFollower& follower, double y_m, double heading_rad) {
  sim::Renderer renderer(vm_test::straight_world(), sim::CameraModel{});
  cv::Mat bgr;
  ReplayRun run;
  for (double x = 0.0; x <= 9.0; x += 0.05) {
    renderer.render(visnav::Pose2D{x, y_m, heading_rad}, bgr);
    const vm::FollowStep s = follower.step(bgr, x);
    ++run.steps;
    EXPECT_TRUE(std::isfinite(s.command.angular_radps));
    EXPECT_NE(s.status, vm::FollowStatus::failed) << s.failure;
    if (s.status == vm::FollowStatus::switched) ++run.switches;
    run.last_target = s.target;
    if (s.finished()) {
      run.goal = s.status == vm::FollowStatus::goal;
      break;
    }
  }
  return run;
}

}  // namespace

TEST(VisualMemoryReplay, TheTaughtPosesSwitchThroughEveryReferenceAndStopAtTheGoal) {
  vm::VisualMemory m = vm_test::teach_straight(8.0);
  const int n = static_cast<int>(m.references.size());
  auto follower = vm::MemoryFollower::create(vm::ReplayParams{}, std::move(m), 8.0);
  ASSERT_TRUE(follower.ok()) << follower.error().message;
  const ReplayRun run = replay_open_loop(*follower, 0.0, 0.0);
  std::printf("replay: %d switches of %d references, goal %s after %d frames\n", run.switches, n,
              run.goal ? "reached" : "NOT reached", run.steps);
  EXPECT_TRUE(run.goal);
  EXPECT_EQ(run.last_target, n - 1);
  EXPECT_EQ(run.switches, n - 2);  // target starts at reference 1
}

TEST(VisualMemoryReplay, SteersBackTowardsThePathFromARotatedOrShiftedView) {
  const vm::VisualMemory m = vm_test::teach_straight(6.0);
  sim::Renderer renderer(vm_test::straight_world(), sim::CameraModel{});
  cv::Mat bgr;
  for (const char* controller : {"centroid", "AIJCA", "IJC", "IJCU", "IJP", "IJPU", "RH"}) {
    for (const double heading : {-0.1, 0.1}) {
      vm::ReplayParams p;
      p.controller = controller;
      auto follower = vm::MemoryFollower::create(p, m, 6.0);
      ASSERT_TRUE(follower.ok());
      vm::FollowStep s;
      for (double x = 0.0; x <= 0.3; x += 0.05) {
        renderer.render(visnav::Pose2D{x, 0.0, heading}, bgr);
        s = follower->step(bgr, x);
      }
      ASSERT_GT(s.tracked, 8) << controller;
      // rotated left (heading > 0): turn right (ω < 0), and the reverse
      EXPECT_LT(s.command.angular_radps * heading, 0.0) << controller << " heading " << heading << ": "
                                                        << vm::to_string(s.status) << " " << s.detail;
    }
  }
}

TEST(VisualMemoryReplay, AFrameOfTheWrongSizeIsABadFrameWithAZeroCommand) {
  auto follower = vm::MemoryFollower::create(vm::ReplayParams{}, vm_test::teach_straight(3.0), 3.0);
  ASSERT_TRUE(follower.ok());
  const vm::FollowStep s = follower->step(cv::Mat(100, 100, CV_8UC3, cv::Scalar(10, 20, 30)), 0.0);
  EXPECT_EQ(s.status, vm::FollowStatus::bad_frame);
  EXPECT_EQ(s.command.linear_mps, 0.0);
  EXPECT_EQ(s.command.angular_radps, 0.0);
  const vm::FollowStep e = follower->step(cv::Mat(), 0.0);
  EXPECT_EQ(e.status, vm::FollowStatus::bad_frame);
}

TEST(VisualMemoryReplay, ABlankViewIsLostThenFailsWithAReason) {
  vm::ReplayParams p;
  p.max_lost_frames = 5;
  auto follower = vm::MemoryFollower::create(p, vm_test::teach_straight(3.0), 3.0);
  ASSERT_TRUE(follower.ok());
  const cv::Mat blank(240, 320, CV_8UC3, cv::Scalar(128, 128, 128));
  vm::FollowStep s;
  for (int i = 0; i < 6; ++i) {
    s = follower->step(blank, 0.0);
    EXPECT_EQ(s.command.linear_mps, 0.0);
    EXPECT_EQ(s.command.angular_radps, 0.0);
    if (i < 5) {
      EXPECT_EQ(s.status, vm::FollowStatus::lost) << i;
    }
  }
  EXPECT_EQ(s.status, vm::FollowStatus::failed);
  EXPECT_FALSE(s.failure.empty());
}

TEST(VisualMemoryReplay, SeedFoursImageErrorRuleAlsoSwitchesThroughTheReferences) {
  vm::VisualMemory m = vm_test::teach_straight(6.0);
  const int n = static_cast<int>(m.references.size());
  vm::ReplayParams p;
  p.switch_rule = "image_error";
  auto follower = vm::MemoryFollower::create(p, std::move(m), 6.0);
  ASSERT_TRUE(follower.ok());
  sim::Renderer renderer(vm_test::straight_world(), sim::CameraModel{});
  cv::Mat bgr;
  int by_image = 0, by_odometry = 0;
  bool goal = false;
  for (double x = 0.0; x <= 7.5 && !goal; x += 0.05) {
    renderer.render(visnav::Pose2D{x, 0.0, 0.0}, bgr);
    const vm::FollowStep s = follower->step(bgr, x);
    if (s.status == vm::FollowStatus::switched) (s.detail.find("odometry") != std::string::npos ? by_odometry : by_image)++;
    goal = s.status == vm::FollowStatus::goal;
  }
  std::printf("image-error rule: %d switches by the image error, %d by odometry, of %d references\n", by_image,
              by_odometry, n);
  EXPECT_TRUE(goal);
  EXPECT_EQ(by_odometry, 0);
  EXPECT_EQ(by_image, n - 2);
}

TEST(VisualMemoryTeach, TurningOnTheSpotGivesReferencesWithoutThreeDAndAReplayWithoutNaN) {
  // Pure rotation: 60° to the left on the spot, in 1° steps (no baseline, nothing to triangulate).
  sim::Renderer renderer(vm_test::straight_world(), sim::CameraModel{});
  auto teacher = vm::MemoryTeacher::create(vm::TeachParams{});
  ASSERT_TRUE(teacher.ok());
  cv::Mat bgr;
  for (int deg = 0; deg <= 60; ++deg) {
    visnav::Pose2D pose{2.0, 0.0, deg * 3.14159265358979 / 180.0};
    renderer.render(pose, bgr);
    visnav::Odometry odom;
    odom.pose = pose;
    ASSERT_TRUE(teacher->add_frame(bgr, odom, 0.0).ok());
  }
  auto memory = teacher->finish();
  ASSERT_TRUE(memory.ok());
  ASSERT_GE(memory->references.size(), 2u);
  for (const auto& r : memory->references) EXPECT_EQ(r.count_3d(), 0);
  EXPECT_EQ(teacher->references_without_3d(), static_cast<int>(memory->references.size()));
  // The relative rotation is the odometric one: about the camera's y axis by the heading change.
  for (std::size_t k = 1; k < memory->references.size(); ++k) {
    const auto& r = memory->references[k];
    const double dth = r.heading_rad - memory->references[k - 1].heading_rad;
    EXPECT_NEAR(std::atan2(r.R_from_prev(0, 2), r.R_from_prev(2, 2)), dth, 1e-9);
  }
  // Replaying the rotation: no pose anywhere, every law answers (IJC falls back), nothing NaN.
  vm::ReplayParams p;
  p.controller = "IJC";
  auto follower = vm::MemoryFollower::create(p, std::move(*memory), 0.0);
  ASSERT_TRUE(follower.ok());
  for (int deg = 0; deg <= 60; deg += 2) {
    renderer.render(visnav::Pose2D{2.0, 0.0, deg * 3.14159265358979 / 180.0}, bgr);
    const vm::FollowStep s = follower->step(bgr, 0.0);
    EXPECT_TRUE(std::isfinite(s.command.angular_radps) && std::isfinite(s.command.linear_mps));
    EXPECT_FALSE(s.pose_ok) << deg;
    if (s.status == vm::FollowStatus::no_pose) {
      EXPECT_NE(s.detail.find("fallback AIJCA"), std::string::npos) << s.detail;
    }
    if (s.finished()) break;
  }
}

TEST(VisualMemoryReplay, DetectsTheTurnOfAnArcAndSlowsDown) {
  // curve20m courtyard: 1.5 m straight, then a 90° left arc of radius 2 m (ideal poses).
  auto world = sim::load_world_cached(std::string(VISNAV_TEST_SOURCE_DIR) + "/config/worlds/curve20m.yaml");
  ASSERT_TRUE(world.ok()) << world.error().message;
  sim::Renderer renderer(*world, sim::CameraModel{});
  auto pose_at = [](double s) {
    const double x0 = -1.5, y0 = -3.5, straight = 1.5, r = 2.0;
    if (s <= straight) return visnav::Pose2D{x0 + s, y0, 0.0};
    const double th = (s - straight) / r;
    return visnav::Pose2D{x0 + straight + r * std::sin(th), y0 + r * (1.0 - std::cos(th)), th};
  };
  const double length = 1.5 + 2.0 * 3.14159265358979 / 2.0;
  auto teacher = vm::MemoryTeacher::create(vm::TeachParams{});
  ASSERT_TRUE(teacher.ok());
  cv::Mat bgr;
  for (double s = 0.0; s <= length; s += 0.04) {
    renderer.render(pose_at(s), bgr);
    visnav::Odometry odom;
    odom.pose = pose_at(s);
    odom.distance_m = s;
    ASSERT_TRUE(teacher->add_frame(bgr, odom, s).ok());
  }
  auto memory = teacher->finish();
  ASSERT_TRUE(memory.ok());
  vm::ReplayParams p;
  auto follower = vm::MemoryFollower::create(p, std::move(*memory), length);
  ASSERT_TRUE(follower.ok());
  int straight_turning = 0, straight_frames = 0, arc_turning = 0, arc_frames = 0;
  for (double s = 0.0; s <= length; s += 0.04) {
    renderer.render(pose_at(s), bgr);
    const vm::FollowStep st = follower->step(bgr, s);
    if (st.finished()) break;
    if (s < 0.5) {
      ++straight_frames;
      straight_turning += st.turning;
      if (!st.turning) {
        EXPECT_DOUBLE_EQ(st.command.linear_mps, p.speed_mps);
      }
    } else if (s > 2.0 && s < length - 0.5) {
      ++arc_frames;
      arc_turning += st.turning;
      if (st.turning) {
        EXPECT_DOUBLE_EQ(st.command.linear_mps, p.turn_speed_mps);
      }
    }
  }
  std::printf("turn detected on %d of %d straight frames, %d of %d arc frames\n", straight_turning, straight_frames,
              arc_turning, arc_frames);
  EXPECT_EQ(straight_turning, 0);
  EXPECT_GT(arc_turning, arc_frames / 2);
}

TEST(VisualMemoryReplay, IlluminationCompensationResumesMoreFeaturesUnderAnotherLight) {
  // Taught in the base light; replayed 0.1 m off the line with the image at 45 % contrast and a
  // brightness offset (another time of day), the left half covered for 1 m mid-edge so that
  // features must be resumed from the reference images.
  const vm::VisualMemory m = vm_test::teach_straight(6.0);
  sim::Renderer renderer(vm_test::straight_world(), sim::CameraModel{});
  int resumed[2] = {0, 0}, tracked[2] = {0, 0}, lost[2] = {0, 0};
  bool goal[2] = {false, false};
  for (int on = 0; on < 2; ++on) {
    vm::ReplayParams p;
    p.illumination_compensation = on == 1;
    auto follower = vm::MemoryFollower::create(p, m, 6.0);
    ASSERT_TRUE(follower.ok());
    cv::Mat bgr, dim;
    for (double x = 0.0; x <= 7.5; x += 0.05) {
      renderer.render(visnav::Pose2D{x, 0.1, 0.0}, bgr);
      bgr.convertTo(dim, CV_8U, 0.45, 40.0);
      if (x > 2.5 && x < 3.5) dim(cv::Rect(0, 0, dim.cols / 2, dim.rows)).setTo(cv::Scalar(20, 20, 20));
      const vm::FollowStep s = follower->step(dim, x);
      resumed[on] += s.resumed;
      tracked[on] += s.tracked;
      lost[on] += s.status == vm::FollowStatus::lost;
      if (s.finished()) {
        goal[on] = s.status == vm::FollowStatus::goal;
        break;
      }
    }
    std::printf("illumination_compensation=%d: %s, %d resumed, %d tracked feature-frames, %d lost frames\n", on,
                goal[on] ? "goal" : "NO GOAL", resumed[on], tracked[on], lost[on]);
  }
  EXPECT_TRUE(goal[1]);
  EXPECT_EQ(lost[1], 0);
  EXPECT_GT(resumed[1], resumed[0]);
  EXPECT_GT(tracked[1], 2 * tracked[0]);
}
