// visnav SDK — the Cyclone DDS transport: a small RAII layer over the Cyclone DDS C API.
//
// Plugins and tools use this header only; it never includes dds.h or idlc-generated headers.
// Messages are plain C++ structs (namespace visnav::dds::msg) mirroring the ROS 2 message
// layouts; the runtime converts them to/from the idlc-generated C types internally.
//
// Wire conventions (ROS 2 / rmw_cyclonedds_cpp compatible):
//  * ROS topic `/cmd_vel` is the DDS topic `rt/cmd_vel` (see `ros_topic()`),
//  * ROS type `geometry_msgs/msg/Twist` is the DDS type `geometry_msgs::msg::dds_::Twist_`
//    (see `MessageTraits<M>::type_name`), plain CDR (final extensibility).
//
// Ownership and lifetime: `Participant` is a cheap shared handle; every Writer, Reader and
// Subscription keeps its participant alive, so destruction order does not matter. All types
// are move-only (except Participant, which is copyable) and release their DDS entities in the
// destructor; a moved-from object may only be destroyed or assigned to.
//
// Thread-safety: `Writer::write` may be called from any thread. A `Reader` is used from one
// thread at a time. A `Subscription` owns one dedicated thread that waits on a DDS waitset and
// calls the handler for every sample; the handler must only store the value (e.g. into a
// `LatestSlot`) and return quickly — decisions happen in the tick thread. Stats accessors are
// thread-safe.
//
// Loopback-only operation (tests): set CYCLONEDDS_URI to a config that pins the interface,
// e.g. `<General><Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces></General>`;
// see `loopback_config_xml()`.
//
// When the runtime is built without DDS (VISNAV_BUILD_DDS=OFF), `available()` is false and
// every create() fails with an error saying so.
#pragma once

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "visnav/host.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav::dds {

/// True when the runtime library was built with Cyclone DDS.
[[nodiscard]] bool available();

// ------------------------------------------------------------------------------------------
// Messages (ROS 2 layouts). Times are ROS times: seconds + nanoseconds since the Unix epoch.
// ------------------------------------------------------------------------------------------
namespace msg {

struct Time {  // builtin_interfaces/msg/Time
  std::int32_t sec = 0;
  std::uint32_t nanosec = 0;
  [[nodiscard]] double seconds() const { return static_cast<double>(sec) + 1e-9 * static_cast<double>(nanosec); }
  [[nodiscard]] static Time from_seconds(double t_s);
};
struct Header {  // std_msgs/msg/Header
  Time stamp;
  std::string frame_id;
};
struct Vector3 { double x = 0.0, y = 0.0, z = 0.0; };        // geometry_msgs/msg/Vector3
struct Twist { Vector3 linear; Vector3 angular; };           // geometry_msgs/msg/Twist
struct Point { double x = 0.0, y = 0.0, z = 0.0; };          // geometry_msgs/msg/Point
struct Quaternion { double x = 0.0, y = 0.0, z = 0.0, w = 1.0; };  // geometry_msgs/msg/Quaternion
struct Pose { Point position; Quaternion orientation; };     // geometry_msgs/msg/Pose
struct PoseWithCovariance { Pose pose; std::array<double, 36> covariance{}; };
struct TwistWithCovariance { Twist twist; std::array<double, 36> covariance{}; };
struct Odometry {  // nav_msgs/msg/Odometry
  Header header;
  std::string child_frame_id;
  PoseWithCovariance pose;
  TwistWithCovariance twist;
};
struct Image {  // sensor_msgs/msg/Image
  Header header;
  std::uint32_t height = 0;  ///< rows, px
  std::uint32_t width = 0;   ///< columns, px
  std::string encoding;      ///< "rgb8", "bgr8", "mono8", ...
  std::uint8_t is_bigendian = 0;
  std::uint32_t step = 0;    ///< bytes per row
  std::vector<std::uint8_t> data;  ///< step * height bytes
};
struct CompressedImage {  // sensor_msgs/msg/CompressedImage
  Header header;
  std::string format;  ///< "jpeg", "png" (image_transport also writes "bgr8; jpeg compressed bgr8")
  std::vector<std::uint8_t> data;
};

/// visnav/msg/Telemetry — one per tick of `visnav run` (mirrors visnav::NavStatus).
struct Telemetry {
  Header header;
  std::uint64_t sequence_number = 0;
  std::string node_path;
  std::string map_node;
  std::string edge;
  double distance_m = 0.0;
  std::int32_t matches = 0;
  std::int32_t inliers = 0;
  double offset_px = 0.0;
  double linear_mps = 0.0;
  double angular_radps = 0.0;
  std::string status;
};

/// Mission control requests (visnav/msg/Control.command).
enum class ControlCommand : std::uint8_t { pause = 1, resume = 2, abort = 3, swap_detector = 4 };

/// visnav/msg/Control.
struct Control {
  Header header;
  std::uint64_t sequence_number = 0;
  std::uint8_t command = 0;  ///< a ControlCommand value; others are rejected by ControlSubscriber
  std::string argument;      ///< swap_detector: the detector type (e.g. "orb")
};

}  // namespace msg

