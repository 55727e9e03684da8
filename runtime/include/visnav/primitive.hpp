// visnav SDK — a navigation primitive is a type: a teacher and a replayer per edge kind.
//
// A primitive plugin writes two small classes against the interfaces below and registers each
// with one line; the runtime's one adapter turns them into behaviour-tree nodes and does what
// every primitive needs alike (docs/navigation.md, "Protocol for primitive nodes"):
//
//   * ports: generated from the class's `Params` struct and its ParamSchema (declared once: the
//     port defaults are the struct's defaults, the schema's ranges are checked on literal ports
//     before the first tick), plus the protocol ports (`edge`, `carried_m`, `lap`, the lost
//     policy for a replayer; `edge_from`, `edge_to`, `finish`, `edge` for a teacher);
//   * the edge: record lookup on `{edge}`, kind check, payload read once (checksum verified by
//     the map store) and handed to begin() before the robot moves;
//   * frames: each frame is processed once (Frame::sequence must grow); its size is checked
//     against the taught one (edge statistics image_width_px/image_height_px); the active
//     detector runs on it when the class sets `kUsesDetector`;
//   * distance: odometric distance since the edge started, counting FollowRoute's carried
//     overshoot (`{edge_carried_m}`);
//   * lost detection: the step's confidence goes through NavHealthMonitor (nav_health.hpp);
//   * telemetry: one NavStatus per processed frame;
//   * policies, the same for every primitive:
//       - a failed velocity command fails the node with "sending the command: <reason>";
//       - a tick without a new frame re-sends the last command while the odometric distance
//         since the last processed frame stays within the lost policy's max_frozen_m; beyond
//         it the node stops the robot and fails "camera frozen: no new frame ...";
//       - halt and failure stop the robot; a teacher never commands the robot;
//       - a replay node's FAILURE writes its reason to the output `failure` and its kind, one of
//         replay_failure's codes, to `failure_code` (trees key on the code, not on the text).
//
// Minimal replayer (see examples/primitive for a whole primitive, teacher and payload included):
//   struct CreepParams {
//     double speed_mps = 0.2;
//     [[nodiscard]] visnav::Status validate() const { return schema().check(*this); }
//     static const visnav::ParamSchema<CreepParams>& schema();   // .field("speed_mps", ...).range(0.01, 1)
//   };
//   class CreepReplayer final : public visnav::EdgeReplayer {
//    public:
//     using Params = CreepParams;
//     static constexpr bool kUsesDetector = false;
//     explicit CreepReplayer(const Params& p) : p_(p) {}
//     visnav::Status begin(const visnav::ReplayStart& s) override { length_m_ = s.edge.length_m; return visnav::ok(); }
//     visnav::ReplayStep step(const visnav::ReplayInput& in) override { ... }
//   };
//   VISNAV_TRY(visnav::register_replayer<CreepReplayer>(registry, host, "ReplayCreepEdge", "...", {"creep"}));
//
// Frames: distances in metres of Odometry::distance_m, headings odom-frame radians (types.hpp).
// Ownership: the adapter owns one teacher/replayer per node instance, made anew at each start.
// Thread-safety: tick thread only; the interfaces are called by the adapter only.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <numbers>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "visnav/devices.hpp"
#include "visnav/host.hpp"
#include "visnav/map.hpp"
#include "visnav/nav_health.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav::bt {
class NodeRegistry;  // visnav/bt/registry.hpp: only the registration functions below take one
}  // namespace visnav::bt

