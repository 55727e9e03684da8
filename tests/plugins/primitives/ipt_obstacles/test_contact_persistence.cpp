// Persistence of contact points over robot positions (contact_persistence.hpp): a fixed ground
// point is confirmed once the robot has moved min_baseline_m, a point that travels with the robot
// (a sliding track on a paver joint) never is, whatever the travel.
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "error_expect.hpp"
#include "visnav/ipt_obstacles/contact_persistence.hpp"

namespace visnav::ipt {
namespace {

using visnav::test::fails_with;
using visnav::test::key_only;

/// The robot drives along +x, a pair every 2 cm; each pair sees `seen(x_robot)` with 3 cm of
/// ranging noise along x and 1 cm across. Returns the robot's x at the first confirmation (or
/// a negative value when nothing was confirmed within `travel_m`).
template <class Seen>
double first_confirmation(ContactPersistence& memory, Seen seen, double travel_m) {
  std::mt19937 rng(7);
  std::normal_distribution<double> along(0.0, 0.03), across(0.0, 0.01);
  for (double x = 0.0; x <= travel_m; x += 0.02) {
    const cv::Point2d truth = seen(x);
    const double ex = along(rng);
    const double ey = across(rng);
    const std::vector<cv::Point2d> pair{{truth.x + ex, truth.y + ey}};
    memory.add(pair, {x, 0.0}, x);
    memory.forget(x, 1.0);
    if (!memory.confirmed().empty()) return x;
  }
  return -1.0;
}

TEST(ContactPersistence, AFixedGroundPointIsConfirmedAfterTheBaseline) {
  ContactPersistence memory(ContactPersistenceParams{});
  const double at = first_confirmation(memory, [](double) { return cv::Point2d{3.0, 0.1}; }, 2.0);
  EXPECT_GE(at, 0.3 - 1e-9);  // never from one position
  EXPECT_LE(at, 0.4);
}

TEST(ContactPersistence, APointMovingWithTheRobotIsNeverConfirmed) {
  ContactPersistence memory(ContactPersistenceParams{});
  // 1.5 m ahead of the robot, always: a trace re-found at the same image position.
  EXPECT_LT(first_confirmation(memory, [](double x) { return cv::Point2d{x + 1.5, 0.2}; }, 3.0), 0.0);
  // The same 2.5 m ahead and to the right (a joint seen further out: 2.5 m is the replay's corridor).
  ContactPersistence far(ContactPersistenceParams{});
  EXPECT_LT(first_confirmation(far, [](double x) { return cv::Point2d{x + 2.5, -0.4}; }, 3.0), 0.0);
  EXPECT_FALSE(memory.all().empty());  // they are kept, only not confirmed
}

TEST(ContactPersistence, OnlyTheCandidatesAskedForAreTestedAndForgetDropsOldSightings) {
  ContactPersistence memory(ContactPersistenceParams{});
  const std::vector<cv::Point2d> a{{2.0, 0.0}, {2.0, 3.0}};
  memory.add(a, {0.0, 0.0}, 0.0);
  memory.add(a, {0.5, 0.0}, 0.5);
  EXPECT_TRUE(memory.confirmed().empty());  // two pairs: not enough views (min_views 3)
  memory.add(a, {0.6, 0.0}, 0.6);
  EXPECT_EQ(memory.confirmed().size(), 6U);
  EXPECT_EQ(memory.confirmed([](const cv::Point2d& p) { return p.y < 1.0; }).size(), 3U);
  EXPECT_EQ(memory.confirmed_since(4).size(), 2U);  // the last pair's two points
  memory.forget(1.2, 1.0);  // the sightings from 0.0 m are 1.2 m of travel behind
  EXPECT_EQ(memory.size(), 4U);
  EXPECT_TRUE(memory.confirmed().empty());
}

TEST(ContactPersistence, AFixedPointFoundByTwoPairsOnlyIsNotConfirmed) {
  // The campus square's false contact (seed 1, odom frame): one ground point, found by the pair
  // at the first and at the last of about 36 pairs over 0.72 m, by no pair in between.
  ContactPersistence memory(ContactPersistenceParams{});
  const std::vector<cv::Point2d> seen{{2.94, -3.95}, {2.93, -3.96}};
  const std::vector<cv::Point2d> again{{2.96, -3.96}, {2.95, -3.97}};
  memory.add(seen, {1.98, -2.44}, 0.0);
  memory.add(again, {2.37, -3.05}, 0.72);
  EXPECT_TRUE(memory.confirmed().empty());
  ContactPersistenceParams two;
  two.min_views = 2;
  memory.set_params(two);
  EXPECT_EQ(memory.confirmed().size(), 4U);  // what the baseline test alone accepts
}

/// Pairs from a logged replay: robot position (odom frame) and the contact points of the pair;
/// `empty_before` pairs without points were made on the way from the previous one.
struct LoggedPair {
  cv::Point2d robot_m;
  std::vector<cv::Point2d> points_m;
  int empty_before = 0;
};

/// Replays `pairs` into `memory` (odometer = path length, empty pairs spread evenly); true when
/// something was confirmed after the last pair.
bool replay(ContactPersistence& memory, const std::vector<LoggedPair>& pairs) {
  cv::Point2d at = pairs.front().robot_m;
  double odom = 0.0;
  for (const auto& p : pairs) {
    for (int k = 1; k <= p.empty_before; ++k) {
      const cv::Point2d next = at + (p.robot_m - at) * (static_cast<double>(k) / (p.empty_before + 1));
      memory.add({}, next, odom + cv::norm(next - at));
    }
    odom += cv::norm(p.robot_m - at);
    at = p.robot_m;
    memory.add(p.points_m, at, odom);
    memory.forget(odom, 1.0);
  }
  return !memory.confirmed().empty();
}

TEST(ContactPersistence, TheHallFloorsTraceEndsAreNotConfirmedWithTheViewShare) {
  // Campus seed 1 with the van and the person, session 14 (the direction test on), edge e2 in the
  // hall: the robot drives along a tile joint; traces from noise obstacle features end at ground
  // corners on the joint 0.9-1.3 m ahead. Three pairs put points within the radius (views), but
  // they are 3 of 18 pairs made over those 0.56 m. The filter of session 11 confirms it (the lane
  // detour of that run); with min_view_share 0.4 it is not.
  const std::vector<LoggedPair> hall{
      {{12.431, -17.824}, {{11.73, -18.52}, {11.72, -18.51}, {11.73, -18.52}}, 0},
      {{12.344, -17.909}, {{11.21, -19.02}, {11.20, -19.01}}, 3},
      {{12.177, -18.071}, {{10.96, -19.27}, {10.96, -19.26}, {10.97, -19.27}, {10.96, -19.26}, {10.95, -19.26}}, 3},
      {{12.091, -18.154}, {{10.95, -19.29}}, 3},
      {{11.777, -18.464}, {{10.83, -19.44}, {10.83, -19.43}, {10.82, -19.43}}, 12},
  };
  ContactPersistence before(ContactPersistenceParams{});
  EXPECT_TRUE(replay(before, hall));
  ContactPersistenceParams share;
  share.min_view_share = 0.4;
  ContactPersistence after(share);
  EXPECT_FALSE(replay(after, hall));
}

TEST(ContactPersistence, AContactFoundByEverySecondPairIsConfirmedWithTheViewShare) {
  // A real obstacle's contact 2 m ahead, found by every second pair (3 cm of range noise): the
  // view share (0.5) passes 0.4 and the point is confirmed as soon as the baseline allows.
  ContactPersistenceParams share;
  share.min_view_share = 0.4;
  ContactPersistence memory(share);
  std::mt19937 rng(3);
  std::normal_distribution<double> along(0.0, 0.03);
  double at = -1.0;
  int k = 0;
  for (double x = 0.0; x <= 1.0 && at < 0.0; x += 0.02, ++k) {
    std::vector<cv::Point2d> pair;
    if (k % 2 == 0) {
      const double e = along(rng);
      pair.push_back({2.0 + e, 0.1});
    }
    memory.add(pair, {x, 0.0}, x);
    memory.forget(x, 1.0);
    if (!memory.confirmed().empty()) at = x;
  }
  EXPECT_GE(at, 0.3 - 1e-9);
  EXPECT_LE(at, 0.45);
  // Found by every pair it is confirmed exactly as without the share.
  ContactPersistence every(share);
  const double seen = first_confirmation(every, [](double) { return cv::Point2d{3.0, 0.1}; }, 2.0);
  EXPECT_GE(seen, 0.3 - 1e-9);
  EXPECT_LE(seen, 0.4);
}

TEST(ContactPersistence, BadParamsAreRejected) {
  ContactPersistenceParams p;
  p.radius_ratio = 1.0;  // a point moving with the robot would confirm itself
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::out_of_range, key_only("radius_ratio")));
  p = {};
  p.min_baseline_m = 0.0;
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::out_of_range, key_only("min_baseline_m")));
  p = {};
  p.min_views = 1;  // one pair would confirm anything
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::out_of_range, key_only("min_views")));
  p = {};
  p.min_view_share = 1.5;  // more views than pairs
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::out_of_range, key_only("min_view_share")));
}

}  // namespace
}  // namespace visnav::ipt