/// Wire names of a message type. Defined for every struct in `msg`.
template <typename M> struct MessageTraits;
#define VISNAV_DDS_MESSAGE_(M, NAME) \
  template <> struct MessageTraits<msg::M> { static constexpr const char* type_name = NAME; };
VISNAV_DDS_MESSAGE_(Twist, "geometry_msgs::msg::dds_::Twist_")
VISNAV_DDS_MESSAGE_(Odometry, "nav_msgs::msg::dds_::Odometry_")
VISNAV_DDS_MESSAGE_(Image, "sensor_msgs::msg::dds_::Image_")
VISNAV_DDS_MESSAGE_(CompressedImage, "sensor_msgs::msg::dds_::CompressedImage_")
VISNAV_DDS_MESSAGE_(Telemetry, "visnav::msg::dds_::Telemetry_")
VISNAV_DDS_MESSAGE_(Control, "visnav::msg::dds_::Control_")
#undef VISNAV_DDS_MESSAGE_

/// DDS topic name of a ROS 2 topic: "/cmd_vel" or "cmd_vel" -> "rt/cmd_vel"; a name that
/// already starts with "rt/" is returned unchanged.
[[nodiscard]] std::string ros_topic(std::string_view ros_name);

/// A CYCLONEDDS_URI value restricting Cyclone to the loopback interface (for tests and
/// single-host deployments): `<CycloneDDS><Domain>...127.0.0.1...</Domain></CycloneDDS>`.
[[nodiscard]] std::string loopback_config_xml();

/// Seconds since the Unix epoch (the clock DDS source timestamps use).
[[nodiscard]] double epoch_now_s();

// ------------------------------------------------------------------------------------------
// QoS
// ------------------------------------------------------------------------------------------
enum class Reliability { best_effort, reliable };
enum class Durability { volatile_data, transient_local };

struct Qos {
  Reliability reliability = Reliability::reliable;
  Durability durability = Durability::volatile_data;
  int history_depth = 1;    ///< keep-last depth; 0 = keep-all
  double deadline_s = 0.0;  ///< 0 = no deadline

  /// ROS 2 "sensor data" profile: best effort, volatile, keep-last 5. A best-effort reader
  /// matches both reliable and best-effort writers.
  [[nodiscard]] static Qos sensor_data() { return Qos{Reliability::best_effort, Durability::volatile_data, 5, 0.0}; }
  /// ROS 2 default profile: reliable, volatile, keep-last 10.
  [[nodiscard]] static Qos ros_default() { return Qos{Reliability::reliable, Durability::volatile_data, 10, 0.0}; }
};

/// "best_effort"/"reliable" and "volatile"/"transient_local" as used in plugin params.
[[nodiscard]] Result<Reliability> parse_reliability(std::string_view text);
[[nodiscard]] Result<Durability> parse_durability(std::string_view text);
[[nodiscard]] const char* to_string(Reliability r);
[[nodiscard]] const char* to_string(Durability d);

// ------------------------------------------------------------------------------------------
// Entities
// ------------------------------------------------------------------------------------------
namespace detail {
struct ParticipantCore;
struct WriterCore;
struct ReaderCore;
struct SubscriptionCore;
}  // namespace detail

/// A domain participant. Copies share the same participant.
/// DDS Security (OMG DDS Security 1.1, Cyclone's builtin plugins) files of one identity; paths
/// of PEM certificates/keys and S/MIME-signed XML documents (docs/security.md; `visnav security
/// init` makes them).
struct SecurityFiles {
  std::string ca;             ///< CA certificate (PEM) that signed the identities, governance and permissions
  std::string identity_cert;  ///< this participant's certificate (PEM), signed by `ca`
  std::string private_key;    ///< its private key (PEM, unencrypted: protect it with file permissions)
  std::string governance;     ///< signed governance document (.p7s): what is encrypted/signed
  std::string permissions;    ///< signed permissions of this identity (.p7s): topics it may publish/subscribe

