// Map-vs-view evaluation of a recorded run (evaluate.hpp).
#include "visnav/evaluation/evaluate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include <opencv2/imgcodecs.hpp>

#include "visnav/feature_replay/local_map.hpp"
#include "visnav/feature_replay/segment_map.hpp"
#include "visnav/recorded/odometry_log.hpp"
#include "visnav/recorded/run_format.hpp"

namespace visnav::evaluation {

namespace fs = std::filesystem;
namespace fr = visnav::feature_replay;

namespace {

constexpr const char* kLocalMaps = "feature_localmaps";
constexpr const char* kSegment = "feature_segment";

struct RouteEdge {
  std::string id;
  bool local_maps = false;
  double start_m = 0.0;
  double length_m = 0.0;
  std::shared_ptr<const fr::LocalMapPath> path;
  std::shared_ptr<const fr::SegmentMap> segment;
  std::unique_ptr<fr::SegmentReplayer> replayer;
  bool begun = false;
};

}  // namespace

Result<std::vector<FrameEvaluation>> evaluate_run(const MapStore& map, const std::string& run_dir, Detector& detector,
                                                  const EvaluationOptions& options) {
  // --- the route ---
  std::vector<RouteEdge> route;
  std::vector<std::string> ids = options.edges;
  if (ids.empty())
    for (const EdgeRecord& e : map.edges())
      if (e.kind == kLocalMaps || e.kind == kSegment) ids.push_back(e.id);
  if (ids.empty()) return fail(map.graph_path() + ": the map has no feature edges (feature_localmaps or feature_segment)");
  double start_m = 0.0;
  for (const std::string& id : ids) {
    const EdgeRecord* e = map.find_edge(id);
    if (e == nullptr) return fail(map.graph_path() + ": no edge '" + id + "'");
    if (e->kind != kLocalMaps && e->kind != kSegment)
      return fail(map.graph_path() + ": edge '" + id + "' is of kind '" + e->kind + "', not a feature edge");
    VISNAV_ASSIGN(std::vector<std::uint8_t> body, map.read_payload(id));
    RouteEdge r;
    r.id = id;
    r.start_m = start_m;
    r.local_maps = e->kind == kLocalMaps;
    if (r.local_maps) {
      auto path = fr::LocalMapPath::deserialize(body);
      if (!path) return path.error().with_context(map.payload_path(id));
      r.length_m = std::max(path->length_m, e->length_m);
      r.path = std::make_shared<const fr::LocalMapPath>(std::move(*path));
    } else {
      auto seg = fr::SegmentMap::deserialize(body);
      if (!seg) return seg.error().with_context(map.payload_path(id));
      r.length_m = std::max(seg->length_m, e->length_m);
      r.segment = std::make_shared<const fr::SegmentMap>(std::move(*seg));
      r.replayer = std::make_unique<fr::SegmentReplayer>(r.segment, fr::SegmentReplayParams{}, options.heading);
    }
    start_m += r.length_m;
    route.push_back(std::move(r));
  }

  // --- the run ---
  VISNAV_ASSIGN(recorded::FrameList frames, recorded::read_run_frames(run_dir));
  VISNAV_ASSIGN(recorded::OdometryLog odometry, recorded::OdometryLog::load((fs::path(run_dir) / recorded::kOdometryFile).string()));
  VISNAV_TRY(odometry.check_coverage(frames.times(), frames.file, 1.0, recorded::OdometrySync::latest));
  VISNAV_ASSIGN(auto truth, recorded::read_ground_truth(run_dir));

  fr::HeadingEstimator estimator(options.heading);
  Features features;
  std::vector<FrameEvaluation> rows;
  rows.reserve(frames.frames.size());
  double first_distance_m = 0.0;
  for (std::size_t i = 0; i < frames.frames.size(); ++i) {
    const recorded::FrameEntry& f = frames.frames[i];
    const std::string where = frames.file + ":" + std::to_string(f.line);
    auto odo = odometry.sample_at(f.t_s, recorded::OdometrySync::latest);
    if (!odo) return fail(where + ": no odometry at t = " + std::to_string(f.t_s) + " s");
    if (i == 0) first_distance_m = odo->distance_m;
    cv::Mat image = cv::imread(f.path, cv::IMREAD_ANYCOLOR);
    if (image.empty()) return fail(where + ": image '" + f.path + "' cannot be read");
    if (auto st = detector.detect(image, features); !st) return fail(where + ": detector: " + st.error().message);

    FrameEvaluation row;
    row.frame_index = static_cast<long>(i);
    row.t_s = f.t_s;
    row.run_distance_m = odo->distance_m - first_distance_m + options.start_offset_m;
    row.features = static_cast<int>(features.keypoints.size());
    std::size_t k = 0;
    while (k + 1 < route.size() && row.run_distance_m >= route[k + 1].start_m) ++k;
    RouteEdge& edge = route[k];
    row.edge = edge.id;
    row.edge_distance_m = row.run_distance_m - edge.start_m;
    const double width = static_cast<double>(image.cols);
    if (edge.local_maps) {
      row.style = "localmaps";
      row.map_index = edge.path->nearest_map(row.edge_distance_m);
      if (row.map_index >= 0) {
        const fr::LocalMap& lm = edge.path->maps[static_cast<std::size_t>(row.map_index)];
        row.map_distance_m = lm.distance_m;
        auto est = estimator.estimate(lm.view(), features, width);
        if (!est) return fail(where + ": edge '" + edge.id + "', local map " + std::to_string(row.map_index) + ": " + est.error().message);
        row.estimate = *est;
      }
    } else {
      row.style = "segment";
      if (!edge.begun) {
        edge.replayer->begin(odo->distance_m - row.edge_distance_m);
        edge.begun = true;
      }
      const fr::SegmentReplayOutput out = edge.replayer->step(odo->distance_m, features, width);
      row.estimate = out.estimate;
    }
    if (!truth.empty()) {
      auto it = std::upper_bound(truth.begin(), truth.end(), f.t_s + 1e-9,
                                 [](double t, const std::pair<double, Pose2D>& s) { return t < s.first; });
      if (it != truth.begin()) {
        row.has_truth = true;
        row.truth = (it - 1)->second;
      }
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

EvaluationSummary summarize(const std::vector<FrameEvaluation>& rows) {
  EvaluationSummary s;
  s.frames = static_cast<long>(rows.size());
  std::vector<double> abs_offsets;
  double inliers = 0.0;
  for (const auto& r : rows) {
    inliers += r.estimate.inliers;
    if (!r.estimate.valid) continue;
    ++s.valid;
    abs_offsets.push_back(std::abs(r.estimate.offset_px));
  }
  if (!rows.empty()) s.mean_inliers = inliers / static_cast<double>(rows.size());
  if (!abs_offsets.empty()) {
    double sum = 0.0;
    for (double v : abs_offsets) sum += v;
    s.mean_abs_offset_px = sum / static_cast<double>(abs_offsets.size());
    std::sort(abs_offsets.begin(), abs_offsets.end());
    const std::size_t n = abs_offsets.size();
    s.median_abs_offset_px = n % 2 == 1 ? abs_offsets[n / 2] : 0.5 * (abs_offsets[n / 2 - 1] + abs_offsets[n / 2]);
  }
  return s;
}

Status write_csv(const std::vector<FrameEvaluation>& rows, const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) return fail(path + ": cannot be written");
  std::fputs("frame_index,t_s,run_distance_m,edge,style,edge_distance_m,map_index,map_distance_m,features,offset_px,"
             "heading_correction_rad,matches,inliers,confidence,valid,true_x_m,true_y_m,true_heading_rad\n",
             f);
  for (const auto& r : rows) {
    std::fprintf(f, "%ld,%.9g,%.6f,%s,%s,%.6f,%d,%.6f,%d,%.3f,%.6f,%d,%d,%.4f,%d,", r.frame_index, r.t_s, r.run_distance_m,
                 r.edge.c_str(), r.style.c_str(), r.edge_distance_m, r.map_index, r.map_distance_m, r.features,
                 r.estimate.offset_px, r.estimate.heading_correction_rad, r.estimate.matches, r.estimate.inliers,
                 r.estimate.confidence, r.estimate.valid ? 1 : 0);
    if (r.has_truth)
      std::fprintf(f, "%.6f,%.6f,%.6f\n", r.truth.x_m, r.truth.y_m, r.truth.heading_rad);
    else
      std::fputs(",,\n", f);
  }
  const bool good = std::ferror(f) == 0;
  if (std::fclose(f) != 0 || !good) return fail(path + ": write error");
  return ok();
}

}  // namespace visnav::evaluation
