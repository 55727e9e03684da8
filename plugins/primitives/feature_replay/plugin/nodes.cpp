// TeachFeatureEdge / ReplayFeatureEdge: the feature_replay core as an EdgeTeacher and an
// EdgeReplayer (see nodes.hpp); the runtime's adapter does the rest.
#include "nodes.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "payload_check.hpp"
#include "visnav/feature_replay/experience.hpp"
#include "visnav/feature_replay/heading.hpp"
#include "visnav/feature_replay/local_map.hpp"
#include "visnav/feature_replay/segment_map.hpp"
#include "visnav/feature_replay/start_view_search.hpp"
#include "visnav/map.hpp"
#include "visnav/primitive.hpp"

namespace visnav::feature_replay {
namespace {

std::string format_double(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3f", v);
  return buf;
}

// ------------------------------------------------------------------------------------ teach

/// Defaults of the nodes where they were tuned in the simulator (docs/feature_replay.md,
/// "Behaviour-tree nodes"); every other default is the core's.
LocalMapTeachParams tuned_local_map_teach() {
  LocalMapTeachParams p;
  p.command_tolerance = 0.01;
  return p;
}

struct FeatureTeachParams {
  std::string style = "segment";
  SegmentTeachParams segment;
  LocalMapTeachParams localmaps = tuned_local_map_teach();
  double min_record_speed_mps = 0.02;

  [[nodiscard]] Status validate() const {
    VISNAV_TRY(schema().check(*this));
    if (!(min_record_speed_mps > 0.0)) return fail("min_record_speed_mps must be > 0");
    VISNAV_TRY(segment.validate());
    return localmaps.validate();
  }
  static const ParamSchema<FeatureTeachParams>& schema() {
    using P = FeatureTeachParams;
    static const auto s =
        ParamSchema<P>{}
            .field("style", &P::style,
                   "map style: segment (A, seed 000: kind feature_segment) or localmaps (B, seed 002: kind "
                   "feature_localmaps)")
            .one_of({"segment", "localmaps"})
            .include(&P::segment, SegmentTeachParams::schema(),
                     {{"max_landmarks_per_m", "max_landmarks_per_m"},
                      {"min_observations", "min_observations"},
                      {"max_track_step_px", "max_track_step_px"}})
            .include(&P::localmaps, LocalMapTeachParams::schema(),
                     {{"map_interval_m", "map_spacing_m"},
                      {"max_features_per_map", "max_features_per_map"},
                      {"store_image", "store_image"},
                      {"command_tolerance", "command_tolerance"}})
            .field("min_record_speed_mps", &P::min_record_speed_mps,
                   "style B: twists slower than this are not recorded (replay is indexed by distance, so a "
                   "recorded stop or turn on the spot would halt the replay there), m/s")
            .range(0.0, 10.0);
    return s;
  }
};

class FeatureTeacher final : public EdgeTeacher {
 public:
  using Params = FeatureTeachParams;
  static constexpr bool kUsesDetector = true;
  explicit FeatureTeacher(const Params& params) : params_(params) {}

  Status begin(const TeachStart& start) override {
    if (params_.style == "segment") {
      segment_.emplace(params_.segment);
      segment_->begin(wrap_angle_rad(start.odometry.pose.heading_rad));
    } else {
      localmaps_.emplace(params_.localmaps);
      localmaps_->begin();
    }
    return ok();
  }

  Status step(const TeachInput& in) override {
    // Standing still or turning on the spot is not recorded: the replay is indexed by distance and
    // would stop there for ever (finish() records the final stop).
    if (localmaps_ && std::abs(in.odometry.twist.linear_mps) >= params_.min_record_speed_mps)
      localmaps_->record_command(in.edge_distance_m, in.odometry.twist);
    if (in.frame == nullptr) return ok();
    last_added_ = false;
    if (in.frame_problem != nullptr) return ok();
    // E.g. the detector was switched mid-edge (descriptor type changed): the adapter skips the frame.
    VISNAV_TRY(segment_ ? segment_->add_frame(in.edge_distance_m, *in.features)
                        : localmaps_->add_frame(in.edge_distance_m, *in.features, in.frame->image));
    last_added_ = true;
    return ok();
  }