  /// Every path set and readable; errors name the key ("security.private_key: ...: cannot read").
  [[nodiscard]] Status validate() const;
};

/// The files of identity `name` in a keystore made by `visnav security init`:
/// KEYSTORE/ca.pem, KEYSTORE/governance.p7s, KEYSTORE/<name>/{cert.pem,key.pem,permissions.p7s}.
[[nodiscard]] SecurityFiles keystore_identity(const std::string& keystore, const std::string& name);

/// Process-wide default: every Participant::create(domain_id) afterwards authenticates with
/// `files` (std::nullopt: security off, the default). Validates the files first. Thread-safe.
[[nodiscard]] Status set_default_security(std::optional<SecurityFiles> files);
/// True if set_default_security() enabled security.
[[nodiscard]] bool default_security_enabled();
namespace detail {
/// The process default of set_default_security (a copy). Thread-safe.
[[nodiscard]] std::optional<SecurityFiles> default_security();
}  // namespace detail

class Participant {
 public:
  /// Joins DDS domain `domain_id` (0..232), with the process default security
  /// (set_default_security). Cyclone reads CYCLONEDDS_URI when the first participant of a domain
  /// is created in the process.
  [[nodiscard]] static Result<Participant> create(int domain_id);
  /// Joins with explicit security: `security` set = authenticate with those files (errors name
  /// them, e.g. a certificate not signed by the CA); std::nullopt = an unsecured participant.
  [[nodiscard]] static Result<Participant> create(int domain_id, const std::optional<SecurityFiles>& security);

  [[nodiscard]] int domain_id() const;
  /// This participant's GUID, 32 lowercase hex digits (what receivers see as
  /// SampleInfo::writer_participant). Logged at start so operators can pin a command source.
  [[nodiscard]] std::string guid() const;

 private:
  template <typename M> friend class Writer;
  template <typename M> friend class Reader;
  template <typename M> friend class Subscription;
  explicit Participant(std::shared_ptr<detail::ParticipantCore> core) : core_(std::move(core)) {}
  std::shared_ptr<detail::ParticipantCore> core_;
};

/// Where and how an endpoint communicates.
struct EndpointOptions {
  std::string topic;      ///< DDS topic name, e.g. "rt/cmd_vel"
  Qos qos;
  std::string partition;  ///< empty = the default partition (what ROS 2 uses)
};

/// Typed data writer. M is one of the structs in `msg`.
template <typename M>
class Writer {
 public:
  [[nodiscard]] static Result<Writer> create(const Participant& participant, const EndpointOptions& options);
  Writer(Writer&&) noexcept;
  Writer& operator=(Writer&&) noexcept;
  ~Writer();

  /// Publishes one sample (source timestamp = now). Thread-safe. Fails when DDS rejects it
  /// (e.g. the writer was deleted, out of resources); the message has the DDS return code.
  Status write(const M& sample);
  /// Number of currently matched readers.
  [[nodiscard]] int matched_readers() const;
  /// Waits up to `timeout_s` until at least `count` readers are matched.
  [[nodiscard]] bool wait_for_readers(int count, double timeout_s) const;
  [[nodiscard]] const std::string& topic() const;

 private:
  explicit Writer(std::unique_ptr<detail::WriterCore> core);
  std::unique_ptr<detail::WriterCore> core_;
};

/// Per-sample metadata.
struct SampleInfo {
  double source_time_s = 0.0;   ///< writer's source timestamp, s since the Unix epoch
  double receive_time_s = 0.0;  ///< when it was taken here, s since the Unix epoch
  std::uint64_t writer_handle = 0;  ///< instance handle of the publication (identifies the writer)
  /// GUID of the writer's participant, 32 lowercase hex digits (Participant::guid() of the
  /// sender); empty if discovery data was not available. Identifies the sending process for
  /// command arbitration; it can be forged by anyone on an unsecured domain (use DDS Security).
  std::string writer_participant;
};

/// Typed data reader with explicit, non-blocking `take` and a blocking `wait` (waitset).
template <typename M>
class Reader {
 public:
  using Handler = std::function<void(M&& sample, const SampleInfo& info)>;

