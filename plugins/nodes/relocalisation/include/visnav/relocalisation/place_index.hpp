// relocalisation core — the place index of a map (issue 21).
//
// A place is a taught position: one local map of a feature_localmaps edge, one sample every
// `segment_spacing_m` along a feature_segment edge (the landmarks visible there, at their expected
// image positions), or one reference image of a visual_memory edge (those store images and
// tracked corners but no descriptors: the reference image is described with a detector at index
// time, the run's configured detector for BuildPlaceIndex and on-demand builds, `--detector` for
// `visnav reloc-index`; it must be the detector Relocalise runs with). path_following edges store
// one colour model per edge, nothing that varies along it: they are not indexed (Relocalise says
// so rather than guessing, see relocaliser.hpp). Each place gets a whole-image binary code: the map's binary descriptors are
// clustered into a vocabulary of `vocabulary_words` words (k-majority, the binary counterpart of
// k-means: each word is the bitwise majority of its members), and bit w of a place's code is set
// when one of its descriptors is nearest to word w (a bag-of-binary-words presence vector). The
// Hamming distance between two codes is the size of the symmetric difference of their word sets.
//
// Lookup is a brute-force Hamming scan over all codes (popcount of 64-bit words): 16 words per
// place at the default 1024 bits, ~0.1 ms per 1000 places on one core; bench/relocalisation
// measures it on 1 km and 10 km maps. A similarity-search library (faiss IndexBinaryFlat) does the
// same scan; HNSW would be sub-linear but its graph must be rebuilt or stored, and the scan is a
// small part of a query (the histogram verification of the candidates dominates).
// Thumbnail places (path_following edges, compared by shifted NCC) are searched in three stages:
// a sub-linear first stage (shift-tolerant window vectors in a k-means inverted file of
// ~sqrt(vectors) cells, thumbnail_first_stage), then a half-resolution and a full-resolution NCC
// pass on the few hundred places it returns (query_thumbnails).
//
// The index lives in the map folder as `place_index.bin`: magic "VNAVPIDX", format version,
// body length and CRC-32 of the body (map_format::crc32), then the body: parameters, the list of
// indexed edges with their payload sizes (a map changed since the index was built is detected as
// stale), the vocabulary, the places and their codes, the thumbnail places (version 2) and the
// first stage's cells (version 3; a version-2 file's cells are trained at load). Written crash-safely like the map's own
// files (temporary file, fsync, rename, folder fsync). Only binary (CV_8U) descriptors can be
// indexed; a map of float descriptors is refused with a clear error.
//
// Thread-safety: a PlaceIndex is immutable once built (const methods may be called from any
// thread). PlaceSource caches decoded payloads and is single-threaded.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "visnav/devices.hpp"
#include "visnav/map.hpp"
#include "visnav/params.hpp"
#include "visnav/path_payload.hpp"
#include "visnav/result.hpp"

