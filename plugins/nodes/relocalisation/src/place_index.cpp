// The place index: vocabulary training (k-majority), place codes, Hamming lookup, file format.
#include "visnav/relocalisation/place_index.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <numbers>
#include <optional>
#include <random>

#include <opencv2/imgproc.hpp>

#include "visnav/feature_payloads.hpp"
#include "visnav/file_io.hpp"
#include "visnav/path_payload.hpp"
#include "visnav/visual_memory_payload.hpp"

namespace visnav::reloc {

namespace fs = std::filesystem;
using feature_replay::LocalMapPath;
using feature_replay::SegmentMap;

bool describable_kind(std::string_view kind) {
  return kind == kSegmentKind || kind == kLocalMapsKind || kind == kMemoryKind;
}

bool indexable_kind(std::string_view kind) { return describable_kind(kind) || kind == kPathKind; }

const ParamSchema<PlaceIndexParams>& PlaceIndexParams::schema() {
  using P = PlaceIndexParams;
  static const auto s =
      ParamSchema<P>{}
          .field("vocabulary_words", &P::vocabulary_words, "bits of a place code (words of the vocabulary); multiple of 64")
          .range(64, 8192)
          .field("segment_spacing_m", &P::segment_spacing_m, "place spacing along feature_segment edges, m")
          .range(0.05, 10.0)
          .field("vocabulary_sample", &P::vocabulary_sample, "descriptors sampled to train the vocabulary")
          .range(64, 1000000)
          .field("vocabulary_iterations", &P::vocabulary_iterations, "k-majority iterations")
          .range(1, 50);
  return s;
}

namespace {

/// Hamming distance of two descriptor rows of `bytes` bytes.
inline int hamming(const std::uint8_t* a, const std::uint8_t* b, int bytes) {
  int d = 0;
  int i = 0;
  for (; i + 8 <= bytes; i += 8) {
    std::uint64_t x, y;
    std::memcpy(&x, a + i, 8);
    std::memcpy(&y, b + i, 8);
    d += std::popcount(x ^ y);
  }
  for (; i < bytes; ++i) d += std::popcount(static_cast<unsigned>(a[i] ^ b[i]));
  return d;
}

/// Row of `vocabulary` nearest to `row`.
int nearest_word(const cv::Mat& vocabulary, const std::uint8_t* row) {
  int best = 0;
  int best_d = 1 << 30;
  for (int w = 0; w < vocabulary.rows; ++w) {
    const int d = hamming(vocabulary.ptr<std::uint8_t>(w), row, vocabulary.cols);
    if (d < best_d) {
      best_d = d;
      best = w;
    }
  }
  return best;
}

/// k-majority clustering of the rows of `sample` into `words` words (deterministic).
cv::Mat train_vocabulary(const cv::Mat& sample, int words, int iterations, const IndexProgress& progress) {
  const int bytes = sample.cols;
  cv::Mat vocabulary(words, bytes, CV_8UC1);
  // Initial words: evenly spaced sample rows (the sample is already a random draw).
  for (int w = 0; w < words; ++w) {
    const int r = static_cast<int>((static_cast<long long>(w) * sample.rows) / words);
    sample.row(r).copyTo(vocabulary.row(w));
  }
  std::vector<int> assignment(static_cast<std::size_t>(sample.rows), 0);
  std::vector<int> bit_counts(static_cast<std::size_t>(words) * static_cast<std::size_t>(bytes) * 8);
  std::vector<int> members(static_cast<std::size_t>(words));
  for (int it = 0; it < iterations; ++it) {
    if (progress) progress("vocabulary", it, iterations);
    std::fill(bit_counts.begin(), bit_counts.end(), 0);
    std::fill(members.begin(), members.end(), 0);
    for (int r = 0; r < sample.rows; ++r) {
      const std::uint8_t* row = sample.ptr<std::uint8_t>(r);
      const int w = nearest_word(vocabulary, row);
      assignment[static_cast<std::size_t>(r)] = w;
      ++members[static_cast<std::size_t>(w)];
      int* counts = bit_counts.data() + static_cast<std::size_t>(w) * static_cast<std::size_t>(bytes) * 8;
      for (int b = 0; b < bytes; ++b)
        for (int k = 0; k < 8; ++k) counts[b * 8 + k] += (row[b] >> k) & 1;
    }
    for (int w = 0; w < words; ++w) {
      const int n = members[static_cast<std::size_t>(w)];
      if (n == 0) continue;  // an empty word keeps its value
      const int* counts = bit_counts.data() + static_cast<std::size_t>(w) * static_cast<std::size_t>(bytes) * 8;
      std::uint8_t* out = vocabulary.ptr<std::uint8_t>(w);
      for (int b = 0; b < bytes; ++b) {
        std::uint8_t v = 0;
        for (int k = 0; k < 8; ++k)
          if (2 * counts[b * 8 + k] > n) v = static_cast<std::uint8_t>(v | (1u << k));
        out[b] = v;
      }
    }
  }
  if (progress) progress("vocabulary", iterations, iterations);
  return vocabulary;
}

Error index_error(const std::string& file, const std::string& what) {
  return fail(ErrorCode::parse_error, file + ": damaged place index: " + what +
                                          " (rebuild it with `visnav reloc-index MAP`)");
}

}  // namespace

// ------------------------------------------------------------------------------- PlaceIndex

Status PlaceIndex::encode(const cv::Mat& descriptors, std::span<std::uint64_t> out) const {
  std::fill(out.begin(), out.end(), 0);
  if (descriptors.empty()) return ok();
  if (descriptors.type() != CV_8UC1 || descriptors.cols != vocabulary.cols)
    return fail(ErrorCode::invalid_value, "place code: descriptors must be binary (CV_8UC1) rows of " +
                                              std::to_string(vocabulary.cols) + " bytes, got type " +
                                              std::to_string(descriptors.type()) + " with " +
                                              std::to_string(descriptors.cols) + " columns");
  for (int r = 0; r < descriptors.rows; ++r) {
    const int w = nearest_word(vocabulary, descriptors.ptr<std::uint8_t>(r));
    out[static_cast<std::size_t>(w / 64)] |= std::uint64_t{1} << (w % 64);
  }
  return ok();
}

bool PlaceIndex::covers(std::uint32_t edge) const {
  for (const auto& p : places)
    if (p.edge == edge) return true;
  for (const auto& p : thumbnail_places)
    if (p.edge == edge) return true;
  return false;
}

cv::Mat coarse_thumbnail(const cv::Mat& thumbnail_u8) {
  cv::Mat half;
  cv::resize(thumbnail_u8, half, cv::Size(std::max(1, thumbnail_u8.cols / 2), std::max(1, thumbnail_u8.rows / 2)), 0, 0,
             cv::INTER_AREA);
  return normalise_thumbnail(half);
}

int signature_dims(int height_px) {
  return kSignatureBands * (kSignatureFrequencies + kSignatureColumns) + std::max(0, height_px);
}

void thumbnail_signatures(const cv::Mat& thumbnail_u8, bool stored, std::vector<float>& out) {
  const int w = thumbnail_u8.cols;
  const int h = thumbnail_u8.rows;
  const auto dims = static_cast<std::size_t>(signature_dims(h));
  const int windows = stored ? kStoredWindows : kLiveWindows;
  const std::size_t first = out.size();
  out.resize(first + static_cast<std::size_t>(windows) * dims, 0.0f);
  if (w < 8 || h < 4) return;
  const int ww = w / 2;  // window width
  const cv::Mat n = normalise_thumbnail(thumbnail_u8);
  cv::Mat raw;
  thumbnail_u8.convertTo(raw, CV_32F);
  std::vector<float> cos_t(static_cast<std::size_t>(kSignatureFrequencies * ww));
  std::vector<float> sin_t(cos_t.size());
  for (int k = 0; k < kSignatureFrequencies; ++k)
    for (int x = 0; x < ww; ++x) {
      const double a = 2.0 * std::numbers::pi * (k + 1) * x / ww;
      cos_t[static_cast<std::size_t>(k * ww + x)] = static_cast<float>(std::cos(a));
      sin_t[static_cast<std::size_t>(k * ww + x)] = static_cast<float>(std::sin(a));
    }
  const std::size_t spectrum = static_cast<std::size_t>(kSignatureBands * kSignatureFrequencies);
  const std::size_t blocks = static_cast<std::size_t>(kSignatureBands * kSignatureColumns);
  auto unit = [](float* v, std::size_t len, float scale, bool centre) {
    if (centre) {
      double m = 0.0;
      for (std::size_t i = 0; i < len; ++i) m += v[i];
      m /= static_cast<double>(len);
      for (std::size_t i = 0; i < len; ++i) v[i] -= static_cast<float>(m);
    }
    double sq = 0.0;
    for (std::size_t i = 0; i < len; ++i) sq += static_cast<double>(v[i]) * v[i];
    const float f = sq > 1e-12 ? static_cast<float>(scale / std::sqrt(sq)) : 0.0f;
    for (std::size_t i = 0; i < len; ++i) v[i] *= f;
  };
  for (int win = 0; win < windows; ++win) {
    // Stored windows 1/8 of the width apart, live ones 1/4 (both from the left edge to the right).
    const int x0 = (w - ww) * win / (windows - 1);
    float* v = out.data() + first + static_cast<std::size_t>(win) * dims;
    for (int y = 0; y < h; ++y) {
      const int band = std::min(kSignatureBands - 1, y * kSignatureBands / h);
      const float* nrow = n.ptr<float>(y) + x0;
      const float* rrow = raw.ptr<float>(y) + x0;
      for (int k = 0; k < kSignatureFrequencies; ++k) {
        float re = 0.0f, im = 0.0f;
        const float* c = cos_t.data() + static_cast<std::size_t>(k * ww);
        const float* sn = sin_t.data() + static_cast<std::size_t>(k * ww);
        for (int x = 0; x < ww; ++x) {
          re += nrow[x] * c[x];
          im += nrow[x] * sn[x];
        }
        v[band * kSignatureFrequencies + k] += std::sqrt(std::sqrt(re * re + im * im));
      }
      float row_sum = 0.0f;
      for (int x = 0; x < ww; ++x) {
        row_sum += rrow[x];
        v[spectrum + static_cast<std::size_t>(band * kSignatureColumns + x * kSignatureColumns / ww)] += rrow[x];
      }
      v[spectrum + blocks + static_cast<std::size_t>(y)] = row_sum / static_cast<float>(ww);
    }
    unit(v, spectrum, 1.0f, false);
    unit(v + spectrum, blocks, kSignatureBlockWeight, true);
    unit(v + spectrum + blocks, static_cast<std::size_t>(h), kSignatureProfileWeight, true);
  }
}

namespace {

float squared_distance(const float* a, const float* b, std::size_t n) {
  float d = 0.0f;
  for (std::size_t i = 0; i < n; ++i) {
    const float t = a[i] - b[i];
    d += t * t;
  }
  return d;
}

/// Index of the centroid nearest to `x`.
std::uint32_t nearest_cell(const float* x, const std::vector<float>& centroids, std::size_t dims) {
  std::uint32_t best = 0;
  float best_d = std::numeric_limits<float>::max();
  for (std::size_t c = 0; c * dims < centroids.size(); ++c) {
    const float d = squared_distance(x, centroids.data() + c * dims, dims);
    if (d < best_d) {
      best_d = d;
      best = static_cast<std::uint32_t>(c);
    }
  }
  return best;
}

/// k-means (Lloyd) of `n` vectors of `dims` floats into `cells` centroids, deterministic: trained
/// on at most kCellTrainingVectors evenly spaced vectors, the initial centroids evenly spaced
/// among them; an empty cell keeps its centroid. Returns the centroids; `assignment` receives
/// every vector's nearest cell.
constexpr std::size_t kCellTrainingVectors = 16384;
std::vector<float> train_cells(const std::vector<float>& all, std::size_t total, std::size_t dims, std::size_t cells,
                               int iterations, std::vector<std::uint32_t>& final_assignment) {
  const std::size_t n = std::min(total, kCellTrainingVectors);
  std::vector<float> vectors(n * dims);
  for (std::size_t i = 0; i < n; ++i) std::copy_n(all.data() + (i * total / n) * dims, dims, vectors.data() + i * dims);
  std::vector<float> centroids(cells * dims);
  for (std::size_t c = 0; c < cells; ++c) {
    const std::size_t v = c * n / cells;
    std::copy_n(vectors.data() + v * dims, dims, centroids.data() + c * dims);
  }
  std::vector<std::uint32_t> assignment(n, 0);
  std::vector<double> sums(cells * dims);
  std::vector<std::size_t> counts(cells);
  for (int it = 0; it < iterations; ++it) {
    for (std::size_t v = 0; v < n; ++v) assignment[v] = nearest_cell(vectors.data() + v * dims, centroids, dims);
    std::fill(sums.begin(), sums.end(), 0.0);
    std::fill(counts.begin(), counts.end(), 0);
    for (std::size_t v = 0; v < n; ++v) {
      const std::size_t c = assignment[v];
      ++counts[c];
      for (std::size_t i = 0; i < dims; ++i) sums[c * dims + i] += vectors[v * dims + i];
    }
    for (std::size_t c = 0; c < cells; ++c)
      if (counts[c] > 0)
        for (std::size_t i = 0; i < dims; ++i)
          centroids[c * dims + i] = static_cast<float>(sums[c * dims + i] / static_cast<double>(counts[c]));
  }
  final_assignment.resize(total);
  for (std::size_t v = 0; v < total; ++v) final_assignment[v] = nearest_cell(all.data() + v * dims, centroids, dims);
  return centroids;
}

constexpr int kCellIterations = 8;

}  // namespace

void PlaceIndex::prepare_thumbnails() {
  normalised.clear();
  coarse.clear();
  normalised.reserve(thumbnails.size());
  coarse.reserve(thumbnails.size());
  for (const cv::Mat& t : thumbnails) {
    normalised.push_back(normalise_thumbnail(t));
    coarse.push_back(coarse_thumbnail(t));
  }
  const std::size_t n = thumbnails.size();
  const std::size_t vectors = n * kStoredWindows;
  const auto dims = static_cast<std::size_t>(signature_dims(thumbnail_height_px));
  signatures.clear();
  signatures.reserve(vectors * dims);
  for (std::size_t p = 0; p < n; ++p) thumbnail_signatures(thumbnails[p], true, signatures);
  if (n == 0) {
    thumbnail_centroids.clear();
    thumbnail_cell.clear();
    cell_members.clear();
    return;
  }
  if (thumbnail_cell.size() != vectors || thumbnail_centroids.empty() || thumbnail_centroids.size() % dims != 0) {
    const auto cells =
        std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(std::sqrt(static_cast<double>(vectors)))));
    thumbnail_centroids = train_cells(signatures, vectors, dims, cells, kCellIterations, thumbnail_cell);
  }
  cell_members.assign(thumbnail_centroids.size() / dims, {});
  for (std::size_t v = 0; v < vectors; ++v) cell_members[thumbnail_cell[v]].push_back(static_cast<std::uint32_t>(v));
}

