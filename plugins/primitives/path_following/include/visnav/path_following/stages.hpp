// visnav path following — drawing of the pipeline stages (seed 000 Fig. 2), for `visnav pathseg`.
//
// Pure: returns a new BGR image, writes nothing. Thread-safety: thread-safe.
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

#include "visnav/path_following/path_follower.hpp"

namespace visnav::path_following {

/// Five panels side by side, each the size of `bgr`, titled:
///   1 "input + horizon", 2 "superpixels" (random colour per segment, seeded by `colour_seed`),
///   3 "reference region" (trapezoid; segments behind the kept reference models highlighted),
///   4 "classification" (binary mask before opening),
///   5 "path + steering" (final region tinted, contour, middle points, steering arrow, v, ω).
/// `stages` must come from the process() call that produced `estimate` on `bgr`; `params` (the
/// follower's) scale the steering arrow.
/// A dark/no-reference frame draws the panels it has (empty stages are drawn black).
[[nodiscard]] cv::Mat render_stages(const cv::Mat& bgr, const PathEstimate& estimate, const PathStages& stages,
                                    const PathFollowerParams& params, std::uint64_t colour_seed = 7);

}  // namespace visnav::path_following
