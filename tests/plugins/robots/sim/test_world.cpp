// World files: the shipped worlds load; bad files are rejected with file:line and the value.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "visnav_sim/world.hpp"

namespace vs = visnav::sim;

namespace {

const std::string kHeader =
    "world:\n"                                                        // 1
    "  textures:\n"                                                   // 2
    "    grass: {procedural: noise, color: [90, 140, 60]}\n"          // 3
    "    gravel: {procedural: noise, color: [150, 140, 130]}\n"       // 4
    "  default_ground: {texture: grass, class: grass}\n";             // 5

std::string error_of(const std::string& text) {
  auto w = vs::parse_world(text, "bad.yaml", ".");
  EXPECT_FALSE(w.ok()) << "expected the world to be rejected";
  return w.ok() ? std::string() : w.error().message;
}

}  // namespace

TEST(SimWorld, ShippedWorldsLoad) {
  for (const char* name : {"campus", "straight6m", "lemniscate"}) {
    auto path = vs::resolve_world_path(name);
    ASSERT_TRUE(path.ok()) << path.error().message;
    auto w = vs::load_world_cached(*path);
    ASSERT_TRUE(w.ok()) << w.error().message;
    EXPECT_FALSE((*w)->walls.empty()) << name;
    EXPECT_FALSE((*w)->regions.empty()) << name;
  }
}

TEST(SimWorld, RegionLookupAndLabels) {
  auto w = vs::parse_world(kHeader +
                               "  regions:\n"
                               "    - {name: p, texture: gravel, class: path, polygon: [[0, -1], [10, -1], [10, 1], [0, 1]]}\n"
                               "    - {name: q, texture: gravel, class: path, width_m: 2, polyline: [[0, 5], [10, 5]]}\n",
                           "w.yaml", ".");
  ASSERT_TRUE(w.ok()) << w.error().message;
  EXPECT_EQ((*w)->ground_label_at(5, 0), vs::LabelClass::path);
  EXPECT_EQ((*w)->ground_label_at(5, 2.5), vs::LabelClass::grass);
  EXPECT_EQ((*w)->ground_label_at(5, 5.8), vs::LabelClass::path);
  EXPECT_EQ((*w)->ground_label_at(5, 6.3), vs::LabelClass::grass);
  EXPECT_EQ((*w)->ground_label_at(-50, 0), vs::LabelClass::grass);
}

TEST(SimWorld, MissingTextureFileNamesFileLineAndValue) {
  const std::string msg = error_of(
      "world:\n"
      "  textures:\n"
      "    grass: {image: no_such_photo.png}\n"
      "  default_ground: {texture: grass}\n");
  EXPECT_NE(msg.find("bad.yaml:3"), std::string::npos) << msg;
  EXPECT_NE(msg.find("no_such_photo.png"), std::string::npos) << msg;
}

TEST(SimWorld, SelfIntersectingPolygonRejected) {
  const std::string msg = error_of(kHeader +
                                   "  regions:\n"                                                            // 6
                                   "    - name: bowtie\n"                                                    // 7
                                   "      texture: gravel\n"                                                 // 8
                                   "      polygon: [[0, 0], [4, 4], [4, 0], [0, 4]]\n");                     // 9
  EXPECT_NE(msg.find("bad.yaml:9"), std::string::npos) << msg;
  EXPECT_NE(msg.find("self-intersecting"), std::string::npos) << msg;
  EXPECT_NE(msg.find("[4, 4]"), std::string::npos) << msg;
}

TEST(SimWorld, UnknownKeyRejected) {
  const std::string msg = error_of(kHeader +
                                   "  walls:\n"                                                              // 6
                                   "    - {texture: gravel, from: [0, 0], to: [1, 0], colour: red}\n");      // 7
  EXPECT_NE(msg.find("bad.yaml:7"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unknown key 'colour'"), std::string::npos) << msg;
}

TEST(SimWorld, BadValuesRejected) {
  std::string msg = error_of(kHeader +
                             "  walls:\n"
                             "    - {texture: gravel, from: [0, 0], to: [1, 0], height_m: tall}\n");        // 7
  EXPECT_NE(msg.find("bad.yaml:7"), std::string::npos) << msg;
  EXPECT_NE(msg.find("'tall'"), std::string::npos) << msg;
  msg = error_of(kHeader +
                 "  walls:\n"
                 "    - {texture: marble, from: [0, 0], to: [1, 0]}\n");                                      // 7
  EXPECT_NE(msg.find("bad.yaml:7"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unknown texture 'marble'"), std::string::npos) << msg;
  msg = error_of(kHeader +
                 "  regions:\n"
                 "    - {texture: gravel, class: lava, polygon: [[0, 0], [1, 0], [1, 1]]}\n");                // 7
  EXPECT_NE(msg.find("bad.yaml:7"), std::string::npos) << msg;
  EXPECT_NE(msg.find("'lava'"), std::string::npos) << msg;
  msg = error_of(kHeader + "  ground_resolution_m: -1\n");                                                   // 6
  EXPECT_NE(msg.find("bad.yaml:6"), std::string::npos) << msg;
  msg = error_of("world:\n  textures: {a: {procedural: noise}\n");
  EXPECT_NE(msg.find("bad.yaml:"), std::string::npos) << msg;
}

TEST(SimWorld, ResolveWorldPathListsTriedPaths) {
  auto p = vs::resolve_world_path("no_such_world");
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().code, visnav::ErrorCode::not_found) << p.error().message;
  EXPECT_NE(p.error().message.find("no_such_world.yaml"), std::string::npos) << p.error().message;  // the tried paths
}
