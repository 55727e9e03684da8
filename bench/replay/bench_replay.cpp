// bench_replay — per-frame feature replay cost on a 10 km map vs a 100 m map (issue 6, "Scale":
// "a benchmark shows per-frame replay cost on a 10 km map within 1.1x of a 100 m map").
//
// Maps (realistic feature edges, written through the real API):
//  * Teach once in simulation: four straight 10 m stretches of the campus world
//    (config/worlds/campus.yaml) are rendered with the visnav_sim renderer at 320x240 / 60 deg
//    (config/sim_feature.yaml's camera) every 5 cm, detected with the star_brief detector core
//    (target_keypoints 300, as that config) and taught with the real LocalMapTeacher (a local map
//    every 0.2 m, all features, the operator's (0.3 m/s, 0) command) — the four serialised
//    LocalMapPath bodies are the payload pool (~0.5 MB each, ~50 KB/m, the figure of
//    docs/feature_replay.md).
//  * Replicate: a 100 m map (10 edges of 10 m) and a 10 km map (1000 edges) of kind
//    feature_localmaps, a chain n0 -> n1 -> ... written with MapStore::add_edge (edge i carries
//    pool body i % 4). Cached in $TMPDIR/visnav_bench_maps/replay_* (about 0.55 GB for the 10 km
//    map), regenerated when missing, incomplete or when the taught pool changed (its CRC is kept in
//    the marker file).
//
// Replay (what PlanRoute + FollowRoute + ReplayFeatureEdge do, through the shipped code):
//  * MapStore::open, plan_route(n0 -> last node), pick the edge in the middle of the route (an
//    edge carrying pool body 0 in both maps, so both maps do identical work per frame);
//  * edge start (ReplayFeatureEdge::load_edge): find_edge + read_payload (checksummed) +
//    LocalMapPath::deserialize + LocalMapReplayer (validated path) + begin();
//  * per frame: FollowRoute's per-tick MapStore::find_edge(route[i]) + LocalMapReplayer::step
//    (nearest local map by distance, match, histogram vote, command). The current features are
//    detected beforehand from frames rendered 0.3 m to the left of the taught line and turned
//    0.05 rad (so the replayer steers), one every 0.1 m; the odometry advances 3 cm per frame
//    (0.3 m/s at 10 Hz). Detection itself is map-independent and not part of the figure
//    (bench_feature_replay measures it).
//
// Figures (thread CPU time, single-threaded, cv::setNumThreads(1)):
//  * ReplayFrame/<map>: us per frame; ReplayFrameRatio: both maps interleaved frame by frame (same
//    distance, same features, same machine load), us_per_frame_100m/_10km and
//    ratio_10km_over_100m (target <= 1.1);
//  * EdgeChange/<map>: ms per edge start (consecutive route edges, warm page cache), plus
//    amortised_us_per_frame = that / frames per edge (10 m at 3 cm per frame);
//  * PlanRoute/<map>, MapAccess/<map> (find_edge; resolve_node by name), OpenMap/<map>:
//    context for the once-per-mission costs.
// A summary line with the figures and the ratio is printed at the end.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core/utility.hpp>

#include "visnav/detectors/detector_types.hpp"
#include "visnav/feature_replay/local_map.hpp"
#include "visnav/map.hpp"
#include "visnav_sim/render.hpp"
#include "visnav_sim/world.hpp"

namespace fr = visnav::feature_replay;
namespace vs = visnav::sim;
namespace fs = std::filesystem;

