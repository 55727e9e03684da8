// Relocalise and BuildPlaceIndex: thin adapters over the relocalisation core (see nodes.hpp).
#include "nodes.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "visnav/bt/node.hpp"
#include "visnav/bt/param_ports.hpp"
#include "visnav/map.hpp"
#include "visnav/relocalisation/place_index.hpp"
#include "visnav/relocalisation/relocaliser.hpp"
#include "visnav/relocalisation/verifier.hpp"

namespace visnav::reloc {
namespace {

using bt::NodeStatus;

std::string fmt(double v, int digits = 3) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

double wrap(double a) {
  const double r = std::remainder(a, 2.0 * std::numbers::pi);
  return r <= -std::numbers::pi ? r + 2.0 * std::numbers::pi : r;
}

/// The node's parameters: the decision's, the look-around turn and the camera's field of view.
struct RelocaliseNodeParams {
  RelocaliseParams decision;
  double look_around_deg = 0.0;
  double turn_speed_radps = 0.3;
  double horizontal_fov_deg = 60.0;
  double creep_m = 0.0;
  double creep_speed_mps = 0.2;
  int creep_unrecognised = 0;

  [[nodiscard]] Status validate() const {
    VISNAV_TRY(schema().check(*this));
    return decision.validate();
  }
  static const ParamSchema<RelocaliseNodeParams>& schema() {
    using P = RelocaliseNodeParams;
    static const auto s =
        ParamSchema<P>{}
            .include(&P::decision, RelocaliseParams::schema(),
                     {{"frames", "frames"},
                      {"max_frames", "max_frames"},
                      {"candidates", "candidates"},
                      {"min_confidence", "min_confidence"},
                      {"place_tolerance_m", "place_tolerance_m"},
                      {"max_runner_up_ratio", "max_runner_up_ratio"},
                      {"min_agreement", "min_agreement"},
                      {"min_answer_confidence", "min_answer_confidence"},
                      {"min_features", "min_features"},
                      {"min_image_stddev", "min_image_stddev"},
                      {"prior_sigma_m", "prior_sigma_m"},
                      {"thumbnail_candidates", "thumbnail_candidates"},
                      {"min_thumbnail_ncc", "min_thumbnail_ncc"},
                      {"thumbnail_confident_ncc", "thumbnail_confident_ncc"},
                      {"thumbnail_vote_weight", "thumbnail_vote_weight"},
                      {"thumbnail_max_shift_deg", "thumbnail_max_shift_deg"},
                      {"thumbnail_coarse_candidates", "thumbnail_coarse_candidates"},
                      {"thumbnail_index_candidates", "thumbnail_index_candidates"},
                      {"min_cell_agreement", "min_cell_agreement"},
                      {"max_cell_uncertainty_m", "max_cell_uncertainty_m"},
                      {"max_along_uncertainty_m", "max_along_uncertainty_m"}})
            .field("look_around_deg", &P::look_around_deg,
                   "turn in place this far left, then right, then back while taking frames (0 = stand still), deg")
            .range(0.0, 180.0)
            .field("turn_speed_radps", &P::turn_speed_radps, "turn rate while looking around, rad/s")
            .range(0.05, 2.0)
            .field("horizontal_fov_deg", &P::horizontal_fov_deg,
                   "camera horizontal field of view (converts image offsets to heading offsets), deg")
            .range(1.0, 360.0)
            .field("creep_m", &P::creep_m,
                   "after `frames` frames, creep this far forward (steering to the best place's taught heading) "
                   "while taking frames, and answer only then (0 = never drive forward), m")
            .range(0.0, 5.0)
            .field("creep_speed_mps", &P::creep_speed_mps, "forward speed while creeping, m/s")
            .range(0.02, 1.0)
            .field("creep_unrecognised", &P::creep_unrecognised,
                   "1: creep even when no place was verified in the first frames (else not_on_map at once)")
            .range(0, 1);
    return s;
  }
};

/// The map's place index: loaded and checked against the map, or built (and saved) when the map
/// has none yet. A damaged or stale index is an error (rebuilt by `visnav reloc-index M`).
Result<std::shared_ptr<const PlaceIndex>> index_for(const MapStore& map, Detector* detector, Logger& logger,
                                                    const std::string& who) {
  auto loaded = load_place_index(map.dir());
  if (loaded) {
    VISNAV_TRY(loaded->matches(map));
    // visual_memory places described by another detector than the run's: refused, never queried.
    VISNAV_TRY(check_detector(map, *loaded, detector));
    return std::make_shared<const PlaceIndex>(std::move(*loaded));
  }
  if (loaded.error().code != ErrorCode::not_found) return std::move(loaded).error();
  logger.warn(who, map.dir() + ": no place index yet; building it now");
  int last_tenth = -1;
  std::string last_phase;
  const auto t0 = std::chrono::steady_clock::now();
  auto built = build_place_index(map, PlaceIndexParams{}, detector, [&](const char* phase, double done, double total) {
    const int tenth = total > 0.0 ? static_cast<int>(10.0 * done / total) : 10;
    if (phase != last_phase || tenth != last_tenth) {
      if (phase != last_phase || tenth % 5 == 0)
        logger.info(who, std::string("building the place index: ") + phase + " " + std::to_string(tenth * 10) + " %");
      last_phase = phase;
      last_tenth = tenth;
    }
  });
  if (!built) return std::move(built).error();
  VISNAV_TRY(save_place_index(map.dir(), *built));
  logger.info(who, "place index built: " + std::to_string(built->places.size()) + " places in " +
                       fmt(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 1) +
                       " s, saved to " + index_path(map.dir()));
  return std::make_shared<const PlaceIndex>(std::move(*built));
}

// -------------------------------------------------------------------------------- Relocalise

class Relocalise final : public bt::StatefulActionNode {
 public:
  Relocalise(const std::string& name, const bt::NodeConfig& config, HostServices& host)
      : StatefulActionNode(name, config), host_(host) {}