namespace visnav {

/// `angle_rad` wrapped into (-pi, pi] (odom-frame headings, e.g. an edge's azimuth).
[[nodiscard]] inline double wrap_angle_rad(double angle_rad) {
  const double a = std::remainder(angle_rad, 2.0 * std::numbers::pi);
  return a <= -std::numbers::pi ? a + 2.0 * std::numbers::pi : a;
}

// ------------------------------------------------------------------------------------ replay

/// The kinds of a replay node's failure, the set its output `failure_code` takes (the adapter
/// writes one with every FAILURE, "" while it runs or after a success; docs/feature_replay.md,
/// "Failure codes"). Stable tokens: a tree or decorator keys on them, never on `failure`'s text.
namespace replay_failure {
/// The primitive lost what it follows (ReplayStep::failure_code; e.g. FollowPathEdge's path).
inline constexpr std::string_view view_lost = "view_lost";
/// Another reason of the primitive's own (ReplayStep::failure without a code).
inline constexpr std::string_view primitive = "primitive";
/// The lost policy stopped it: no confident frame for max_blind_m, heading off, saturated.
inline constexpr std::string_view route_lost = "route_lost";
/// The input stopped: camera frozen, no new frames, no odometry, no running session.
inline constexpr std::string_view input_lost = "input_lost";
/// The velocity command could not be sent.
inline constexpr std::string_view command_failed = "command_failed";
/// A port or param value is refused (schema, validate(), distance_scale, lost policy).
inline constexpr std::string_view bad_params = "bad_params";
/// The edge's payload does not read, verify or decode (begin()).
inline constexpr std::string_view bad_payload = "bad_payload";
/// The edge is unknown, or of a kind the node does not replay.
inline constexpr std::string_view bad_edge = "bad_edge";
/// No map is loaded.
inline constexpr std::string_view no_map = "no_map";
/// The primitive needs a detector and the config has none.
inline constexpr std::string_view no_detector = "no_detector";
/// Every code above, once.
inline constexpr std::array<std::string_view, 10> all = {view_lost,      primitive,  route_lost,  input_lost,
                                                         command_failed, bad_params, bad_payload, bad_edge,
                                                         no_map,         no_detector};
}  // namespace replay_failure

/// What a replayer starts an edge with. References are valid during begin() only.
struct ReplayStart {
  const EdgeRecord& edge;
  std::span<const std::uint8_t> payload;  ///< the edge's payload body (store checksum verified)
  const Odometry& odometry;                ///< at the start
  double origin_m = 0.0;                   ///< Odometry::distance_m at which the edge counts as started
  const LostPolicy& policy;                ///< the node's lost policy (e.g. its min_confidence)
  Logger& logger;
  std::string_view node_path;              ///< for log messages
};

/// One new frame. References are valid during step() only.
struct ReplayInput {
  /// The robot's odometry; its distance_m counts from origin_m in the teach run's metres (the
  /// node's `distance_scale`, FollowRoute's odometry scale estimate; 1 = as measured).
  const Odometry& odometry;
  double edge_distance_m = 0.0;    ///< Odometry::distance_m - origin_m
  const Frame& frame;
  /// The active detector's features of `frame` (kUsesDetector), empty when the frame was
  /// unusable; nullptr for a primitive without a detector.
  const Features* features = nullptr;
  /// nullptr, or why the frame is unusable ("empty frame", "frame size differs from the taught
  /// one", "detector failed on the frame"); its confidence counts as 0 whatever step() says.
  const char* frame_problem = nullptr;
};

/// What a replayer answers for one frame.
struct ReplayStep {
  Twist command;                ///< to send, before the lost policy's speed factor
  double confidence = 0.0;      ///< this frame's confidence that the route is seen, [0, 1]
  bool saturated = false;       ///< the correction is at its clamp
  bool informative = true;      ///< false where the map expects little to see (nav_health.hpp)
  double distance_m = 0.0;      ///< along the edge (within the lap), for the heading profile and telemetry
  bool finished = false;        ///< edge done: the adapter stops the robot and succeeds
  /// Not driving the edge yet (e.g. turning to find the start view): the command is sent, the
  /// lost policy is not fed and does not slow the command.
  bool orienting = false;
  int lap = 0;                  ///< 0-based lap (closed paths driven several times), output `lap`
  int matches = 0;              ///< telemetry
  int inliers = 0;
  double offset_px = 0.0;
  std::string status;           ///< short state for telemetry ("steering", "path lost", ...)
  std::string failure;          ///< non-empty: the primitive's own reason to stop; the node fails with it
  /// With failure: a stable code for it (`view_lost` when the primitive lost what it follows,
  /// replay_failure::view_lost); empty = `primitive`. The node writes it to `failure_code`.
  std::string failure_code;
  /// Optional: what the primitive saw in this frame, for the live view (host.hpp NavOverlay).
  /// Owned by the replayer, valid until its next step(); the adapter puts it in the NavStatus.
  const NavOverlay* overlay = nullptr;
};

/// Traverses one edge of its kind(s). Made by the adapter at every start from validated Params.
class EdgeReplayer {
 public:
  virtual ~EdgeReplayer() = default;
  /// Decodes the payload and prepares the edge. Error (the payload does not decode, or does not
  /// fit the edge): the node fails "edge <id> payload: <error>" before the robot moves.
  virtual Status begin(const ReplayStart& start) = 0;
  /// One new frame. Must not throw.
  virtual ReplayStep step(const ReplayInput& input) = 0;
  /// False: the edge has no single taught heading profile (e.g. a closed path driven in laps),
  /// the lost policy's heading check is off. Called after begin().
  [[nodiscard]] virtual bool heading_check() const { return true; }
  /// Called once when the edge ended in success (a step() reported finished and the lost policy
  /// let the node succeed), before the node returns SUCCESS: e.g. to store what the replay
  /// learned about the edge. An error is logged as a warning; the node still succeeds.
  virtual Status succeeded() { return ok(); }
};

// ------------------------------------------------------------------------------------- teach

/// What a teacher starts with. Valid during begin() only.
struct TeachStart {
  const Odometry& odometry;
  Logger& logger;
  std::string_view node_path;
};

/// One tick while the operator drives. Valid during step()/finish() only.
struct TeachInput {
  const Odometry& odometry;
  double edge_distance_m = 0.0;        ///< odometric distance since the edge started (>= 0)
  const Frame* frame = nullptr;        ///< the new frame, nullptr when this tick has none
  const Features* features = nullptr;  ///< its features (kUsesDetector), empty when unusable
  const char* frame_problem = nullptr; ///< see ReplayInput
};

/// What a teacher hands back at the end: the adapter adds from/to, length, azimuth,
/// end_heading_rad and its own statistics (frames, bytes, image size) and stores the edge.
struct TaughtEdge {
  std::string kind;
  std::vector<std::uint8_t> payload;
  std::map<std::string, double> statistics;
};

/// Records one edge while the operator drives (never commands the robot).
class EdgeTeacher {
 public:
  virtual ~EdgeTeacher() = default;
  virtual Status begin(const TeachStart& start) = 0;
  /// Every tick. An error skips this tick's frame (logged once per edge); the teach goes on.
  virtual Status step(const TeachInput& input) = 0;
  /// Ends the edge at `last` (its frame is the last processed one, or nullptr). Error: the node fails.
  virtual Result<TaughtEdge> finish(const TeachInput& last) = 0;
};

// ------------------------------------------------------------------------------ registration

/// A primitive class with its schema, type-erased for the runtime's adapter.
struct PrimitiveType {
  std::string node_id;                ///< behaviour-tree node ID, e.g. "ReplayFeatureEdge"
  std::string description;
  std::vector<std::string> kinds;     ///< edge kinds a replayer accepts (a teacher: informative)
  bool uses_detector = false;
  std::vector<ParamDoc> params;       ///< one port each, default = the Params struct's default
  /// Type and constraint of one value of param `key` (the port check).
  std::function<Status(std::string_view key, const ConfigNode& value)> check_param;
  /// Parses all params (a map, one entry per port) with the schema and validate(), nothing else:
  /// the tree check of literal ports (so validate refuses what the node's start would).
  std::function<Status(const ConfigNode& params)> check_params;
  /// Parses all params (a map, one entry per port) with the schema and validate(), then makes the object.
  std::function<Result<std::unique_ptr<EdgeReplayer>>(const ConfigNode& params)> make_replayer;
  std::function<Result<std::unique_ptr<EdgeTeacher>>(const ConfigNode& params)> make_teacher;
};

/// Registers the adapter node of a replayer/teacher type (runtime; used by the templates below).
Status register_replayer_type(bt::NodeRegistry& registry, HostServices& host, PrimitiveType type);
Status register_teacher_type(bt::NodeRegistry& registry, HostServices& host, PrimitiveType type);

namespace detail {
template <typename C, typename Base>
PrimitiveType primitive_type(std::string node_id, std::string description, std::vector<std::string> kinds) {
  using Params = typename C::Params;
  PrimitiveType t;
  t.node_id = std::move(node_id);
  t.description = std::move(description);
  t.kinds = std::move(kinds);
  t.uses_detector = C::kUsesDetector;
  t.params = Params::schema().docs();
  t.check_param = [](std::string_view key, const ConfigNode& value) { return Params::schema().check_field(key, value); };
  t.check_params = [](const ConfigNode& params) -> Status {
    auto parsed = Params::schema().parse(params);
    if (!parsed) return parsed.error();
    return ok();
  };
  auto make = [](const ConfigNode& params) noexcept -> Result<std::unique_ptr<Base>> {
    try {
      VISNAV_ASSIGN(Params p, Params::schema().parse(params));
      return std::unique_ptr<Base>(std::make_unique<C>(p));
    } catch (const std::exception& e) {
      return fail(std::string("primitive constructor threw: ") + e.what());
    }
  };
  if constexpr (std::is_same_v<Base, EdgeReplayer>) t.make_replayer = make;
  else t.make_teacher = make;
  return t;
}
}  // namespace detail

/// Registers replayer class R as node `node_id` for edges of `kinds`. R derives from
/// EdgeReplayer, has `using Params` (a struct with defaults, validate() and schema()),
/// `static constexpr bool kUsesDetector` and a constructor `explicit R(const Params&)`.
template <typename R>
Status register_replayer(bt::NodeRegistry& registry, HostServices& host, std::string node_id, std::string description,
                         std::vector<std::string> kinds) {
  static_assert(std::is_base_of_v<EdgeReplayer, R>, "R must derive from visnav::EdgeReplayer");
  return register_replayer_type(registry, host,
                                detail::primitive_type<R, EdgeReplayer>(std::move(node_id), std::move(description),
                                                                        std::move(kinds)));
}

/// Registers teacher class T (same requirements, deriving from EdgeTeacher) as node `node_id`.
template <typename T>
Status register_teacher(bt::NodeRegistry& registry, HostServices& host, std::string node_id, std::string description,
                        std::vector<std::string> kinds) {
  static_assert(std::is_base_of_v<EdgeTeacher, T>, "T must derive from visnav::EdgeTeacher");
  return register_teacher_type(registry, host,
                               detail::primitive_type<T, EdgeTeacher>(std::move(node_id), std::move(description),
                                                                      std::move(kinds)));
}

}  // namespace visnav
