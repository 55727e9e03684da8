// Generated worlds (visnav_sim/generate.hpp): deterministic per seed, valid by construction
// (clearance, path legs on path ground, closed route), drivable without a collision, and the
// check rejects what it promises to reject.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <sstream>

#include "visnav_sim/commands.hpp"
#include "visnav_sim/generate.hpp"

namespace vs = visnav::sim;
namespace fs = std::filesystem;

namespace {

struct Parsed {
  std::shared_ptr<const vs::World> world;
  vs::Route route;
  std::vector<cv::Point2d> closed;
  std::vector<std::string> kinds;
};

Parsed parse(const vs::GeneratedWorld& g) {
  Parsed p;
  auto world = vs::parse_world(g.world_yaml, g.name + ".yaml", ".");
  EXPECT_TRUE(world) << (world ? "" : world.error().message);
  auto route = vs::parse_route(g.route_yaml, g.name + "_route.yaml");
  EXPECT_TRUE(route) << (route ? "" : route.error().message);
  if (!world || !route) return p;
  p.world = *world;
  p.route = *route;
  for (const auto& w : route->waypoints) { p.closed.push_back(w.position_m); p.kinds.push_back(w.kind); }
  p.closed.push_back(p.closed.front());
  return p;
}

vs::GeneratedWorld make(int seed, const std::string& kind = "any", const std::string& obstacles = "auto") {
  vs::GenerateParams gp;
  gp.seed = seed;
  gp.kind = kind;
  gp.obstacles = obstacles;
  auto g = vs::generate_world(gp);
  EXPECT_TRUE(g) << "seed " << seed << ": " << (g ? "" : g.error().message);
  return g ? *g : vs::GeneratedWorld{};
}

}  // namespace

TEST(Generate, TheSeedAloneDecidesTheWorld) {
  const auto a = make(17), b = make(17), c = make(18);
  EXPECT_EQ(a.world_yaml, b.world_yaml);
  EXPECT_EQ(a.route_yaml, b.route_yaml);
  EXPECT_EQ(a.obstacles_yaml, b.obstacles_yaml);
  EXPECT_NE(a.world_yaml, c.world_yaml);
  EXPECT_EQ(a.name, "gen_0017");
}

TEST(Generate, EverySeedIsAClosedRouteClearOfWallsWithPathLegsOnPaths) {
  std::map<std::string, int> kinds;
  int with_obstacles = 0, path_legs = 0;
  // generate_world runs the check itself (an error otherwise); the first seeds are re-checked
  // here on an independent parse (a world parse costs ~0.5 s of texture synthesis)
  for (int seed = 1; seed <= 30; ++seed) {
    const auto g = make(seed);
    ++kinds[g.kind];
    auto route = vs::parse_route(g.route_yaml, g.name + "_route.yaml");
    ASSERT_TRUE(route) << route.error().message;
    Parsed p;
    p.route = *route;
    for (const auto& w : route->waypoints) { p.closed.push_back(w.position_m); p.kinds.push_back(w.kind); }
    p.closed.push_back(p.closed.front());
    EXPECT_TRUE(p.route.closed) << seed;
    EXPECT_GE(g.route_length_m, 35.0) << seed;
    EXPECT_LE(g.route_length_m, 130.0) << seed;
    if (seed <= 6) {
      const Parsed full = parse(g);
      ASSERT_TRUE(full.world) << seed;
      auto st = vs::check_generated_world(*full.world, p.closed, p.kinds, 1.7);
      EXPECT_TRUE(st) << g.name << ": " << (st ? "" : st.error().message);
    }
    // the start is the route's first waypoint, on the first leg's heading
    ASSERT_TRUE(p.route.start.has_value());
    EXPECT_NEAR(p.route.start->x_m, p.closed[0].x, 0.01);
    const cv::Point2d d = p.closed[1] - p.closed[0];
    EXPECT_NEAR(std::remainder(std::atan2(d.y, d.x) - p.route.start->heading_rad, 2 * CV_PI), 0.0, 0.01) << seed;
    if (g.kind == "indoor") { EXPECT_EQ(g.path_legs, 0) << seed; }
    if (g.kind == "outdoor") { EXPECT_GE(g.path_legs, 1) << seed; }
    path_legs += g.path_legs;
    if (!g.obstacles_yaml.empty()) {
      ++with_obstacles;
      EXPECT_EQ(seed % 3, 0) << "obstacles auto: every third seed only";
    }
  }
  EXPECT_GE(kinds["indoor"], 4);
  EXPECT_GE(kinds["outdoor"], 8);
  EXPECT_GE(kinds["mixed"], 4);
  EXPECT_GE(with_obstacles, 6);
  EXPECT_GE(path_legs, 15);
}

