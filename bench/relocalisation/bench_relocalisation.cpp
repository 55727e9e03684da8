// Query cost of the place index on synthetic maps of 1 km and 10 km (issue 21: <= 50 ms per
// query on 2 cores, growing sub-linearly with map length; index size per metre).
//
// A synthetic index has one place every 0.2 m (feature_localmaps' default spacing) with a code of
// 1024 bits, ~25 % set (a 300-feature frame hits ~260 words), and a vocabulary of 1024 random
// 32-byte words. A query is: code 300 descriptors (nearest word each), scan every code, verify the
// 12 nearest with histogram voting against 150 reference features each (what Relocalise does per
// frame; the verification does not depend on the map's length, the scan does). The figures are
// the Time (wall) and CPU columns, per query; the counters give the places and the index size.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "visnav/histogram_voting.hpp"
#include "visnav/relocalisation/place_index.hpp"

using namespace visnav;
using namespace visnav::reloc;

namespace {

constexpr double kSpacingM = 0.2;

cv::Mat random_rows(std::mt19937& rng, int rows, int cols) {
  cv::Mat m(rows, cols, CV_8UC1);
  std::uniform_int_distribution<int> b(0, 255);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) m.at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(b(rng));
  return m;
}

PlaceIndex synthetic_index(double length_m) {
  std::mt19937 rng(11);
  PlaceIndex index;
  index.params.vocabulary_words = 1024;
  index.edges.push_back({"e0", kLocalMapsKind, length_m, 0});
  index.vocabulary = random_rows(rng, 1024, 32);
  const auto places = static_cast<std::size_t>(length_m / kSpacingM);
  index.places.resize(places);
  index.codes.resize(places * 16);
  std::bernoulli_distribution bit(0.25);
  for (std::size_t p = 0; p < places; ++p) {
    index.places[p] = {0, static_cast<float>(p * kSpacingM)};
    for (int w = 0; w < 16; ++w) {
      std::uint64_t v = 0;
      for (int k = 0; k < 64; ++k) v |= static_cast<std::uint64_t>(bit(rng)) << k;
      index.codes[p * 16 + static_cast<std::size_t>(w)] = v;
    }
  }
  return index;
}

Features random_features(std::mt19937& rng, int n) {
  Features f;
  f.descriptors = random_rows(rng, n, 32);
  std::uniform_real_distribution<float> u(0.f, 320.f), v(0.f, 240.f);
  for (int i = 0; i < n; ++i) f.keypoints.emplace_back(cv::Point2f(u(rng), v(rng)), 7.f);
  return f;
}

void BM_ScanOnly(benchmark::State& state) {
  const double length_m = static_cast<double>(state.range(0));
  const PlaceIndex index = synthetic_index(length_m);
  std::vector<std::uint64_t> code(index.codes.begin(), index.codes.begin() + 16);
  std::vector<PlaceCandidate> hits;
  for (auto _ : state) {
    index.query(code, 12, hits);
    benchmark::DoNotOptimize(hits.data());
  }
  state.counters["places"] = static_cast<double>(index.places.size());
}

void BM_Query(benchmark::State& state) {
  const double length_m = static_cast<double>(state.range(0));
  const PlaceIndex index = synthetic_index(length_m);
  std::mt19937 rng(5);
  const Features frame = random_features(rng, 300);
  std::vector<Features> refs;
  for (int i = 0; i < 12; ++i) refs.push_back(random_features(rng, 150));
  std::vector<std::vector<cv::Point2f>> ref_px;
  for (const auto& r : refs) {
    ref_px.emplace_back();
    for (const auto& k : r.keypoints) ref_px.back().push_back(k.pt);
  }
  feature_replay::HeadingEstimator estimator;
  std::vector<std::uint64_t> code(16);
  std::vector<PlaceCandidate> hits;
  for (auto _ : state) {
    (void)index.encode(frame.descriptors, code);
    index.query(code, 12, hits);
    for (std::size_t i = 0; i < hits.size(); ++i) {
      auto e = estimator.estimate(feature_replay::ReferenceView{refs[i].descriptors, ref_px[i]}, frame, 320.0);
      benchmark::DoNotOptimize(e);
    }
  }
  const std::size_t bytes = index.byte_size();
  state.counters["places"] = static_cast<double>(index.places.size());
  state.counters["index_MB"] = static_cast<double>(bytes) / 1e6;
  state.counters["index_bytes_per_m"] = static_cast<double>(bytes) / length_m;
}

}  // namespace

/// Thumbnail places (path_following edges): `length_m` of path edge, one 64x24 thumbnail every
/// 0.5 m (the path teacher's spacing); a query compares one live thumbnail with the places within
/// +-30 deg of shift (PlaceIndex::query_thumbnails, what Relocalise does per frame). Arg 1: the
/// coarse candidates (0 = the exhaustive pass; 32 = Relocalise's default two-pass search). The
/// counter target_ratio is the CPU time per query over the 50 ms target (< 1: met).
void BM_ThumbnailScan(benchmark::State& state) {
  const double length_m = static_cast<double>(state.range(0));
  const int coarse_candidates = static_cast<int>(state.range(1));
  std::mt19937 rng(5);
  PlaceIndex index;
  index.edges.push_back({"p0", kPathKind, length_m, 0});
  index.thumbnail_width_px = 64;
  index.thumbnail_height_px = 24;
  const auto places = static_cast<std::size_t>(length_m / 0.5);
  for (std::size_t p = 0; p < places; ++p) {
    index.thumbnail_places.push_back({0, static_cast<float>(0.5 * static_cast<double>(p))});
    index.thumbnails.push_back(random_rows(rng, 24, 64));
  }
  index.prepare_thumbnails();
  const cv::Mat live = random_rows(rng, 24, 64);
  std::vector<ThumbnailHit> hits;
  for (auto _ : state) {
    index.query_thumbnails(live, 32, 3, 0.4, hits, coarse_candidates);
    benchmark::DoNotOptimize(hits.data());
  }
  state.counters["places"] = static_cast<double>(places);
  state.counters["bytes_per_m"] = static_cast<double>(index.byte_size()) / length_m;
  // (0.05 x iterations / CPU seconds) inverted: CPU seconds per query / 0.05 s.
  state.counters["target_ratio"] =
      benchmark::Counter(0.050, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

BENCHMARK(BM_ThumbnailScan)
    ->Args({100, 0})
    ->Args({1000, 0})
    ->Args({1000, 32})
    ->Args({10000, 32})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ScanOnly)->Arg(1000)->Arg(10000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Query)->Arg(1000)->Arg(10000)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
