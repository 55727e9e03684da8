#include "nodes.hpp"

#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "visnav/edge_evidence.hpp"
#include "visnav/map.hpp"
#include "visnav/path_payload.hpp"
#include "visnav/primitive.hpp"
#include "visnav/path_following/along_track.hpp"
#include "visnav/path_following/path_follower.hpp"
#include "visnav/path_following/path_loss_monitor.hpp"
#include "visnav/path_following/taught_offset.hpp"

namespace visnav::path_following {
namespace {

constexpr const char* kKind = "path_following";

// The payload codec is the SDK's (visnav/path_payload.hpp: VPF1 colour models only, VPF2 also
// the thumbnails relocalisation indexes); these convert the colour models to and from it.
std::vector<path_payload::ColourModelData> to_data(const std::vector<ColourModel>& models) {
  std::vector<path_payload::ColourModelData> out(models.size());
  for (std::size_t k = 0; k < models.size(); ++k) {
    for (int i = 0; i < 3; ++i) out[k].mean[static_cast<std::size_t>(i)] = models[k].mean[i];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) out[k].cov[static_cast<std::size_t>(r * 3 + c)] = models[k].cov(r, c);
  }
  return out;
}

std::vector<ColourModel> from_data(const path_payload::PathPayload& p) {
  std::vector<ColourModel> models(p.models.size());
  for (std::size_t k = 0; k < models.size(); ++k) {
    for (int i = 0; i < 3; ++i) models[k].mean[i] = p.models[k].mean[static_cast<std::size_t>(i)];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) models[k].cov(r, c) = p.models[k].cov[static_cast<std::size_t>(r * 3 + c)];
  }
  return models;
}


/// The follower's params as both nodes expose them (names predate the core's; declared once in
/// PathFollowerParams::schema()). Replay port defaults differ from the core's where the trees
/// were tuned: model_blend 0.3.
const std::vector<std::pair<std::string, std::string>> kFollowerPorts = {
    {"max_linear_mps", "max_speed_mps"}, {"alpha_radps", "steer_gain_radps"}, {"grace_s", "grace_s"},
    {"model_blend", "model_blend"},      {"taught_gate_distance", "taught_gate_distance"}};

PathFollowerParams tuned_follower() {
  PathFollowerParams p;
  p.model_blend = 0.3;
  return p;
}

struct FollowPathParams {
  PathFollowerParams follower = tuned_follower();
  AlongTrackParams along;  ///< the edge's end from its taught thumbnails (along_track.hpp)
  TaughtOffsetParams lateral;  ///< the taught lateral position (taught_offset.hpp)
  double junction_clear_m = 2.0;     ///< junction mode for this long after the start node
  double junction_approach_m = 0.0;  ///< and this long before the end node; 0 = off

  [[nodiscard]] Status validate() const {
    VISNAV_TRY(schema().check(*this));
    VISNAV_TRY(along.validate());
    VISNAV_TRY(lateral.validate());
    return follower.validate();
  }
  static const ParamSchema<FollowPathParams>& schema() {
    static const auto s = ParamSchema<FollowPathParams>{}
                              .include(&FollowPathParams::follower, PathFollowerParams::schema(), kFollowerPorts)
                              .include(&FollowPathParams::along, AlongTrackParams::schema(),
                                       {{"along_gain", "along_gain"},
                                        {"along_window_m", "along_window_m"},
                                        {"along_max_shift_px", "along_max_shift_px"},
                                        {"along_min_ncc", "along_min_ncc"},
                                        {"along_min_contrast", "along_min_contrast"},
                                        {"along_gate_m", "along_gate_m"},
                                        {"along_max_shift_m", "along_max_shift_m"}})
                              .include(&FollowPathParams::lateral, TaughtOffsetParams::schema(),
                                       {{"taught_offset_gain", "taught_offset_gain"},
                                        {"taught_offset_window_m", "taught_offset_window_m"},
                                        {"taught_offset_max_sd", "taught_offset_max_sd"}})
                              .field("junction_clear_m", &FollowPathParams::junction_clear_m,
                                     "junction mode for this long after the start node (see path_follower.hpp), m")
                              .range(0.0, 1000.0)
                              .field("junction_approach_m", &FollowPathParams::junction_approach_m,
                                     "junction mode also for this long before the edge's end node (an L corner or "
                                     "junction ahead pulls the follower into cutting it), m; 0 = off")
                              .range(0.0, 1000.0);
    return s;
  }
};

/// FollowPathEdge: control law (1) until the edge's odometric length; its own "path lost"
/// (grace_s without the path) besides the shared lost policy.
class PathReplayer final : public EdgeReplayer {
 public:
  using Params = FollowPathParams;
  static constexpr bool kUsesDetector = false;
  explicit PathReplayer(const Params& params) : params_(params), monitor_(params.follower.grace_s) {}