  Result<TaughtEdge> finish(const TeachInput& last) override {
    TaughtEdge edge;
    if (segment_) {
      auto map = segment_->finish(last.edge_distance_m);
      if (!map) return fail("style A map: " + map.error().message);
      edge.payload = map->serialize();
      edge.kind = kSegmentKind;
      edge.statistics["landmarks"] = static_cast<double>(map->landmarks.size());
      return edge;
    }
    const Features none;
    auto path_map = localmaps_->finish(last.edge_distance_m, last_added_ ? *last.features : none,
                                       last.frame != nullptr ? last.frame->image : cv::Mat());
    if (!path_map) return fail("style B map: " + path_map.error().message);
    edge.payload = path_map->serialize();
    std::size_t features = 0;
    for (const auto& m : path_map->maps) features += m.positions_px.size();
    edge.kind = kLocalMapsKind;
    edge.statistics["local_maps"] = static_cast<double>(path_map->maps.size());
    edge.statistics["features"] = static_cast<double>(features);
    edge.statistics["commands"] = static_cast<double>(path_map->commands.size());
    return edge;
  }

 private:
  Params params_;
  std::optional<SegmentTeacher> segment_;
  std::optional<LocalMapTeacher> localmaps_;
  bool last_added_ = false;  ///< the latest frame's features are in the map (finish may store them)
};

// ----------------------------------------------------------------------------------- replay

SegmentReplayParams tuned_segment_replay() {
  SegmentReplayParams p;
  p.gain_radps_per_px = 0.01;  // tuned in the simulator (the core's 0.003 is seed 000's)
  // Per-frame along-track tracking off: on the campus experiment it made the hybrid result worse
  // (docs/feature_replay.md, "Along-track correction"). The end-window correction is on: its
  // estimates agreed with the ground truth within 0.08 m where its gates let them through.
  p.along_gain = 0.0;
  p.along_end_window_m = 1.0;
  return p;
}

struct FeatureReplayParams {
  SegmentReplayParams segment = tuned_segment_replay();
  LocalMapReplayParams localmaps;
  HeadingParams heading;
  double scan_deg = 75.0;
  double scan_speed_radps = 0.4;
  double start_max_offset = 0.15;
  int min_expected_features = 15;
  bool learn_experiences = false;
  double learn_hold_m = 1.0;
  int max_experiences = 4;
  double experience_recheck_below = 0.5;