std::size_t PlaceIndex::thumbnail_cells() const { return cell_members.size(); }

void PlaceIndex::thumbnail_first_stage(const cv::Mat& live_u8, int count, std::vector<std::uint32_t>& out,
                                       double probe) const {
  out.clear();
  const std::size_t n = thumbnails.size();
  if (count <= 0 || n == 0 || live_u8.cols != thumbnail_width_px || live_u8.rows != thumbnail_height_px) return;
  if (static_cast<std::size_t>(count) >= n || cell_members.empty()) {
    for (std::size_t p = 0; p < n; ++p) out.push_back(static_cast<std::uint32_t>(p));
    return;
  }
  const auto dims = static_cast<std::size_t>(signature_dims(thumbnail_height_px));
  std::vector<float> live;
  thumbnail_signatures(live_u8, false, live);
  std::vector<std::pair<float, std::uint32_t>> cells(cell_members.size());
  std::vector<std::pair<float, std::uint32_t>> near;  // (distance, place)
  const auto wanted = static_cast<std::size_t>(std::max(1.0, probe * count));
  for (int win = 0; win < kLiveWindows; ++win) {
    const float* q = live.data() + static_cast<std::size_t>(win) * dims;
    for (std::size_t c = 0; c < cells.size(); ++c)
      cells[c] = {squared_distance(q, thumbnail_centroids.data() + c * dims, dims), static_cast<std::uint32_t>(c)};
    std::sort(cells.begin(), cells.end());
    std::size_t visited = 0;
    for (const auto& [d, c] : cells) {
      for (std::uint32_t v : cell_members[c])
        near.emplace_back(squared_distance(q, signatures.data() + static_cast<std::size_t>(v) * dims, dims),
                          v / kStoredWindows);
      visited += cell_members[c].size();
      if (visited >= wanted) break;
    }
  }
  // Each place at its nearest pair, then the count nearest places.
  std::sort(near.begin(), near.end(), [](const auto& a, const auto& b) {
    return a.second != b.second ? a.second < b.second : a.first < b.first;
  });
  near.erase(std::unique(near.begin(), near.end(), [](const auto& a, const auto& b) { return a.second == b.second; }),
             near.end());
  const auto keep = std::min(near.size(), static_cast<std::size_t>(count));
  std::partial_sort(near.begin(), near.begin() + static_cast<std::ptrdiff_t>(keep), near.end());
  for (std::size_t i = 0; i < keep; ++i) out.push_back(near[i].second);
}

