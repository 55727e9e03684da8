// FollowPathEdge with the taught-appearance gate through the real session (loader, sim robot and
// camera, behaviour tree, map store): on the campus gravel loop's north-south leg a 14 m path
// edge is taught southwards from (32, -9) across the junction with the asphalt service road
// (y = -16, leaving east). The edge's appearance summary keeps the gravel only (the asphalt is
// seen in a minority of the teach frames); replayed from 0.3 m beside the start, the robot
// crosses the asphalt on the gravel models and stays on the 2.2 m gravel path. Without the gate
// (taught_gate_distance="0", printed for comparison, not asserted) the re-learned models adopt
// the asphalt.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>

#include "path_session.hpp"
#include "visnav/runner.hpp"

namespace fs = std::filesystem;
using namespace visnav;

TEST(FollowPathEdgeGate, CrossesTheAsphaltServiceRoadOnTheTaughtGravel) {
  const fs::path dir = visnav::test::path_test_dir("gate");
  SessionOptions so;
  so.use_default_plugin_path = false;
  so.extra_plugin_dirs = {VISNAV_TEST_PLUGIN_DIR};
  auto session = visnav::test::make_path_session(dir, "world: campus, start_pose: \"32;-9;-90\"", "error", so);
  ASSERT_TRUE(session);
  SimulationControl* sim = session->robot().simulation();
  ASSERT_NE(sim, nullptr);
  const double south = -std::numbers::pi / 2.0;
  auto tree_from = [&](const std::string& body) { return visnav::test::tree_from(*session, dir, body); };

  {  // teach: 14 m along the centre line x = 32, steered on the ground truth
    auto teach = tree_from(R"(<TeachPathEdge edge_from="" edge_to="" finish="{finish}"/>)");
    ASSERT_TRUE(teach.ok()) << teach.error().message;
    teach->blackboard().set("finish", false);
    RunOptions ro;
    ro.after_tick = [&](const TickInfo&) {
      const Pose2D p = sim->ground_truth_pose();
      if (p.y_m <= -23.0) {
        teach->blackboard().set("finish", true);
        (void)session->robot().stop();
      } else {  // heading south: a positive x offset is to the left, so turn right (ω < 0)
        (void)session->robot().send_command({0.5, 1.5 * (south - p.heading_rad) - 0.8 * (p.x_m - 32.0)});
      }
      return true;
    };
    ASSERT_EQ(run_tree(*session, *teach, ro).outcome, RunOutcome::success);
  }
  ASSERT_EQ(session->map()->edges().size(), 1u);
  const EdgeRecord edge = session->map()->edges()[0];
  std::printf("taught %.2f m, %.0f colour models in the summary, path seen in %.0f learn frames\n", edge.length_m,
              edge.statistics.at("colour_models"), edge.statistics.at("frames_path_seen"));
  EXPECT_EQ(edge.statistics.at("colour_models"), 1.0) << "the asphalt must stay out of the summary";

  auto replay = [&](const std::string& gate, double& max_dx, Pose2D& end) {
    EXPECT_TRUE(sim->set_ground_truth_pose({32.3, -9.0, south}).ok());
    auto tree = tree_from("<FollowPathEdge edge=\"" + edge.id + "\" taught_gate_distance=\"" + gate + "\"/>");
    EXPECT_TRUE(tree.ok()) << tree.error().message;
    max_dx = 0.0;
    RunOptions ro;
    ro.after_tick = [&](const TickInfo&) {
      max_dx = std::max(max_dx, std::abs(sim->ground_truth_pose().x_m - 32.0));
      return max_dx < 2.0;  // far off the path: enough seen
    };
    const RunReport report = tree.ok() ? run_tree(*session, *tree, ro) : RunReport{};
    end = sim->ground_truth_pose();
    return report;
  };
  double max_dx_off = 0.0, max_dx_on = 0.0;
  Pose2D end_off, end_on;
  const RunReport off = replay("0", max_dx_off, end_off);
  const RunReport on = replay("6", max_dx_on, end_on);
  std::printf("without the gate: %s, end (%.2f, %.2f), max |x - 32| %.2f m\n", to_string(off.outcome), end_off.x_m,
              end_off.y_m, max_dx_off);
  std::printf("with the gate:    %s, end (%.2f, %.2f), max |x - 32| %.2f m\n", to_string(on.outcome), end_on.x_m,
              end_on.y_m, max_dx_on);
  EXPECT_EQ(on.outcome, RunOutcome::success) << on.reason;
  EXPECT_LT(max_dx_on, 1.1) << "left the 2.2 m gravel path";
  EXPECT_LT(end_on.y_m, -20.0) << "crossed the junction";
  EXPECT_LT(std::abs(end_on.x_m - 32.0), 0.3);
  fs::remove_all(dir);
}