  [[nodiscard]] Status validate() const {
    VISNAV_TRY(schema().check(*this));
    if (!(segment.speed_mps > 0.0 && segment.speed_mps <= 3.0)) return fail("speed_mps must be in (0, 3]");
    if (!(segment.max_angular_radps > 0.0)) return fail("max_angular_radps must be > 0");
    if (!(scan_speed_radps > 0.0)) return fail("scan_speed_radps must be > 0");
    VISNAV_TRY(segment.validate());
    VISNAV_TRY(localmaps.validate());
    return heading.validate();
  }
  static const ParamSchema<FeatureReplayParams>& schema() {
    using P = FeatureReplayParams;
    static const auto s =
        ParamSchema<P>{}
            .include(&P::segment, SegmentReplayParams::schema(), {{"speed_mps", "speed_mps"}})
            .range(0.0, 3.0)  // the node's limit (the core takes [-5, 5]); 0 is refused by validate()
            .include(&P::segment, SegmentReplayParams::schema(),
                     {{"gain_radps_per_px", "gain_radps_per_px"},
                      {"max_angular_radps", "max_angular_radps"},
                      {"distance_margin_m", "distance_margin_m"},
                      {"along_gain", "along_gain"},
                      {"max_along_step_m", "max_along_step_m"},
                      {"max_along_correction_m", "max_along_correction_m"},
                      {"along_end_window_m", "along_end_window_m"},
                      {"along_min_frames", "along_min_frames"},
                      {"along_max_sd_m", "along_max_sd_m"},
                      {"temporal_decay", "temporal_decay"},
                      {"temporal_hold_m", "temporal_hold_m"}})
            .include(&P::localmaps, LocalMapReplayParams::schema(),
                     {{"gain_radps_per_px", "correction_gain_radps_per_px"},
                      {"max_correction_radps", "max_correction_radps"},
                      {"laps", "laps"}})
            .include(&P::heading, HeadingParams::schema(), {{"ratio", "ratio"}, {"min_confidence", "min_confidence"}})
            .field("scan_deg", &P::scan_deg,
                   "start-view search: when an edge's first frames do not see its taught start view, turn in "
                   "place up to this far left and right to find it (0 = off; at most the lost policy's max_heading_deviation_deg "
                   "less 14 deg, so that a view found is not one the heading check refuses), deg")
            .range(0.0, 180.0)
            .field("scan_speed_radps", &P::scan_speed_radps, "start-view search: turn rate, rad/s")
            .range(0.0, 3.0)
            .field("start_max_offset", &P::start_max_offset,
                   "start-view search: the first frames see the start view only if their mean |offset| is at most "
                   "this fraction of the image width (0.15 of a 60 deg camera is 9 deg); a confident match farther "
                   "off means the robot faces away from the edge")
            .range(0.01, 0.5)
            .field("min_expected_features", &P::min_expected_features,
                   "lost policy: where the map holds fewer landmarks/features than this at the current distance, a "
                   "frame without a match does not count as blind (nothing was seen there when teaching either)")
            .range(0, 1000000)
            .field("learn_experiences", &P::learn_experiences,
                   "multi-experience maps: after the edge succeeds, store this replay's view of it as a new appearance "
                   "experience of the edge (<map>/experiences/<edge>.bin; docs/feature_replay.md)")
            .field("learn_hold_m", &P::learn_hold_m,
                   "multi-experience maps, learning: a frame without a confident match is stored with the last "
                   "confident offset for up to this distance, m; above 1 the edge start also counts as aligned, so "
                   "a stretch where nothing matches is learned as seen on odometry (pair with a longer max_blind_m)")
            .range(0.0, 1000.0)
            .field("max_experiences", &P::max_experiences,
                   "multi-experience maps: experiences kept per edge, the taught one included; learning one more "
                   "evicts the oldest learned one")
            .range(1, 64)
            .field("experience_recheck_below", &P::experience_recheck_below,
                   "multi-experience maps: the experience that matched the last frame is tried first; the others are "
                   "tried too only when its confidence is below this (1 = try all every frame)")
            .range(0.0, 1.0);
    return s;
  }
};

/// Replays a feature edge of either style against each of its appearance experiences (the taught
/// payload and those learned by earlier replays, experience.hpp): per frame the selector picks
/// the experience that matches best, trying the last frame's winner first. With
/// learn_experiences, the frames of this replay (registered to the reference heading) are taught
/// into a new map of the edge's style as they come and stored as a new experience when the edge
/// succeeds.
class FeatureReplayer final : public EdgeReplayer {
 public:
  using Params = FeatureReplayParams;
  static constexpr bool kUsesDetector = true;
  explicit FeatureReplayer(const Params& params, HostServices* host = nullptr) : params_(params), host_(host) {}