  static bt::PortsList provided_ports() {
    bt::PortsList p = {
        bt::input_port<std::string>("prior_edge", "",
                                    "odometry prior: the edge the robot is believed to be on (empty = none; used "
                                    "with prior_sigma_m > 0)"),
        bt::input_port<double>("prior_distance_m", "0", "odometry prior: distance along prior_edge, m"),
        bt::output_port<std::string>("edge", "{reloc_edge}", "edge the robot is on"),
        bt::output_port<double>("distance_m", "{reloc_distance_m}", "distance along that edge from its start, m"),
        bt::output_port<double>("heading_offset_rad", "{reloc_heading_offset_rad}",
                                "robot heading minus the taught heading there, rad (CCW +)"),
        bt::output_port<double>("turn_rad", "{reloc_turn_rad}",
                                "turn that faces the taught heading (-heading_offset_rad), for TurnToAzimuth relative"),
        bt::output_port<double>("confidence", "{reloc_confidence}", "[0, 1]"),
        bt::output_port<double>("along_uncertainty_m", "{reloc_along_uncertainty_m}",
                                "how far the truth may be from distance_m along the route (place spacing, "
                                "spread of the frames' votes), m"),
        bt::output_port<std::string>("status", "{reloc_status}",
                                     "localised, ambiguous, not_on_map, camera_blocked, or not_indexed (prior_edge "
                                     "is of a kind the index does not cover, e.g. path_following)"),
        bt::output_port<std::string>("reason", "{reloc_reason}", "one line: why this answer"),
    };
    bt::append_param_ports(p, RelocaliseNodeParams::schema());  // ranges checked on literals
    return p;
  }

  NodeStatus on_start() override {
    if (auto st = start(); !st) return failed(st.error().message);
    if (!not_indexed_.empty()) {  // the prior names an edge nothing can be recognised on: say so, never guess
      stop();
      (void)set_output("status", std::string("not_indexed"));
      (void)set_output("reason", not_indexed_);
      (void)set_output("confidence", 0.0);
      host_.logger().warn(path(), not_indexed_);
      return NodeStatus::failure;
    }
    return on_running();
  }

