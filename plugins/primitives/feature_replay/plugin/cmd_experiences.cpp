// `visnav map-experiences` (see cmd_experiences.hpp).
#include "cmd_experiences.hpp"

#include <cstdio>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "nodes.hpp"
#include "payload_check.hpp"
#include "visnav/command_line.hpp"
#include "visnav/feature_replay/experience.hpp"
#include "visnav/feature_replay/local_map.hpp"
#include "visnav/feature_replay/segment_map.hpp"
#include "visnav/map.hpp"

namespace visnav::feature_replay {
namespace fs = std::filesystem;

const char* const kExperiencesUsage =
    "usage: visnav map experiences MAP [--check]\n"
    "       visnav map experiences MAP --add-from DRIVE_MAP [--max-experiences N]\n"
    "       visnav map-experiences ... (the same)\n"
    "\n"
    "Lists the appearance experiences of every feature edge (feature_segment, feature_localmaps) of map\n"
    "folder MAP: experience 0 is the taught payload, the others were learned by replays with\n"
    "learn_experiences or added from a supervised drive (MAP/experiences/<edge>.bin). Per experience:\n"
    "number, when it was learned, by whom, its size (landmarks or local maps, bytes). Every experience\n"
    "file is verified: checksum, format, edge, that it was learned for the edge's current taught\n"
    "payload, and each body decodes and matches the edge's length. Experience files of edges the map\n"
    "does not have are reported too.\n"
    "\n"
    "  --check              print only the problems and a summary line\n"
    "  --add-from DRIVE_MAP add a supervised drive as experiences: DRIVE_MAP is a map taught by driving\n"
    "                       the route of MAP again in new conditions (same teach tree, same route, e.g.\n"
    "                       once per season); each feature edge of MAP that DRIVE_MAP has under the same\n"
    "                       id, kind and nodes gets the drive's view as a new experience, its distances\n"
    "                       scaled to the taught length (at most 25 % apart), the taught azimuth and\n"
    "                       commands kept. MAP's graph and payloads are not changed. Edges the drive\n"
    "                       lacks are listed as not driven.\n"
    "  --max-experiences N  with --add-from: at most N experiences per edge counting the taught one,\n"
    "                       the oldest learned evicted (default 4, as ReplayFeatureEdge's max_experiences)\n"
    "\n"
    "Exit status: 0 every experience valid (--add-from: at least one experience added and no edge\n"
    "refused), 1 a map or experience problem (one line each, naming the file and the edge), 2 usage\n"
    "error.\n";

namespace {

/// "812 landmarks" / "15 local maps" for a body of `kind`, or the decode/validate error.
Result<std::string> describe_body(std::span<const std::uint8_t> body, const EdgeRecord& edge) {
  if (edge.kind == kSegmentKind) {
    VISNAV_TRY(check_body<SegmentMap>(body, edge));
    auto m = SegmentMap::deserialize(body);
    return std::to_string(m->landmarks.size()) + " landmarks";
  }
  VISNAV_TRY(check_body<LocalMapPath>(body, edge));
  auto p = LocalMapPath::deserialize(body);
  std::size_t features = 0;
  for (const auto& m : p->maps) features += m.positions_px.size();
  return std::to_string(p->maps.size()) + " local maps, " + std::to_string(features) + " features";
}

/// --add-from: one line per feature edge of the taught map.
int add_from_drive(const std::string& map_dir, const std::string& drive_dir, int max_experiences) {
  auto outcomes = add_drive_experiences(map_dir, drive_dir, "supervised drive " + drive_dir, max_experiences);
  if (!outcomes) {
    std::fprintf(stderr, "map experiences: %s\n", outcomes.error().message.c_str());
    return 1;
  }
  std::size_t added = 0, refused = 0;
  for (const DriveExperienceOutcome& o : *outcomes) {
    if (o.added) {
      ++added;
      std::string evicted;
      for (std::uint32_t n : o.evicted) evicted += ", evicted experience " + std::to_string(n);
      std::printf("edge %s: added experience %u (%s, distances x %.3f%s)\n", o.edge_id.c_str(), o.number,
                  o.note.c_str(), o.length_scale, evicted.c_str());
    } else if (o.note.rfind("not driven", 0) == 0) {
      std::printf("edge %s: %s\n", o.edge_id.c_str(), o.note.c_str());
    } else {
      ++refused;
      std::printf("edge %s: REFUSED: %s\n", o.edge_id.c_str(), o.note.c_str());
    }
  }
  std::printf("%s: %zu experience%s added from %s, %zu edge%s refused\n", map_dir.c_str(), added,
              added == 1 ? "" : "s", drive_dir.c_str(), refused, refused == 1 ? "" : "s");
  return added > 0 && refused == 0 ? 0 : 1;
}

}  // namespace

int run_map_experiences(int argc, char** argv, HostServices& host) {
  (void)host;
  if (cli::print_help_if_asked(argc, argv, kExperiencesUsage)) return 0;
  std::string map_dir;
  std::string add_from;
  int max_experiences = 4;
  bool check_only = false;
  cli::OptionReader opt(argc, argv);
  while (opt.next()) {
    const std::string& a = opt.arg();
    if (a == "--check") {
      check_only = true;
    } else if (a == "--add-from") {
      auto v = opt.value();
      if (!v) return cli::usage_error("map experiences", v.error().message, kExperiencesUsage);
      add_from = *v;
    } else if (a == "--max-experiences") {
      auto v = opt.number(1, 64);
      if (!v) return cli::usage_error("map experiences", v.error().message, kExperiencesUsage);
      max_experiences = static_cast<int>(*v);
    } else if (!a.empty() && a[0] == '-') {
      return cli::usage_error("map experiences", "unknown option '" + a + "'", kExperiencesUsage);
    } else if (map_dir.empty()) {
      map_dir = a;
    } else {
      return cli::usage_error("map experiences", "unexpected argument '" + a + "'", kExperiencesUsage);
    }
  }
  if (map_dir.empty()) return cli::usage_error("map experiences", "missing MAP", kExperiencesUsage);
  if (!add_from.empty() && check_only)
    return cli::usage_error("map experiences", "--check and --add-from exclude each other", kExperiencesUsage);
  if (!add_from.empty()) return add_from_drive(map_dir, add_from, max_experiences);
  auto map = MapStore::open(map_dir);
  if (!map) {
    std::fprintf(stderr, "map experiences: %s\n", map.error().message.c_str());
    return 1;
  }
  std::vector<std::string> problems;
  std::set<std::string> feature_edges;
  std::size_t edges = 0, learned = 0;
  for (const EdgeRecord& edge : map->edges()) {
    if (edge.kind != kSegmentKind && edge.kind != kLocalMapsKind) continue;
    ++edges;
    feature_edges.insert(edge.id);
    auto teach = map->read_payload(edge.id);
    if (!teach) {
      problems.push_back(teach.error().message);
      continue;
    }
    auto set = load_experiences(map_dir, edge.id, *teach);
    if (!set) {
      problems.push_back(set.error().message);
      continue;
    }
    const std::string file = experience_path(map_dir, edge.id);
    if (!check_only) {
      std::printf("edge %s (%s, %.2f m): %zu experience%s\n", edge.id.c_str(), edge.kind.c_str(), edge.length_m,
                  set->learned.size() + 1, set->learned.empty() ? "" : "s");
      auto taught = describe_body(*teach, edge);
      std::printf("  0  taught  %s  %s, %zu bytes\n", edge.created.c_str(),
                  taught ? taught->c_str() : ("INVALID: " + taught.error().message).c_str(), teach->size());
    }
    for (const Experience& e : set->learned) {
      ++learned;
      auto what = describe_body(e.body, edge);
      if (!what)
        problems.push_back(file + ": edge " + edge.id + ": experience " + std::to_string(e.number) + ": " +
                           what.error().message);
      if (!check_only)
        std::printf("  %-2u learned %s  %s, %zu bytes  (%s)\n", e.number, e.created.c_str(),
                    what ? what->c_str() : "INVALID", e.body.size(), e.source.c_str());
    }
  }
  // Experience files no feature edge owns (the edge was removed or renamed).
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(fs::path(map_dir) / kExperienceFolder, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.empty() || name[0] == '.' || entry.path().extension() != ".bin") continue;
    if (feature_edges.count(entry.path().stem().string()) == 0)
      problems.push_back(entry.path().string() + ": no feature edge '" + entry.path().stem().string() + "' in the map");
  }
  for (const auto& p : problems) std::printf("%s\n", p.c_str());
  if (!problems.empty()) {
    std::fprintf(stderr, "map experiences: %s: INVALID (%zu problem%s)\n", map_dir.c_str(), problems.size(),
                 problems.size() == 1 ? "" : "s");
    return 1;
  }
  std::printf("%s: OK (%zu feature edge%s, %zu learned experience%s, every one verified)\n", map_dir.c_str(), edges,
              edges == 1 ? "" : "s", learned, learned == 1 ? "" : "s");
  return 0;
}

}  // namespace visnav::feature_replay
