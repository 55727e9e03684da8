// Internal: dead-reckoned layout and drawing of a map (`visnav map render`).
#pragma once

#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "visnav/map.hpp"

namespace visnav::map_detail {

/// Node positions (odom frame, metres) and the drawn segment of every edge.
struct MapLayout {
  std::map<std::string, cv::Point2d, std::less<>> node_xy_m;
  struct EdgeSegment {
    cv::Point2d start_m;
    cv::Point2d end_m;       ///< dead-reckoned end: start + length_m · (cos azimuth, sin azimuth)
    cv::Point2d to_node_m;   ///< where the `to` node was placed (differs from end_m when loops close)
  };
  std::vector<EdgeSegment> edges;  ///< parallel to MapStore::edges()
};

/// Places the nodes: a node with a position_hint keeps it; the others are reached by integrating
/// edge azimuth and length forwards along the edges from placed nodes (the first node of the map
/// when none has a hint); a node reachable only against edge directions is placed backwards from
/// an edge's end. Unconnected components are placed side by side. Pure.
[[nodiscard]] MapLayout layout_map(const MapStore& map);

/// BGR colour of a primitive kind (feature kinds red, path following blue, as seed 000 Fig. 1).
[[nodiscard]] cv::Scalar kind_colour(const std::string& kind);

/// Draws the map: edges as arrows coloured by kind, with a tick at every position an edge marks
/// (statistics "mark.<name>_m", metres from its start), nodes with names, legend, scale bar.
/// `width_px` ≥ 200. Pure (no file I/O).
[[nodiscard]] Result<cv::Mat> render_map(const MapStore& map, int width_px);

}  // namespace visnav::map_detail