  NodeStatus on_running() override {
    FrameBus& bus = *host_.frame_bus();
    const auto odom = bus.latest_odometry();
    const auto frame = bus.latest_frame();
    if (!odom) return failed("no odometry");
    const Twist turn = motion(*odom);
    if (!frame || (have_sequence_ && frame->sequence == last_sequence_)) return send(turn);
    have_sequence_ = true;
    last_sequence_ = frame->sequence;

    FrameVotes fv;
    fv.odom_distance_m = odom->distance_m;
    fv.odom_heading_rad = odom->pose.heading_rad;
    std::string blank;
    Detector* detector = host_.active_detector();
    if (detector == nullptr) return failed("Relocalise needs a detector (config section detector:)");
    if (frame->image.empty()) blank = "empty frame";
    else if (auto st = detector->detect(frame->image, features_); !st) blank = "detector failed: " + st.error().message;
    if (blank.empty()) blank = blank_reason(frame->image, features_, params_.decision);
    fv.blank = !blank.empty();
    if (fv.blank && blank != last_blank_) host_.logger().info(path(), "blank frame: " + blank);
    last_blank_ = blank;
    if (!fv.blank) {
      verifier_->set_detector(detector);
      auto votes = verifier_->votes(features_, frame->image.cols, params_.decision.candidates,
                                    params_.decision.min_confidence);
      if (!votes) return failed(votes.error().message);
      fv.votes = std::move(*votes);
    }
    if (!fv.blank) {  // path_following places: the frame's thumbnail
      auto thumb_votes = verifier_->thumbnail_votes(frame->image, params_.decision);
      if (!thumb_votes) return failed(thumb_votes.error().message);
      fv.votes.insert(fv.votes.end(), thumb_votes->begin(), thumb_votes->end());
    }
    const std::size_t vote_count = fv.votes.size();
    relocaliser_->add(std::move(fv));
    const RelocAnswer a = relocaliser_->decide();
    publish(a, turn, vote_count);
    if (a.status == RelocStatus::pending) {
      if (a.has_best) steer_offset_rad_ = a.heading_offset_rad;
      // Enough frames standing (and the look-around sweep done): creep forward for the sequence
      // check over the robot's own motion.
      if (creep_ == Creep::waiting && a.usable_frames >= params_.decision.frames && sweep_done()) {
        creep_ = Creep::creeping;
        creep_start_m_ = odom->distance_m;
        creep_start_s_ = odom->timestamp_s;
        host_.logger().info(path(), "creeping " + fmt(params_.creep_m, 2) + " m forward for the sequence check");
      }
      // Looking around or creeping: keep moving until done; an early final answer still ends it.
      return send(turn);
    }
    stop();
    const std::string reason =
        a.status == RelocStatus::not_on_map && !unindexed_note_.empty() ? a.reason + unindexed_note_ : a.reason;
    (void)set_output("status", std::string(to_string(a.status)));
    (void)set_output("reason", reason);
    (void)set_output("confidence", a.confidence);
    if (a.status != RelocStatus::localised) {
      host_.logger().warn(path(), reason);
      return NodeStatus::failure;
    }
    const std::string& edge_id = index_->edges[a.edge].id;
    (void)set_output("edge", edge_id);
    (void)set_output("distance_m", a.distance_m);
    (void)set_output("heading_offset_rad", a.heading_offset_rad);
    (void)set_output("along_uncertainty_m", a.along_uncertainty_m);
    (void)set_output("turn_rad", -a.heading_offset_rad);
    host_.logger().info(path(), a.reason + "; heading offset " + fmt(a.heading_offset_rad * 180.0 / std::numbers::pi, 1) +
                                    " deg, confidence " + fmt(a.confidence));
    return NodeStatus::success;
  }

  void on_halted() override { stop(); }

 private:
  Status start() {
    MapStore* map = host_.map();
    if (map == nullptr) return fail(ErrorCode::missing, "Relocalise needs a map (visnav run --map M)");
    if (host_.frame_bus() == nullptr || host_.robot() == nullptr)
      return fail(ErrorCode::missing, "Relocalise needs a running robot and camera");
    VISNAV_ASSIGN(params_, bt::parse_param_ports(*this, RelocaliseNodeParams::schema()));
    // One index per map folder for the node's life (a tree relocalising several times reloads nothing).
    if (!index_ || index_dir_ != map->dir()) {
      VISNAV_ASSIGN(index_, index_for(*map, host_.active_detector(), host_.logger(), path()));
      index_dir_ = map->dir();
    }
    feature_replay::HeadingParams heading;
    heading.horizontal_fov_deg = params_.horizontal_fov_deg;
    verifier_.emplace(*index_, *map, heading, host_.active_detector());
    relocaliser_.emplace(params_.decision, verifier_->route_edges());
    // Edges the index does not cover (path_following edges taught before thumbnails: one colour
    // model per edge, nothing that varies along it). A robot on one of them cannot be recognised:
    // not_on_map says they exist, and a prior on one is answered not_indexed before anything moves.
    not_indexed_.clear();
    unindexed_note_.clear();
    int unindexed = 0;
    double unindexed_m = 0.0;
    std::string kinds;
    auto covered = [&](const std::string& id) {
      for (std::size_t i = 0; i < index_->edges.size(); ++i)
        if (index_->edges[i].id == id) return index_->covers(static_cast<std::uint32_t>(i));
      return false;
    };
    for (const EdgeRecord& e : map->edges())
      if (!covered(e.id)) {
        ++unindexed;
        unindexed_m += e.length_m;
        if (kinds.find(e.kind) == std::string::npos) kinds += (kinds.empty() ? "" : ", ") + e.kind;
      }
    if (unindexed > 0)
      unindexed_note_ = " (" + std::to_string(unindexed) + " edges of kind " + kinds + ", " + fmt(unindexed_m, 1) +
                        " m, are not indexed: the robot may be on one of them)";
    VISNAV_ASSIGN(const std::string prior_edge, get_input<std::string>("prior_edge"));
    if (const EdgeRecord* rec = prior_edge.empty() ? nullptr : map->find_edge(prior_edge);
        rec != nullptr && !covered(rec->id)) {
      not_indexed_ = "not indexed: the prior edge " + prior_edge + " is a " + rec->kind +
                     " edge without places in the index (a path_following edge taught before thumbnails: "
                     "nothing along it to recognise); drive to a node or onto an indexed edge first";
      return ok();
    }
    if (!prior_edge.empty()) {
      VISNAV_ASSIGN(const double prior_m, get_input<double>("prior_distance_m"));
      bool found = false;
      for (std::size_t i = 0; i < index_->edges.size(); ++i)
        if (index_->edges[i].id == prior_edge) {
          relocaliser_->set_prior(static_cast<std::uint32_t>(i), prior_m);
          found = true;
        }
      if (!found)
        return fail(ErrorCode::not_found, {"", 0, "prior_edge"},
                    "'" + prior_edge + "' is not an edge of the place index");
    }
    have_sequence_ = false;
    creep_ = params_.creep_m > 0.0 ? Creep::waiting : Creep::none;
    relocaliser_->hold(creep_ == Creep::waiting, params_.creep_unrecognised != 0);
    steer_offset_rad_.reset();
    last_blank_.clear();
    sweep_ = 0;
    turned_rad_ = 0.0;
    last_heading_.reset();
    (void)set_output("status", std::string("pending"));
    stop();
    return ok();
  }

