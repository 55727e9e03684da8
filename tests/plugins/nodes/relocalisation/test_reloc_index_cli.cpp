// `visnav reloc-index` on a map with a visual_memory edge (issue 21), through the real CLI and
// plugins: without --detector the edge is refused (exit 1, the edge and the fix named); with the
// detector the index is built, saved and passes --check; a damaged index fails --check.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "temp_folder.hpp"
#include "visnav/map.hpp"
#include "visnav/visual_memory_payload.hpp"

namespace fs = std::filesystem;
using namespace visnav;

namespace {

struct CliRun {
  int status = -1;
  std::string output;
};

CliRun reloc_index(const std::string& args) {
  const std::string cmd = "VISNAV_PLUGIN_PATH=" + std::string(VISNAV_TEST_PLUGIN_DIR) + " " + VISNAV_TEST_CLI +
                          " reloc-index " + args + " 2>&1";
  CliRun r;
  FILE* pipe = popen(cmd.c_str(), "r");
  if (pipe == nullptr) return r;
  std::array<char, 4096> buf{};
  while (fgets(buf.data(), static_cast<int>(buf.size()), pipe) != nullptr) r.output += buf.data();
  const int st = pclose(pipe);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

/// A textured 320x240 grey image of its own (blurred noise: many corners).
cv::Mat texture(int seed) {
  cv::Mat noise(60, 80, CV_8UC1);
  cv::RNG rng(static_cast<std::uint64_t>(seed));
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat image;
  cv::resize(noise, image, cv::Size(320, 240), 0, 0, cv::INTER_NEAREST);
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0.8);
  return image;
}

/// A map a -> b with one visual_memory edge of 12 reference images 0.5 m apart; its edge id.
std::string make_memory_map(const std::string& dir) {
  auto map = MapStore::create(dir, "visual memory");
  EXPECT_TRUE(map.ok()) << map.error().message;
  if (!map) return {};
  NodeRecord a, b;
  a.name = "a";
  b.name = "b";
  auto ia = map->add_node(a);
  auto ib = map->add_node(b);
  visual_memory::VisualMemory m;
  m.width_px = 320;
  m.height_px = 240;
  m.focal_px = 160.0 / std::tan(30.0 * M_PI / 180.0);
  for (int k = 0; k < 12; ++k) {
    visual_memory::Reference r;
    r.distance_m = 0.5 * k;
    r.image = texture(200 + k);
    m.references.push_back(std::move(r));
  }
  EdgeRecord e;
  e.from = *ia;
  e.to = *ib;
  e.kind = "visual_memory";
  e.length_m = 5.5;
  auto id = map->add_edge(e, m.encode());
  EXPECT_TRUE(id.ok()) << id.error().message;
  return id ? *id : std::string();
}

}  // namespace

TEST(RelocIndexCommand, DescribesVisualMemoryReferencesWithTheGivenDetector) {
  visnav::test::TempFolder tmp("visnav_reloc_index_cli");
  const std::string map_dir = tmp.file("map");
  const std::string edge = make_memory_map(map_dir);
  ASSERT_FALSE(edge.empty());
  const std::string small = " --set vocabulary_words=256 --set vocabulary_sample=3000";

  const CliRun no_detector = reloc_index(map_dir + small);
  EXPECT_EQ(no_detector.status, 1) << no_detector.output;
  EXPECT_NE(no_detector.output.find("edge " + edge), std::string::npos) << no_detector.output;
  EXPECT_NE(no_detector.output.find("--detector"), std::string::npos) << no_detector.output;
  EXPECT_FALSE(fs::exists(map_dir + "/place_index.bin"));

  const CliRun usage = reloc_index(map_dir + " --detector-set threshold=10");
  EXPECT_EQ(usage.status, 2) << "--detector-set without --detector is a usage error: " << usage.output;

  const CliRun unknown = reloc_index(map_dir + " --detector no_such_detector");
  EXPECT_EQ(unknown.status, 1) << unknown.output;
  EXPECT_NE(unknown.output.find("no_such_detector"), std::string::npos) << unknown.output;

  const CliRun built = reloc_index(map_dir + small + " --detector star_brief");
  ASSERT_EQ(built.status, 0) << built.output;
  EXPECT_NE(built.output.find("12 places over 1 edges"), std::string::npos) << built.output;
  ASSERT_TRUE(fs::exists(map_dir + "/place_index.bin"));
  const CliRun check = reloc_index(map_dir + " --check");
  EXPECT_EQ(check.status, 0) << check.output;
  // The same detector described the references: the index passes the detector check too.
  const CliRun same = reloc_index(map_dir + " --check --detector star_brief");
  EXPECT_EQ(same.status, 0) << same.output;

  // One flipped byte: --check refuses the index, naming the file.
  std::vector<char> bytes;
  {
    std::ifstream in(map_dir + "/place_index.bin", std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  ASSERT_GT(bytes.size(), 100u);
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x01);
  std::ofstream(map_dir + "/place_index.bin", std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  const CliRun damaged = reloc_index(map_dir + " --check");
  EXPECT_EQ(damaged.status, 1) << damaged.output;
  EXPECT_NE(damaged.output.find("place_index.bin"), std::string::npos) << damaged.output;
}