  Status begin(const ReplayStart& start) override {
    logger_ = &start.logger;
    who_ = std::string(start.node_path);
    edge_id_ = start.edge.id;
    // Laps drive a closed one-edge loop again from its start; on an open edge the next lap would
    // start where the edge ends and drive its first stretch again somewhere else (issue 38).
    if (params_.localmaps.laps > 1 && start.edge.from != start.edge.to)
      return fail(ErrorCode::inconsistent,
                  "laps=" + std::to_string(params_.localmaps.laps) + " on edge " + edge_id_ + ", which runs from node '" +
                      start.edge.from + "' to node '" + start.edge.to +
                      "': laps > 1 drives only a closed one-edge loop (from == to); give laps=1");
    MapStore* map = host_ != nullptr ? host_->map() : nullptr;
    map_dir_ = map != nullptr ? map->dir() : std::string();
    experiences_ = ExperienceSet{};
    experience_numbers_ = {0};
    if (!map_dir_.empty()) {
      VISNAV_ASSIGN(experiences_, load_experiences(map_dir_, edge_id_, start.payload));
      for (const Experience& e : experiences_.learned) experience_numbers_.push_back(e.number);
    }
    segments_.clear();
    localmaps_.clear();
    // Experience 0 is the taught payload; a learned body that does not decode names its file.
    auto add_body = [&](std::span<const std::uint8_t> body, std::size_t k) -> Status {
      auto where = [&](const Error& e) {
        return k == 0 ? e
                      : fail(ErrorCode::parse_error, ErrorLocation(experience_path(map_dir_, edge_id_), 0, edge_id_),
                             "experience " + std::to_string(experience_numbers_[k]) + ": " + e.message);
      };
      if (start.edge.kind == kSegmentKind) {
        auto map_body = SegmentMap::deserialize(body);
        if (!map_body) return where(map_body.error());
        segments_.emplace_back(std::make_shared<const SegmentMap>(std::move(*map_body)), params_.segment, params_.heading);
        if (!segments_.back().map_valid()) return where(Error{"invalid segment map"});
        segments_.back().begin(start.origin_m);
      } else {
        auto path = LocalMapPath::deserialize(body);
        if (!path) return where(path.error());
        localmaps_.emplace_back(std::make_shared<const LocalMapPath>(std::move(*path)), params_.localmaps, params_.heading);
        if (!localmaps_.back().path_valid()) return where(Error{"invalid local-map path"});
        localmaps_.back().begin(start.origin_m);
      }
      return ok();
    };
    VISNAV_TRY(add_body(start.payload, 0));
    for (std::size_t k = 0; k < experiences_.learned.size(); ++k) VISNAV_TRY(add_body(experiences_.learned[k].body, k + 1));
    // Where the taught evidence ends (any experience): past it a frame without a match is
    // counted as blind, so a replay beyond the last landmark stops within max_blind_m instead of
    // driving on an edge the map cannot back (issue 39: a crafted 500 m edge drove for 1,663 s).
    evidence_end_m_ = 0.0;
    for (const auto& seg : segments_) evidence_end_m_ = std::max(evidence_end_m_, evidence_end_m(seg.map()));
    for (const auto& lm : localmaps_) evidence_end_m_ = std::max(evidence_end_m_, evidence_end_m(lm.path()));
    const int count = static_cast<int>(experience_numbers_.size());
    selector_ = ExperienceSelector(count, params_.experience_recheck_below);
    segment_out_.assign(segments_.size(), SegmentReplayOutput{});
    along_notes_.clear();
    along_reported_ = false;
    localmap_out_.assign(localmaps_.size(), LocalMapReplayOutput{});
    if (count > 1)
      logger_->info(who_, "edge " + edge_id_ + ": " + std::to_string(count) + " appearance experiences");

    lap_seen_ = 0;
    learning_ = params_.learn_experiences && !map_dir_.empty();
    registrar_.reset(params_.learn_hold_m, params_.learn_hold_m > 1.0);
    learned_frames_ = 0;
    if (learning_) {
      if (!segments_.empty()) {
        segment_teacher_.emplace(SegmentTeachParams{});
        segment_teacher_->begin(segments_.front().map().azimuth_rad);
      } else {
        LocalMapTeachParams teach;
        teach.max_features_per_map = max_local_map_features();
        localmap_teacher_.emplace(teach);
        localmap_teacher_->begin();
      }
    }
    StartViewSearchParams search;
    search.scan_rad = params_.scan_deg * std::numbers::pi / 180.0;
    search.scan_speed_radps = params_.scan_speed_radps;
    search.max_offset = params_.start_max_offset;
    search.min_confidence = start.policy.min_confidence;
    search.max_heading_deviation_rad = heading_check() ? start.policy.max_heading_deviation_rad : 0.0;
    search_.begin(search, start.odometry.distance_m - start.origin_m);
    return ok();
  }

  /// A closed multi-lap path has no single taught heading profile.
  [[nodiscard]] bool heading_check() const override { return !segments_.empty() || params_.localmaps.laps == 1; }

  /// The live view's overlay: the votes of this frame (buffers reused from frame to frame).
  const NavOverlay* fill_overlay(const HeadingEstimator& estimator, const Features& current, double offset_px) {
    matched_px_.clear();
    reference_px_.clear();
    inlier_.clear();
    for (const FeatureMatch& m : estimator.last_matches()) {
      if (m.current_index < 0 || static_cast<std::size_t>(m.current_index) >= current.keypoints.size()) continue;
      const cv::Point2f p = current.keypoints[static_cast<std::size_t>(m.current_index)].pt;
      matched_px_.push_back(p);
      reference_px_.emplace_back(p.x - m.du_px, p.y - m.dv_px);
      inlier_.push_back(m.inlier ? 1 : 0);
    }
    overlay_.matched_px = matched_px_;
    overlay_.reference_px = reference_px_;
    overlay_.inlier = inlier_;
    overlay_.histogram = estimator.last_histogram();
    overlay_.histogram_bin_px = estimator.params().bin_width_px;
    overlay_.offset_px = offset_px;
    return &overlay_;
  }