  Status begin(const ReplayStart& start) override {
    // Decoded once: the colour models for the follower, the thumbnails for the along-track estimate.
    VISNAV_ASSIGN(path_payload::PathPayload payload, path_payload::PathPayload::decode(start.payload));
    const std::vector<ColourModel> models = from_data(payload);
    along_.emplace(params_.along, payload.thumbnails);
    lateral_.emplace(params_.lateral, std::move(payload.offsets));
    logger_ = &start.logger;
    node_path_ = std::string(start.node_path);
    VISNAV_ASSIGN(PathFollower made, PathFollower::create(params_.follower));
    follower_.emplace(std::move(made));
    follower_->set_taught_models(models);  // the gate (inactive when taught_gate_distance = 0)
    if (params_.follower.model_blend > 0.0) follower_->set_prior_models(models);
    length_m_ = start.edge.length_m;
    edge_id_ = start.edge.id;
    return ok();
  }

  ReplayStep step(const ReplayInput& in) override {
    ReplayStep out;
    // Where along the taught edge the robot is: odometry, corrected by the taught thumbnails.
    if (along_->active() && in.frame_problem == nullptr) along_->update(in.frame.image, in.edge_distance_m);
    const double taught_m = in.edge_distance_m + along_->shift_m();
    out.distance_m = taught_m;
    out.offset_px = offset_px_;
    if (taught_m >= length_m_) {
      out.finished = true;
      out.informative = false;  // the end is decided by distance; this frame is not steered on
      out.status = "edge done";
      if (along_->active() && logger_ != nullptr)
        logger_->info(node_path_, "edge " + edge_id_ + ": ended at " + format_m(in.edge_distance_m) + " m of odometry (" +
                                      format_m(length_m_) + " m taught; along-track correction " +
                                      format_m(along_->shift_m()) + " m from " + std::to_string(along_->accepted()) +
                                      " of " + std::to_string(along_->accepted() + along_->rejected()) + " frames)");
      return out;
    }
    const bool junction = in.edge_distance_m < params_.junction_clear_m ||
                          length_m_ - in.edge_distance_m < params_.junction_approach_m;
    follower_->set_junction_mode(junction);
    // Steer to where the path lay in the teacher's view here (held where the profile has no sample).
    if (const auto target = lateral_->target(taught_m, junction)) follower_->set_target_offset(*target);
    Status processed = in.frame_problem != nullptr ? Status(fail(in.frame_problem))
                                                   : follower_->process(in.frame.image, estimate_);
    if (!processed) {
      // An unusable frame counts as not seeing the path.
      out.status = "bad frame: " + processed.error().message;
      verdict_ = monitor_.update(in.frame.timestamp_s, PathStatus::no_reference);
    } else {
      out.confidence = estimate_.status == PathStatus::ok ? 1.0 : 0.0;
      out.status = to_string(estimate_.status);
      if (estimate_.reference_source != ReferenceSource::learned)
        out.status += " (path models drifted from the taught appearance: " +
                      std::string(to_string(estimate_.reference_source)) + " models kept)";
      verdict_ = monitor_.update(in.frame.timestamp_s, estimate_.status);
      out.command = estimate_.command;  // zero unless the path is seen
      offset_px_ = estimate_.mean_offset * in.frame.image.cols / 2.0;
      out.offset_px = offset_px_;
      // The live view's overlay: the segmented path and its centre line (the follower's buffers).
      overlay_.path_mask = estimate_.mask;
      overlay_.path_middle_px = estimate_.middle_points;
      overlay_.offset_px = offset_px_;
      out.overlay = &overlay_;
    }
    if (verdict_ == PathLossMonitor::Verdict::lost) {
      const auto reason = monitor_.last_bad_status();
      out.status = "path lost";
      out.failure_code = replay_failure::view_lost;
      out.failure = "path lost on edge " + edge_id_ + " (" +
                    std::string(reason ? to_string(*reason) : std::string_view("unknown")) + " for more than " +
                    std::to_string(monitor_.grace_s()) + " s)";
    }
    return out;
  }

 private:
  static std::string format_m(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2f", v);
    return buf;
  }

  NavOverlay overlay_;
  Params params_;
  std::optional<AlongTrackEstimator> along_;
  std::optional<TaughtOffsetProfile> lateral_;
  Logger* logger_ = nullptr;
  std::string node_path_;
  std::optional<PathFollower> follower_;
  PathEstimate estimate_;
  PathLossMonitor monitor_;
  PathLossMonitor::Verdict verdict_ = PathLossMonitor::Verdict::ok;
  double offset_px_ = 0.0;  ///< mean path-centre offset from the image centre, px (+ = right)
  double length_m_ = 0.0;
  std::string edge_id_;
};

struct TeachPathParams {
  PathFollowerParams follower = tuned_follower();
  int learn_every = 5;  ///< learn the path appearance every N frames
  double thumbnail_spacing_m = 0.5;  ///< a place thumbnail every this much edge distance (0 = none), m