  [[nodiscard]] static Result<Reader> create(const Participant& participant, const EndpointOptions& options);
  Reader(Reader&&) noexcept;
  Reader& operator=(Reader&&) noexcept;
  ~Reader();

  /// Takes every available sample without blocking, calling `handler` for each valid one in
  /// arrival order. Returns the number of valid samples.
  Result<std::size_t> take(const Handler& handler);
  /// Blocks up to `timeout_s` until data is available. Returns false on timeout.
  Result<bool> wait(double timeout_s);
  [[nodiscard]] int matched_writers() const;
  [[nodiscard]] bool wait_for_writers(int count, double timeout_s) const;
  [[nodiscard]] const std::string& topic() const;

 private:
  explicit Reader(std::unique_ptr<detail::ReaderCore> core);
  std::unique_ptr<detail::ReaderCore> core_;
};

/// Counters of a Subscription (monotonic).
struct SubscriptionStats {
  std::uint64_t samples = 0;             ///< valid samples handed to the handler
  std::uint64_t wrong_type_writers = 0;  ///< writers seen on this topic with another type (never matched)
  std::uint64_t deadline_missed = 0;     ///< requested-deadline-missed count (when Qos::deadline_s > 0)
  int matched_writers = 0;               ///< currently matched writers
};

/// A reader with its own thread: waits on a waitset and calls `on_sample` for every sample.
/// Also watches the DCPSPublication built-in topic and reports writers that publish on the
/// same topic name with a different type (DDS never delivers their data; they are counted in
/// `stats().wrong_type_writers` and reported once each through `on_warning`).
template <typename M>
class Subscription {
 public:
  using Handler = std::function<void(M&& sample, const SampleInfo& info)>;
  using WarningHandler = std::function<void(const std::string& message)>;

  /// Starts the thread. `on_sample` and `on_warning` (may be empty) run on that thread.
  [[nodiscard]] static Result<std::unique_ptr<Subscription>> create(const Participant& participant,
                                                                    const EndpointOptions& options,
                                                                    Handler on_sample, WarningHandler on_warning = {});
  /// Stops and joins the thread; no handler runs after the destructor returns.
  ~Subscription();
  Subscription(const Subscription&) = delete;
  Subscription& operator=(const Subscription&) = delete;

  [[nodiscard]] SubscriptionStats stats() const;
  [[nodiscard]] const std::string& topic() const;

 private:
  explicit Subscription(std::unique_ptr<detail::SubscriptionCore> core);
  std::unique_ptr<detail::SubscriptionCore> core_;
};

// The runtime library instantiates the templates for exactly these message types.
#define VISNAV_DDS_EXTERN_(M)                   \
  extern template class Writer<msg::M>;         \
  extern template class Reader<msg::M>;         \
  extern template class Subscription<msg::M>;
VISNAV_DDS_EXTERN_(Twist)
VISNAV_DDS_EXTERN_(Odometry)
VISNAV_DDS_EXTERN_(Image)
VISNAV_DDS_EXTERN_(CompressedImage)
VISNAV_DDS_EXTERN_(Telemetry)
VISNAV_DDS_EXTERN_(Control)
#undef VISNAV_DDS_EXTERN_

// ------------------------------------------------------------------------------------------
// Helpers for plugin code
// ------------------------------------------------------------------------------------------

/// A latest-value slot: a producer thread `put`s, consumers read the newest value or wait for
/// one newer than a version they have seen. Thread-safe.
template <typename T>
class LatestSlot {
 public:
  void put(T value) {
    {
      std::lock_guard lock(mutex_);
      value_ = std::move(value);
      ++version_;
    }
    changed_.notify_all();
  }
  [[nodiscard]] std::optional<T> get() const {
    std::lock_guard lock(mutex_);
    return value_;
  }
  /// Number of puts so far (0 = empty).
  [[nodiscard]] std::uint64_t version() const {
    std::lock_guard lock(mutex_);
    return version_;
  }
  /// Waits up to `timeout_s` for a value with version > `seen_version`; returns it with its version.
  [[nodiscard]] std::optional<std::pair<T, std::uint64_t>> wait_newer(std::uint64_t seen_version, double timeout_s) const {
    std::unique_lock lock(mutex_);
    const auto timeout = std::chrono::duration<double>(timeout_s > 0.0 ? timeout_s : 0.0);
    if (!changed_.wait_for(lock, timeout, [&] { return version_ > seen_version && value_.has_value(); }))
      return std::nullopt;
    return std::make_pair(*value_, version_);
  }