void PlaceIndex::query_thumbnails(const cv::Mat& live_u8, int max_shift_px, int k, double min_ncc,
                                  std::vector<ThumbnailHit>& out, int coarse_candidates, int index_candidates) const {
  out.clear();
  if (k <= 0 || live_u8.empty() || live_u8.cols != thumbnail_width_px || live_u8.rows != thumbnail_height_px) return;
  // The places searched: all, or the first stage's (inverted file over the signatures).
  std::vector<std::uint32_t> searched;
  if (index_candidates > 0 && static_cast<std::size_t>(index_candidates) < normalised.size())
    thumbnail_first_stage(live_u8, index_candidates, searched);
  else
    for (std::size_t p = 0; p < normalised.size(); ++p) searched.push_back(static_cast<std::uint32_t>(p));
  const cv::Mat live = normalise_thumbnail(live_u8);
  auto best_shift = [](const cv::Mat& a, const cv::Mat& b, int from, int to, std::uint32_t p) {
    ThumbnailHit best{p, -1.0, 0};
    for (int s = from; s <= to; ++s) {
      const double c = thumbnail_ncc(a, b, s);
      if (c > best.ncc) best = {p, c, s};
    }
    return best;
  };
  const bool two_pass = coarse_candidates > 0 && searched.size() > static_cast<std::size_t>(coarse_candidates) &&
                        coarse.size() == normalised.size();
  if (!two_pass) {
    for (std::uint32_t p : searched) {
      ThumbnailHit best = best_shift(live, normalised[p], -max_shift_px, max_shift_px, p);
      if (best.ncc >= min_ncc) out.push_back(best);
    }
  } else {
    // Coarse pass at half resolution (a quarter of the pixels, half the shifts): every place at
    // its best coarse shift; then the coarse_candidates best are searched at full resolution
    // within +-2 px of twice their coarse shift (the coarse peak is 2 px wide at full scale).
    const cv::Mat live_coarse = coarse_thumbnail(live_u8);
    const int coarse_shift = (max_shift_px + 1) / 2;
    std::vector<ThumbnailHit> rough(searched.size());
    for (std::size_t i = 0; i < searched.size(); ++i)
      rough[i] = best_shift(live_coarse, coarse[searched[i]], -coarse_shift, coarse_shift, searched[i]);
    const auto keep = static_cast<std::ptrdiff_t>(coarse_candidates);
    std::partial_sort(rough.begin(), rough.begin() + keep, rough.end(),
                      [](const ThumbnailHit& a, const ThumbnailHit& b) { return a.ncc > b.ncc; });
    for (std::ptrdiff_t i = 0; i < keep; ++i) {
      const ThumbnailHit& r = rough[static_cast<std::size_t>(i)];
      const int from = std::max(-max_shift_px, 2 * r.shift_px - 2);
      const int to = std::min(max_shift_px, 2 * r.shift_px + 2);
      ThumbnailHit best = best_shift(live, normalised[r.place], from, to, r.place);
      if (best.ncc >= min_ncc) out.push_back(best);
    }
  }
  const auto keep = std::min<std::size_t>(static_cast<std::size_t>(k), out.size());
  std::partial_sort(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(keep), out.end(),
                    [](const ThumbnailHit& a, const ThumbnailHit& b) {
                      return a.ncc != b.ncc ? a.ncc > b.ncc : a.place < b.place;
                    });
  out.resize(keep);
}