  ReplayStep step(const ReplayInput& in) override {
    const double width_px = in.frame.image.empty() ? 0.0 : static_cast<double>(in.frame.image.cols);
    ReplayStep out;
    ReplayState state;
    HeadingEstimate estimate;
    const int previous = selector_.current();
    int lap = 0;
    double distance_m = 0.0;
    const HeadingEstimator* estimator = nullptr;
    if (!segments_.empty()) {
      const int k = selector_.select([&](int i) {
        SegmentReplayOutput& r = segment_out_[static_cast<std::size_t>(i)];
        // Horizontal axis only: a camera pitched down has its focus of expansion above the image
        // centre, where the core's vertical model puts it (suspected bias, docs/feature_replay.md).
        r = segments_[static_cast<std::size_t>(i)].step(in.odometry.distance_m, *in.features, width_px, 0.0,
                                                         in.odometry.pose.heading_rad);
        return ExperienceSelector::Score{r.estimate.confidence, r.estimate.inliers};
      });
      const SegmentReplayOutput& r = segment_out_[static_cast<std::size_t>(k)];
      estimator = &segments_[static_cast<std::size_t>(k)].estimator();
      out.command = r.command;
      state = r.state;
      out.finished = r.finished;
      out.distance_m = r.distance_m;
      estimate = r.estimate;
      out.saturated = state == ReplayState::steering &&
                      std::abs(out.command.angular_radps) >= params_.segment.max_angular_radps - 1e-9;
      out.informative = r.expected_landmarks >= params_.min_expected_features || r.distance_m > evidence_end_m_;
      note_along(r, segments_[static_cast<std::size_t>(k)].map().length_m);
    } else {
      const int k = selector_.select([&](int i) {
        LocalMapReplayOutput& r = localmap_out_[static_cast<std::size_t>(i)];
        r = localmaps_[static_cast<std::size_t>(i)].step(in.odometry.distance_m, *in.features, width_px);
        return ExperienceSelector::Score{r.estimate.confidence, r.estimate.inliers};
      });
      const LocalMapReplayer& replayer = localmaps_[static_cast<std::size_t>(k)];
      const LocalMapReplayOutput& r = localmap_out_[static_cast<std::size_t>(k)];
      estimator = &replayer.estimator();
      out.command = r.command;
      state = r.state;
      out.finished = r.finished;
      out.distance_m = r.distance_m;
      estimate = r.estimate;
      const double clamp = params_.localmaps.max_correction_radps;
      out.saturated = state == ReplayState::steering && clamp > 0.0 && std::abs(r.correction_radps) >= clamp - 1e-9;
      const auto& maps = replayer.path().maps;
      out.informative = r.map_index < 0 || r.map_index >= static_cast<int>(maps.size()) ||
                        static_cast<int>(maps[static_cast<std::size_t>(r.map_index)].positions_px.size()) >=
                            params_.min_expected_features ||
                        r.distance_m > evidence_end_m_;
      out.lap = r.lap;
      // Laps are counted by the experience driving; one that was not stepped catches up when it is.
      if (r.lap > lap_seen_) {
        lap_seen_ = r.lap;
        logger_->info(who_, "edge " + edge_id_ + ": lap " + std::to_string(r.lap + 1) + " started");
      }
    }
    lap = out.lap;
    distance_m = out.distance_m;
    if (selector_.current() != previous)
      logger_->log(LogLevel::debug, who_,
                   "edge " + edge_id_ + ": experience " +
                       std::to_string(experience_numbers_[static_cast<std::size_t>(selector_.current())]) +
                       " matches best (confidence " + format_double(estimate.confidence) + ")");
    out.matches = estimate.matches;
    out.inliers = estimate.inliers;
    out.offset_px = estimate.offset_px;
    out.overlay = fill_overlay(*estimator, *in.features, estimate.offset_px);
    out.confidence = in.frame_problem != nullptr ? 0.0 : estimate.confidence;
    out.status = to_string(state);
    if (state != last_state_ && (state == ReplayState::low_confidence || state == ReplayState::no_features ||
                                 state == ReplayState::bad_input))
      logger_->log(LogLevel::debug, who_, "edge " + edge_id_ + ": " + to_string(state) + " (no correction)");
    last_state_ = state;

    bool orienting = false;
    if (search_.searching()) {
      const bool probing = search_.probing();
      const double offset_fraction = width_px > 0.0 ? std::abs(out.offset_px) / width_px : 1.0;
      if (auto turn = search_.update(in.odometry.pose.heading_rad, out.confidence, offset_fraction, out.informative,
                                     *logger_, who_, edge_id_)) {
        out.command = *turn;
        out.orienting = true;
        orienting = true;
        out.status = probing ? "looking for the start view" : "turning to find the start view";
      }
    }
    // Learning: the first lap's frames while driving the edge (not while looking for its start).
    if (learning_ && !orienting && !out.finished && lap == 0 && in.frame_problem == nullptr && in.features != nullptr) {
      if (const Features* view = registrar_.add(distance_m, *in.features, estimate)) {
        const double d = std::max(0.0, distance_m);
        const Status st = segment_teacher_ ? segment_teacher_->add_frame(d, *view)
                                           : localmap_teacher_->add_frame(d, *view);
        if (st) ++learned_frames_;
      }
    }
    return out;
  }

