// visnav simulator — procedurally generated worlds with a closed teach route (issue 38).
//
// `generate_world(seed)` draws one world from a family of places: an indoor hall with corridors,
// an outdoor park with paths on grass/gravel/asphalt, or a mixed site whose route passes through
// a building. The seed alone decides everything (same seed, same files, on every machine with
// the same standard library). The output is text in the existing formats: a world file
// (docs/sim.md "World files"), a closed waypoint route (docs/sim.md "Route scripts") whose legs
// are tagged `feature` or `path`, and, for some seeds, an obstacle file for the replays
// (`visnav experiment --obstacles`).
//
// Valid by construction: every wall, fence, building, pillar and tree trunk is placed by
// rejection sampling at a clearance from the route (GenerateParams); every `path` leg lies on a
// `path` region; the obstacles stand on the route with free space beside them. The generator
// checks this on the parsed world before returning (check_generated_world), so an invalid draw
// is a bug, reported as an error, never written.
//
// Frames and units: the world frame of world.hpp (x east, y north, metres, degrees in YAML).
// Thread-safety: pure functions; safe to call from any thread.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core/types.hpp>

#include "visnav/result.hpp"
#include "visnav_sim/world.hpp"

namespace visnav::sim {

/// What `visnav sim generate` draws. Kinds: "indoor", "outdoor", "mixed", or "any" (drawn from
/// the seed: a quarter indoor, half outdoor, a quarter mixed).
struct GenerateParams {
  int seed = 1;
  std::string kind = "any";
  /// Obstacle file: "auto" = for every third seed (seed % 3 == 0) where a leg has room,
  /// "yes" = whenever a leg has room, "no" = never.
  std::string obstacles = "auto";
  double route_clearance_m = 1.8;     ///< walls, fences, buildings, pillars and trunks vs the route
  double corridor_half_width_m = 1.8; ///< indoor corridors and building halls: wall offset from the route
};

/// One generated world. `name` is gen_<seed, 4 digits>; the route names its world file
/// `<name>.yaml` (resolved next to the route file).
struct GeneratedWorld {
  std::string name;
  std::string kind;            ///< indoor | outdoor | mixed
  std::string world_yaml;
  std::string route_yaml;
  std::string obstacles_yaml;  ///< empty: no obstacle file for this seed
  double route_length_m = 0.0;
  int path_legs = 0;           ///< legs tagged `path`
  int feature_legs = 0;
  int obstacles = 0;           ///< obstacles in obstacles_yaml
  std::string summary;         ///< one line: kind, route length, legs, textures, lighting
};

/// Draws the world of `params.seed`. Error: a bad kind/obstacles value, or (a bug) a draw that
/// fails its own check after the bounded number of attempts.
[[nodiscard]] Result<GeneratedWorld> generate_world(const GenerateParams& params);

/// The invariants the generator promises, checked on a parsed world and route: the route is a
/// closed waypoint route; every wall (static obstacles included) and tree trunk is at least
/// `clearance_m` from the route polyline, except obstacles named `route_obstacle_*`; every
/// `path` leg's points (every 0.5 m, 1 m trimmed at each end) lie on `path` ground.
/// Error: the first violated invariant, naming the wall/tree/leg and the distance.
[[nodiscard]] Status check_generated_world(const World& world, const std::vector<cv::Point2d>& route_closed_polyline,
                                           const std::vector<std::string>& leg_kinds, double clearance_m);

/// Writes `<dir>/<name>.yaml`, `<dir>/<name>_route.yaml`, `<dir>/<name>_obstacles.yaml` (when
/// there are obstacles) and `<dir>/<name>_top.png` (top view with the route and the obstacles).
/// Returns the paths written. Error: the folder cannot be created or a file cannot be written.
[[nodiscard]] Result<std::vector<std::string>> write_generated_world(const GeneratedWorld& generated,
                                                                     const std::string& dir);

}  // namespace visnav::sim
