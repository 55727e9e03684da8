// visnav SDK — the payload of `visual_memory` edges: the taught path as a chain of key reference
// images (seed 003 Fig. 2) and its codec. It belongs to the visual_memory primitive; it is in the
// SDK so that other plugins read those edges without including a plugin's headers (the place
// index of relocalisation describes the reference images, issue 21). Implemented in the runtime
// library (runtime/src/map/visual_memory_payload.cpp).
//
// Frames: each reference k has its own camera frame (OpenCV: x right, y down, z forward,
// metres). `R_from_prev`, `t_from_prev_m` map a point from reference k-1's camera frame to
// reference k's: X_k = R X_{k-1} + t (metric: the essential matrix's unit translation scaled by
// the odometric distance between the two references). `points3d_m[j]` is feature j in reference
// k's frame, triangulated between k-1 and k; only features shared with k-1 have one
// (`has_3d[j]`). Reference 0 and references taught while turning on the spot (baseline below
// TeachParams::min_baseline_m) have none.
//
// Payload body (little endian, PayloadWriter): magic "VVM1", image width, height, focal px, then
// per reference: distance_m, heading_rad, R (9 doubles), t (3), the grey image as PNG, feature
// count n, n × (id, u, v, has_3d, X, Y, Z). decode() checks every count, every number's
// finiteness and the PNG against the stated size; a body that does not decode is an error, never
// a crash.
// Ownership: value types; images are cv::Mat (reference counted, never written after decode).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <opencv2/core.hpp>

#include "visnav/result.hpp"

namespace visnav::visual_memory {

struct Reference {
  double distance_m = 0.0;   ///< odometric distance along the edge when taught
  double heading_rad = 0.0;  ///< odometric heading when taught (odom frame)
  cv::Matx33d R_from_prev = cv::Matx33d::eye();
  cv::Vec3d t_from_prev_m{0.0, 0.0, 0.0};
  cv::Mat image;                         ///< CV_8UC1
  std::vector<std::int32_t> ids;         ///< track id per feature (shared features keep their id)
  std::vector<cv::Point2f> points_px;
  std::vector<std::uint8_t> has_3d;
  std::vector<cv::Point3f> points3d_m;   ///< reference frame, valid where has_3d

  [[nodiscard]] int count_3d() const;
  /// Index of feature `id`, or -1.
  [[nodiscard]] int find(std::int32_t id) const;
};

struct VisualMemory {
  int width_px = 0;
  int height_px = 0;
  double focal_px = 0.0;
  std::vector<Reference> references;

  [[nodiscard]] std::vector<std::uint8_t> encode(int png_compression = 3) const;
  static Result<VisualMemory> decode(std::span<const std::uint8_t> body);
};

}  // namespace visnav::visual_memory