 private:
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  std::optional<T> value_;
  std::uint64_t version_ = 0;
};

/// Rate limiter for warnings about bad input: `allow(now_s)` is true at most once per
/// `min_interval_s`; `suppressed()` is the number of refused calls since the last allowed one.
/// Thread-safe.
class WarningLimiter {
 public:
  explicit WarningLimiter(double min_interval_s = 1.0) : min_interval_s_(min_interval_s) {}
  bool allow(double now_s) {
    std::lock_guard lock(mutex_);
    if (has_last_ && now_s - last_s_ < min_interval_s_) { ++suppressed_; return false; }
    has_last_ = true;
    last_s_ = now_s;
    last_suppressed_ = suppressed_;
    suppressed_ = 0;
    return true;
  }
  /// Calls refused before the most recent allowed call.
  [[nodiscard]] std::uint64_t suppressed_before_last() const {
    std::lock_guard lock(mutex_);
    return last_suppressed_;
  }

 private:
  mutable std::mutex mutex_;
  double min_interval_s_;
  double last_s_ = 0.0;
  bool has_last_ = false;
  std::uint64_t suppressed_ = 0;
  std::uint64_t last_suppressed_ = 0;
};

/// True if `text` is a participant GUID as Participant::guid() and SampleInfo::writer_participant
/// write it: 32 lowercase hex digits. Pure.
[[nodiscard]] bool is_participant_guid(std::string_view text);

/// Which participant may publish a stream the robot side acts on (issue 17: command arbitration;
/// docs/security.md). Rule "" accepts any sender; a participant GUID (is_participant_guid)
/// accepts only that participant; "first" locks onto the first sender with a known GUID and then
/// accepts only it. A sample whose sender GUID is unknown (empty) is refused under any rule but
/// "". Used by `visnav simd` for cmd_vel and by the `dds` robot plugin for odometry, so both
/// apply the same rule. Thread-safe (subscription threads admit, other threads read counts).
/// A GUID identifies a process but does not authenticate it; DDS Security is the protection.
class WriterArbiter {
 public:
  /// Anyone may write (rule "").
  WriterArbiter() = default;
  /// Parses a rule; an invalid one is ErrorCode::invalid_value with the rule shown through log_safe.
  [[nodiscard]] static Result<WriterArbiter> parse(std::string_view rule);
  WriterArbiter(WriterArbiter&& other) noexcept;
  WriterArbiter& operator=(WriterArbiter&& other) noexcept;

  struct Verdict {
    bool accepted = false;  ///< the sample may be used
    bool locked = false;    ///< rule "first": this sample's sender just became the allowed writer
  };
  /// Decides on one sample from `writer_participant`; a refusal increments refused().
  Verdict admit(std::string_view writer_participant);

  /// No rule: every sender is accepted.
  [[nodiscard]] bool open() const { return rule_.empty(); }
  /// The rule as given: "", "first" or a GUID.
  [[nodiscard]] const std::string& rule() const { return rule_; }
  /// The GUID allowed now; empty for rule "" and for "first" before the first sender.
  [[nodiscard]] std::string allowed() const;
  /// Samples refused so far.
  [[nodiscard]] std::uint64_t refused() const;
  /// "any participant", "only participant <GUID>" or "the first sender (not yet locked)": for logs.
  [[nodiscard]] std::string describe() const;

 private:
  mutable std::mutex mutex_;
  std::string rule_;
  std::string allowed_;
  std::uint64_t refused_ = 0;
};

/// Fills a sensor_msgs/Image from a grey CV_8UC1 (encoding mono8) or BGR CV_8UC3 (bgr8) image,
/// tightly packed (step = width * channels), reusing `out.data`'s capacity. Other types: error.
Status fill_image_message(const cv::Mat& image, msg::Image& out);

/// Yaw (rad, counter-clockwise about +z) of a quaternion, and the quaternion of a yaw.
[[nodiscard]] double yaw_from_quaternion(const msg::Quaternion& q);
[[nodiscard]] msg::Quaternion quaternion_from_yaw(double yaw_rad);