namespace visnav::reloc {

inline constexpr const char* kIndexFile = "place_index.bin";
inline constexpr char kIndexMagic[8] = {'V', 'N', 'A', 'V', 'P', 'I', 'D', 'X'};
/// 2: + detector, thumbnail places; 3: + the thumbnail places' cells (1 and 2 are still read).
inline constexpr std::uint32_t kIndexVersion = 3;
inline constexpr const char* kSegmentKind = "feature_segment";
inline constexpr const char* kLocalMapsKind = "feature_localmaps";
inline constexpr const char* kMemoryKind = "visual_memory";
inline constexpr const char* kPathKind = "path_following";

/// True for the edge kinds the index lists (the feature primitive's, visual_memory and
/// path_following; a path_following edge taught before thumbnails existed is listed without places).
[[nodiscard]] bool indexable_kind(std::string_view kind);
/// True for the kinds whose places carry binary descriptors (BoW code + histogram verification).
[[nodiscard]] bool describable_kind(std::string_view kind);

/// Thumbnails are normalised and compared as the path replay's along-track estimate does (the
/// SDK's visnav/path_payload.hpp): local contrast normalisation as in SeqSLAM, so a darker or
/// brighter view of the same place compares alike, and zero-mean NCC over a column shift.
using path_payload::normalise_thumbnail;
using path_payload::thumbnail_ncc;

/// The coarse thumbnail of the two-pass search: `thumbnail_u8` at half its width and height
/// (area average), then normalise_thumbnail.
[[nodiscard]] cv::Mat coarse_thumbnail(const cv::Mat& thumbnail_u8);

/// The shift-tolerant global vectors of a thumbnail (the first stage of the thumbnail search).
/// A window half the thumbnail's width is described by: per band of kSignatureBands rows of the
/// normalised thumbnail (normalise_thumbnail), the square-rooted magnitudes of the horizontal DFT
/// at 1..kSignatureFrequencies cycles per window, averaged over the band's rows (a sideways shift
/// changes the phases, not the magnitudes); the raw grey means of kSignatureBands x
/// kSignatureColumns blocks, z-scored (the coarse layout); the raw row means, z-scored (the
/// skyline's height). Each part is scaled to unit length and weighted (1, kSignatureBlockWeight,
/// kSignatureProfileWeight). A stored thumbnail gives kStoredWindows windows, 1/8 of the width
/// apart (left edge to right edge); a live one kLiveWindows, 1/4 apart: for any shift within
/// +-half the width, one live window lies within 1/16 of the width of one stored window.
inline constexpr int kSignatureBands = 6;
inline constexpr int kSignatureFrequencies = 6;
inline constexpr int kSignatureColumns = 4;
inline constexpr float kSignatureBlockWeight = 1.0f;
inline constexpr float kSignatureProfileWeight = 0.7f;
inline constexpr int kStoredWindows = 5;
inline constexpr int kLiveWindows = 3;
/// Floats per window vector for a thumbnail of `height_px` rows.
[[nodiscard]] int signature_dims(int height_px);
/// The window vectors of `thumbnail_u8` (at least 8 x 4 px): kStoredWindows (`stored`) or
/// kLiveWindows of signature_dims(rows) floats each, appended to `out` window after window.
void thumbnail_signatures(const cv::Mat& thumbnail_u8, bool stored, std::vector<float>& out);

/// One thumbnail hit: the best shift of a thumbnail place.
struct ThumbnailHit {
  std::uint32_t place = 0;  ///< index into PlaceIndex::thumbnail_places
  double ncc = -1.0;
  int shift_px = 0;         ///< live view shifted right by this much (the robot turned left: + heading offset)
};

struct PlaceIndexParams {
  int vocabulary_words = 1024;       ///< bits of a place code (multiple of 64)
  double segment_spacing_m = 0.25;   ///< place spacing along feature_segment edges, m
  int vocabulary_sample = 12000;     ///< descriptors sampled (deterministically) to train the vocabulary
  int vocabulary_iterations = 5;     ///< k-majority iterations

  [[nodiscard]] Status validate() const { return schema().check(*this); }
  static const ParamSchema<PlaceIndexParams>& schema();
};

/// An edge the index covers, as it was when the index was built.
struct IndexedEdge {
  std::string id;
  std::string kind;
  double length_m = 0.0;
  std::uint64_t payload_bytes = 0;
};

/// One taught position.
struct PlaceRef {
  std::uint32_t edge = 0;   ///< index into PlaceIndex::edges
  float distance_m = 0.0f;  ///< along the edge from its start
};

/// One lookup hit.
struct PlaceCandidate {
  std::uint32_t place = 0;  ///< index into PlaceIndex::places
  int hamming = 0;          ///< code distance, bits
};

/// The place index of one map. See the file comment for the code and the file format.
class PlaceIndex {
 public:
  PlaceIndexParams params;
  std::vector<IndexedEdge> edges;
  std::vector<PlaceRef> places;
  cv::Mat vocabulary;                 ///< vocabulary_words rows of descriptor bytes, CV_8UC1
  std::vector<std::uint64_t> codes;   ///< places.size() * code_words(), row-major
  /// Which detector described the visual_memory references (its config type, e.g. "star_brief",
  /// or "the run's detector" when built by a node; empty: no visual_memory place, or a version-1
  /// index). Informative: check_detector() compares codes, not names.
  std::string detector;
  /// path_following places: one per stored thumbnail (VPF2 payloads), compared by thumbnail_ncc.
  std::vector<PlaceRef> thumbnail_places;
  int thumbnail_width_px = 0;
  int thumbnail_height_px = 0;
  std::vector<cv::Mat> thumbnails;    ///< per thumbnail place, CV_8UC1 as stored
  std::vector<cv::Mat> normalised;    ///< per thumbnail place, normalise_thumbnail (not stored)
  std::vector<cv::Mat> coarse;        ///< per thumbnail place, coarse_thumbnail (not stored)
  /// The first stage's inverted file (version 3): the stored window vectors of every thumbnail
  /// place (thumbnail_signatures, kStoredWindows per place) clustered by k-means into
  /// ~sqrt(vectors) cells; `thumbnail_centroids` cells x signature_dims floats, `thumbnail_cell`
  /// the cell of each vector (place p's windows are vectors kStoredWindows p ...; both stored;
  /// trained at load for a version-2 file). Empty when the index has no thumbnail place.
  std::vector<float> thumbnail_centroids;
  std::vector<std::uint32_t> thumbnail_cell;
  std::vector<float> signatures;                  ///< the window vectors, place after place (not stored)
  std::vector<std::vector<std::uint32_t>> cell_members;  ///< per cell, its vectors (not stored)