void PlaceIndex::query(std::span<const std::uint64_t> q, int k, std::vector<PlaceCandidate>& out) const {
  out.clear();
  const std::size_t w = static_cast<std::size_t>(code_words());
  if (k <= 0 || places.empty() || q.size() != w) return;
  out.resize(places.size());
  const std::uint64_t* c = codes.data();
  for (std::size_t p = 0; p < places.size(); ++p, c += w) {
    int d = 0;
    for (std::size_t i = 0; i < w; ++i) d += std::popcount(c[i] ^ q[i]);
    out[p] = PlaceCandidate{static_cast<std::uint32_t>(p), d};
  }
  const auto keep = std::min<std::size_t>(static_cast<std::size_t>(k), out.size());
  std::partial_sort(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(keep), out.end(),
                    [](const PlaceCandidate& a, const PlaceCandidate& b) {
                      return a.hamming != b.hamming ? a.hamming < b.hamming : a.place < b.place;
                    });
  out.resize(keep);
}

std::vector<std::uint8_t> PlaceIndex::serialize() const {
  PayloadWriter body;
  body.put<std::int32_t>(params.vocabulary_words);
  body.put<double>(params.segment_spacing_m);
  body.put<std::int32_t>(params.vocabulary_sample);
  body.put<std::int32_t>(params.vocabulary_iterations);
  body.put<std::uint32_t>(static_cast<std::uint32_t>(edges.size()));
  for (const auto& e : edges) {
    body.put_string(e.id);
    body.put_string(e.kind);
    body.put<double>(e.length_m);
    body.put<std::uint64_t>(e.payload_bytes);
  }
  body.put<std::int32_t>(vocabulary.cols);
  body.put_bytes({vocabulary.data, vocabulary.total()});
  body.put<std::uint32_t>(static_cast<std::uint32_t>(places.size()));
  for (const auto& p : places) {
    body.put<std::uint32_t>(p.edge);
    body.put<float>(p.distance_m);
  }
  for (std::uint64_t c : codes) body.put<std::uint64_t>(c);
  // Version 2: the detector and the thumbnail places.
  body.put_string(detector);
  body.put<std::int32_t>(thumbnail_width_px);
  body.put<std::int32_t>(thumbnail_height_px);
  body.put<std::uint32_t>(static_cast<std::uint32_t>(thumbnail_places.size()));
  for (std::size_t i = 0; i < thumbnail_places.size(); ++i) {
    body.put<std::uint32_t>(thumbnail_places[i].edge);
    body.put<float>(thumbnail_places[i].distance_m);
    const cv::Mat t = thumbnails[i].isContinuous() ? thumbnails[i] : thumbnails[i].clone();
    body.put_bytes({t.data, t.total()});
  }
  // Version 3: the first stage's inverted file (cells of the thumbnail signatures).
  const auto dims = static_cast<std::uint32_t>(signature_dims(thumbnail_height_px));
  const auto cells = static_cast<std::uint32_t>(thumbnail_places.empty() ? 0 : thumbnail_centroids.size() / dims);
  body.put<std::uint32_t>(dims);
  body.put<std::uint32_t>(cells);
  for (std::size_t i = 0; i < static_cast<std::size_t>(cells) * dims; ++i) body.put<float>(thumbnail_centroids[i]);
  if (cells > 0)
    for (std::uint32_t c : thumbnail_cell) body.put<std::uint32_t>(c);  // kStoredWindows per place
  const std::vector<std::uint8_t>& b = body.bytes();
  PayloadWriter file;
  for (char ch : kIndexMagic) file.put<std::uint8_t>(static_cast<std::uint8_t>(ch));
  file.put<std::uint32_t>(kIndexVersion);
  file.put<std::uint32_t>(map_format::crc32(b));
  file.put<std::uint64_t>(b.size());
  std::vector<std::uint8_t> out = file.take();
  out.insert(out.end(), b.begin(), b.end());
  return out;
}

