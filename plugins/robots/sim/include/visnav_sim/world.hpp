// visnav simulator — the world model and its YAML loader.
//
// A world is a flat ground (z = 0) covered by textured polygon regions, vertical textured
// rectangles standing on it (walls, facades, fences, tree billboards) and a sky gradient.
// It is described by a YAML file (config/worlds/*.yaml; every key is documented in
// docs/sim.md) and loaded once; afterwards it is immutable.
//
// Frames and units: the `world` frame of visnav/types.hpp — x east, y north, z up, metres;
// headings in radians counter-clockwise from +x (the YAML file states angles in degrees).
//
// Errors: every problem in a world file (syntax, unknown key, bad value, missing texture
// file, self-intersecting polygon, unknown texture name) is a visnav::Error whose message
// starts with "file:line:" and names the key or the offending value.
//
// Thread-safety: a loaded World is immutable and may be shared between threads
// (std::shared_ptr<const World>). load_world_cached() is thread-safe.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include "visnav/config_node.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::sim {

/// Ground-truth class of a pixel in a label render (CV_8UC1 values).
enum class LabelClass : std::uint8_t {
  sky = 0,
  path = 1,      ///< a path the path-following primitive should follow (gravel, asphalt path)
  grass = 2,
  floor = 3,     ///< indoor floor
  pavement = 4,  ///< open paved area without a path (square, courtyard)
  ground = 5,    ///< any other ground
  wall = 6,      ///< walls, facades, corridors
  fence = 7,
  tree = 8,
  obstacle = 9,
};
inline constexpr int kLabelClassCount = 10;

[[nodiscard]] const char* to_string(LabelClass label);
[[nodiscard]] std::optional<LabelClass> label_class_from_string(std::string_view text);
/// Display colour (BGR) of a class, for label visualisations and the top view.
[[nodiscard]] cv::Vec3b label_color(LabelClass label);

/// A texture with its mip pyramid. Texel (i, j) of level k covers texel_m * 2^k metres.
struct Texture {
  std::string name;
  std::vector<cv::Mat> levels;  ///< CV_8UC4 BGRA, square, power-of-two side; levels[0] is full size
  int size_log2 = 0;            ///< log2 of levels[0] side
  double texel_m = 0.01;        ///< metres per level-0 texel (tiled textures)
  bool tiled = true;            ///< false: stretched once over its surface (billboards)
  bool has_alpha = false;       ///< texels with alpha < 128 are transparent (walls only)
  /// Seasonal replacements: (season name, texture index).
  std::vector<std::pair<std::string, int>> seasons;
};

/// A textured polygon on the ground. Later regions are drawn over earlier ones.
struct GroundRegion {
  std::string name;
  int texture = 0;  ///< index into World::textures
  LabelClass label = LabelClass::ground;
  std::vector<cv::Point2d> polygon;  ///< world metres; for `polyline` regions the buffered outline is not stored
  std::vector<cv::Point2d> polyline;  ///< centre line of a `polyline` region (paths), else empty
  double width_m = 0.0;               ///< width of a `polyline` region
  SourceLocation where;
};

/// A vertical textured rectangle from `from` to `to` (world metres), z in [base_m, top_m].
struct Wall {
  std::string name;
  cv::Point2d from;
  cv::Point2d to;
  double base_m = 0.0;
  double top_m = 2.5;
  int texture = 0;
  LabelClass label = LabelClass::wall;
  SourceLocation where;
  int mover = -1;  ///< index into World::movers when the wall belongs to a moving obstacle, else -1
};

/// The horizontal top of an obstacle (a convex polygon at height top_m), drawn by the renderer
/// when the camera is above it; it carries the obstacle's label and the object id of its first
/// wall. Collisions use the obstacle's walls only.
struct Cap {
  std::vector<cv::Point2d> ring;  ///< world metres, convex, >= 3 vertices (the obstacle's footprint)
  double top_m = 1.0;
  int texture = 0;
  LabelClass label = LabelClass::obstacle;
  std::size_t first_wall = 0;  ///< index in World::walls of the obstacle's first wall (its object id)
  int mover = -1;              ///< index into World::movers when the obstacle moves, else -1
};

/// An obstacle that moves (issue 16: a walking person, a moving box). Its walls are stored in
/// World::walls at the first point of `path` (with Wall::mover set) and are displaced by
/// offset_at(t) at simulated time t, seconds since the run started; the renderer and the
/// robot's collision check apply the offset. The motion is a constant speed along the polyline
/// (no turning of the body: it translates).
struct MovingObstacle {
  enum class Motion { once, loop, back_and_forth };
  std::string name;
  std::vector<cv::Point2d> path;  ///< world metres, >= 2 points; path[0] is the obstacle's `at`
  double speed_mps = 1.0;         ///< > 0
  double start_s = 0.0;           ///< stands at path[0] until then
  Motion motion = Motion::once;   ///< once: stops at the last point; loop: back to path[0] along
                                  ///< the closing segment and again; back_and_forth: reverses at the ends
  /// Yielding walker (`yield_m`, docs/sim.md): > 0 = it stands while the robot's body is within
  /// this gap ahead of it on its way (MoverStates, robot.hpp); 0 = blind (a pure function of time).
  double yield_m = 0.0;
  double radius_m = 0.25;  ///< farthest point of its ring from `at` (the yield test's body size)

  /// Position of the obstacle's reference point (path[0] at rest) at simulated time `time_s`
  /// (a blind walker: walked_at(time_s) metres along its motion).
  [[nodiscard]] cv::Point2d position_at(double time_s) const;
  /// Stands this long at every waypoint it reaches (the ends and turns of back_and_forth and
  /// loop included), seconds; 0 = walks on. Not with yield_m > 0 (the world file refuses it).
  double pause_s = 0.0;

