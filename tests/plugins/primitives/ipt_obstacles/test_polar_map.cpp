// The polar map and the navigation decisions (spec §11 items 11-18) on hand-placed points.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "visnav/ipt_obstacles/polar_map.hpp"

namespace visnav::ipt {
namespace {

constexpr double kDeg = CV_PI / 180.0;

cv::Point2d at(double range_m, double bearing_deg, const Pose2D& robot = {}) {
  const double a = robot.heading_rad + bearing_deg * kDeg;
  return {robot.x_m + range_m * std::cos(a), robot.y_m + range_m * std::sin(a)};
}

TEST(NavigationFilterBookkeeping, SectorsFollowTheRobotAndPointsBeyondTheGoalDoNotCount) {
  NavigationFilter f{PolarMapParams{}};
  EXPECT_EQ(f.sector_count(), 30);
  const Pose2D robot{0, 0, 0};
  const cv::Point2d p = at(2.0, 30);
  EXPECT_EQ(f.sector_of(30 * kDeg), 17);
  const Pose2D turned{0, 0, -12 * kDeg};  // a 12° right turn: the point moves to +42°
  const double b = std::atan2(p.y, p.x) - turned.heading_rad;
  EXPECT_EQ(f.sector_of(b), 18);
  // an obstacle right on the goal line but beyond the goal is ignored
  f.add_points(std::vector<cv::Point2d>{at(3.0, 0)});
  const Decision d = f.decide(robot, at(2.0, 0));
  EXPECT_EQ(d.situation, Situation::goal_free);
  EXPECT_NEAR(d.heading_rad, 0.0, 1e-12);
}

TEST(NavigationFilterGF, StraightAndGrazing) {
  const Pose2D robot{0, 0, 0};
  const cv::Point2d goal = at(5.0, 0);
  {  // P_R at 2 m, 40° right: ε = asin(0.95/2) = 28.4° < 40° → straight to the goal
    NavigationFilter f{PolarMapParams{}};
    f.add_points(std::vector<cv::Point2d>{at(2.0, -40)});
    const Decision d = f.decide(robot, goal);
    EXPECT_EQ(d.situation, Situation::goal_free);
    EXPECT_NEAR(d.heading_rad, 0.0, 1e-12);
    EXPECT_TRUE(d.reset);
    EXPECT_TRUE(f.points().empty());
  }
  {  // P_R at 2 m, 20° right: θ_mot = −20° + 28.4° = 8.4° left
    NavigationFilter f{PolarMapParams{}};
    f.add_points(std::vector<cv::Point2d>{at(2.0, -20)});
    const Decision d = f.decide(robot, goal);
    EXPECT_EQ(d.situation, Situation::goal_grazing);
    EXPECT_NEAR(d.heading_rad / kDeg, -20.0 + std::asin(0.95 / 2.0) / kDeg, 1e-9);
    EXPECT_NEAR(d.heading_rad / kDeg, 8.36, 0.05);
  }
}

TEST(NavigationFilterGO, GapWidthRule) {
  const Pose2D robot{0, 0, 0};
  const cv::Point2d goal = at(6.0, 0);
  auto decide_with_gap = [&](double gap_m, PolarMapParams p = {}) {
    NavigationFilter f{p};
    // a wall across the goal line at 3 m with one gap of gap_m centred 1 m to the left
    std::vector<cv::Point2d> pts;
    for (double y = -3.0; y <= 1.0 - gap_m / 2 + 1e-9; y += 0.1) pts.push_back({3.0, y});
    for (double y = 1.0 + gap_m / 2; y <= 4.0 + 1e-9; y += 0.1) pts.push_back({3.0, y});
    f.add_points(pts);
    return f.decide(robot, goal);
  };
  const Decision wide = decide_with_gap(1.0);
  EXPECT_EQ(wide.situation, Situation::gap);
  EXPECT_GT(wide.heading_rad, 0.0);  // towards the gap on the left
  const Decision narrow = decide_with_gap(0.9);
  EXPECT_NE(narrow.situation, Situation::gap);
  PolarMapParams two_s;
  two_s.gap_width_m = 1.9;
  EXPECT_NE(decide_with_gap(1.0, two_s).situation, Situation::gap);
  EXPECT_EQ(decide_with_gap(2.0, two_s).situation, Situation::gap);
}

TEST(NavigationFilterGO, PushAwayFromTheCloserEnd) {
  const Pose2D robot{0, 0, 0};
  // an obstacle across the goal, two points: left end at 2 m / +30°, right end at 3 m / −30°
  NavigationFilter f{PolarMapParams{}};
  std::vector<cv::Point2d> pts{at(2.0, 30), at(2.5, 10), at(2.6, 0), at(2.8, -10), at(3.0, -30)};
  f.add_points(pts);
  const Decision d = f.decide(robot, at(6.0, 0));
  ASSERT_TRUE(d.translate);
  // the candidate on the left passes the 2 m end: θ_PL + ε (Case 3-like end of the run)
  EXPECT_TRUE(d.situation == Situation::gap_end_behind || d.situation == Situation::gap) << d.reason;
  EXPECT_TRUE(f.tenacity_on());
}

TEST(NavigationFilter, SecurityZoneSwitchesToThePotentialField) {
  NavigationFilter f{PolarMapParams{}};
  f.add_points(std::vector<cv::Point2d>{at(0.8, 10)});
  const Decision d = f.decide({0, 0, 0}, at(5.0, 0));
  EXPECT_EQ(d.situation, Situation::high_risk);
  EXPECT_LT(d.heading_rad, 0.0);  // pushed right, away from the point on the left
}

TEST(NavigationFilter, TenacityKeepsTheFirstSideUntilReset) {
  const Pose2D robot{0, 0, 0};
  const cv::Point2d goal = at(8.0, 0);
  NavigationFilter f{PolarMapParams{}};
  // a wall across the goal from −2.0 m to +1.6 m lateral at 3 m: the left end is nearer the goal line
  std::vector<cv::Point2d> wall;
  for (double y = -2.0; y <= 1.6 + 1e-9; y += 0.1) wall.push_back({3.0, y});
  f.add_points(wall);
  const Decision first = f.decide(robot, goal);
  ASSERT_TRUE(first.translate);
  EXPECT_GT(first.heading_rad, 0.0);
  EXPECT_EQ(f.tenacity_side(), 1);
  // the wall turns out longer on the left: the right end would now deviate less, tenacity keeps left
  for (double y = 1.7; y <= 4.5 + 1e-9; y += 0.1) f.add_points(std::vector<cv::Point2d>{{3.0, y}});
  const Decision second = f.decide(robot, goal);
  ASSERT_TRUE(second.translate);
  EXPECT_GT(second.heading_rad, 0.0);
  // a fresh filter (after a reset) picks the smaller deviation: now the right
  NavigationFilter fresh{PolarMapParams{}};
  fresh.add_points(f.points());
  const Decision third = fresh.decide(robot, goal);
  ASSERT_TRUE(third.translate);
  EXPECT_LT(third.heading_rad, 0.0);
}

TEST(NavigationFilterGO, AVanAcrossThePathIsPassedAtAnEnd) {
  NavigationFilter f{PolarMapParams{}};
  std::vector<cv::Point2d> rear;  // the van's rear, 2 m ahead, from 0.75 m right to 1.15 m left
  for (double y = -0.75; y <= 1.15 + 1e-9; y += 0.1) rear.push_back({2.0, y});
  f.add_points(rear);
  const Decision d = f.decide({0, 0, 0}, {9.0, 0.0});
  EXPECT_EQ(d.situation, Situation::gap_end_behind) << d.reason;
  EXPECT_TRUE(d.translate);
  EXPECT_LT(d.heading_rad, 0.0);  // the right end is nearer the goal line
}

TEST(NavigationFilter, GoalReachedResets) {
  NavigationFilter f{PolarMapParams{}};
  f.add_points(std::vector<cv::Point2d>{at(2.0, 0)});
  const Decision d = f.decide({0, 0, 0}, {0.1, 0.0});
  EXPECT_EQ(d.situation, Situation::goal_reached);
  EXPECT_FALSE(d.translate);
  EXPECT_TRUE(f.points().empty());
}

TEST(NavigationFilter, EnclosedGoalGivesNoCandidateWithAReason) {
  NavigationFilter f{PolarMapParams{}};
  std::vector<cv::Point2d> ring;
  for (int b = 0; b < 360; b += 5) ring.push_back(at(1.2, b));
  f.add_points(ring);
  const Decision d = f.decide({0, 0, 0}, at(3.0, 0));
  EXPECT_EQ(d.situation, Situation::no_candidate);
  EXPECT_FALSE(d.translate);
  EXPECT_FALSE(d.reason.empty());
}


TEST(NavigationFilterBookkeeping, RepeatedSightingsKeepOnePointPerCell) {
  // a robot standing before a 1 m wall sees its 21 points every cycle
  std::vector<cv::Point2d> wall;
  for (int i = 0; i <= 20; ++i) wall.emplace_back(2.0, -0.5 + 0.05 * i + 0.01);
  NavigationFilter merged(PolarMapParams{});
  for (int cycle = 0; cycle < 200; ++cycle) merged.add_points(wall);
  EXPECT_EQ(merged.points().size(), wall.size());
  PolarMapParams every;
  every.merge_cell_m = 0.0;
  NavigationFilter kept(every);
  for (int cycle = 0; cycle < 200; ++cycle) kept.add_points(wall);
  EXPECT_EQ(kept.points().size(), 200 * wall.size());
  // a reset keeps the near points, and the cells are re-indexed: sightings again add nothing
  PolarMapParams near_keep;
  near_keep.reset_keep_near_m = 2.03;
  NavigationFilter filter(near_keep);
  filter.add_points(wall);
  filter.reset(Pose2D{0.0, 0.0, 0.0});
  const std::size_t after_reset = filter.points().size();
  EXPECT_GT(after_reset, 0U);
  EXPECT_LT(after_reset, wall.size());
  filter.add_points(wall);
  EXPECT_EQ(filter.points().size(), wall.size());
  PolarMapParams bad;
  bad.merge_cell_m = -0.1;
  const Status st = bad.validate();
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("merge_cell_m"), std::string::npos) << st.error().message;
}

TEST(NavigationFilter, AFieldPointingBehindKeepsItsTurningSide) {
  // two walls close on both sides and one ahead: the potential field points behind the robot;
  // its side must not flip from one cycle to the next with a small change of the points
  NavigationFilter filter(PolarMapParams{});
  std::vector<cv::Point2d> pts = {{0.6, 0.02}, {0.5, 0.6}, {0.5, -0.6}};
  filter.add_points(pts);
  const Decision first = filter.decide(Pose2D{0, 0, 0}, {5.0, 0.0});
  ASSERT_EQ(first.situation, Situation::high_risk);
  ASSERT_GT(std::fabs(first.heading_rad), CV_PI / 2);
  filter.reset();
  filter.add_points(std::vector<cv::Point2d>{{0.6, first.heading_rad > 0 ? 0.04 : -0.04}, {0.5, 0.6}, {0.5, -0.6}});
  const Decision second = filter.decide(Pose2D{0, 0, 0}, {5.0, 0.0});
  ASSERT_EQ(second.situation, Situation::high_risk);
  EXPECT_GT(first.heading_rad * second.heading_rad, 0.0) << first.heading_rad << " then " << second.heading_rad;
}

}  // namespace
}  // namespace visnav::ipt