namespace {

/// The body of an index file, after the header checks (magic, version, length, checksum);
/// `version_out` is the file's format version.
Result<std::span<const std::uint8_t>> checked_body(std::span<const std::uint8_t> file, const std::string& name,
                                                   std::uint32_t& version_out) {
  constexpr std::size_t kHeader = 8 + 4 + 4 + 8;
  if (file.size() < kHeader)
    return index_error(name, "truncated header (" + std::to_string(file.size()) + " bytes)");
  if (std::memcmp(file.data(), kIndexMagic, 8) != 0) return index_error(name, "not a place index (bad magic)");
  PayloadReader head(file.subspan(8, kHeader - 8));
  const auto version = head.get<std::uint32_t>();
  const auto crc = head.get<std::uint32_t>();
  const auto length = head.get<std::uint64_t>();
  if (!version || !crc || !length) return index_error(name, "truncated header");
  if (*version < 1 || *version > kIndexVersion)
    return index_error(name, "format version " + std::to_string(*version) + ", this build reads 1 to " +
                                 std::to_string(kIndexVersion));
  if (*length != file.size() - kHeader)
    return index_error(name, "body length " + std::to_string(*length) + " bytes, file holds " +
                                 std::to_string(file.size() - kHeader));
  const auto body = file.subspan(kHeader);
  if (const std::uint32_t computed = map_format::crc32(body); computed != *crc) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "checksum mismatch (stored 0x%08x, computed 0x%08x)", *crc, computed);
    return index_error(name, buf);
  }
  version_out = *version;
  return body;
}

/// Version 1: the parameters, the edge table, the vocabulary, the places and their codes.
Status read_places(PayloadReader& r, PlaceIndex& index, std::uint32_t version, const std::string& name) {
  auto bad = [&](const std::string& what) { return index_error(name, what); };
  auto words = r.get<std::int32_t>();
  auto spacing = r.get<double>();
  auto sample = r.get<std::int32_t>();
  auto iterations = r.get<std::int32_t>();
  if (!words || !spacing || !sample || !iterations) return bad("truncated parameters");
  index.params = {*words, *spacing, *sample, *iterations};
  if (auto st = index.params.validate(); !st || *words % 64 != 0) return bad("invalid parameters");
  auto edge_count = r.get<std::uint32_t>();
  if (!edge_count || *edge_count > r.remaining()) return bad("edge table");
  for (std::uint32_t i = 0; i < *edge_count; ++i) {
    IndexedEdge e;
    auto id = r.get_string();
    auto kind = r.get_string();
    auto len = r.get<double>();
    auto bytes = r.get<std::uint64_t>();
    if (!id || !kind || !len || !bytes) return bad("edge table entry " + std::to_string(i));
    index.edges.push_back({*id, *kind, *len, *bytes});
  }
  auto cols = r.get<std::int32_t>();
  auto vocab = r.get_bytes();
  if (!cols || !vocab || *cols <= 0 || *cols > 1024 ||
      vocab->size() != static_cast<std::size_t>(*cols) * static_cast<std::size_t>(*words))
    return bad("vocabulary");
  index.vocabulary = cv::Mat(*words, *cols, CV_8UC1);
  std::memcpy(index.vocabulary.data, vocab->data(), vocab->size());
  auto place_count = r.get<std::uint32_t>();
  if (!place_count) return bad("place count");
  const std::size_t w = static_cast<std::size_t>(index.code_words());
  const std::size_t table = static_cast<std::size_t>(*place_count) * (8 + 8 * w);
  if (version == 1 ? table != r.remaining() : table > r.remaining()) return bad("place table size");
  index.places.resize(*place_count);
  for (auto& p : index.places) {
    auto e = r.get<std::uint32_t>();
    auto d = r.get<float>();
    if (!e || !d || *e >= index.edges.size() || !std::isfinite(*d)) return bad("place entry");
    p = PlaceRef{*e, *d};
  }
  index.codes.resize(index.places.size() * w);
  for (auto& c : index.codes) {
    auto v = r.get<std::uint64_t>();
    if (!v) return bad("codes");
    c = *v;
  }
  return ok();
}

/// Version 2: the detector and the thumbnail places; `thumb_count_out` is how many.
Status read_thumbnails(PayloadReader& r, PlaceIndex& index, const std::string& name, std::uint32_t& thumb_count_out) {
  auto bad = [&](const std::string& what) { return index_error(name, what); };
  auto det = r.get_string();
  auto tw = r.get<std::int32_t>();
  auto th = r.get<std::int32_t>();
  auto thumb_count = r.get<std::uint32_t>();
  if (!det || !tw || !th || !thumb_count) return bad("thumbnail header");
  index.detector = *det;
  if (*thumb_count > 0 && (*tw < 8 || *th < 4 || *tw > 512 || *th > 512)) return bad("thumbnail size");
  index.thumbnail_width_px = *tw;
  index.thumbnail_height_px = *th;
  if (*thumb_count > r.remaining()) return bad("thumbnail count");
  for (std::uint32_t i = 0; i < *thumb_count; ++i) {
    auto e = r.get<std::uint32_t>();
    auto d = r.get<float>();
    auto px = r.get_bytes();
    if (!e || !d || !px || *e >= index.edges.size() || !std::isfinite(*d) ||
        px->size() != static_cast<std::size_t>(*tw) * static_cast<std::size_t>(*th))
      return bad("thumbnail place " + std::to_string(i));
    index.thumbnail_places.push_back({*e, *d});
    cv::Mat t(*th, *tw, CV_8UC1);
    std::memcpy(t.data, px->data(), px->size());
    index.thumbnails.push_back(std::move(t));
  }
  thumb_count_out = *thumb_count;
  return ok();
}