  [[nodiscard]] bool sweep_done() const { return params_.look_around_deg <= 0.0 || sweep_ >= 3; }

  /// This tick's command: the look-around turn, then the creep (forward, steering the best
  /// place's heading offset to zero); ends the creep (releasing the decision) once it has
  /// covered creep_m, or after three times its expected duration (a robot that cannot move).
  Twist motion(const Odometry& odom) {
    const Twist turn = look_around(odom);
    if (creep_ != Creep::creeping) return turn;
    const double covered_m = std::abs(odom.distance_m - creep_start_m_);
    const double limit_s = 3.0 * params_.creep_m / params_.creep_speed_mps + 2.0;
    if (covered_m >= params_.creep_m || odom.timestamp_s - creep_start_s_ > limit_s) {
      creep_ = Creep::done;
      relocaliser_->hold(false);
      return Twist{};
    }
    const double steer = steer_offset_rad_ ? std::clamp(-*steer_offset_rad_, -params_.turn_speed_radps,
                                                        params_.turn_speed_radps)
                                           : 0.0;
    return Twist{params_.creep_speed_mps, steer};
  }

  /// The look-around command: left to +look_around_deg, right to -look_around_deg, back to 0.
  Twist look_around(const Odometry& odom) {
    if (last_heading_) turned_rad_ += wrap(odom.pose.heading_rad - *last_heading_);
    last_heading_ = odom.pose.heading_rad;
    const double limit = params_.look_around_deg * std::numbers::pi / 180.0;
    if (limit <= 0.0 || sweep_ >= 3) return Twist{};
    const double targets[3] = {limit, -limit, 0.0};
    const double error = targets[sweep_] - turned_rad_;
    if (std::abs(error) < 0.03) {
      ++sweep_;
      return look_around(odom);
    }
    return Twist{0.0, std::copysign(params_.turn_speed_radps, error)};
  }

  NodeStatus send(const Twist& t) {
    if (auto st = host_.robot()->send_command(t); !st) return failed("sending the command: " + st.error().message);
    return NodeStatus::running;
  }
  void stop() {
    if (Robot* r = host_.robot()) (void)r->stop();
  }
  NodeStatus failed(const std::string& message) {
    stop();
    (void)set_output("reason", message);
    host_.logger().error(path(), message);
    return NodeStatus::failure;
  }
  void publish(const RelocAnswer& a, const Twist& command, std::size_t votes) {
    Telemetry* t = host_.telemetry();
    if (t == nullptr) return;
    NavStatus s;
    s.node_path = path();
    s.edge = a.status == RelocStatus::localised ? index_->edges[a.edge].id : std::string();
    s.distance_m = a.distance_m;
    s.matches = static_cast<int>(votes);
    s.command = command;
    s.confidence = a.confidence;
    s.status = "relocalising: " + std::string(to_string(a.status)) + " (" + std::to_string(a.usable_frames) +
               " frames, " + std::to_string(a.blank_frames) + " blank)";
    t->publish(s);
  }

