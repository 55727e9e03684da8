// Renderer geometry against the pinhole model, labels and texture detail.
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "visnav_sim/render.hpp"
#include "visnav_sim/world.hpp"

namespace vs = visnav::sim;
using visnav::Pose2D;

namespace {

const char* kGeometryWorld =
    "world:\n"
    "  textures:\n"
    "    a: {procedural: noise, color: [90, 140, 60]}\n"
    "    b: {procedural: tiles, color: [200, 200, 200]}\n"
    "  default_ground: {texture: a, class: grass}\n"
    "  regions:\n"
    "    - {name: patch, texture: b, class: path, polygon: [[5, -1], [8, -1], [8, 1], [5, 1]]}\n"
    "  walls:\n"
    "    - {name: near, texture: b, from: [10, 1], to: [10, -1], height_m: 1.0}\n"
    "    - {name: far_left, texture: b, from: [200, 60], to: [200, 0], height_m: 30}\n"
    "    - {name: far_right, texture: b, from: [200, 0], to: [200, -60], height_m: 30}\n";

std::shared_ptr<const vs::World> geometry_world() {
  static auto w = vs::parse_world(kGeometryWorld, "geometry.yaml", ".");
  EXPECT_TRUE(w.ok()) << w.error().message;
  return *w;
}

vs::CameraModel model(double pitch_deg) {
  vs::CameraModel m;
  m.width_px = 320;
  m.height_px = 240;
  m.hfov_deg = 60;
  m.height_m = 0.5;
  m.pitch_down_deg = pitch_deg;
  return m;
}

/// First row (from the top) in column u whose object id equals `id`, or -1.
int first_row(const cv::Mat& ids, int u, std::uint16_t id) {
  for (int v = 0; v < ids.rows; ++v)
    if (ids.at<std::uint16_t>(v, u) == id) return v;
  return -1;
}
int last_row(const cv::Mat& ids, int u, std::uint16_t id) {
  for (int v = ids.rows - 1; v >= 0; --v)
    if (ids.at<std::uint16_t>(v, u) == id) return v;
  return -1;
}
int first_col(const cv::Mat& ids, int v, std::uint16_t id) {
  for (int u = 0; u < ids.cols; ++u)
    if (ids.at<std::uint16_t>(v, u) == id) return u;
  return -1;
}

}  // namespace

TEST(SimRender, PointsOnKnownPlanesProjectPerPinholeModel) {
  for (double pitch : {0.0, 10.0}) {
    const vs::CameraModel m = model(pitch);
    vs::Renderer r(geometry_world(), m);
    cv::Mat bgr, labels, ids;
    r.render(Pose2D{}, bgr, &labels, &ids);
    const double f = 160.0 / std::tan(30.0 * CV_PI / 180.0);
    const double cx = 159.5, cy = 119.5, phi = pitch * CV_PI / 180.0, h = 0.5;
    // independent pinhole model: forward distance d, height z of a point in the x-z plane
    auto v_of = [&](double d, double z) {
      const double up = z - h;
      const double zc = d * std::cos(phi) - up * std::sin(phi);
      const double yc = -up * std::cos(phi) - d * std::sin(phi);
      return cy + f * yc / zc;
    };
    auto u_of = [&](double d, double y, double z) {
      const double up = z - h;
      const double zc = d * std::cos(phi) - up * std::sin(phi);
      return cx - f * y / zc;
    };
    // the wall's top edge (x = 10, z = 1) and its left end (y = 1): first covered pixel centre
    const int wall_id = 0x8000;
    EXPECT_NEAR(first_row(ids, 160, wall_id), std::ceil(v_of(10, 1.0)), 1.0) << "pitch " << pitch;
    EXPECT_NEAR(first_col(ids, static_cast<int>(std::lround(v_of(10, 0.5))), wall_id), std::ceil(u_of(10, 1.0, 0.5)), 1.0);
    // ground patch: the line x = 8 (far edge, seen below the wall) and x = 5 (near edge)
    const int patch_id = 1;
    EXPECT_NEAR(first_row(ids, 160, patch_id), v_of(8, 0.0), 1.0) << "pitch " << pitch;
    EXPECT_NEAR(last_row(ids, 160, patch_id), v_of(5, 0.0), 1.0) << "pitch " << pitch;
    // and the library's own projection agrees with the independent model
    const auto p = vs::project(m, vs::camera_pose(m, Pose2D{}), {10, 1, 1});
    ASSERT_TRUE(p.has_value());
    EXPECT_NEAR(p->x, u_of(10, 1, 1), 1e-9);
    EXPECT_NEAR(p->y, v_of(10, 1), 1e-9);
    EXPECT_EQ(labels.at<std::uint8_t>(0, 160), static_cast<std::uint8_t>(vs::LabelClass::sky));
  }
}

