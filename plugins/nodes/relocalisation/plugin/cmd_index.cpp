// `visnav reloc-index` (see cmd_index.hpp).
#include "cmd_index.hpp"

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "visnav/command_line.hpp"
#include "visnav/devices.hpp"
#include "visnav/map.hpp"
#include "visnav/relocalisation/place_index.hpp"

namespace visnav::reloc {

const char* const kIndexUsage =
    "usage: visnav reloc-index MAP [--check] [--set K=V ...] [--detector TYPE [--detector-set K=V ...]]\n"
    "\n"
    "Builds the place index of map folder MAP (MAP/place_index.bin) from the descriptors its feature\n"
    "edges store (feature_segment, feature_localmaps) and from the reference images of its\n"
    "visual_memory edges, described with --detector: a whole-image binary code per taught place,\n"
    "used by the Relocalise node. A map taught before the index existed gets one this way; a damaged\n"
    "or stale index is replaced. path_following edges taught with thumbnails (payload VPF2) add one\n"
    "thumbnail place per stored thumbnail; older ones (VPF1) are listed but have no place.\n"
    "Prints places, size, bytes per metre and build time.\n"
    "\n"
    "  --check     only verify the existing index (checksum, format, edges match the map; with\n"
    "              --detector also that it described the visual_memory references); no write\n"
    "  --detector TYPE      detector that describes visual_memory reference images (required when the\n"
    "              map has such edges): the detector Relocalise will run with, e.g. star_brief\n"
    "  --detector-set K=V   a parameter of that detector (repeatable), as in its config params: block\n"
    "  --set K=V   index parameter (repeatable): vocabulary_words (bits per code, multiple of 64,\n"
    "              default 1024), segment_spacing_m (default 0.25), vocabulary_sample (12000),\n"
    "              vocabulary_iterations (5)\n"
    "\n"
    "Exit status: 0 index built (or valid with --check), 1 map or index problem, 2 usage error.\n";

int run_reloc_index(int argc, char** argv, HostServices& host) {
  if (cli::print_help_if_asked(argc, argv, kIndexUsage)) return 0;
  std::string map_dir;
  bool check = false;
  ConfigNode sets = ConfigNode::make_map();
  std::string detector_type;
  ConfigNode detector_sets = ConfigNode::make_map();
  cli::OptionReader opt(argc, argv);
  while (opt.next()) {
    const std::string& a = opt.arg();
    if (a == "--check") {
      check = true;
    } else if (a == "--set") {
      auto v = opt.value();
      if (!v) return cli::usage_error("reloc-index", v.error().message, kIndexUsage);
      const auto eq = v->find('=');
      if (eq == std::string::npos || eq == 0)
        return cli::usage_error("reloc-index", "--set: expected K=V, got '" + *v + "'", kIndexUsage);
      sets.set(v->substr(0, eq), ConfigNode::make_scalar(v->substr(eq + 1)));
    } else if (a == "--detector") {
      auto v = opt.value();
      if (!v) return cli::usage_error("reloc-index", v.error().message, kIndexUsage);
      detector_type = *v;
    } else if (a == "--detector-set") {
      auto v = opt.value();
      if (!v) return cli::usage_error("reloc-index", v.error().message, kIndexUsage);
      const auto eq = v->find('=');
      if (eq == std::string::npos || eq == 0)
        return cli::usage_error("reloc-index", "--detector-set: expected K=V, got '" + *v + "'", kIndexUsage);
      detector_sets.set(v->substr(0, eq), ConfigNode::make_scalar(v->substr(eq + 1)));
    } else if (!a.empty() && a[0] == '-') {
      return cli::usage_error("reloc-index", "unknown option '" + a + "'", kIndexUsage);
    } else if (map_dir.empty()) {
      map_dir = a;
    } else {
      return cli::usage_error("reloc-index", "unexpected argument '" + a + "'", kIndexUsage);
    }
  }
  if (map_dir.empty()) return cli::usage_error("reloc-index", "missing MAP", kIndexUsage);
  auto params = PlaceIndexParams::schema().parse(sets);
  if (!params) return cli::usage_error("reloc-index", "--set: " + params.error().message, kIndexUsage);
  auto map = MapStore::open(map_dir);
  if (!map) {
    std::fprintf(stderr, "reloc-index: %s\n", map.error().message.c_str());
    return 1;
  }
  std::unique_ptr<Detector> detector;
  if (!detector_type.empty()) {
    auto made = host.create_detector(detector_type, detector_sets);
    if (!made) {
      std::fprintf(stderr, "reloc-index: --detector %s: %s\n", detector_type.c_str(), made.error().message.c_str());
      return 1;
    }
    detector = std::move(*made);
  } else if (!detector_sets.entries().empty()) {
    return cli::usage_error("reloc-index", "--detector-set needs --detector", kIndexUsage);
  }
  if (check) {
    auto index = load_place_index(map_dir);
    if (!index) {
      std::fprintf(stderr, "reloc-index: %s\n", index.error().message.c_str());
      return 1;
    }
    if (auto st = index->matches(*map); !st) {
      std::fprintf(stderr, "reloc-index: %s\n", st.error().message.c_str());
      return 1;
    }
    // With --detector: also that the visual_memory references were described by that detector.
    if (detector)
      if (auto st = check_detector(*map, *index, detector.get()); !st) {
        std::fprintf(stderr, "reloc-index: %s\n", st.error().message.c_str());
        return 1;
      }
    std::printf("%s: valid, %zu places over %zu edges, %zu thumbnail places\n", index_path(map_dir).c_str(),
                index->places.size(), index->edges.size(), index->thumbnail_places.size());
    return 0;
  }
  const auto t0 = std::chrono::steady_clock::now();
  cli::ProgressLine progress;
  auto index = build_place_index(*map, *params, detector.get(), [&](const char* phase, double done, double total) {
    progress.show(phase, done, total, "");
  }, detector_type);
  progress.end();
  if (!index) {
    std::fprintf(stderr, "reloc-index: %s\n", index.error().message.c_str());
    return 1;
  }
  if (auto st = save_place_index(map_dir, *index); !st) {
    std::fprintf(stderr, "reloc-index: %s\n", st.error().message.c_str());
    return 1;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  double length_m = 0.0;
  for (const auto& e : index->edges) length_m += e.length_m;
  const std::size_t bytes = index->byte_size();
  std::printf("%s: %zu places over %zu edges (%.1f m), %zu thumbnail places, %zu bytes (%.0f bytes/m), built in %.2f s\n",
              index_path(map_dir).c_str(), index->places.size(), index->edges.size(), length_m,
              index->thumbnail_places.size(), bytes,
              length_m > 0.0 ? static_cast<double>(bytes) / length_m : 0.0, seconds);
  return 0;
}

}  // namespace visnav::reloc
