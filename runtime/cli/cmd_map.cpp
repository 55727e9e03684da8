// `visnav map info|validate|render|route` — inspect a hybrid topological map folder.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "command.hpp"
#include "map/render.hpp"
#include "visnav/loader.hpp"
#include "visnav/map.hpp"
#include "visnav/runtime_host.hpp"

namespace {

constexpr const char* kUsage =
    "usage: visnav map info M                 nodes, edges, kinds, lengths, bytes per metre\n"
    "       visnav map validate M [--plugin-path DIR]... [--no-plugins]\n"
    "                                         check every file: graph, payload headers and sizes against the\n"
    "                                         graph, and every payload body decoded by its primitive's reader\n"
    "                                         (from the plugins on the search path); exit 1 listing each problem\n"
    "       visnav map render M -o map.png [--width PX]\n"
    "                                         draw the graph laid out by odometry, edges coloured by kind\n"
    "       visnav map route M FROM TO [--cost KIND=MULT ...] [--default-cost MULT]\n"
    "                                         cheapest route (Dijkstra; cost = length_m x multiplier of the kind;\n"
    "                                         MULT 'inf' forbids a kind)\n"
    "       visnav map SUB M ...              a subcommand contributed by a plugin as command map-SUB, e.g.\n"
    "                                         `visnav map experiences M` (feature_replay: appearance experiences)\n"
    "M is a map folder (graph.yaml + edges/). FROM/TO are node ids or names. validate also runs every\n"
    "plugin command map-SUB as `map-SUB M --check` (files a primitive keeps beside its payloads).\n"
    "Exit status: 0 ok, 1 failure (problems printed), 2 usage error.\n";

std::string human_bytes(double b) {
  char buf[32];
  if (b >= 1e9) std::snprintf(buf, sizeof buf, "%.2f GB", b / 1e9);
  else if (b >= 1e6) std::snprintf(buf, sizeof buf, "%.2f MB", b / 1e6);
  else if (b >= 1e3) std::snprintf(buf, sizeof buf, "%.1f kB", b / 1e3);
  else std::snprintf(buf, sizeof buf, "%.0f B", b);
  return buf;
}

int usage_error(const std::string& message) {
  std::cerr << "visnav map: " << message << "\n" << kUsage;
  return 2;
}

int info(const visnav::MapStore& map) {
  const auto s = map.stats();
  std::printf("map '%s' (%s)\n", map.name().c_str(), map.dir().c_str());
  std::printf("nodes: %zu   edges: %zu   length: %.2f m   payload: %s   %.0f B/m\n", s.nodes, s.total.edges,
              s.total.length_m, human_bytes(static_cast<double>(s.total.payload_bytes)).c_str(), s.total.bytes_per_m());
  if (!s.per_kind.empty()) {
    std::printf("\n%-24s %6s %12s %12s %12s\n", "kind", "edges", "length_m", "bytes", "bytes/m");
    for (const auto& [kind, k] : s.per_kind) {
      std::printf("%-24s %6zu %12.2f %12llu %12.1f\n", kind.c_str(), k.edges, k.length_m,
                  static_cast<unsigned long long>(k.payload_bytes), k.bytes_per_m());
    }
  }
  if (!map.nodes().empty()) {
    std::printf("\nnodes (id, name: outgoing edge -> node @ azimuth):\n");
    std::size_t shown = 0;
    for (const auto& n : map.nodes()) {
      if (++shown > 50) {
        std::printf("  ... %zu more\n", map.nodes().size() - 50);
        break;
      }
      std::printf("  %s '%s':", n.id.c_str(), n.name.c_str());
      const auto outs = map.outgoing(n.id);
      if (outs.empty()) std::printf(" (no outgoing edges)");
      for (const auto* e : outs) {
        std::printf(" %s -> %s @ %.1f deg (%s, %.1f m);", e->id.c_str(), e->to.c_str(), e->azimuth_rad * 180.0 / M_PI,
                    e->kind.c_str(), e->length_m);
      }
      std::printf("\n");
    }
  }
  const auto leftovers = map.leftover_files();
  if (!leftovers.empty()) {
    std::printf("\n%zu leftover file(s) not part of the map (interrupted writes; safe to delete):\n", leftovers.size());
    for (const auto& f : leftovers) std::printf("  %s\n", f.c_str());
  }
  return 0;
}

int validate(const std::string& dir, const std::vector<std::string>& rest) {
  std::vector<std::string> plugin_dirs;
  bool use_plugins = true;
  for (std::size_t i = 0; i < rest.size(); ++i) {
    if (rest[i] == "--plugin-path" && i + 1 < rest.size()) {
      plugin_dirs.push_back(rest[++i]);
    } else if (rest[i] == "--no-plugins") {
      use_plugins = false;
    } else {
      return usage_error("validate: unexpected argument '" + rest[i] + "'");
    }
  }
  auto map = visnav::MapStore::open(dir);
  if (!map) {
    std::cout << map.error().message << "\n";
    std::cerr << "visnav map validate: " << dir << ": INVALID (1 problem)\n";
    return 1;
  }
  // Payload bodies are decoded by the primitives' own readers (PayloadCheckEntry of the plugins
  // on the search path); the loader outlives every use of the map below.
  auto loader = visnav::PluginLoader::with_default_path(plugin_dirs);
  if (use_plugins) {
    if (auto scanned = loader.scan(); !scanned) std::cerr << "visnav map validate: " << scanned.error().message << "\n";
    loader.install_payload_checks(*map);
  }
  std::vector<std::string> unchecked;
  for (const auto& e : map->edges())
    if (!map->has_payload_check(e.kind) &&
        std::find(unchecked.begin(), unchecked.end(), e.kind) == unchecked.end())
      unchecked.push_back(e.kind);
  for (const auto& kind : unchecked)
    std::cerr << "visnav map validate: warning: no plugin provides a reader for edge kind '" << kind
              << "': its payload bodies are checked by checksum only\n";
  auto problems = map->validate();
  for (const auto& p : problems) std::cout << p << "\n";
  // Files a primitive keeps beside its payloads (e.g. learned experiences) are checked by its
  // map-SUB command; it prints its own problems.
  if (use_plugins) {
    for (const auto& c : loader.commands()) {
      if (c.name.rfind("map-", 0) != 0) continue;
      std::cout.flush();
      if (visnav::cli::run_plugin_command(c, {dir, "--check"}, loader) != 0)
        problems.push_back("map " + c.name.substr(4) + " --check failed");
    }
  }
  if (!problems.empty()) {
    std::cerr << "visnav map validate: " << dir << ": INVALID (" << problems.size() << " problem"
              << (problems.size() == 1 ? "" : "s") << ")\n";
    return 1;
  }
  const auto leftovers = map->leftover_files();
  std::cout << dir << ": OK (" << map->nodes().size() << " nodes, " << map->edges().size()
            << " edges, every payload verified" << (unchecked.empty() ? " and decoded" : "") << ")";
  if (!leftovers.empty()) std::cout << "; " << leftovers.size() << " leftover file(s) ignored";
  std::cout << "\n";
  return 0;
}

int render(const visnav::MapStore& map, const std::string& out, int width_px) {
  auto img = visnav::map_detail::render_map(map, width_px);
  if (!img) {
    std::cerr << "visnav map render: " << img.error().message << "\n";
    return 1;
  }
  try {
    if (!cv::imwrite(out, *img)) {
      std::cerr << "visnav map render: " << out << ": could not write the image (check the extension and folder)\n";
      return 1;
    }
  } catch (const cv::Exception& e) {
    std::cerr << "visnav map render: " << out << ": " << e.what() << "\n";
    return 1;
  }
  std::cout << "wrote " << out << " (" << img->cols << "x" << img->rows << ")\n";
  return 0;
}

bool parse_multiplier(const std::string& text, double& out) {
  if (text == "inf") {
    out = std::numeric_limits<double>::infinity();
    return true;
  }
  try {
    std::size_t used = 0;
    out = std::stod(text, &used);
    return used == text.size();
  } catch (...) {
    return false;
  }
}

int route(const visnav::MapStore& map, const std::vector<std::string>& rest) {
  std::vector<std::string> positional;
  visnav::RouteCost cost;
  for (std::size_t i = 0; i < rest.size(); ++i) {
    if (rest[i] == "--cost" || rest[i] == "--default-cost") {
      if (i + 1 >= rest.size()) return usage_error(rest[i] + " needs a value");
      const std::string v = rest[++i];
      double m = 0.0;
      if (rest[i - 1] == "--default-cost") {
        if (!parse_multiplier(v, m)) return usage_error("bad multiplier '" + v + "'");
        cost.default_multiplier = m;
      } else {
        const auto eq = v.find('=');
        if (eq == std::string::npos || !parse_multiplier(v.substr(eq + 1), m)) {
          return usage_error("--cost expects KIND=MULT, got '" + v + "'");
        }
        cost.kind_multiplier[v.substr(0, eq)] = m;
      }
    } else {
      positional.push_back(rest[i]);
    }
  }
  if (positional.size() != 2) return usage_error("route needs FROM and TO");
  auto r = visnav::plan_route(map, positional[0], positional[1], cost);
  if (!r) {
    std::cerr << "visnav map route: " << r.error().message << "\n";
    return 1;
  }
  std::printf("route %s -> %s: %zu edges, %.2f m, cost %.2f\n", r->from.c_str(), r->to.c_str(), r->edge_ids.size(),
              r->length_m, r->cost);
  for (const auto& id : r->edge_ids) {
    const auto* e = map.find_edge(id);
    std::printf("  %-12s %s -> %s  %-20s %8.2f m  azimuth %7.1f deg\n", id.c_str(), e->from.c_str(), e->to.c_str(),
                e->kind.c_str(), e->length_m, e->azimuth_rad * 180.0 / M_PI);
  }
  return 0;
}

int run_map(const std::vector<std::string>& args) {
  if (args.size() < 2) return usage_error(args.empty() ? "missing subcommand" : "missing map folder");
  const std::string& sub = args[0];
  const std::string& dir = args[1];
  const std::vector<std::string> rest(args.begin() + 2, args.end());
  if (sub == "validate") {
    return validate(dir, rest);
  }
  if (sub != "info" && sub != "render" && sub != "route") {
    // A subcommand a plugin contributes as command map-SUB (e.g. `map experiences`).
    auto loader = visnav::PluginLoader::with_default_path();
    if (auto scanned = loader.scan(); !scanned) std::cerr << "visnav map: " << scanned.error().message << "\n";
    for (const auto& c : loader.commands())
      if (c.name == "map-" + sub) return visnav::cli::run_plugin_command(c, std::vector<std::string>(args.begin() + 1, args.end()), loader);
    return usage_error("unknown subcommand '" + sub + "'");
  }
  std::string out;
  int width_px = 1200;
  if (sub == "render") {
    for (std::size_t i = 0; i < rest.size(); ++i) {
      if ((rest[i] == "-o" || rest[i] == "--output") && i + 1 < rest.size()) {
        out = rest[++i];
      } else if (rest[i] == "--width" && i + 1 < rest.size()) {
        try {
          width_px = std::stoi(rest[++i]);
        } catch (...) {
          return usage_error("bad --width '" + rest[i] + "'");
        }
      } else {
        return usage_error("unexpected argument '" + rest[i] + "'");
      }
    }
    if (out.empty()) return usage_error("render needs -o FILE.png");
  } else if (sub == "info" && !rest.empty()) {
    return usage_error("info takes no options");
  }
  auto map = visnav::MapStore::open(dir);
  if (!map) {
    std::cerr << "visnav map " << sub << ": " << map.error().message << "\n";
    return 1;
  }
  if (sub == "info") return info(*map);
  if (sub == "render") return render(*map, out, width_px);
  return route(*map, rest);
}

}  // namespace

VISNAV_COMMAND(map, "map", "inspect a map folder: info, validate, render, route", kUsage, run_map)