  /// Fills `normalised`, `coarse` and `signatures` from `thumbnails` and the cells' member lists;
  /// trains the cells first when `thumbnail_cell` does not cover every thumbnail place
  /// (deserialize and build_place_index call it).
  void prepare_thumbnails();
  /// Number of inverted-file cells.
  [[nodiscard]] std::size_t thumbnail_cells() const;
  /// The first stage: the `count` thumbnail places whose window vectors are nearest to one of
  /// `live_u8`'s live windows, nearest first, looked up in the inverted file: for each live
  /// window, the cells are ranked by their centroid's distance and visited in that order until
  /// they hold at least `probe` x count vectors (or all are visited); a place's distance is the
  /// smallest over the pairs visited. Cost ~ kLiveWindows x (cells + probe x count) distances
  /// (cells ~ sqrt(vectors): sub-linear). Every place when count >= the places; none when
  /// `live_u8` is not of the index's thumbnail size. `out` is reused.
  void thumbnail_first_stage(const cv::Mat& live_u8, int count, std::vector<std::uint32_t>& out,
                             double probe = kFirstStageProbe) const;
  static constexpr double kFirstStageProbe = 8.0;

  /// True when `edge` (index into edges) has at least one place of either kind.
  [[nodiscard]] bool covers(std::uint32_t edge) const;
  /// The thumbnail places most like `live_u8` (a CV_8UC1 thumbnail of the index's size, e.g.
  /// path_payload::make_thumbnail of a frame), each at its best shift within +-max_shift_px, best
  /// first (ties by place), at most `k` with ncc >= min_ncc. `coarse_candidates` 0: one exhaustive
  /// pass over every place and shift. > 0 (and fewer than the places): two passes — every place
  /// compared at half resolution (coarse_thumbnail, shifts within +-max_shift_px / 2), then only
  /// the coarse_candidates best compared at full resolution within +-2 px of their coarse shift
  /// (about a sixth of the exhaustive cost plus the refinement). `index_candidates` > 0 (and
  /// fewer than the places): only the places thumbnail_first_stage returns are searched (the
  /// two passes then run on them). Needs prepare_thumbnails().
  void query_thumbnails(const cv::Mat& live_u8, int max_shift_px, int k, double min_ncc,
                        std::vector<ThumbnailHit>& out, int coarse_candidates = 0, int index_candidates = 0) const;

  /// 64-bit words per code.
  [[nodiscard]] int code_words() const { return params.vocabulary_words / 64; }
  [[nodiscard]] std::span<const std::uint64_t> code(std::size_t place) const {
    const auto w = static_cast<std::size_t>(code_words());
    return {codes.data() + place * w, w};
  }
  /// The code of a set of binary descriptors (CV_8UC1 rows as wide as the vocabulary's). `code`
  /// must hold code_words() words. Error: wrong descriptor type or width.
  Status encode(const cv::Mat& descriptors, std::span<std::uint64_t> code) const;
  /// The `k` places nearest to `code` by Hamming distance, nearest first (ties by place index).
  /// Cost: one scan of every code. `out` is reused.
  void query(std::span<const std::uint64_t> code, int k, std::vector<PlaceCandidate>& out) const;