  HostServices& host_;
  RelocaliseNodeParams params_;
  std::shared_ptr<const PlaceIndex> index_;
  std::string index_dir_;
  std::optional<PlaceVerifier> verifier_;
  std::optional<Relocaliser> relocaliser_;
  Features features_;
  bool have_sequence_ = false;
  std::uint64_t last_sequence_ = 0;
  std::string last_blank_;
  std::string not_indexed_;     // non-empty: the prior is on an edge kind the index does not cover
  std::string unindexed_note_;  // appended to not_on_map: the map has edges the index does not cover
  int sweep_ = 0;
  double turned_rad_ = 0.0;
  enum class Creep : std::uint8_t { none, waiting, creeping, done };
  Creep creep_ = Creep::none;
  double creep_start_m_ = 0.0;
  double creep_start_s_ = 0.0;
  std::optional<double> steer_offset_rad_;
  std::optional<double> last_heading_;
};

// ---------------------------------------------------------------------------- BuildPlaceIndex

class BuildPlaceIndex final : public bt::SyncActionNode {
 public:
  BuildPlaceIndex(const std::string& name, const bt::NodeConfig& config, HostServices& host)
      : SyncActionNode(name, config), host_(host) {}
  static bt::PortsList provided_ports() {
    return {bt::input_port<bool>("only_if_missing", "false",
                                 "keep an existing index that matches the map (a damaged or stale one is rebuilt)"),
            bt::input_port<bool>("required", "true",
                                 "false: a map that cannot be indexed (e.g. float descriptors) is a warning and the "
                                 "node succeeds (the end of a teach tree: the taught map is kept either way)")};
  }

 protected:
  NodeStatus tick() override {
    MapStore* map = host_.map();
    if (map == nullptr) return failed("BuildPlaceIndex needs a map (visnav run --map M)");
    auto keep = get_input<bool>("only_if_missing");
    if (!keep) return failed(keep.error().message);
    auto required = get_input<bool>("required");
    if (!required) return failed(required.error().message);
    required_ = *required;
    if (*keep)
      if (auto loaded = load_place_index(map->dir());
          loaded && loaded->matches(*map) && check_detector(*map, *loaded, host_.active_detector()))
        return NodeStatus::success;
    // A map of path_following edges only has nothing to index: not an error at the end of a teach.
    if (std::none_of(map->edges().begin(), map->edges().end(), [](const EdgeRecord& e) { return describable_kind(e.kind); })) {
      host_.logger().info(path(), "no edge to index (the place index needs feature_segment, feature_localmaps "
                                  "or visual_memory edges; path_following thumbnails are indexed beside them)");
      return NodeStatus::success;
    }
    if (auto st = map->flush(); !st) return failed(st.error().message);
    const auto t0 = std::chrono::steady_clock::now();
    // visual_memory reference images are described with the run's detector, the one Relocalise uses.
    auto built = build_place_index(*map, PlaceIndexParams{}, host_.active_detector());
    if (!built) return failed(built.error().message);
    if (auto st = save_place_index(map->dir(), *built); !st) return failed(st.error().message);
    host_.logger().info(path(), "place index: " + std::to_string(built->places.size()) + " places, " +
                                    std::to_string(built->thumbnail_places.size()) + " thumbnail places, " +
                                    std::to_string(built->byte_size()) + " bytes, built in " +
                                    fmt(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 2) +
                                    " s");
    return NodeStatus::success;
  }

 private:
  NodeStatus failed(const std::string& message) {
    if (!required_) {
      host_.logger().warn(path(), "no place index: " + message + " (Relocalise cannot use this map)");
      return NodeStatus::success;
    }
    host_.logger().error(path(), message);
    return NodeStatus::failure;
  }
  HostServices& host_;
  bool required_ = true;
};

}  // namespace

Status register_reloc_nodes(bt::NodeRegistry& registry, HostServices& host) {
  VISNAV_TRY(registry.register_node<Relocalise>(
      "Relocalise",
      "Where on the map the robot is, from a short sequence of frames verified by histogram voting (or "
      "ambiguous / not_on_map / camera_blocked)",
      [&host](const std::string& n, const bt::NodeConfig& c) { return std::make_unique<Relocalise>(n, c, host); }));
  return registry.register_node<BuildPlaceIndex>(
      "BuildPlaceIndex", "Builds the map's place index (place_index.bin) for Relocalise",
      [&host](const std::string& n, const bt::NodeConfig& c) { return std::make_unique<BuildPlaceIndex>(n, c, host); });
}

}  // namespace visnav::reloc
