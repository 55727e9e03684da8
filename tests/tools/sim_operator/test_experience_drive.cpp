// `visnav experiment --experience-teach A` (issue 13, multi-experience maps by a supervised
// drive), closed loop through the real loader, plugins, trees and the experiment core, with the
// realistic error models on: the 20 m rectangle of config/worlds/curve20m.yaml taught as feature
// segments, driven again by the scripted operator under another appearance into a scratch map,
// whose edges become experiences of the taught ones; then one replay loop in that appearance.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "experiment.hpp"
#include "visnav/feature_replay/experience.hpp"
#include "visnav/feature_replay/segment_map.hpp"
#include "visnav/map.hpp"

namespace fs = std::filesystem;
using namespace visnav;
using namespace visnav::simop;
namespace fr = visnav::feature_replay;

TEST(ExperienceDrive, EveryTaughtFeatureEdgeGetsTheDrivesViewAndTheReplayCompletes) {
  ExperimentOptions o;
  o.world = "curve20m";
  o.route = "curve20m_polygon";
  o.maps = {"feature"};
  o.seeds = 1;
  o.loops = 1;
  o.jobs = 1;
  o.displace_m = 0.3;
  o.displace_heading_deg = 5.0;
  o.progress = false;
  o.replay_appearance = "dusk";
  o.experience_teach = "dusk";
  o.config = std::string(VISNAV_TEST_SOURCE_DIR) + "/config/sim_experiment.yaml";
  o.out = (fs::temp_directory_path() / ("visnav_expdrive_" + std::to_string(::getpid()))).string();
  fs::remove_all(o.out);
  auto runs = run_experiment(o);
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  ASSERT_EQ(runs->size(), 1u);
  const ExperimentRun& r = runs->front();
  ASSERT_EQ(r.setup_error, "") << r.setup_error;
  EXPECT_GE(r.experience_edges, 3);
  EXPECT_EQ(r.experiences_added, r.experience_edges) << "every feature edge was driven again";
  ASSERT_EQ(r.loops.size(), 1u);
  EXPECT_TRUE(r.loops[0].completed) << r.loops[0].failure;

  // The taught map now holds, per feature edge, the taught payload (unchanged, its checksum is
  // what the experience file is bound to) and one experience of the taught length.
  const std::string map_dir = o.out + "/feature/seed1/map";
  auto map = MapStore::open(map_dir);
  ASSERT_TRUE(map.ok()) << map.error().message;
  int with_experience = 0;
  for (const EdgeRecord& e : map->edges()) {
    if (e.kind != fr::kSegmentKind) continue;
    auto teach = map->read_payload(e.id);
    ASSERT_TRUE(teach.ok());
    auto set = fr::load_experiences(map_dir, e.id, *teach);
    ASSERT_TRUE(set.ok()) << set.error().message;
    ASSERT_EQ(set->learned.size(), 1u) << e.id;
    EXPECT_NE(set->learned[0].source.find("supervised drive in dusk"), std::string::npos);
    auto body = fr::SegmentMap::deserialize(set->learned[0].body);
    ASSERT_TRUE(body.ok()) << body.error().message;
    EXPECT_DOUBLE_EQ(body->length_m, fr::SegmentMap::deserialize(*teach)->length_m);
    EXPECT_FALSE(body->landmarks.empty());
    ++with_experience;
  }
  EXPECT_EQ(with_experience, r.experience_edges);
  EXPECT_TRUE(fs::exists(o.out + "/feature/seed1/experience_drive/map"));
  std::error_code ec;
  fs::remove_all(o.out, ec);
}