TEST(SimRender, YawShiftsDistantContentByFTanTheta) {
  const vs::CameraModel m = model(0.0);
  vs::Renderer r(geometry_world(), m);
  cv::Mat bgr, ids;
  const double f = m.fx();
  const int row = 100;  // above the horizon: only the far walls
  for (double yaw_deg : {0.0, 5.0, 12.0, -8.0}) {
    r.render(Pose2D{0, 0, yaw_deg * CV_PI / 180.0}, bgr, nullptr, &ids);
    // boundary between far_left (id 0x8001) and far_right (0x8002): the world point y = 0
    const int u_right = first_col(ids, row, 0x8002);
    ASSERT_GE(u_right, 0);
    const double expected = m.cx() + f * std::tan(yaw_deg * CV_PI / 180.0);
    EXPECT_NEAR(u_right, expected, 1.0) << "yaw " << yaw_deg;
  }
}

TEST(SimRender, LabelsMarkThePathOnStraight6m) {
  auto path = vs::resolve_world_path("straight6m");
  ASSERT_TRUE(path.ok());
  auto world = vs::load_world_cached(*path);
  ASSERT_TRUE(world.ok()) << world.error().message;
  vs::CameraModel m = model(10.0);
  vs::Renderer r(*world, m);
  cv::Mat bgr, labels, mask;
  r.render(Pose2D{}, bgr, &labels);
  vs::label_mask(labels, vs::LabelClass::path, mask);
  const vs::CameraPose pose = vs::camera_pose(m, Pose2D{});
  auto label_at = [&](double x, double y) {
    const auto p = vs::project(m, pose, {x, y, 0.0});
    EXPECT_TRUE(p.has_value());
    return static_cast<vs::LabelClass>(labels.at<std::uint8_t>(cv::Point(static_cast<int>(std::lround(p->x)), static_cast<int>(std::lround(p->y)))));
  };
  EXPECT_EQ(label_at(3.0, 0.0), vs::LabelClass::path);
  EXPECT_EQ(label_at(3.0, 0.7), vs::LabelClass::path);   // the path is 1.6 m wide
  EXPECT_EQ(label_at(3.0, 1.0), vs::LabelClass::grass);
  EXPECT_EQ(label_at(3.0, -1.2), vs::LabelClass::grass);
  int sky = 0;
  for (int u = 0; u < 320; ++u) sky += labels.at<std::uint8_t>(0, u) == static_cast<std::uint8_t>(vs::LabelClass::sky);
  EXPECT_GT(sky, 0);
  const double path_fraction = cv::countNonZero(mask(cv::Rect(0, 120, 320, 120))) / (320.0 * 120.0);
  EXPECT_GT(path_fraction, 0.3);   // looking along the path from its centre line
  EXPECT_LT(path_fraction, 0.97);  // with grass on both sides
}