namespace {

constexpr const char* kKind = "feature_localmaps";  // fr::kLocalMapsKind (plugin header, not linked)
constexpr double kEdgeLengthM = 10.0;
constexpr double kTeachStepM = 0.05;      // a frame every 5 cm while teaching (0.5 m/s at 10 Hz)
constexpr double kReplayFrameStepM = 0.03;  // odometry advance per replay frame (0.3 m/s at 10 Hz)
constexpr double kReplayImageStepM = 0.1;   // a rendered replay image every 10 cm
constexpr double kReplayLateralM = 0.3;     // replay line: 0.3 m left of the taught one ...
constexpr double kReplayYawRad = 0.05;      // ... turned 0.05 rad
constexpr int kWidthPx = 320, kHeightPx = 240;
constexpr std::size_t kPool = 4;

/// A straight taught stretch: start pose (world frame) and heading.
const visnav::Pose2D kStretches[kPool] = {
    {7.5, -6.0, M_PI / 2},   // across the paved square towards the hall's west door
    {8.5, 13.0, 0.0},        // inside the hall, eastwards
    {32.0, -9.0, -M_PI / 2}, // along the east gravel path, across the service road
    {30.0, -26.0, M_PI},     // along the south gravel path, westwards
};

visnav::Pose2D along(const visnav::Pose2D& start, double d_m, double lateral_m = 0.0, double yaw_rad = 0.0) {
  const double c = std::cos(start.heading_rad), s = std::sin(start.heading_rad);
  return {start.x_m + c * d_m - s * lateral_m, start.y_m + s * d_m + c * lateral_m, start.heading_rad + yaw_rad};
}

double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

[[noreturn]] void die(const std::string& what) { throw std::runtime_error(what); }

// ------------------------------------------------------------------------------ teach once

struct Taught {
  std::vector<std::vector<std::uint8_t>> bodies;  // kPool serialised LocalMapPaths
  std::vector<std::size_t> local_maps, features, commands;
  std::vector<visnav::Features> replay_features;   // for stretch 0, one per kReplayImageStepM
  std::uint32_t crc = 0;
};

std::unique_ptr<visnav::detectors::DetectorBase> make_detector() {
  auto det = visnav::detectors::create_detector("star_brief",
                                                visnav::detectors::make_params({{"target_keypoints", "300"}}));
  if (!det) die("star_brief: " + det.error().message);
  return std::move(*det);
}

const Taught& taught() {
  static const Taught t = [] {
    const auto t0 = std::chrono::steady_clock::now();
    auto path = vs::resolve_world_path("campus");
    if (!path) die(path.error().message);
    auto world = vs::load_world(*path);
    if (!world) die(world.error().message);
    vs::CameraModel model;
    model.width_px = kWidthPx;
    model.height_px = kHeightPx;
    model.hfov_deg = 60.0;
    vs::Renderer renderer(*world, model);
    cv::Mat bgr;
    visnav::Features f;
    Taught out;
    for (const auto& start : kStretches) {
      auto det = make_detector();
      renderer.render(start, bgr);
      for (int i = 0; i < 8; ++i) (void)det->detect(bgr, f);  // settle the adaptive threshold
      fr::LocalMapTeacher teacher;  // defaults: a local map every 0.2 m, all features
      teacher.begin();
      const int steps = static_cast<int>(std::lround(kEdgeLengthM / kTeachStepM));
      for (int k = 0; k < steps; ++k) {
        const double d = k * kTeachStepM;
        renderer.render(along(start, d), bgr);
        if (auto st = det->detect(bgr, f); !st) die("detect: " + st.error().message);
        teacher.record_command(d, visnav::Twist{0.3, 0.0});
        if (auto st = teacher.add_frame(d, f); !st) die("teach: " + st.error().message);
      }
      renderer.render(along(start, kEdgeLengthM), bgr);
      (void)det->detect(bgr, f);
      auto p = teacher.finish(kEdgeLengthM, f);
      if (!p) die("teach finish: " + p.error().message);
      std::size_t n = 0;
      for (const auto& m : p->maps) n += m.positions_px.size();
      out.local_maps.push_back(p->maps.size());
      out.features.push_back(n);
      out.commands.push_back(p->commands.size());
      out.bodies.push_back(p->serialize());
      out.crc = visnav::map_format::crc32(out.bodies.back(), out.crc);
    }
    // Replay images along stretch 0, displaced and turned.
    auto det = make_detector();
    renderer.render(along(kStretches[0], 0.0, kReplayLateralM, kReplayYawRad), bgr);
    for (int i = 0; i < 8; ++i) (void)det->detect(bgr, f);
    const int images = static_cast<int>(std::lround(kEdgeLengthM / kReplayImageStepM)) + 1;
    for (int k = 0; k < images; ++k) {
      renderer.render(along(kStretches[0], k * kReplayImageStepM, kReplayLateralM, kReplayYawRad), bgr);
      visnav::Features cur;
      if (auto st = det->detect(bgr, cur); !st) die("detect: " + st.error().message);
      out.replay_features.push_back(std::move(cur));
    }
    std::fprintf(stderr, "taught %zu stretches of %.0f m in %.1f s: local maps", kPool, kEdgeLengthM,
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    for (std::size_t i = 0; i < kPool; ++i)
      std::fprintf(stderr, " %zu (%zu features, %.0f KB)", out.local_maps[i], out.features[i], out.bodies[i].size() / 1e3);
    std::fprintf(stderr, "\n");
    return out;
  }();
  return t;
}

// ------------------------------------------------------------------------------ replicate

struct MapSpec {
  const char* name;  // also the benchmark suffix
  int edges;
};
constexpr MapSpec k100m{"100m", 10};
constexpr MapSpec k10km{"10km", 1000};

std::string numbered(const char* prefix, long long i) { return prefix + std::to_string(i); }

const std::string& generated(const MapSpec& spec) {
  static std::map<std::string, std::string> cache;
  if (auto it = cache.find(spec.name); it != cache.end()) return it->second;
  const Taught& t = taught();
  const std::string dir = (fs::temp_directory_path() / "visnav_bench_maps" / (std::string("replay_") + spec.name)).string();
  const std::string marker = dir + "/.complete";
  char want[64];
  std::snprintf(want, sizeof want, "edges=%d crc=%08x", spec.edges, t.crc);
  bool ok_map = false;
  if (std::ifstream in(marker); in) {
    std::string line;
    std::getline(in, line);
    auto m = visnav::MapStore::open(dir);
    ok_map = line == want && m && static_cast<int>(m->edges().size()) == spec.edges;
  }
  if (!ok_map) {
    fs::remove_all(dir);
    const auto t0 = std::chrono::steady_clock::now();
    auto map = visnav::MapStore::create(dir, std::string("bench replay ") + spec.name);
    if (!map) die(map.error().message);
    map->set_autoflush(false);
    map->set_sync(false);  // generator: atomic renames without fsync (MapStore::set_sync)
    std::uint64_t bytes = 0;
    for (int i = 0; i <= spec.edges; ++i) {
      auto n = map->add_node({.id = numbered("n", i), .name = numbered("place ", i), .position_hint = {}});
      if (!n) die(n.error().message);
    }
    for (int i = 0; i < spec.edges; ++i) {
      const std::size_t p = static_cast<std::size_t>(i) % kPool;
      visnav::EdgeRecord e;
      e.id = numbered("e", i);
      e.from = numbered("n", i);
      e.to = numbered("n", i + 1);
      e.kind = kKind;
      e.length_m = kEdgeLengthM;
      e.azimuth_rad = kStretches[p].heading_rad;
      // The statistics TeachFeatureEdge writes for a style B edge.
      e.statistics = {{"local_maps", static_cast<double>(t.local_maps[p])},
                      {"features", static_cast<double>(t.features[p])},
                      {"commands", static_cast<double>(t.commands[p])},
                      {"image_width_px", kWidthPx},
                      {"image_height_px", kHeightPx},
                      {"end_heading_rad", kStretches[p].heading_rad}};
      auto r = map->add_edge(e, t.bodies[p]);
      if (!r) die(r.error().message);
      bytes += t.bodies[p].size();
    }
    if (auto st = map->flush(); !st) die(st.error().message);
    std::ofstream(marker) << want << "\n";
    std::fprintf(stderr, "generated %s: %d edges, %.0f MB in %.1f s\n", dir.c_str(), spec.edges, bytes / 1e6,
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return cache.emplace(spec.name, dir).first->second;
}

// ------------------------------------------------------------------------------ replay rig

/// One replay session over one map: the open map, the planned route, the edge being replayed.
struct Rig {
  visnav::MapStore map;
  visnav::Route route;
  std::size_t position = 0;  // index in route.edge_ids of the edge replayed per frame
  std::optional<fr::LocalMapReplayer> replayer;
  double origin_m = 0.0;     // odometry distance at the edge start
  std::size_t frame = 0;

  explicit Rig(visnav::MapStore m) : map(std::move(m)) {}

  /// ReplayFeatureEdge::load_edge + on_start for `edge_id`, with the node's default port values.
  void start_edge(const std::string& edge_id, double odometry_m) {
    const visnav::EdgeRecord* edge = map.find_edge(edge_id);
    if (edge == nullptr || edge->kind != kKind) die("edge " + edge_id + " missing or of another kind");
    auto body = map.read_payload(edge_id);
    if (!body) die(body.error().message);
    auto parsed = fr::LocalMapPath::deserialize(*body);
    if (!parsed) die("edge " + edge_id + " payload: " + parsed.error().message);
    fr::LocalMapReplayParams p;
    p.gain_radps_per_px = 0.003;  // ReplayFeatureEdge port defaults
    p.max_correction_radps = 0.3;
    p.laps = 1;
    fr::HeadingParams heading;
    heading.ratio = 0.7;
    heading.min_confidence = 0.25;
    replayer.emplace(std::make_shared<const fr::LocalMapPath>(std::move(*parsed)), p, heading);
    if (!replayer->path_valid()) die("edge " + edge_id + ": invalid local-map path");
    replayer->begin(odometry_m);
    origin_m = odometry_m;
  }

  /// One frame: FollowRoute's per-tick edge lookup + the replayer step.
  fr::LocalMapReplayOutput step() {
    const double d = std::fmod(static_cast<double>(frame) * kReplayFrameStepM, kEdgeLengthM - 0.2);
    ++frame;
    const auto& feats = taught().replay_features;
    const auto image = std::min(static_cast<std::size_t>(std::lround(d / kReplayImageStepM)), feats.size() - 1);
    const visnav::EdgeRecord* edge = map.find_edge(route.edge_ids[position]);
    benchmark::DoNotOptimize(edge);
    return replayer->step(origin_m + d, feats[image], kWidthPx);
  }
};

std::unique_ptr<Rig> make_rig(const MapSpec& spec) {
  auto m = visnav::MapStore::open(generated(spec));
  if (!m) die(m.error().message);
  auto rig = std::make_unique<Rig>(std::move(*m));
  auto route = visnav::plan_route(rig->map, "n0", numbered("n", spec.edges));
  if (!route) die(route.error().message);
  if (static_cast<int>(route->edge_ids.size()) != spec.edges) die("unexpected route length");
  rig->route = std::move(*route);
  // The middle of the route, rounded down to an edge carrying pool body 0 (edge i has body i % 4).
  rig->position = (rig->route.edge_ids.size() / 2) / kPool * kPool;
  rig->start_edge(rig->route.edge_ids[rig->position], 1000.0 + kEdgeLengthM * static_cast<double>(rig->position));
  return rig;
}

/// make_rig, or nullptr after skipping the benchmark with the reason.
std::unique_ptr<Rig> rig_or_skip(benchmark::State& state, const MapSpec& spec) {
  try {
    return make_rig(spec);
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return nullptr;
  }
}

std::map<std::string, double>& results() {
  static std::map<std::string, double> r;
  return r;
}

// ------------------------------------------------------------------------------ benchmarks

void BM_ReplayFrame(benchmark::State& state, const MapSpec* spec) {
  cv::setNumThreads(1);
  std::unique_ptr<Rig> rig = rig_or_skip(state, *spec);
  if (!rig) return;
  for (int i = 0; i < 50; ++i) (void)rig->step();  // warm the estimator's buffers
  std::int64_t steering = 0, inliers = 0;
  const double c0 = thread_cpu_s();
  for (auto _ : state) {
    const auto out = rig->step();
    steering += out.state == fr::ReplayState::steering ? 1 : 0;
    inliers += out.estimate.inliers;
    benchmark::DoNotOptimize(out);
  }
  const double n = static_cast<double>(state.iterations());
  const double us = 1e6 * (thread_cpu_s() - c0) / n;
  state.counters["us_per_frame"] = us;
  state.counters["steering_frac"] = static_cast<double>(steering) / n;
  state.counters["mean_inliers"] = static_cast<double>(inliers) / n;
  state.counters["map_edges"] = static_cast<double>(rig->map.edges().size());
  results()[std::string("frame_us_") + spec->name] = us;
}

/// Both maps interleaved frame by frame: same distance and features, same machine load.
void BM_ReplayFrameRatio(benchmark::State& state) {
  cv::setNumThreads(1);
  std::unique_ptr<Rig> small = rig_or_skip(state, k100m);
  std::unique_ptr<Rig> large = small ? rig_or_skip(state, k10km) : nullptr;
  if (!large) return;
  for (int i = 0; i < 50; ++i) {
    (void)small->step();
    (void)large->step();
  }
  double small_s = 0.0, large_s = 0.0;
  bool large_first = false;
  auto timed = [](Rig& rig) {
    const double t0 = thread_cpu_s();
    auto out = rig.step();
    benchmark::DoNotOptimize(out);
    return thread_cpu_s() - t0;
  };
  for (auto _ : state) {
    // Alternate the order so neither map always runs with the other's data in the cache.
    if (large_first) {
      large_s += timed(*large);
      small_s += timed(*small);
    } else {
      small_s += timed(*small);
      large_s += timed(*large);
    }
    large_first = !large_first;
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["us_per_frame_100m"] = 1e6 * small_s / n;
  state.counters["us_per_frame_10km"] = 1e6 * large_s / n;
  state.counters["ratio_10km_over_100m"] = large_s / small_s;
  state.counters["within_1_1"] = large_s / small_s <= 1.1 ? 1.0 : 0.0;
  results()["ratio_frame_us_100m"] = 1e6 * small_s / n;
  results()["ratio_frame_us_10km"] = 1e6 * large_s / n;
  results()["ratio"] = large_s / small_s;
}

/// Edge start on consecutive route edges (what FollowRoute + ReplayFeatureEdge do at every node).
void BM_EdgeChange(benchmark::State& state, const MapSpec* spec) {
  cv::setNumThreads(1);
  std::unique_ptr<Rig> rig = rig_or_skip(state, *spec);
  if (!rig) return;
  std::size_t next = rig->position;
  double cpu_s = 0.0;
  const auto w0 = std::chrono::steady_clock::now();
  for (auto _ : state) {
    next = (next + 1) % rig->route.edge_ids.size();
    const double t0 = thread_cpu_s();
    rig->start_edge(rig->route.edge_ids[next], rig->origin_m + kEdgeLengthM);
    cpu_s += thread_cpu_s() - t0;
  }
  const double n = static_cast<double>(state.iterations());
  const double wall_ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count() / n;
  const double ms = 1e3 * cpu_s / n;
  const double frames_per_edge = kEdgeLengthM / kReplayFrameStepM;
  state.counters["ms_per_edge_change"] = ms;
  state.counters["wall_ms_per_edge_change"] = wall_ms;
  state.counters["amortised_us_per_frame"] = 1e3 * wall_ms / frames_per_edge;
  state.counters["payload_MB"] = static_cast<double>(rig->map.find_edge(rig->route.edge_ids[next])->payload_bytes) / 1e6;
  results()[std::string("edge_ms_") + spec->name] = ms;
  results()[std::string("edge_wall_ms_") + spec->name] = wall_ms;
}

/// Opens a generated map for a benchmark; skips the benchmark with the reason if that fails.
std::optional<visnav::MapStore> open_or_skip(benchmark::State& state, const MapSpec& spec) {
  auto m = visnav::MapStore::open(generated(spec));
  if (!m) {
    state.SkipWithError(m.error().message.c_str());
    return std::nullopt;
  }
  return std::move(*m);
}

void BM_PlanRoute(benchmark::State& state, const MapSpec* spec) {
  auto m = open_or_skip(state, *spec);
  if (!m) return;
  const std::string goal = numbered("n", spec->edges);
  for (auto _ : state) {
    auto r = visnav::plan_route(*m, "n0", goal);
    benchmark::DoNotOptimize(r);
  }
  state.counters["edges"] = static_cast<double>(m->edges().size());
}

void BM_OpenMap(benchmark::State& state, const MapSpec* spec) {
  const std::string& dir = generated(*spec);
  for (auto _ : state) {
    auto m = visnav::MapStore::open(dir);
    if (!m) {
      state.SkipWithError(m.error().message.c_str());
      return;
    }
    benchmark::DoNotOptimize(m);
  }
}

/// Graph queries a tree may make every tick: find_edge (FollowRoute) and resolve_node by name
/// (AtNode with a node name). Both should not grow with the map.
void BM_MapAccess(benchmark::State& state, const MapSpec* spec) {
  auto m = open_or_skip(state, *spec);
  if (!m) return;
  const std::string edge = numbered("e", spec->edges / 2);
  const std::string name = numbered("place ", spec->edges / 2);
  double find_s = 0.0, name_s = 0.0;
  constexpr int kCalls = 1000;  // per timed batch (thread CPU clock reads are syscalls)
  for (auto _ : state) {
    const double t0 = thread_cpu_s();
    for (int i = 0; i < kCalls; ++i) benchmark::DoNotOptimize(m->find_edge(edge));
    const double t1 = thread_cpu_s();
    for (int i = 0; i < kCalls; ++i) benchmark::DoNotOptimize(m->resolve_node(name));
    const double t2 = thread_cpu_s();
    find_s += t1 - t0;
    name_s += t2 - t1;
  }
  const double n = kCalls * static_cast<double>(state.iterations());
  state.counters["find_edge_ns"] = 1e9 * find_s / n;
  state.counters["resolve_node_by_name_ns"] = 1e9 * name_s / n;
  results()[std::string("find_edge_ns_") + spec->name] = 1e9 * find_s / n;
  results()[std::string("resolve_name_ns_") + spec->name] = 1e9 * name_s / n;
}

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);
  using benchmark::RegisterBenchmark;
  for (const MapSpec* s : {&k100m, &k10km})
    RegisterBenchmark((std::string("ReplayFrame/") + s->name).c_str(), BM_ReplayFrame, s)
        ->Unit(benchmark::kMicrosecond)->Iterations(2000);
  RegisterBenchmark("ReplayFrameRatio/10km_vs_100m", BM_ReplayFrameRatio)->Unit(benchmark::kMicrosecond)->Iterations(4000);
  for (const MapSpec* s : {&k100m, &k10km})
    RegisterBenchmark((std::string("EdgeChange/") + s->name).c_str(), BM_EdgeChange, s)
        ->Unit(benchmark::kMillisecond)->Iterations(60);
  for (const MapSpec* s : {&k100m, &k10km})
    RegisterBenchmark((std::string("PlanRoute/") + s->name).c_str(), BM_PlanRoute, s)->Unit(benchmark::kMicrosecond);
  for (const MapSpec* s : {&k100m, &k10km})
    RegisterBenchmark((std::string("MapAccess/") + s->name).c_str(), BM_MapAccess, s)->Unit(benchmark::kMicrosecond);
  for (const MapSpec* s : {&k100m, &k10km})
    RegisterBenchmark((std::string("OpenMap/") + s->name).c_str(), BM_OpenMap, s)->Unit(benchmark::kMillisecond);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  auto& r = results();
  auto get = [&](const char* k) { return r.count(k) != 0 ? r[k] : std::nan(""); };
  std::printf("\nsummary: per-frame replay (find_edge + local-map step, thread CPU): 100 m map %.1f us, 10 km map %.1f us, "
              "ratio %.3f (target <= 1.1) [separate runs: %.1f / %.1f us]\n",
              get("ratio_frame_us_100m"), get("ratio_frame_us_10km"), get("ratio"), get("frame_us_100m"), get("frame_us_10km"));
  std::printf("summary: edge change (find_edge + read_payload + deserialize + replayer): 100 m map %.2f ms, 10 km map %.2f ms "
              "(CPU; wall %.2f / %.2f ms), amortised over %.0f frames per %.0f m edge: %.1f / %.1f us per frame\n",
              get("edge_ms_100m"), get("edge_ms_10km"), get("edge_wall_ms_100m"), get("edge_wall_ms_10km"),
              kEdgeLengthM / kReplayFrameStepM, kEdgeLengthM, 1e3 * get("edge_wall_ms_100m") / (kEdgeLengthM / kReplayFrameStepM),
              1e3 * get("edge_wall_ms_10km") / (kEdgeLengthM / kReplayFrameStepM));
  std::printf("summary: map access per call: find_edge %.0f / %.0f ns, resolve_node by name %.0f / %.0f ns (100 m / 10 km)\n",
              get("find_edge_ns_100m"), get("find_edge_ns_10km"), get("resolve_name_ns_100m"), get("resolve_name_ns_10km"));
  return 0;
}
