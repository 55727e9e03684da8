// Obstacle profiles (spec §11 items 9, 10): a box face drawn with the DPT on a plain floor,
// its border traced down to the ground contact.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "thesis_rig.hpp"
#include "visnav/ipt_obstacles/profiles.hpp"

namespace visnav::ipt {
namespace {

using testing::thesis_rig;

cv::Point to_px(const std::optional<cv::Point2d>& p) {
  EXPECT_TRUE(p.has_value());
  return {static_cast<int>(std::lround(p->x)), static_cast<int>(std::lround(p->y))};
}

struct Scene {
  IptCamera cam = thesis_rig();
  Pose2D robot{0.0, 0.0, CV_PI / 2};  // looking along +y
  cv::Mat grey;
  double base_row = 0.0;  // true base row of the box's left border
  int left_col = 0;
};

/// A dark box face x ∈ [−0.2, 0.2] m, 1.5 m ahead, 1 m tall, on a light floor with a painted
/// light-grey line (a floor edge) at x = 0.6 m.
Scene make_scene() {
  Scene s;
  const LensPose lens = lens_pose(s.cam, s.robot);
  s.grey = cv::Mat(s.cam.height_px, s.cam.width_px, CV_8UC1, cv::Scalar(200));
  const std::vector<cv::Point> line{to_px(project_point(s.cam, lens, {0.6, 0.8, 0})), to_px(project_point(s.cam, lens, {0.62, 0.8, 0})),
                                    to_px(project_point(s.cam, lens, {0.62, 3.0, 0})), to_px(project_point(s.cam, lens, {0.6, 3.0, 0}))};
  cv::fillConvexPoly(s.grey, line, cv::Scalar(120));
  const std::vector<cv::Point> face{to_px(project_point(s.cam, lens, {-0.2, 1.5, 0})), to_px(project_point(s.cam, lens, {0.2, 1.5, 0})),
                                    to_px(project_point(s.cam, lens, {0.2, 1.5, 1.0})), to_px(project_point(s.cam, lens, {-0.2, 1.5, 1.0}))};
  cv::fillConvexPoly(s.grey, face, cv::Scalar(60));
  s.base_row = project_point(s.cam, lens, {-0.2, 1.5, 0})->y;
  s.left_col = face[0].x;
  return s;
}

ClassifiedFeature feature(double u, double v, FeatureClass label) {
  ClassifiedFeature f;
  f.pixel = {u, v};
  f.label = label;
  return f;
}

TEST(IptProfiles, ReducedCannyMarksVerticalBordersNotHorizontalOnes) {
  const Scene s = make_scene();
  cv::Mat edges;
  EdgeScratch scratch;
  reduced_canny(s.grey, ProfileParams{}, edges, scratch);
  EXPECT_NE(edges.at<std::uint8_t>(100, s.left_col), 0);       // the face's left border
  EXPECT_EQ(edges.at<std::uint8_t>(static_cast<int>(s.base_row) + 1, 128), 0);  // its bottom border is horizontal
  EXPECT_EQ(edges.at<std::uint8_t>(40, 20), 0);                 // plain floor
}

TEST(IptProfiles, ContactPointAtTheBaseOfTheBorderAndItsDistance) {
  const Scene s = make_scene();
  cv::Mat edges;
  EdgeScratch scratch;
  ProfileParams params;
  params.min_supporting_features = 1;  // one feature: the tracing rule alone
  reduced_canny(s.grey, params, edges, scratch);
  const std::vector<ClassifiedFeature> features{feature(s.left_col, 90, FeatureClass::obstacle)};
  const auto contacts = contact_points(edges, features, s.cam, s.robot, params);
  ASSERT_FALSE(contacts.empty());
  for (const auto& c : contacts) {
    EXPECT_NEAR(c.pixel.y, s.base_row, 2.0);
    EXPECT_NEAR(c.ground_m.y, 1.5, 0.06);  // 1 px at 1.5 m is 28 mm (spec §3.5); 2 px allowed
    EXPECT_NEAR(c.ground_m.x, -0.2, 0.03);
    EXPECT_NEAR(c.range_m, std::hypot(c.ground_m.x, c.ground_m.y), 1e-9);
    EXPECT_GT(c.bearing_rad, 0.0);  // left of the heading
    EXPECT_EQ(c.feature, 0);
  }
}

TEST(IptProfiles, AContactNeedsTracesFromTwoObstacleFeatures) {
  const Scene s = make_scene();
  cv::Mat edges;
  EdgeScratch scratch;
  const ProfileParams params;  // default: 2 supporting features within 10 px
  ASSERT_EQ(params.min_supporting_features, 2);
  reduced_canny(s.grey, params, edges, scratch);
  const std::vector<ClassifiedFeature> one{feature(s.left_col, 90, FeatureClass::obstacle)};
  EXPECT_TRUE(contact_points(edges, one, s.cam, s.robot, params).empty());
  const std::vector<ClassifiedFeature> two{feature(s.left_col, 90, FeatureClass::obstacle),
                                           feature(s.left_col + 1, 70, FeatureClass::obstacle)};
  const auto contacts = contact_points(edges, two, s.cam, s.robot, params);
  ASSERT_FALSE(contacts.empty());
  for (const auto& c : contacts) EXPECT_NEAR(c.pixel.y, s.base_row, 2.0);
}

TEST(IptProfiles, FloorEdgesWithoutObstacleFeaturesGiveNoContact) {
  const Scene s = make_scene();
  cv::Mat edges;
  EdgeScratch scratch;
  ProfileParams params;
  params.min_vertical_run_px = 1;  // keep the slanted floor line as an edge: the linking rule alone must drop it
  reduced_canny(s.grey, params, edges, scratch);
  const LensPose lens = lens_pose(s.cam, s.robot);
  const auto on_line = *project_point(s.cam, lens, {0.6, 1.2, 0});
  ASSERT_NE(edges.at<std::uint8_t>(static_cast<int>(on_line.y), static_cast<int>(on_line.x)), 0);  // the line is an edge
  const std::vector<ClassifiedFeature> features{feature(on_line.x, on_line.y, FeatureClass::ground),
                                                feature(s.left_col, 90, FeatureClass::unclassified)};
  EXPECT_TRUE(contact_points(edges, features, s.cam, s.robot, params).empty());
}

TEST(IptProfiles, TheVerticalRunFilterDropsShortTextureEdges) {
  Scene s = make_scene();
  // fine staggered bricks (8×4 px, each course shifted 3 px) on the floor left of the box:
  // strong vertical steps, none longer than one 4-row course
  for (int v = 130; v < 190; ++v)
    for (int u = 10; u < 70; ++u) s.grey.at<std::uint8_t>(v, u) = (((u + 3 * (v / 4)) / 8) % 2) != 0 ? 230 : 90;
  cv::Mat edges;
  EdgeScratch scratch;
  ProfileParams params;
  params.min_vertical_run_px = 1;
  reduced_canny(s.grey, params, edges, scratch);
  EXPECT_GT(cv::countNonZero(edges(cv::Rect(12, 132, 56, 56))), 500);
  params.min_vertical_run_px = 9;
  reduced_canny(s.grey, params, edges, scratch);
  EXPECT_EQ(cv::countNonZero(edges(cv::Rect(12, 132, 56, 56))), 0);
  EXPECT_NE(edges.at<std::uint8_t>(100, s.left_col), 0);  // the box border survives
}

TEST(IptProfiles, AGroundFeatureOnTheBorderStopsTheTrace) {
  const Scene s = make_scene();
  cv::Mat edges;
  EdgeScratch scratch;
  ProfileParams params;
  params.min_supporting_features = 1;
  reduced_canny(s.grey, params, edges, scratch);
  const std::vector<ClassifiedFeature> features{feature(s.left_col, 90, FeatureClass::obstacle),
                                                feature(s.left_col, 105, FeatureClass::ground)};
  const auto contacts = contact_points(edges, features, s.cam, s.robot, params);
  ASSERT_FALSE(contacts.empty());
  for (const auto& c : contacts) {  // stopped within reach of it, well above the base
    EXPECT_LE(c.pixel.y, 105 + params.ground_reach_px);
    EXPECT_LT(c.pixel.y, s.base_row - 10);
  }
}

TEST(IptProfiles, ABrokenBorderIsBridged) {
  Scene s = make_scene();
  // cut a 3-row gap into the border, 10 rows above the base
  const int gap_row = static_cast<int>(s.base_row) - 10;
  s.grey(cv::Rect(0, gap_row, s.grey.cols, 3)).setTo(cv::Scalar(200));
  cv::Mat edges;
  EdgeScratch scratch;
  ProfileParams params;
  params.min_supporting_features = 1;
  reduced_canny(s.grey, params, edges, scratch);
  // a feature just above the gap: the 15-row window reaches below it
  const std::vector<ClassifiedFeature> features{feature(s.left_col, gap_row - 2, FeatureClass::obstacle)};
  const auto contacts = contact_points(edges, features, s.cam, s.robot, params);
  ASSERT_FALSE(contacts.empty());
  double lowest = 0;
  for (const auto& c : contacts) lowest = std::max(lowest, c.pixel.y);
  EXPECT_NEAR(lowest, s.base_row, 2.0);
}

}  // namespace
}  // namespace visnav::ipt
