// visnav SDK — the payloads of the feature primitive's edges: `feature_segment` (map style A,
// seed 000: a straight segment's landmarks (e, k, u, v, f, g)) and `feature_localmaps` (map style
// B, seed 002: local maps by distance plus the operator's recorded commands), their codecs and
// invariants. They belong to feature_replay (segment_map.hpp and local_map.hpp describe how they
// are taught and replayed, docs/feature_replay.md the byte layout); they are in the SDK so that
// other plugins read those edges without including a plugin's headers (the place index of
// relocalisation, issue 21). Implemented in the runtime library
// (runtime/src/map/feature_payloads.cpp).
//
// Decoding never crashes on garbage: wrong magic or version, truncation, trailing bytes,
// non-finite or inconsistent values are an Error.
// Distances: metres from the edge's start. Image positions: pixels, u right, v down.
// Thread-safety: value types, immutable once built; may be shared between threads.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "visnav/histogram_voting.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::feature_replay {

/// One landmark (e, k, u, v, f, g) of seed 000; its descriptor e is row i of SegmentMap::descriptors.
struct Landmark {
  std::uint32_t count = 0;        ///< k: frames in which it was detected
  cv::Point2f first_px;           ///< u: image position at the first detection
  cv::Point2f last_px;            ///< v: image position at the last detection
  float first_distance_m = 0.0f;  ///< f: distance from the segment start at the first detection
  float last_distance_m = 0.0f;   ///< g: distance at the last detection (>= f)

  /// Expected image position at distance d (linear interpolation, clamped to [f, g]).
  [[nodiscard]] cv::Point2f expected_px(double distance_m) const;
};

/// One taught segment: azimuth, odometric length and landmarks sorted by first distance.
struct SegmentMap {
  /// Payload layout version written by serialize() (see docs/feature_replay.md).
  static constexpr std::uint16_t kFormatVersion = 1;

  double length_m = 0.0;
  double azimuth_rad = 0.0;           ///< heading at the segment start (odom/compass frame)
  std::vector<Landmark> landmarks;    ///< sorted by first_distance_m
  cv::Mat descriptors;                ///< row i describes landmarks[i]; CV_8UC1 or CV_32FC1
  double max_span_m = 0.0;            ///< max(g - f) over the landmarks (replay search window)

  /// Compact little-endian binary body (the map store adds its own header and checksum).
  [[nodiscard]] std::vector<std::uint8_t> serialize() const;
  /// Parses a body made by serialize(); rejects wrong magic/version, truncation, trailing bytes,
  /// non-finite or inconsistent values with an Error (never crashes on garbage).
  [[nodiscard]] static Result<SegmentMap> deserialize(std::span<const std::uint8_t> body);
  /// Checks the invariants (sizes, ordering, finite values).
  [[nodiscard]] Status validate() const;
};

struct RecordedCommand {
  double distance_m = 0.0;  ///< distance from the path start at which the operator issued it
  Twist command;
};

struct LocalMap {
  double distance_m = 0.0;                 ///< distance from the path start
  std::vector<cv::Point2f> positions_px;   ///< keypoint positions
  cv::Mat descriptors;                     ///< one row per position (CV_8UC1 or CV_32FC1)
  std::vector<std::uint8_t> jpeg;          ///< optional JPEG of the image (empty if not stored)

  [[nodiscard]] ReferenceView view() const { return ReferenceView{descriptors, positions_px}; }
};

struct LocalMapPath {
  static constexpr std::uint16_t kFormatVersion = 1;

  double length_m = 0.0;
  std::vector<LocalMap> maps;              ///< sorted by distance
  std::vector<RecordedCommand> commands;   ///< sorted by distance

  /// Index of the local map nearest `distance_m` (-1 if there are none). O(log n).
  [[nodiscard]] int nearest_map(double distance_m) const;
  /// The last command issued at or before `distance_m` (the first one before it; zero if none). O(log n).
  [[nodiscard]] Twist command_at(double distance_m) const;

  /// Compact little-endian binary body (the map store adds its own header and checksum).
  [[nodiscard]] std::vector<std::uint8_t> serialize() const;
  /// Parses a body made by serialize(); rejects garbage, truncation and inconsistent values.
  [[nodiscard]] static Result<LocalMapPath> deserialize(std::span<const std::uint8_t> body);
  [[nodiscard]] Status validate() const;
};

}  // namespace visnav::feature_replay