/// Copies the fields of `status` that visnav/msg/Telemetry carries into `out` (header and
/// sequence_number are the caller's; string capacities are reused). The one NavStatus-to-message
/// mapping: DDS telemetry and MCAP recordings both use it.
void fill_telemetry_message(const NavStatus& status, msg::Telemetry& out);

// ------------------------------------------------------------------------------------------
// Telemetry and mission control
// ------------------------------------------------------------------------------------------

/// Parameters of the DDS telemetry/control endpoints (a config `params:` block).
struct TelemetryParams {
  int domain_id = 0;
  std::string partition;
  std::string telemetry_topic = "rt/visnav/telemetry";
  std::string control_topic = "rt/visnav/control";

  [[nodiscard]] Status validate() const;
  static const ParamSchema<TelemetryParams>& schema();
};

/// visnav::Telemetry publishing every NavStatus on `telemetry_topic` (reliable, volatile,
/// keep-last 10). `publish` is called from the tick thread; errors are logged (rate-limited)
/// through `logger`, never thrown.
class DdsTelemetry final : public Telemetry {
 public:
  /// Headers are stamped with wall time (s since the Unix epoch, like ROS 2).
  [[nodiscard]] static Result<std::unique_ptr<DdsTelemetry>> create(const TelemetryParams& params, Logger& logger);
  ~DdsTelemetry() override;
  void publish(const NavStatus& status) override;
  [[nodiscard]] std::uint64_t published() const;
  /// Number of matched telemetry readers (e.g. `visnav monitor` instances).
  [[nodiscard]] int matched_readers() const;

 private:
  struct Impl;
  explicit DdsTelemetry(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// One mission-control request.
struct ControlRequest {
  msg::ControlCommand command = msg::ControlCommand::pause;
  std::string argument;  ///< swap_detector: detector type
  double receive_time_s = 0.0;  ///< s since the Unix epoch
};

[[nodiscard]] const char* to_string(msg::ControlCommand command);
/// "pause", "resume", "abort", "swap_detector".
[[nodiscard]] Result<msg::ControlCommand> parse_control_command(std::string_view text);

/// Text from the network made safe for one log line: control characters, DEL, '\\' and bytes
/// >= 0x80 are written as \xNN (a newline or ANSI escape cannot forge a line or recolour the
/// terminal) and the result is cut to `max_bytes` of input with "...(N bytes)" appended. Pure.
[[nodiscard]] std::string log_safe(std::string_view text, std::size_t max_bytes = 64);

/// Limits of a control request (checked before anything is logged or queued).
inline constexpr std::size_t kMaxControlArgumentBytes = 64;
/// Requests accepted per second; more are dropped (a flood cannot starve the tick thread).
inline constexpr double kMaxControlRequestsPerS = 20.0;

/// True if `argument` is valid for `command`: pause/resume/abort take none; swap_detector a
/// detector type of 1-64 characters [A-Za-z0-9_.-]. Pure.
[[nodiscard]] bool valid_control_argument(msg::ControlCommand command, std::string_view argument);

/// Receives control requests on `control_topic` (reliable, keep-last 32) on its own thread and
/// queues them; the tick thread drains the queue with `take_pending()` between ticks.
/// Dropped with a warning (at most one per second, the argument shown through log_safe) and
/// counted in `rejected()`: unknown command codes, arguments invalid for their command
/// (valid_control_argument: size limit, charset), and requests beyond kMaxControlRequestsPerS.
class ControlSubscriber {
 public:
  [[nodiscard]] static Result<std::unique_ptr<ControlSubscriber>> create(const TelemetryParams& params, Logger& logger);
  ~ControlSubscriber();
  /// Requests received since the last call, oldest first. Thread-safe.
  [[nodiscard]] std::vector<ControlRequest> take_pending();
  [[nodiscard]] int matched_writers() const;
  /// Requests dropped as malformed so far (unknown code, swap_detector without a type). Thread-safe.
  [[nodiscard]] std::uint64_t rejected() const;

 private:
  struct Impl;
  explicit ControlSubscriber(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// Sends control requests (used by `visnav monitor --send ...` and tests).
class ControlPublisher {
 public:
  [[nodiscard]] static Result<std::unique_ptr<ControlPublisher>> create(const TelemetryParams& params);
  ~ControlPublisher();
  Status send(msg::ControlCommand command, const std::string& argument = {});
  [[nodiscard]] bool wait_for_subscribers(int count, double timeout_s) const;

 private:
  struct Impl;
  explicit ControlPublisher(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace visnav::dds
