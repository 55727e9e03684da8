// The probe ahead when a replay's path follower gives up on a hidden path (hidden_path_probe.hpp):
// it holds the heading it started with, its odometry budget is per place (a probe restarted
// before the budget ran out continues it), and only the child failures named by the trigger
// start it.
#include <gtest/gtest.h>

#include "error_expect.hpp"
#include "visnav/ipt_obstacles/hidden_path_probe.hpp"

namespace visnav::ipt {
namespace {

using visnav::test::fails_with;
using visnav::test::key_only;

TEST(HiddenPathProbe, HoldsTheStartHeadingAtTheProbeSpeed) {
  HiddenPathProbeParams params;
  ASSERT_TRUE(params.validate());
  HiddenPathProbe probe(params);
  probe.begin(Pose2D{0.0, 0.0, 3.0}, 10.0);
  // Turned 0.1 rad to the left of the held heading: steer right, proportionally.
  const auto left = probe.step(Pose2D{0.1, 0.0, 3.1}, 10.1);
  EXPECT_FALSE(left.exhausted);
  EXPECT_DOUBLE_EQ(left.command.linear_mps, params.speed_mps);
  EXPECT_NEAR(left.command.angular_radps, -0.1 * params.heading_gain_per_s, 1e-9);
  // Across the +-pi seam (held 3.0, now -3.1 = 3.18 rad): still a small right turn, not a 6 rad one.
  const auto seam = probe.step(Pose2D{0.2, 0.0, -3.1}, 10.2);
  EXPECT_LT(seam.command.angular_radps, 0.0);
  EXPECT_GE(seam.command.angular_radps, -params.max_angular_radps);
}

TEST(HiddenPathProbe, TheBudgetIsPerPlace) {
  HiddenPathProbeParams params;
  params.distance_m = 1.5;
  HiddenPathProbe probe(params);
  EXPECT_TRUE(probe.step(Pose2D{}, 0.0).exhausted);  // none started
  probe.begin(Pose2D{}, 5.0);
  EXPECT_NEAR(probe.left_m(5.0), 1.5, 1e-12);
  EXPECT_FALSE(probe.step(Pose2D{}, 6.0).exhausted);
  // The child resumed and gave up again 0.2 m later: the same budget goes on.
  probe.begin(Pose2D{}, 6.2);
  EXPECT_NEAR(probe.left_m(6.2), 0.3, 1e-9);
  EXPECT_FALSE(probe.step(Pose2D{}, 6.49).exhausted);
  EXPECT_TRUE(probe.step(Pose2D{}, 6.5).exhausted);
  EXPECT_DOUBLE_EQ(probe.step(Pose2D{}, 6.5).command.linear_mps, 0.0);
  // After a detour passed the obstacle: a new budget.
  probe.reset();
  probe.begin(Pose2D{}, 6.5);
  EXPECT_NEAR(probe.left_m(6.5), 1.5, 1e-12);
}

TEST(HiddenPathProbe, BadParamsAreRejectedWithTheKey) {
  HiddenPathProbeParams p;
  p.distance_m = 0.0;
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::out_of_range, key_only("distance_m")));
  p = {};
  p.speed_mps = -0.1;
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::out_of_range, key_only("speed_mps")));
}

}  // namespace
}  // namespace visnav::ipt
