// evaluation core — compares a recorded traversal with a taught map frame by frame (the
// map-vs-view evaluation of stroll_bearnav; issue 8).
//
// The route is the chosen feature edges of the map in order (default: every `feature_localmaps`
// and `feature_segment` edge in map order), laid end to end by their odometric lengths. A frame
// of the run at odometric distance d (Odometry::distance_m at the frame time — the sample at or
// before it — minus the first frame's, plus start_offset_m) lies on the edge whose span holds d
// (past the end: the last edge). Per frame:
//  * style B (feature_localmaps): the local map nearest the distance along the edge
//    (LocalMapPath::nearest_map) and the histogram-voting offset of the frame's features
//    against it (HeadingEstimator);
//  * style A (feature_segment): the landmarks expected at that distance and their offset
//    (SegmentReplayer::step, one replayer per edge, started at the edge's first frame).
// offset_px: position of the scene in the recorded frame minus in the map (heading.hpp).
// With the run's ground_truth.csv (simulated runs) each row also carries the true pose.
// Pure apart from reading the map, the run and the images; the detector is given.
// Thread-safety: one evaluation per thread (the detector and estimators are stateful).
#pragma once

#include <string>
#include <vector>

#include "visnav/devices.hpp"
#include "visnav/feature_replay/heading.hpp"
#include "visnav/map.hpp"
#include "visnav/result.hpp"

namespace visnav::evaluation {

struct EvaluationOptions {
  std::vector<std::string> edges;     ///< edge ids in route order; empty = all feature edges in map order
  double start_offset_m = 0.0;        ///< route distance of the run's first frame
  feature_replay::HeadingParams heading;
};

struct FrameEvaluation {
  long frame_index = 0;
  double t_s = 0.0;
  double run_distance_m = 0.0;        ///< along the route
  std::string edge;
  std::string style;                  ///< "localmaps" or "segment"
  double edge_distance_m = 0.0;       ///< along the edge
  int map_index = -1;                 ///< style B: local map used; -1 otherwise
  double map_distance_m = 0.0;        ///< style B: that map's distance along the edge
  int features = 0;                   ///< features detected in the frame
  feature_replay::HeadingEstimate estimate;
  bool has_truth = false;
  Pose2D truth;
};

struct EvaluationSummary {
  long frames = 0;
  long valid = 0;
  double mean_abs_offset_px = 0.0;    ///< over valid estimates
  double median_abs_offset_px = 0.0;  ///< over valid estimates
  double mean_inliers = 0.0;          ///< over all frames
};

/// Evaluates every frame of the recorded run `run_dir` against `map`. Errors name the map edge,
/// the run file (and line) or the image.
[[nodiscard]] Result<std::vector<FrameEvaluation>> evaluate_run(const MapStore& map, const std::string& run_dir,
                                                                Detector& detector, const EvaluationOptions& options);
[[nodiscard]] EvaluationSummary summarize(const std::vector<FrameEvaluation>& rows);
/// Writes the CSV (header + one row per frame). Error names the path.
[[nodiscard]] Status write_csv(const std::vector<FrameEvaluation>& rows, const std::string& path);
/// Draws offset_px over the route distance (valid estimates filled, others hollow; edge
/// boundaries as vertical lines) and writes it as PNG. Error names the path.
[[nodiscard]] Status write_plot(const std::vector<FrameEvaluation>& rows, const std::string& path, const std::string& title);

}  // namespace visnav::evaluation
