// The live view's overlays (docs/live_view.md): what the active primitive saw in a frame
// (NavOverlay, host.hpp) kept past the publish() call that carried it, and drawn two ways —
// as Foxglove ImageAnnotations (points, lines and texts the Image panel draws over /camera)
// and burnt into a copy of the frame (/camera/overlay, for any viewer).
// Drawn: matched features (green: in the winning heading bin, red: other votes) with a line to
// where each was taught, the heading histogram as bars along the bottom edge (bin centres at
// the image centre + offset) with the chosen offset as a magenta line, and the path-following
// segmentation (mask tinted green, its outline, the centre line in cyan).
// Thread-safety: none; the live view uses it from the tick thread.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "visnav/host.hpp"

namespace visnav::view {

/// An owned copy of a NavOverlay; buffers are reused from frame to frame.
struct OverlayCopy {
  bool valid = false;  ///< something was copied since the last clear()
  std::vector<cv::Point2f> matched_px, reference_px;
  std::vector<std::uint8_t> inlier;
  std::vector<int> histogram;
  double histogram_bin_px = 0.0;
  double offset_px = 0.0;
  cv::Mat path_mask;  ///< CV_8UC1 or empty
  std::vector<cv::Point2f> path_middle_px;

  void copy_from(const NavOverlay& o);
  void clear() { valid = false; }
};

/// foxglove.ImageAnnotations JSON for a frame of `size` stamped `t_s` (the frame's timestamp, so
/// the Image panel pairs them). An invalid overlay gives an object with empty lists.
[[nodiscard]] std::string annotations_json(const OverlayCopy& overlay, cv::Size size, double t_s);

/// Draws the overlay into `bgr` (CV_8UC3, modified in place). A mask of another size than the
/// image is ignored.
void draw_overlay(cv::Mat& bgr, const OverlayCopy& overlay);

}  // namespace visnav::view