/// Version 3: the inverted file of the `thumb_count` thumbnail places (thumbnails of height th).
Status read_thumbnail_cells(PayloadReader& r, PlaceIndex& index, const std::string& name, std::uint32_t thumb_count,
                            std::int32_t th) {
  auto bad = [&](const std::string& what) { return index_error(name, what); };
  auto dims = r.get<std::uint32_t>();
  auto cells = r.get<std::uint32_t>();
  if (!dims || !cells) return bad("thumbnail cells header");
  const bool none = thumb_count == 0;
  const std::size_t vectors = static_cast<std::size_t>(thumb_count) * kStoredWindows;
  if (none ? *cells != 0
           : (*dims != static_cast<std::uint32_t>(signature_dims(th)) || *cells == 0 || *cells > vectors))
    return bad("thumbnail cells: " + std::to_string(*cells) + " cells of " + std::to_string(*dims) +
               " dimensions for " + std::to_string(thumb_count) + " thumbnail places");
  const std::size_t floats = static_cast<std::size_t>(*cells) * *dims;
  if (floats * 4 + vectors * 4 != r.remaining()) return bad("thumbnail cells size");
  index.thumbnail_centroids.resize(floats);
  for (float& f : index.thumbnail_centroids) {
    auto v = r.get<float>();
    if (!v || !std::isfinite(*v)) return bad("thumbnail cell centroid");
    f = *v;
  }
  if (!none) {
    index.thumbnail_cell.resize(vectors);
    for (std::uint32_t& c : index.thumbnail_cell) {
      auto v = r.get<std::uint32_t>();
      if (!v || *v >= *cells) return bad("thumbnail cell of a place");
      c = *v;
    }
  }
  return ok();
}

}  // namespace

Result<PlaceIndex> PlaceIndex::deserialize(std::span<const std::uint8_t> file, const std::string& name) {
  std::uint32_t version = 0;
  auto body = checked_body(file, name, version);
  if (!body) return body.error();
  // The checksum matched: what follows fails only on a file written by a broken writer.
  PayloadReader r(*body);
  PlaceIndex index;
  if (auto st = read_places(r, index, version, name); !st) return st.error();
  if (version == 1) return index;
  std::uint32_t thumb_count = 0;
  if (auto st = read_thumbnails(r, index, name, thumb_count); !st) return st.error();
  if (version >= 3) {
    // The inverted file; a version-2 index has none: prepare_thumbnails trains it at load.
    if (auto st = read_thumbnail_cells(r, index, name, thumb_count, index.thumbnail_height_px); !st) return st.error();
  }
  if (!r.at_end()) return index_error(name, "trailing bytes");
  index.prepare_thumbnails();
  return index;
}

Status PlaceIndex::matches(const MapStore& map) const {
  std::vector<const EdgeRecord*> wanted;
  for (const auto& e : map.edges())
    if (indexable_kind(e.kind)) wanted.push_back(&e);
  const std::string file = index_path(map.dir());
  auto stale = [&](const std::string& what) {
    return fail(ErrorCode::inconsistent, file + ": stale place index: " + what +
                                             " since it was built (rebuild it with `visnav reloc-index " + map.dir() +
                                             "`)");
  };
  for (const EdgeRecord* e : wanted) {
    auto it = std::find_if(edges.begin(), edges.end(), [&](const IndexedEdge& x) { return x.id == e->id; });
    if (it == edges.end()) return stale("edge " + e->id + " was added");
    if (it->kind != e->kind || it->payload_bytes != e->payload_bytes) return stale("edge " + e->id + " changed");
  }
  for (const auto& x : edges)
    if (map.find_edge(x.id) == nullptr) return stale("edge " + x.id + " was removed");
  return ok();
}

std::size_t PlaceIndex::byte_size() const { return serialize().size(); }

// ------------------------------------------------------------------------------ PlaceSource

struct PlaceSource::Decoded {
  std::optional<SegmentMap> segment;
  std::optional<LocalMapPath> localmaps;
  /// visual_memory: one place per reference image, described with the detector (sorted by distance).
  std::vector<float> memory_distances;
  std::vector<PlaceFeatures> memory;
};

Result<const PlaceSource::Decoded*> PlaceSource::decode(const EdgeRecord& edge) {
  if (auto it = cache_.find(edge.id); it != cache_.end()) return it->second.get();
  if (!indexable_kind(edge.kind))
    return fail(ErrorCode::invalid_value, "edge " + edge.id + ": kind '" + edge.kind + "' has no feature places");
  VISNAV_ASSIGN(std::vector<std::uint8_t> body, map_.read_payload(edge.id));
  auto decoded = std::make_shared<Decoded>();
  if (edge.kind == kMemoryKind) {
    // The payload keeps images and tracked corners, no descriptors: describe each reference image
    // with the detector Relocalise runs with, so its frames and the references share one vocabulary.
    if (detector_ == nullptr)
      return fail(ErrorCode::invalid_value, "edge " + edge.id +
                                                ": a visual_memory edge is indexed by describing its reference "
                                                "images, which needs a detector (`visnav reloc-index MAP --detector "
                                                "TYPE`, or the run's detector: section)");
    auto m = visual_memory::VisualMemory::decode(body);
    if (!m) return m.error().with_context(map_.payload_path(edge.id));
    Features features;
    for (std::size_t k = 0; k < m->references.size(); ++k) {
      const auto& ref = m->references[k];
      if (auto st = detector_->detect(ref.image, features); !st)
        return st.error().with_context("edge " + edge.id + " reference " + std::to_string(k));
      PlaceFeatures f;
      if (!features.descriptors.empty() && features.descriptors.type() != CV_8UC1)
        return fail(ErrorCode::invalid_value, "edge " + edge.id + ": the detector gives float descriptors, which cannot be indexed");
      f.descriptors = features.descriptors.clone();
      f.positions_px.reserve(features.keypoints.size());
      for (const auto& kp : features.keypoints) f.positions_px.push_back(kp.pt);
      if (f.positions_px.size() != static_cast<std::size_t>(f.descriptors.rows))
        return fail(ErrorCode::inconsistent, "edge " + edge.id + ": the detector gave " +
                                                 std::to_string(f.positions_px.size()) + " keypoints and " +
                                                 std::to_string(f.descriptors.rows) + " descriptors");
      decoded->memory_distances.push_back(static_cast<float>(ref.distance_m));
      decoded->memory.push_back(std::move(f));
    }
  } else if (edge.kind == kSegmentKind) {
    auto m = SegmentMap::deserialize(body);
    if (!m) return m.error().with_context(map_.payload_path(edge.id));
    decoded->segment = std::move(*m);
  } else {
    auto m = LocalMapPath::deserialize(body);
    if (!m) return m.error().with_context(map_.payload_path(edge.id));
    decoded->localmaps = std::move(*m);
  }
  const Decoded* raw = decoded.get();
  cache_.emplace(edge.id, std::move(decoded));
  return raw;
}