TEST(SimRender, AnObstacleLowerThanTheCameraShowsItsTopNotTheGroundInside) {
  // A long low crate (x 1..3 m, 0.3 m tall) seen from 0.5 m: the ray over its near top edge
  // would reach the ground at x = 2.5 m, inside the crate, if the top were open.
  const std::string world_text = std::string(kGeometryWorld) +
                                 "  obstacles:\n"
                                 "    - {name: crate, kind: box, at: [2, 0], size_m: [2, 1], height_m: 0.3, texture: b}\n"
                                 "    - {name: tall, kind: box, at: [4, 1.2], size_m: [2, 0.8], height_m: 0.8, texture: b}\n";
  auto world = vs::parse_world(world_text, "crate.yaml", ".");
  ASSERT_TRUE(world.ok()) << world.error().message;
  ASSERT_EQ((*world)->caps.size(), 2u);
  EXPECT_DOUBLE_EQ((*world)->caps[0].top_m, 0.3);
  const vs::CameraModel m = model(10.0);
  vs::Renderer r(*world, m);
  cv::Mat bgr, labels, ids;
  r.render(Pose2D{}, bgr, &labels, &ids);
  const vs::CameraPose pose = vs::camera_pose(m, Pose2D{});
  const auto far_top = vs::project(m, pose, {3.0, 0.0, 0.3});
  const auto near_bottom = vs::project(m, pose, {1.0, 0.0, 0.0});
  ASSERT_TRUE(far_top && near_bottom);
  const std::uint16_t crate_id = static_cast<std::uint16_t>(0x8000 + (*world)->caps[0].first_wall);
  const int first = static_cast<int>(std::ceil(far_top->y)) + 1, last = static_cast<int>(std::floor(near_bottom->y)) - 1;
  ASSERT_GT(last - first, 20);
  int not_crate = 0;
  for (int v = first; v <= last; ++v) {
    not_crate += labels.at<std::uint8_t>(v, 160) != static_cast<std::uint8_t>(vs::LabelClass::obstacle);
    // the top and the near face belong to the crate (the face's id is its own wall's)
    const std::uint16_t id = ids.at<std::uint16_t>(v, 160);
    not_crate += id < crate_id || id > crate_id + 3;
  }
  EXPECT_EQ(not_crate, 0) << "rows " << first << ".." << last;
  // the top's middle is drawn with the top's id (not a far face seen from inside)
  const auto middle = vs::project(m, pose, {2.0, 0.0, 0.3});
  ASSERT_TRUE(middle);
  EXPECT_EQ(ids.at<std::uint16_t>(cv::Point(160, static_cast<int>(std::lround(middle->y)))), crate_id);
  // a box taller than the camera hides its top: above its near face's top edge is what lies beyond
  const auto tall_top = vs::project(m, pose, {3.0, 1.2, 0.8});
  ASSERT_TRUE(tall_top);
  const int u = static_cast<int>(std::lround(tall_top->x));
  const int above = static_cast<int>(std::floor(tall_top->y)) - 2;
  ASSERT_TRUE(u >= 0 && u < ids.cols && above >= 0 && above < ids.rows) << u << ", " << above;
  EXPECT_EQ(ids.at<std::uint16_t>(above + 4, u) & 0x8000, 0x8000);  // just below the edge: the tall box's face
  const std::uint16_t tall_id = static_cast<std::uint16_t>(0x8000 + (*world)->caps[1].first_wall);
  EXPECT_NE(ids.at<std::uint16_t>(above, u), tall_id);
}

TEST(SimRender, TexturesGiveStableKeypointsAtBothResolutions) {
  auto path = vs::resolve_world_path("straight6m");
  ASSERT_TRUE(path.ok());
  auto world = vs::load_world_cached(*path);
  ASSERT_TRUE(world.ok());
  for (int width : {320, 640}) {
    vs::CameraModel m = model(5.0);
    m.width_px = width;
    m.height_px = width * 3 / 4;
    vs::Renderer r(*world, m);
    cv::Mat a, b, ga, gb, labels;
    r.render(Pose2D{1.0, 0.0, 0.3}, a, &labels);  // looking left: wall, trees, path
    r.render(Pose2D{1.05, 0.0, 0.3}, b);          // 5 cm further
    cv::cvtColor(a, ga, cv::COLOR_BGR2GRAY);
    cv::cvtColor(b, gb, cv::COLOR_BGR2GRAY);
    auto orb = cv::ORB::create(500);
    std::vector<cv::KeyPoint> ka, kb;
    cv::Mat da, db;
    orb->detectAndCompute(ga, cv::noArray(), ka, da);
    orb->detectAndCompute(gb, cv::noArray(), kb, db);
    EXPECT_GT(ka.size(), 300u) << width;
    int on_walls = 0;
    for (const auto& k : ka)
      on_walls += labels.at<std::uint8_t>(cv::Point(k.pt)) == static_cast<std::uint8_t>(vs::LabelClass::wall);
    EXPECT_GT(on_walls, 30) << width;
    cv::BFMatcher matcher(cv::NORM_HAMMING, true);
    std::vector<cv::DMatch> matches;
    matcher.match(da, db, matches);
    int good = 0;
    for (const auto& mt : matches)
      good += mt.distance < 40 && cv::norm(ka[static_cast<size_t>(mt.queryIdx)].pt - kb[static_cast<size_t>(mt.trainIdx)].pt) < 8.0;
    EXPECT_GT(good, 100) << width;  // the same features are found again after a small move
  }
}
