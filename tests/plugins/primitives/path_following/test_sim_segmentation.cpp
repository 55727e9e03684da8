// Segmentation quality on frames rendered by the simulator (issue 5, "Must show"): the path
// follower's final region against the renderer's ground-truth path label, IoU >= 0.85, on the
// straight6m and campus worlds from poses on and beside the gravel paths.
// Set VISNAV_PATHSEG_DUMP=<dir> to write every frame's stages drawing there, and
// VISNAV_PATHSEG_PARAMS="key=value;key=value" to try other parameters (defaults otherwise).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "synthetic.hpp"
#include "visnav/path_following/path_follower.hpp"
#include "visnav/path_following/stages.hpp"
#include "visnav_sim/render.hpp"
#include "visnav_sim/world.hpp"

namespace pf = visnav::path_following;
namespace sim = visnav::sim;

namespace {

struct View {
  double x_m, y_m, heading_deg;
};

struct Figures {
  double mean_iou = 0.0;
  double min_iou = 1.0;
  int frames = 0;
  int ok_frames = 0;
};

Figures evaluate(const std::string& world_name, const std::vector<View>& views) {
  Figures fig;
  const std::string path = std::string(VISNAV_TEST_SOURCE_DIR) + "/config/worlds/" + world_name + ".yaml";
  auto world = sim::load_world(path);
  EXPECT_TRUE(world.ok()) << (world.ok() ? "" : world.error().message);
  if (!world.ok()) return fig;
  sim::Renderer renderer(*world, sim::CameraModel{});
  visnav::ConfigNode overrides;
  if (const char* text = std::getenv("VISNAV_PATHSEG_PARAMS")) {
    std::string all(text), item;
    std::stringstream ss(all);
    while (std::getline(ss, item, ';')) {
      const auto eq = item.find('=');
      if (eq != std::string::npos)
        overrides.set(item.substr(0, eq), visnav::ConfigNode::make_scalar(item.substr(eq + 1), {"VISNAV_PATHSEG_PARAMS", 0}));
    }
  }
  auto params = pf::PathFollowerParams::schema().parse(overrides);
  EXPECT_TRUE(params.ok()) << (params.ok() ? "" : params.error().message);
  if (!params.ok()) return fig;
  auto follower = std::move(pf::PathFollower::create(*params).value());
  const char* dump = std::getenv("VISNAV_PATHSEG_DUMP");
  cv::Mat bgr, labels, truth;
  pf::PathEstimate est;
  double sum = 0.0;
  for (const auto& v : views) {
    renderer.render(visnav::Pose2D{v.x_m, v.y_m, v.heading_deg * std::numbers::pi / 180.0}, bgr, &labels);
    sim::label_mask(labels, sim::LabelClass::path, truth);
    const auto st = follower.process(bgr, est);
    EXPECT_TRUE(st.ok());
    if (!st.ok()) continue;
    const double iou = pf::testing::mask_iou(est.mask, truth);
    sum += iou;
    fig.min_iou = std::min(fig.min_iou, iou);
    ++fig.frames;
    if (est.status == pf::PathStatus::ok) ++fig.ok_frames;
    std::printf("%s (%.2f, %.2f, %+.0f deg): status %s IoU %.3f omega %+.3f\n", world_name.c_str(), v.x_m, v.y_m,
                v.heading_deg, std::string(pf::to_string(est.status)).c_str(), iou, est.command.angular_radps);
    if (dump != nullptr) {
      char name[256];
      std::snprintf(name, sizeof name, "%s/%s_%.2f_%.2f_%+.0f.png", dump, world_name.c_str(), v.x_m, v.y_m,
                    v.heading_deg);
      cv::imwrite(name, pf::render_stages(bgr, est, follower.stages(), follower.params()));
    }
  }
  if (fig.frames > 0) fig.mean_iou = sum / fig.frames;
  return fig;
}

}  // namespace

TEST(SimSegmentation, Straight6mPathIoU) {
  std::vector<View> views;
  for (double x : {0.0, 1.5, 3.0, 4.5})
    for (double y : {-0.5, -0.25, 0.0, 0.25, 0.5})
      for (double h : {-15.0, 0.0, 15.0}) views.push_back({x, y, h});
  const auto fig = evaluate("straight6m", views);
  std::printf("straight6m: %d frames, %d ok, mean IoU %.3f, min IoU %.3f\n", fig.frames, fig.ok_frames, fig.mean_iou,
              fig.min_iou);
  EXPECT_EQ(fig.ok_frames, fig.frames);
  EXPECT_GE(fig.mean_iou, 0.85);
  EXPECT_GE(fig.min_iou, 0.75);
}

TEST(SimSegmentation, CampusGravelLoopIoU) {
  // Along the gravel loop's east-west leg (y = -26, heading west) and north-south leg
  // (x = 32, heading south), on and beside the centre line.
  std::vector<View> views;
  for (double x : {28.0, 20.0, 12.0, 4.0})
    for (double dy : {-0.5, 0.0, 0.5}) views.push_back({x, -26.0 + dy, 180.0});
  for (double y : {-8.0, -12.0, -20.0})
    for (double dx : {-0.5, 0.0, 0.5}) views.push_back({32.0 + dx, y, -90.0});
  const auto fig = evaluate("campus", views);
  std::printf("campus: %d frames, %d ok, mean IoU %.3f, min IoU %.3f\n", fig.frames, fig.ok_frames, fig.mean_iou,
              fig.min_iou);
  EXPECT_GE(fig.ok_frames, fig.frames - 2);
  EXPECT_GE(fig.mean_iou, 0.85);
}