  /// Metres walked along the motion by time `time_s` (a blind walker; its pauses counted).
  [[nodiscard]] double walked_at(double time_s) const;
  /// Position after walking `walked_m` metres along the motion (the motion mode applied), and
  /// the unit walking direction there when `direction` is non-null ((0, 0) when it stands at
  /// the end of a `once` path).
  [[nodiscard]] cv::Point2d position_walked(double walked_m, cv::Point2d* direction = nullptr) const;
  /// position_at(time_s) - path[0]: what is added to the obstacle's walls.
  [[nodiscard]] cv::Point2d offset_at(double time_s) const { return position_at(time_s) - path.front(); }
};

struct World {
  std::string name;
  std::string file;  ///< path the world was loaded from (empty if parsed from a string)

  std::vector<Texture> textures;
  std::vector<GroundRegion> regions;
  std::vector<Wall> walls;
  std::vector<MovingObstacle> movers;  ///< moving obstacles; their walls are in `walls` (Wall::mover)
  std::vector<Cap> caps;               ///< tops of `obstacles:` entries (drawn, not collided with)

  int default_texture = 0;  ///< ground outside every region
  LabelClass default_label = LabelClass::ground;
  cv::Vec3b sky_zenith_bgr{200, 140, 90};
  cv::Vec3b sky_horizon_bgr{235, 215, 200};
  double fog_distance_m = 0.0;  ///< 0 = no fog; else colour fades to the horizon colour with exp(-d/fog)
  Pose2D start;                 ///< suggested start pose of robots (world frame)

  /// Region index map: value r > 0 means regions[r - 1]; 0 means the default ground.
  /// Cell (row, col) covers x in [origin.x + col*res, +res), y in [origin.y + row*res, +res).
  cv::Mat region_map;  ///< CV_16UC1
  cv::Point2d region_map_origin_m;
  double region_map_resolution_m = 0.05;

  /// Index of the region at a world point: -1 for the default ground.
  [[nodiscard]] int region_at(double x_m, double y_m) const;
  /// Label of the ground at a world point.
  [[nodiscard]] LabelClass ground_label_at(double x_m, double y_m) const;
  /// Texture index by name, or -1.
  [[nodiscard]] int texture_index(std::string_view wanted) const;
  /// Displacement of a wall at simulated time `time_s`: zero unless it belongs to a moving obstacle.
  [[nodiscard]] cv::Point2d wall_offset(const Wall& wall, double time_s) const {
    return wall.mover < 0 ? cv::Point2d(0, 0) : movers[static_cast<std::size_t>(wall.mover)].offset_at(time_s);
  }
  /// Bounding box of regions and walls (world metres): x, y, width, height.
  [[nodiscard]] cv::Rect2d bounds() const;
};

/// Loads a world file. Relative texture paths are resolved against the file's folder.
[[nodiscard]] Result<std::shared_ptr<const World>> load_world(const std::string& path);
/// Parses world YAML text; `file_label` appears in error locations, `base_dir` resolves
/// relative texture paths.
[[nodiscard]] Result<std::shared_ptr<const World>> parse_world(std::string_view yaml_text,
                                                               const std::string& file_label,
                                                               const std::string& base_dir);
/// load_world() with a process-wide cache keyed by the canonical path (worlds are immutable,
/// textures are large). Thread-safe.
[[nodiscard]] Result<std::shared_ptr<const World>> load_world_cached(const std::string& path);

/// A copy of `base` with the obstacles of an obstacle file added (per-run placement, issue 16):
/// YAML with one top-level key `obstacles:`, a list in the world file's `obstacles:` syntax
/// (docs/sim.md); textures are the world's. Errors name the obstacle file's line and key.
[[nodiscard]] Result<std::shared_ptr<const World>> add_obstacles(const World& base, const std::string& obstacles_path);
/// load_world_cached(world_path), plus add_obstacles() when `obstacles_path` is not empty
/// (resolved against `relative_to` like a world name).
[[nodiscard]] Result<std::shared_ptr<const World>> load_world_with_obstacles(const std::string& world_path,
                                                                             const std::string& obstacles_path,
                                                                             const std::string& relative_to = {});

/// Resolves a world name or path: an existing file as given; else relative to `relative_to`
/// (a file or folder, e.g. the config file naming the world); else `<name>` or `<name>.yaml`
/// in the source tree's and the install tree's config/worlds. Error lists every path tried.
[[nodiscard]] Result<std::string> resolve_world_path(const std::string& name_or_path,
                                                     const std::string& relative_to = {});
/// What the robot and the camera check of a `world` param before building anything: resolves
/// `name_or_path` against the file of the `params:` block and loads it (load_world_cached).
/// Error at the location of the 'world' key: ErrorCode::not_found (no such world; every path
/// tried is listed) or parse_error (the file does not open or parse).
[[nodiscard]] Status check_world_file(const std::string& name_or_path, const ConfigNode& params);
/// Same for route scripts (config/routes).
[[nodiscard]] Result<std::string> resolve_route_path(const std::string& name_or_path,
                                                     const std::string& relative_to = {});

/// Folder holding the scikit-image sample photos used by `image: skimage:<name>` textures:
/// $VISNAV_SKIMAGE_DIR if set, else /usr/lib/python3/dist-packages/skimage/data.
[[nodiscard]] std::string skimage_data_dir();

/// Parses YAML text into a ConfigNode with file:line locations (world and route files): the SDK's
/// parse_yaml_string / parse_yaml_file, with their limits.
[[nodiscard]] Result<ConfigNode> parse_yaml_text(std::string_view text, const std::string& file_label);
[[nodiscard]] Result<ConfigNode> parse_yaml_path(const std::string& path);

}  // namespace visnav::sim