TEST(Generate, AScriptedOperatorDrivesGeneratedRoutesWithoutTouchingAnything) {
  const fs::path dir = fs::temp_directory_path() / ("visnav_generate_" + std::to_string(::getpid()));
  for (int seed : {1, 2, 4}) {  // mixed (through a hall), indoor with a corridor, indoor
    const auto g = make(seed);
    auto files = vs::write_generated_world(g, dir.string());
    ASSERT_TRUE(files) << files.error().message;
    auto route = vs::load_route((dir / (g.name + "_route.yaml")).string());
    ASSERT_TRUE(route) << route.error().message;
    vs::RobotParams rp;
    rp.world = (dir / (g.name + ".yaml")).string();
    rp.body_radius_m = 0.25;
    auto samples = vs::drive_route(*route, rp, 20.0, 900.0);
    ASSERT_TRUE(samples) << g.name << ": " << samples.error().message;
    const auto& end = samples->back().ground_truth;
    EXPECT_LT(std::hypot(end.x_m - route->waypoints.front().position_m.x, end.y_m - route->waypoints.front().position_m.y), 0.6)
        << g.name;
  }
  fs::remove_all(dir);
}

TEST(Generate, TheCheckNamesAWallOnTheRouteAndAPathLegOffThePath) {
  const auto g = make(3, "outdoor", "no");
  Parsed p = parse(g);
  ASSERT_TRUE(p.world);
  // a wall across the first leg
  const cv::Point2d m = (p.closed[0] + p.closed[1]) * 0.5;
  std::string yaml = g.world_yaml;
  const std::string marker = "  walls:\n";
  std::ostringstream wall;
  wall << marker << "    - {name: across, texture: concrete, height_m: 1, polyline: [[" << m.x - 0.5 << ", " << m.y - 0.5 << "], ["
       << m.x + 0.5 << ", " << m.y + 0.5 << "]]}\n";
  yaml.replace(yaml.find(marker), marker.size(), wall.str());
  auto blocked = vs::parse_world(yaml, "blocked.yaml", ".");
  ASSERT_TRUE(blocked) << blocked.error().message;
  auto st = vs::check_generated_world(**blocked, p.closed, p.kinds, 1.7);
  ASSERT_FALSE(st);
  EXPECT_NE(st.error().message.find("wall 'across'"), std::string::npos) << st.error().message;
  // every leg called a path leg: the feature legs are not on a path
  std::vector<std::string> all_path(p.kinds.size(), "path");
  auto off = vs::check_generated_world(*p.world, p.closed, all_path, 1.7);
  ASSERT_FALSE(off);
  EXPECT_NE(off.error().message.find("leaves the path"), std::string::npos) << off.error().message;
}

TEST(Generate, BadKindOrObstaclesValueIsRefusedNamingIt) {
  vs::GenerateParams gp;
  gp.kind = "forest";
  auto g = vs::generate_world(gp);
  ASSERT_FALSE(g);
  EXPECT_NE(g.error().message.find("'forest'"), std::string::npos);
  gp.kind = "any";
  gp.obstacles = "maybe";
  g = vs::generate_world(gp);
  ASSERT_FALSE(g);
  EXPECT_NE(g.error().message.find("'maybe'"), std::string::npos);
}

TEST(SimCommands, GenerateWritesWorldRouteObstaclesAndTopView) {
  const fs::path dir = fs::temp_directory_path() / ("visnav_generate_cmd_" + std::to_string(::getpid()));
  std::ostringstream out, err;
  ASSERT_EQ(vs::sim_main({"generate", "--seed", "2", "--count", "2", "-o", dir.string()}, out, err), 0) << err.str();
  for (const char* f : {"gen_0002.yaml", "gen_0002_route.yaml", "gen_0002_top.png", "gen_0003.yaml", "gen_0003_obstacles.yaml"})
    EXPECT_TRUE(fs::exists(dir / f)) << f;
  EXPECT_FALSE(fs::exists(dir / "gen_0002_obstacles.yaml"));
  EXPECT_NE(out.str().find("gen_0003:"), std::string::npos);
  // the written route finds its world next to it
  auto route = vs::load_route((dir / "gen_0002_route.yaml").string());
  ASSERT_TRUE(route);
  EXPECT_TRUE(vs::resolve_world_path(route->world, (dir / "gen_0002_route.yaml").string()));
  std::ostringstream out2, err2;
  EXPECT_EQ(vs::sim_main({"generate", "--seed", "-4", "-o", dir.string()}, out2, err2), 1);
  EXPECT_NE(err2.str().find("--seed"), std::string::npos) << err2.str();
  fs::remove_all(dir);
}