Result<std::vector<float>> PlaceSource::place_distances(const EdgeRecord& edge, double segment_spacing_m) {
  VISNAV_ASSIGN(const Decoded* d, decode(edge));
  std::vector<float> out;
  if (!d->memory_distances.empty() || (!d->segment && !d->localmaps)) return d->memory_distances;
  if (d->localmaps) {
    for (const auto& m : d->localmaps->maps) out.push_back(static_cast<float>(m.distance_m));
    return out;
  }
  const double length_m = std::max(0.0, d->segment->length_m);
  const int n = static_cast<int>(std::floor(length_m / segment_spacing_m)) + 1;
  for (int i = 0; i < n; ++i) out.push_back(static_cast<float>(i * segment_spacing_m));
  return out;
}

Result<const PlaceFeatures*> PlaceSource::features(const std::string& edge_id, double distance_m) {
  const EdgeRecord* edge = map_.find_edge(edge_id);
  if (edge == nullptr) return fail(ErrorCode::not_found, "place: unknown edge '" + edge_id + "'");
  VISNAV_ASSIGN(const Decoded* d, decode(*edge));
  scratch_.positions_px.clear();
  if (!d->segment && !d->localmaps) {  // visual_memory: the reference nearest distance_m
    if (d->memory.empty()) {
      scratch_.descriptors.release();
      return &scratch_;
    }
    const auto& ds = d->memory_distances;
    auto it = std::lower_bound(ds.begin(), ds.end(), static_cast<float>(distance_m));
    std::size_t i = static_cast<std::size_t>(it - ds.begin());
    if (i == ds.size() || (i > 0 && distance_m - ds[i - 1] < ds[i] - distance_m)) --i;
    return &d->memory[i];
  }
  if (d->localmaps) {
    const int i = d->localmaps->nearest_map(distance_m);
    if (i < 0) {
      scratch_.descriptors.release();
      return &scratch_;
    }
    const auto& m = d->localmaps->maps[static_cast<std::size_t>(i)];
    if (m.descriptors.type() != CV_8UC1)
      return fail(ErrorCode::invalid_value, "edge " + edge_id + ": float descriptors cannot be indexed");
    scratch_.descriptors = m.descriptors;
    scratch_.positions_px = m.positions_px;
    return &scratch_;
  }
  const SegmentMap& s = *d->segment;
  if (!s.descriptors.empty() && s.descriptors.type() != CV_8UC1)
    return fail(ErrorCode::invalid_value, "edge " + edge_id + ": float descriptors cannot be indexed");
  // Landmarks seen at this distance when teaching (f <= d <= g), at their expected positions.
  std::vector<int> rows;
  const auto end = std::upper_bound(s.landmarks.begin(), s.landmarks.end(), distance_m,
                                    [](double v, const feature_replay::Landmark& l) { return v < l.first_distance_m; });
  for (auto it = s.landmarks.begin(); it != end; ++it)
    if (it->last_distance_m >= distance_m) {
      rows.push_back(static_cast<int>(it - s.landmarks.begin()));
      scratch_.positions_px.push_back(it->expected_px(distance_m));
    }
  scratch_.descriptors.create(static_cast<int>(rows.size()), s.descriptors.cols, CV_8UC1);
  for (std::size_t i = 0; i < rows.size(); ++i) s.descriptors.row(rows[i]).copyTo(scratch_.descriptors.row(static_cast<int>(i)));
  return &scratch_;
}

// ----------------------------------------------------------------------------------- build