  /// The file bytes (header + body).
  [[nodiscard]] std::vector<std::uint8_t> serialize() const;
  /// Parses and verifies file bytes: magic, version, length, checksum, then the body's
  /// consistency. `file_name` prefixes every error (code parse_error).
  [[nodiscard]] static Result<PlaceIndex> deserialize(std::span<const std::uint8_t> file, const std::string& file_name);
  /// Ok when the map's indexable edges are exactly the ones indexed (same ids, kinds and payload
  /// sizes); else an `inconsistent` error naming the first difference and the rebuild command.
  [[nodiscard]] Status matches(const MapStore& map) const;
  /// Bytes of the serialised index.
  [[nodiscard]] std::size_t byte_size() const;
};

/// Progress of a long build: phase, done, total.
using IndexProgress = std::function<void(const char* phase, double done, double total)>;

/// Reference features of one place, owned (for HeadingEstimator::estimate).
struct PlaceFeatures {
  cv::Mat descriptors;                    ///< CV_8UC1 rows
  std::vector<cv::Point2f> positions_px;  ///< where each is expected in the image
};

/// Decodes payloads on demand and caches them (one decode per edge; a visual_memory edge's
/// reference images are described once, with `detector`). Single-threaded.
class PlaceSource {
 public:
  /// `detector` (may be nullptr: visual_memory edges are then an error naming the fix) must
  /// outlive the source and be the one whose descriptors the index was (or is being) built with.
  explicit PlaceSource(const MapStore& map, Detector* detector = nullptr) : map_(map), detector_(detector) {}
  /// Replaces the detector for edges not described yet (e.g. the run's detector after a live
  /// reload); descriptions already cached are kept.
  void set_detector(Detector* detector) { detector_ = detector; }
  /// Positions of the places of `edge` (local-map or reference distances, or 0, spacing, ..., length).
  Result<std::vector<float>> place_distances(const EdgeRecord& edge, double segment_spacing_m);
  /// The reference features of the place at `distance_m` on `edge_id`: the local map nearest it,
  /// or the segment landmarks visible there at their expected positions. Valid until the next call.
  Result<const PlaceFeatures*> features(const std::string& edge_id, double distance_m);

 private:
  struct Decoded;
  Result<const Decoded*> decode(const EdgeRecord& edge);
  const MapStore& map_;
  Detector* detector_ = nullptr;
  std::map<std::string, std::shared_ptr<const Decoded>, std::less<>> cache_;
  PlaceFeatures scratch_;
};

/// Builds the index of every indexable edge of `map` (payloads read and verified by the store).
/// `detector` describes the reference images of visual_memory edges (see PlaceSource);
/// `detector_type` (its config type) is recorded in the index when the map has such edges.
/// path_following edges contribute their thumbnails (none for a VPF1 payload: listed, not covered).
/// Errors: no indexable edge, float descriptors, a payload that does not decode (named), a
/// visual_memory edge without a detector (invalid_value naming the edge).
[[nodiscard]] Result<PlaceIndex> build_place_index(const MapStore& map, const PlaceIndexParams& params,
                                                   Detector* detector = nullptr, const IndexProgress& progress = {},
                                                   const std::string& detector_type = {});
/// Ok when frames described by `detector` may be looked up in `index`: an index without
/// visual_memory places, or one whose first (up to) three visual_memory places, described again
/// with `detector` and coded with the vocabulary, share on average at least
/// kMinDetectorAgreement of their words with the stored codes (|A and B| / |A or B|). The same
/// detector gives nearly the stored codes (its adaptive threshold may pick a few other keypoints);
/// another detector's descriptors fall into other words. Else an `inconsistent` error naming the
/// detector recorded and the rebuild command. Cost: the detector run on every reference image of
/// the visual_memory edge(s) holding those places (PlaceSource describes an edge at once).
inline constexpr double kMinDetectorAgreement = 0.5;
[[nodiscard]] Status check_detector(const MapStore& map, const PlaceIndex& index, Detector* detector);

/// Path of the index file of a map folder.
[[nodiscard]] std::string index_path(const std::string& map_dir);
/// Writes the index into the map folder crash-safely (temporary file, fsync, rename, fsync folder).
[[nodiscard]] Status save_place_index(const std::string& map_dir, const PlaceIndex& index);
/// Reads and verifies `place_index.bin` of a map folder. Error code not_found when the file is
/// absent (a map taught before the index existed), parse_error when it is damaged.
[[nodiscard]] Result<PlaceIndex> load_place_index(const std::string& map_dir);

}  // namespace visnav::reloc
