// Closed loop on rendered frames without the behaviour tree (issue 16): render → IPT pipeline
// → navigation filter (thesis Ch. 6) → (v, ω) → ideal unicycle at 10 Hz, in the
// obstacle_course world. The robot (a 0.25 m disc) must reach a goal behind a crate on the
// path without touching it. IPT_TRACE=1 prints the decisions. (Behind the parked van the
// robot still gets stuck: see docs/obstacles.md, "Status".)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "visnav/ipt_obstacles/pipeline.hpp"
#include "visnav/ipt_obstacles/polar_map.hpp"
#include "visnav_sim/render.hpp"
#include "visnav_sim/robot.hpp"
#include "visnav_sim/world.hpp"

namespace visnav::ipt {
namespace {

namespace vs = visnav::sim;

constexpr double kDt = 0.1;
constexpr double kBodyRadius = 0.25;

double clearance_m(const std::vector<vs::CollisionShape>& shapes, const Pose2D& p) {
  double best = 1e9;
  for (const auto& s : shapes) {
    const cv::Point2d d = s.to - s.from, q(p.x_m, p.y_m);
    const double len2 = d.dot(d);
    const double t = len2 > 0 ? std::clamp((q - s.from).dot(d) / len2, 0.0, 1.0) : 0.0;
    best = std::min(best, cv::norm(q - (s.from + t * d)) - s.radius_m);
  }
  return best;
}

struct Outcome {
  bool reached = false;
  double min_clearance_m = 1e9;
  double time_s = 0.0;
};

Outcome drive(const Pose2D& start, const cv::Point2d& goal) {
  auto path = vs::resolve_world_path("obstacle_course");
  EXPECT_TRUE(path.ok());
  auto world = vs::load_world_cached(*path);
  EXPECT_TRUE(world.ok());
  vs::CameraModel model;
  model.hfov_deg = 65.5;
  model.height_m = 0.43;
  model.pitch_down_deg = 9.0;
  vs::Renderer renderer(*world, model);
  IptCamera cam;
  cam.fx_px = cam.fy_px = model.fx();
  cam.cx_px = model.cx();
  cam.cy_px = model.cy();
  cam.height_m = model.height_m;
  cam.pitch_rad = -9.0 * CV_PI / 180.0;
  auto pipeline = ObstaclePipeline::create(cam, PipelineParams{}, ClassifierParams{}, ProfileParams{});
  EXPECT_TRUE(pipeline.ok());
  const auto shapes = vs::collision_shapes(**world, 0.6, 0.25);
  PolarMapParams map_params;
  map_params.reset_keep_near_m = 2.0 * map_params.security_distance_m;  // spec §7.5 [I] reset_keep_near
  NavigationFilter filter{map_params};
  Pose2D pose = start;
  cv::Mat bgr, grey;
  Outcome out;
  for (int step = 0; step < 1200; ++step) {
    renderer.render(pose, bgr);
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
    auto pair = pipeline->process(grey, pose);
    EXPECT_TRUE(pair.ok());
    if (pair.ok() && *pair) {
      std::vector<cv::Point2d> pts;
      for (const auto& c : (*pair)->contacts) {
        pts.push_back(c.ground_m);
        if (std::getenv("IPT_TRACE") != nullptr && c.range_m < 1.2 && step < 40) {
          const auto& f = (*pair)->features[static_cast<std::size_t>(c.feature)];
          std::printf("  contact px %.0f %.0f range %.2f from feature px %.0f %.0f reason %s D %.3f\n", c.pixel.x, c.pixel.y,
                      c.range_m, f.pixel.x, f.pixel.y, to_string(f.reason), f.discrepancy_m);
        }
      }
      filter.add_points(pts);
    }
    const Decision d = filter.decide(pose, goal);
    if (d.situation == Situation::goal_reached) {
      out.reached = true;
      break;
    }
    if (std::getenv("IPT_TRACE") != nullptr && step % 10 == 0)
      std::printf("t %.1f pose %.2f %.2f %.1f deg  %s heading %.1f deg points %zu: %s\n", out.time_s, pose.x_m, pose.y_m,
                  pose.heading_rad * 180 / CV_PI, to_string(d.situation), d.heading_rad * 180 / CV_PI,
                  filter.points().size(), d.reason.c_str());
    const double w = std::clamp(1.5 * d.heading_rad, -0.6, 0.6);
    const double v = d.translate ? 0.2 * std::max(0.0, std::cos(d.heading_rad)) : 0.0;
    pose.x_m += v * std::cos(pose.heading_rad) * kDt;
    pose.y_m += v * std::sin(pose.heading_rad) * kDt;
    pose.heading_rad += (d.translate ? w : std::copysign(0.6, d.heading_rad)) * kDt;
    out.min_clearance_m = std::min(out.min_clearance_m, clearance_m(shapes, pose));
    out.time_s += kDt;
  }
  std::printf("goal (%.1f, %.1f): reached %d after %.1f s, closest approach to an obstacle %.3f m\n", goal.x, goal.y,
              out.reached ? 1 : 0, out.time_s, out.min_clearance_m);
  return out;
}

TEST(IptAvoidClosedLoop, PassesTheCrateOnThePath) {
  const Outcome o = drive({0.0, 0.0, 0.0}, {7.0, 0.0});
  EXPECT_TRUE(o.reached);
  EXPECT_GT(o.min_clearance_m, kBodyRadius);
}

}  // namespace
}  // namespace visnav::ipt