  [[nodiscard]] Status validate() const {
    VISNAV_TRY(schema().check(*this));
    return follower.validate();
  }
  static const ParamSchema<TeachPathParams>& schema() {
    static const auto s = ParamSchema<TeachPathParams>{}
                              .field("learn_every", &TeachPathParams::learn_every, "learn the path appearance every N frames")
                              .range(1, 100000)
                              .field("thumbnail_spacing_m", &TeachPathParams::thumbnail_spacing_m,
                                     "store a low-resolution grey thumbnail of the view every this much edge "
                                     "distance, for relocalisation's place index (0 = none: the edge cannot be "
                                     "recognised), m")
                              .range(0.0, 100.0)
                              .include(&TeachPathParams::follower, PathFollowerParams::schema(), kFollowerPorts);
    return s;
  }
};

/// TeachPathEdge: the edge's payload is the path's appearance summary over the teach frames.
class PathTeacher final : public EdgeTeacher {
 public:
  using Params = TeachPathParams;
  static constexpr bool kUsesDetector = false;
  explicit PathTeacher(const Params& params) : params_(params), summary_(params.follower) {}

  Status begin(const TeachStart& /*start*/) override {
    VISNAV_ASSIGN(PathFollower made, PathFollower::create(params_.follower));
    follower_.emplace(std::move(made));
    thumbnails_.clear();
    offsets_.clear();
    return ok();
  }

  Status step(const TeachInput& in) override {
    if (in.frame == nullptr || in.frame_problem != nullptr) return ok();
    // A thumbnail at the first frame and then every thumbnail_spacing_m of edge distance.
    if (params_.thumbnail_spacing_m > 0.0 &&
        (thumbnails_.empty() || in.edge_distance_m >= thumbnails_.back().distance_m + params_.thumbnail_spacing_m)) {
      VISNAV_ASSIGN(cv::Mat thumb, path_payload::make_thumbnail(in.frame->image));
      thumbnails_.push_back({in.edge_distance_m, std::move(thumb)});
    }
    if (frames_++ % params_.learn_every != 0) return ok();
    if (follower_->process(in.frame->image, estimate_).ok() && estimate_.status == PathStatus::ok) {
      summary_.add_frame(follower_->reference_models());
      ++seen_ok_;
      // Where the path lay in the view where the teacher drove (the replay repeats it).
      if (offsets_.empty() || in.edge_distance_m >= offsets_.back().distance_m)
        offsets_.push_back({in.edge_distance_m, estimate_.plain_offset, estimate_.junction_offset});
    }
    return ok();
  }

  Result<TaughtEdge> finish(const TeachInput& /*last*/) override {
    TaughtEdge edge;
    edge.kind = kKind;
    const std::vector<ColourModel> models = summary_.summary();
    path_payload::PathPayload payload;
    payload.models = to_data(models);
    payload.thumbnails = std::move(thumbnails_);
    thumbnails_.clear();
    payload.offsets = std::move(offsets_);
    offsets_.clear();
    edge.payload = payload.encode();
    edge.statistics["thumbnails"] = static_cast<double>(payload.thumbnails.size());
    edge.statistics["colour_models"] = static_cast<double>(models.size());
    edge.statistics["frames_path_seen"] = static_cast<double>(seen_ok_);
    return edge;
  }

 private:
  Params params_;
  std::optional<PathFollower> follower_;
  PathEstimate estimate_;
  AppearanceSummary summary_;  ///< the path's appearance over the edge (see path_follower.hpp)
  int frames_ = 0;
  int seen_ok_ = 0;
  std::vector<path_payload::Thumbnail> thumbnails_;  ///< by increasing edge distance
  std::vector<path_payload::OffsetSample> offsets_;  ///< per learn frame with the path seen
};

}  // namespace

Status register_path_nodes(bt::NodeRegistry& registry, HostServices& host) {
  VISNAV_TRY(register_replayer<PathReplayer>(
      registry, host, "FollowPathEdge", "Follows the visible path (segmentation, seed 000 Sec. 4) along a path_following edge",
      {kKind}));
  return register_teacher<PathTeacher>(registry, host, "TeachPathEdge",
                                       "Teaches a path_following edge: its odometric length and the path's appearance",
                                       {kKind});
}

Status check_path_payload(std::span<const std::uint8_t> body, const EdgeRecord& edge) noexcept {
  try {
    auto payload = path_payload::PathPayload::decode(body);
    if (!payload) return std::move(payload).error();
    if (edge.from == edge.to)
      return fail(ErrorCode::inconsistent,
                  "edge from node '" + edge.from + "' to itself: a path_following edge joins two places");
    // The thumbnails and the offset profile say how far the teacher saw the path (VPF2/VPF3);
    // a VPF1 body carries no position along the edge, so its length cannot be checked.
    double evidence_end_m = -1.0;
    if (!payload->thumbnails.empty()) evidence_end_m = payload->thumbnails.back().distance_m;
    if (!payload->offsets.empty()) evidence_end_m = std::max(evidence_end_m, payload->offsets.back().distance_m);
    if (evidence_end_m >= 0.0) return check_length_evidence(edge.length_m, evidence_end_m, "thumbnails");
    return ok();
  } catch (...) {  // decoding allocates; an allocation failure must not cross the ABI
    return fail("path-following payload reader threw an exception");
  }
}

}  // namespace visnav::path_following