  /// Stores what this replay saw as a new experience of the edge (learn_experiences).
  Status succeeded() override {
    if (!learning_) return ok();
    learning_ = false;
    if (learned_frames_ < 3)
      return fail("learned no experience: only " + std::to_string(learned_frames_) +
                  " frames of this replay could be registered to the map");
    Experience e;
    e.created = utc_now_iso();
    e.source = "replay by " + who_;
    std::string size;
    if (segment_teacher_) {
      const SegmentMap& teach = segments_.front().map();
      VISNAV_ASSIGN(SegmentMap learned, segment_teacher_->finish(teach.length_m));
      learned.azimuth_rad = teach.azimuth_rad;
      if (learned.landmarks.empty()) return fail("learned no experience: no landmark was tracked long enough");
      size = std::to_string(learned.landmarks.size()) + " landmarks";
      e.body = learned.serialize();
    } else {
      const LocalMapPath& teach = localmaps_.front().path();
      const Features none;
      VISNAV_ASSIGN(LocalMapPath learned, localmap_teacher_->finish(teach.length_m, none));
      // The route's commands stay the taught ones; only the appearance is learned.
      learned.commands = teach.commands;
      learned.length_m = teach.length_m;
      while (!learned.maps.empty() && learned.maps.back().distance_m > teach.length_m) learned.maps.pop_back();
      if (learned.maps.empty()) return fail("learned no experience: no local map was stored");
      VISNAV_TRY(learned.validate());
      size = std::to_string(learned.maps.size()) + " local maps";
      e.body = learned.serialize();
    }
    const std::size_t bytes = e.body.size();
    const auto evicted = experiences_.add(std::move(e), params_.max_experiences);
    VISNAV_TRY(save_experiences(map_dir_, edge_id_, experiences_));
    std::string message = "edge " + edge_id_ + ": learned experience " +
                          std::to_string(experiences_.learned.empty() ? 0 : experiences_.learned.back().number) + " (" +
                          size + ", " + std::to_string(bytes) + " bytes, " + std::to_string(learned_frames_) + " frames)";
    for (std::uint32_t n : evicted) message += "; evicted experience " + std::to_string(n);
    logger_->info(who_, message);
    return ok();
  }

