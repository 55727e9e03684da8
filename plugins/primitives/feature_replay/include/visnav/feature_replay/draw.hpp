// feature_replay core — a picture of one alignment: the two images side by side with the kept
// matches (inliers green, outliers red) and the displacement histogram below (winning window
// highlighted, offset printed). Pure: returns a BGR image, writes nothing.
#pragma once

#include <span>

#include <opencv2/core/mat.hpp>

#include "visnav/devices.hpp"
#include "visnav/feature_replay/heading.hpp"

namespace visnav::feature_replay {

/// `reference`/`current`: the images (grey or BGR); `matches` index into the two feature sets
/// (reference_index -> reference_features, current_index -> current_features).
[[nodiscard]] cv::Mat render_alignment(const cv::Mat& reference, const cv::Mat& current, const Features& reference_features,
                                       const Features& current_features, std::span<const FeatureMatch> matches,
                                       std::span<const int> histogram, const HeadingEstimate& estimate,
                                       const HeadingParams& params);

}  // namespace visnav::feature_replay