Result<PlaceIndex> build_place_index(const MapStore& map, const PlaceIndexParams& params, Detector* detector,
                                     const IndexProgress& progress, const std::string& detector_type) {
  VISNAV_TRY(params.validate());
  if (params.vocabulary_words % 64 != 0)
    return fail(ErrorCode::out_of_range, "vocabulary_words: " + std::to_string(params.vocabulary_words) +
                                             " is not a multiple of 64");
  PlaceIndex index;
  index.params = params;
  PlaceSource source(map, detector);
  // Pass 1: the places and a deterministic reservoir sample of their descriptors.
  std::mt19937_64 rng(0x5eed1dcULL);
  cv::Mat sample;
  long long seen = 0;
  int cols = -1;
  std::vector<const EdgeRecord*> edges;
  for (const auto& e : map.edges())
    if (indexable_kind(e.kind)) edges.push_back(&e);
  if (std::none_of(edges.begin(), edges.end(), [](const EdgeRecord* e) { return describable_kind(e->kind); }))
    return fail(ErrorCode::not_found,
                map.dir() + ": no edge to index (the index needs feature_segment, feature_localmaps or visual_memory "
                            "edges; path_following thumbnails are indexed beside them)");
  for (std::size_t ei = 0; ei < edges.size(); ++ei) {
    const EdgeRecord& e = *edges[ei];
    if (progress) progress("places", static_cast<double>(ei), static_cast<double>(edges.size()));
    index.edges.push_back({e.id, e.kind, e.length_m, e.payload_bytes});
    if (e.kind == kPathKind) {
      // Thumbnail places (VPF2); a VPF1 payload has none: the edge is listed, not covered.
      VISNAV_ASSIGN(std::vector<std::uint8_t> body, map.read_payload(e.id));
      auto payload = path_payload::PathPayload::decode(body);
      if (!payload) return payload.error().with_context(map.payload_path(e.id));
      if (payload->thumbnails.empty()) continue;
      if (index.thumbnail_places.empty()) {
        index.thumbnail_width_px = payload->thumbnail_width_px;
        index.thumbnail_height_px = payload->thumbnail_height_px;
      }
      if (payload->thumbnail_width_px != index.thumbnail_width_px ||
          payload->thumbnail_height_px != index.thumbnail_height_px)
        return fail(ErrorCode::inconsistent, "edge " + e.id + ": thumbnails of " +
                                                 std::to_string(payload->thumbnail_width_px) + "x" +
                                                 std::to_string(payload->thumbnail_height_px) + " px differ from the map's " +
                                                 std::to_string(index.thumbnail_width_px) + "x" +
                                                 std::to_string(index.thumbnail_height_px));
      for (auto& t : payload->thumbnails) {
        index.thumbnail_places.push_back({static_cast<std::uint32_t>(ei), static_cast<float>(t.distance_m)});
        index.thumbnails.push_back(std::move(t.image));
      }
      continue;
    }
    VISNAV_ASSIGN(std::vector<float> distances, source.place_distances(e, params.segment_spacing_m));
    for (float d : distances) {
      VISNAV_ASSIGN(const PlaceFeatures* f, source.features(e.id, d));
      index.places.push_back({static_cast<std::uint32_t>(ei), d});
      if (f->descriptors.empty()) continue;
      if (cols < 0) {
        cols = f->descriptors.cols;
        sample.create(params.vocabulary_sample, cols, CV_8UC1);
      }
      if (f->descriptors.cols != cols)
        return fail(ErrorCode::inconsistent, "edge " + e.id + ": descriptor width " + std::to_string(f->descriptors.cols) +
                                                 " bytes differs from the map's " + std::to_string(cols));
      for (int r = 0; r < f->descriptors.rows; ++r, ++seen) {
        long long slot = seen;
        if (seen >= params.vocabulary_sample) slot = static_cast<long long>(rng() % static_cast<std::uint64_t>(seen + 1));
        if (slot < params.vocabulary_sample) f->descriptors.row(r).copyTo(sample.row(static_cast<int>(slot)));
      }
    }
  }
  if (seen < params.vocabulary_words)
    return fail(ErrorCode::inconsistent, map.dir() + ": only " + std::to_string(seen) +
                                             " descriptors in the map, fewer than vocabulary_words " +
                                             std::to_string(params.vocabulary_words));
  if (seen < params.vocabulary_sample) sample = sample.rowRange(0, static_cast<int>(seen)).clone();
  index.vocabulary = train_vocabulary(sample, params.vocabulary_words, params.vocabulary_iterations, progress);
  // Pass 2: the codes.
  const std::size_t w = static_cast<std::size_t>(index.code_words());
  index.codes.assign(index.places.size() * w, 0);
  for (std::size_t p = 0; p < index.places.size(); ++p) {
    if (progress && p % 64 == 0) progress("codes", static_cast<double>(p), static_cast<double>(index.places.size()));
    const PlaceRef& ref = index.places[p];
    VISNAV_ASSIGN(const PlaceFeatures* f, source.features(index.edges[ref.edge].id, ref.distance_m));
    VISNAV_TRY(index.encode(f->descriptors, {index.codes.data() + p * w, w}));
  }
  if (progress) progress("codes", static_cast<double>(index.places.size()), static_cast<double>(index.places.size()));
  const bool has_memory = std::any_of(index.edges.begin(), index.edges.end(),
                                      [](const IndexedEdge& e) { return e.kind == kMemoryKind; });
  if (has_memory) index.detector = detector_type.empty() ? "the run's detector" : detector_type;
  index.prepare_thumbnails();
  return index;
}

Status check_detector(const MapStore& map, const PlaceIndex& index, Detector* detector) {
  // The first (up to) three visual_memory places, described again and coded.
  std::vector<std::size_t> probe;
  for (std::size_t p = 0; p < index.places.size() && probe.size() < 3; ++p)
    if (index.edges[index.places[p].edge].kind == kMemoryKind) probe.push_back(p);
  if (probe.empty()) return ok();
  if (detector == nullptr) return fail(ErrorCode::invalid_value, "Relocalise needs a detector (config section detector:)");
  PlaceSource source(map, detector);
  std::vector<std::uint64_t> code(static_cast<std::size_t>(index.code_words()));
  double agreement = 0.0;
  for (std::size_t p : probe) {
    const PlaceRef& ref = index.places[p];
    VISNAV_ASSIGN(const PlaceFeatures* f, source.features(index.edges[ref.edge].id, ref.distance_m));
    if (auto st = index.encode(f->descriptors, code); !st)
      return fail(ErrorCode::inconsistent, index_path(map.dir()) + ": the run's detector cannot be used with this place index (" +
                                               st.error().message + "); rebuild it with `visnav reloc-index " + map.dir() +
                                               " --detector TYPE`, TYPE the run's detector");
    const auto stored = index.code(p);
    int both = 0, either = 0;
    for (std::size_t w = 0; w < code.size(); ++w) {
      both += std::popcount(code[w] & stored[w]);
      either += std::popcount(code[w] | stored[w]);
    }
    agreement += either > 0 ? static_cast<double>(both) / either : 1.0;
  }
  agreement /= static_cast<double>(probe.size());
  if (agreement < kMinDetectorAgreement) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.2f", agreement);
    return fail(ErrorCode::inconsistent,
                index_path(map.dir()) + ": stale place index: its visual_memory references were described by " +
                    (index.detector.empty() ? std::string("another detector") : index.detector) +
                    ", and the run's detector describes them differently (words shared " + buf + " < " +
                    std::to_string(kMinDetectorAgreement).substr(0, 4) + "): rebuild it with `visnav reloc-index " +
                    map.dir() + " --detector TYPE`, TYPE the run's detector");
  }
  return ok();
}

// ------------------------------------------------------------------------------------ files

std::string index_path(const std::string& map_dir) { return (fs::path(map_dir) / kIndexFile).string(); }

Status save_place_index(const std::string& map_dir, const PlaceIndex& index) {
  return write_file_durably(map_dir, kIndexFile, index.serialize());
}

Result<PlaceIndex> load_place_index(const std::string& map_dir) {
  const std::string path = index_path(map_dir);
  std::error_code ec;
  if (!fs::exists(path, ec))
    return fail(ErrorCode::not_found, path + ": no place index (build it with `visnav reloc-index " + map_dir + "`)");
  VISNAV_ASSIGN(const std::string text, read_text_file(path, kMaxTableFileBytes, "place index"));
  const std::vector<std::uint8_t> bytes(text.begin(), text.end());
  return PlaceIndex::deserialize(bytes, path);
}

}  // namespace visnav::reloc