 private:
  /// Instrumentation of the along-track estimate (docs/navigation.md, "Along-track estimate vs
  /// truth"): the frames' estimates facing the view are summarised at the edge's end in a debug
  /// line, to be compared with the experiment's edges.csv (the truth the replay cannot see).
  void note_along(const SegmentReplayOutput& r, double length_m) {
    if (std::isfinite(r.along_error_m) && std::abs(r.estimate.offset_px) <= params_.segment.along_max_offset_px)
      along_notes_.push_back({r.distance_m - r.along_correction_m, r.along_error_m});
    if (!r.finished || along_reported_) return;
    along_reported_ = true;
    double sum_all = 0.0, sum_end = 0.0, sq_end = 0.0;
    int n_end = 0;
    for (const auto& [d, e] : along_notes_) {
      sum_all += e;
      if (d < length_m - 1.0) continue;
      sum_end += e;
      sq_end += e * e;
      ++n_end;
    }
    const double mean_end = n_end > 0 ? sum_end / n_end : std::numeric_limits<double>::quiet_NaN();
    const double sd_end = n_end > 1 ? std::sqrt(std::max(0.0, sq_end / n_end - mean_end * mean_end)) : 0.0;
    logger_->log(LogLevel::debug, who_, "edge " + edge_id_ + ": along-track estimate, last 1 m: mean " + format_double(mean_end) +
                            " sd " + format_double(sd_end) + " m (" + std::to_string(n_end) + " frames); whole edge: mean " +
                            format_double(along_notes_.empty() ? 0.0 : sum_all / static_cast<double>(along_notes_.size())) +
                            " m (" + std::to_string(along_notes_.size()) + " frames); correction " +
                            format_double(segments_.front().along_correction_m()) + " m");
  }

  /// Local maps learned keep as many features as the taught ones hold at most (bounded size).
  [[nodiscard]] int max_local_map_features() const {
    std::size_t most = 0;
    for (const auto& m : localmaps_.front().path().maps) most = std::max(most, m.positions_px.size());
    return static_cast<int>(most);
  }

  Params params_;
  HostServices* host_ = nullptr;
  Logger* logger_ = nullptr;
  std::string who_;
  std::string edge_id_;
  std::string map_dir_;
  // One replayer per experience (index 0: the taught payload); only one style is non-empty.
  std::vector<SegmentReplayer> segments_;
  std::vector<LocalMapReplayer> localmaps_;
  std::vector<SegmentReplayOutput> segment_out_;
  std::vector<LocalMapReplayOutput> localmap_out_;
  ExperienceSet experiences_;
  std::vector<std::uint32_t> experience_numbers_;
  ExperienceSelector selector_;
  int lap_seen_ = 0;
  double evidence_end_m_ = 0.0;  ///< farthest taught landmark / local map over the experiences
  // Learning (learn_experiences).
  bool learning_ = false;
  ViewRegistrar registrar_;
  std::optional<SegmentTeacher> segment_teacher_;
  std::optional<LocalMapTeacher> localmap_teacher_;
  int learned_frames_ = 0;
  ReplayState last_state_ = ReplayState::steering;
  std::vector<std::pair<double, double>> along_notes_;  // (odometric distance on the edge, estimate) facing the view
  bool along_reported_ = false;
  StartViewSearch search_;
  NavOverlay overlay_;
  std::vector<cv::Point2f> matched_px_, reference_px_;
  std::vector<std::uint8_t> inlier_;
};

}  // namespace

Status register_feature_nodes(bt::NodeRegistry& registry, HostServices& host) {
  VISNAV_TRY(register_teacher<FeatureTeacher>(
      registry, host, "TeachFeatureEdge",
      "Records a feature edge while the operator drives: style segment (feature_segment, seed 000) or localmaps "
      "(feature_localmaps, seed 002)",
      {kSegmentKind, kLocalMapsKind}));
  // The replayer reads and writes the map's experience files, so it is made with the host (the
  // template's factory passes the params only).
  PrimitiveType replay = detail::primitive_type<FeatureReplayer, EdgeReplayer>(
      "ReplayFeatureEdge",
      "Traverses a feature_segment or feature_localmaps edge, steering by histogram voting of feature offsets against "
      "the best-matching appearance experience of the edge (optionally learning a new one)",
      {kSegmentKind, kLocalMapsKind});
  replay.make_replayer = [host = &host](const ConfigNode& params) noexcept -> Result<std::unique_ptr<EdgeReplayer>> {
    try {
      VISNAV_ASSIGN(FeatureReplayParams p, FeatureReplayParams::schema().parse(params));
      return std::unique_ptr<EdgeReplayer>(std::make_unique<FeatureReplayer>(p, host));
    } catch (const std::exception& e) {
      return fail(std::string("primitive constructor threw: ") + e.what());
    }
  };
  return register_replayer_type(registry, host, std::move(replay));
}

}  // namespace visnav::feature_replay
