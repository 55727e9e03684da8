// The RAII layer of visnav/dds.hpp over the Cyclone DDS C API: participant, typed writers,
// readers and subscriptions (waitset thread), and the conversions between the C++ message
// structs and the idlc-generated C types (ros2_msgs.h, built in runtime/dds/).
#include "visnav/dds.hpp"
#include "visnav/dds_joy.hpp"

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <thread>

#ifdef VISNAV_HAVE_DDS
#include <dds/dds.h>
#include <unistd.h>

#include "ros2_msgs.h"
#endif

namespace visnav::dds {

#ifndef VISNAV_HAVE_DDS

// ---- built without DDS: every create() fails, nothing else is reachable ------------------

bool available() { return false; }

namespace {
Error no_dds() { return fail("visnav was built without Cyclone DDS (VISNAV_BUILD_DDS=OFF)"); }
}  // namespace

namespace detail {
struct ParticipantCore { int domain_id = 0; };
struct WriterCore { std::string topic; };
struct ReaderCore { std::string topic; };
struct SubscriptionCore { std::string topic; };
}  // namespace detail

Result<Participant> Participant::create(int) { return no_dds(); }
Result<Participant> Participant::create(int, const std::optional<SecurityFiles>&) { return no_dds(); }
int Participant::domain_id() const { return core_ ? core_->domain_id : -1; }
std::string Participant::guid() const { return {}; }

template <typename M> Result<Writer<M>> Writer<M>::create(const Participant&, const EndpointOptions&) { return no_dds(); }
template <typename M> Writer<M>::Writer(std::unique_ptr<detail::WriterCore> core) : core_(std::move(core)) {}
template <typename M> Writer<M>::Writer(Writer&&) noexcept = default;
template <typename M> Writer<M>& Writer<M>::operator=(Writer&&) noexcept = default;
template <typename M> Writer<M>::~Writer() = default;
template <typename M> Status Writer<M>::write(const M&) { return no_dds(); }
template <typename M> int Writer<M>::matched_readers() const { return 0; }
template <typename M> bool Writer<M>::wait_for_readers(int, double) const { return false; }
template <typename M> const std::string& Writer<M>::topic() const { return core_->topic; }

template <typename M> Result<Reader<M>> Reader<M>::create(const Participant&, const EndpointOptions&) { return no_dds(); }
template <typename M> Reader<M>::Reader(std::unique_ptr<detail::ReaderCore> core) : core_(std::move(core)) {}
template <typename M> Reader<M>::Reader(Reader&&) noexcept = default;
template <typename M> Reader<M>& Reader<M>::operator=(Reader&&) noexcept = default;
template <typename M> Reader<M>::~Reader() = default;
template <typename M> Result<std::size_t> Reader<M>::take(const Handler&) { return no_dds(); }
template <typename M> Result<bool> Reader<M>::wait(double) { return no_dds(); }
template <typename M> int Reader<M>::matched_writers() const { return 0; }
template <typename M> bool Reader<M>::wait_for_writers(int, double) const { return false; }
template <typename M> const std::string& Reader<M>::topic() const { return core_->topic; }

template <typename M>
Result<std::unique_ptr<Subscription<M>>> Subscription<M>::create(const Participant&, const EndpointOptions&, Handler,
                                                                  WarningHandler) {
  return no_dds();
}
template <typename M> Subscription<M>::Subscription(std::unique_ptr<detail::SubscriptionCore> core) : core_(std::move(core)) {}
template <typename M> Subscription<M>::~Subscription() = default;
template <typename M> SubscriptionStats Subscription<M>::stats() const { return {}; }
template <typename M> const std::string& Subscription<M>::topic() const { return core_->topic; }

#else  // VISNAV_HAVE_DDS

bool available() { return true; }

namespace {

Error dds_error(const std::string& what, dds_return_t rc) {
  return fail(what + ": " + dds_strretcode(rc) + " (DDS return code " + std::to_string(rc) + ")");
}

double to_seconds(dds_time_t t_ns) { return static_cast<double>(t_ns) * 1e-9; }

dds_duration_t to_duration(double t_s) {
  if (t_s <= 0.0) return 0;
  if (t_s > 1e9) return DDS_INFINITY;
  return static_cast<dds_duration_t>(t_s * 1e9);
}

// ---- message conversions -----------------------------------------------------------------
// to_c: the C struct borrows the C++ message's storage (strings, byte buffers) for the
// duration of one dds_write, which only reads it. from_c: deep copy out of a loaned sample.

char* borrow(const std::string& s) { return const_cast<char*>(s.c_str()); }
std::string copy_str(const char* s) { return s != nullptr ? std::string(s) : std::string(); }

void borrow_bytes(const std::vector<std::uint8_t>& v, dds_sequence_uint8& seq) {
  seq._maximum = static_cast<uint32_t>(v.size());
  seq._length = static_cast<uint32_t>(v.size());
  seq._buffer = const_cast<std::uint8_t*>(v.data());
  seq._release = false;
}
void copy_bytes(const dds_sequence_uint8& seq, std::vector<std::uint8_t>& v) {
  if (seq._buffer == nullptr || seq._length == 0) { v.clear(); return; }
  v.assign(seq._buffer, seq._buffer + seq._length);
}

void to_c(const msg::Header& m, std_msgs_msg_dds__Header_& c) {
  c.stamp.sec = m.stamp.sec;
  c.stamp.nanosec = m.stamp.nanosec;
  c.frame_id = borrow(m.frame_id);
}
void from_c(const std_msgs_msg_dds__Header_& c, msg::Header& m) {
  m.stamp.sec = c.stamp.sec;
  m.stamp.nanosec = c.stamp.nanosec;
  m.frame_id = copy_str(c.frame_id);
}
void to_c(const msg::Vector3& m, geometry_msgs_msg_dds__Vector3_& c) { c.x = m.x; c.y = m.y; c.z = m.z; }
void from_c(const geometry_msgs_msg_dds__Vector3_& c, msg::Vector3& m) { m.x = c.x; m.y = c.y; m.z = c.z; }
void to_c(const msg::Twist& m, geometry_msgs_msg_dds__Twist_& c) { to_c(m.linear, c.linear); to_c(m.angular, c.angular); }
void from_c(const geometry_msgs_msg_dds__Twist_& c, msg::Twist& m) { from_c(c.linear, m.linear); from_c(c.angular, m.angular); }

void to_c(const msg::Odometry& m, nav_msgs_msg_dds__Odometry_& c) {
  to_c(m.header, c.header);
  c.child_frame_id = borrow(m.child_frame_id);
  const auto& p = m.pose.pose;
  c.pose.pose.position.x = p.position.x;
  c.pose.pose.position.y = p.position.y;
  c.pose.pose.position.z = p.position.z;
  c.pose.pose.orientation.x = p.orientation.x;
  c.pose.pose.orientation.y = p.orientation.y;
  c.pose.pose.orientation.z = p.orientation.z;
  c.pose.pose.orientation.w = p.orientation.w;
  std::copy(m.pose.covariance.begin(), m.pose.covariance.end(), c.pose.covariance);
  to_c(m.twist.twist, c.twist.twist);
  std::copy(m.twist.covariance.begin(), m.twist.covariance.end(), c.twist.covariance);
}
void from_c(const nav_msgs_msg_dds__Odometry_& c, msg::Odometry& m) {
  from_c(c.header, m.header);
  m.child_frame_id = copy_str(c.child_frame_id);
  auto& p = m.pose.pose;
  p.position = {c.pose.pose.position.x, c.pose.pose.position.y, c.pose.pose.position.z};
  p.orientation = {c.pose.pose.orientation.x, c.pose.pose.orientation.y, c.pose.pose.orientation.z,
                   c.pose.pose.orientation.w};
  std::copy(std::begin(c.pose.covariance), std::end(c.pose.covariance), m.pose.covariance.begin());
  from_c(c.twist.twist, m.twist.twist);
  std::copy(std::begin(c.twist.covariance), std::end(c.twist.covariance), m.twist.covariance.begin());
}

void to_c(const msg::Image& m, sensor_msgs_msg_dds__Image_& c) {
  to_c(m.header, c.header);
  c.height = m.height;
  c.width = m.width;
  c.encoding = borrow(m.encoding);
  c.is_bigendian = m.is_bigendian;
  c.step = m.step;
  borrow_bytes(m.data, c.data);
}
void from_c(const sensor_msgs_msg_dds__Image_& c, msg::Image& m) {
  from_c(c.header, m.header);
  m.height = c.height;
  m.width = c.width;
  m.encoding = copy_str(c.encoding);
  m.is_bigendian = c.is_bigendian;
  m.step = c.step;
  copy_bytes(c.data, m.data);
}

void to_c(const msg::CompressedImage& m, sensor_msgs_msg_dds__CompressedImage_& c) {
  to_c(m.header, c.header);
  c.format = borrow(m.format);
  borrow_bytes(m.data, c.data);
}
void from_c(const sensor_msgs_msg_dds__CompressedImage_& c, msg::CompressedImage& m) {
  from_c(c.header, m.header);
  m.format = copy_str(c.format);
  copy_bytes(c.data, m.data);
}

// Joy: the sequences borrow/copy like the byte buffers above.
void to_c(const msg::Joy& m, sensor_msgs_msg_dds__Joy_& c) {
  to_c(m.header, c.header);
  c.axes._maximum = c.axes._length = static_cast<uint32_t>(m.axes.size());
  c.axes._buffer = const_cast<float*>(m.axes.data());
  c.axes._release = false;
  c.buttons._maximum = c.buttons._length = static_cast<uint32_t>(m.buttons.size());
  c.buttons._buffer = const_cast<std::int32_t*>(m.buttons.data());
  c.buttons._release = false;
}
void from_c(const sensor_msgs_msg_dds__Joy_& c, msg::Joy& m) {
  from_c(c.header, m.header);
  m.axes.assign(c.axes._buffer, c.axes._buffer + (c.axes._buffer != nullptr ? c.axes._length : 0));
  m.buttons.assign(c.buttons._buffer, c.buttons._buffer + (c.buttons._buffer != nullptr ? c.buttons._length : 0));
}

void to_c(const msg::Telemetry& m, visnav_msg_dds__Telemetry_& c) {
  to_c(m.header, c.header);
  c.sequence_number = m.sequence_number;
  c.node_path = borrow(m.node_path);
  c.map_node = borrow(m.map_node);
  c.edge = borrow(m.edge);
  c.distance_m = m.distance_m;
  c.matches = m.matches;
  c.inliers = m.inliers;
  c.offset_px = m.offset_px;
  c.linear_mps = m.linear_mps;
  c.angular_radps = m.angular_radps;
  c.status = borrow(m.status);
}
void from_c(const visnav_msg_dds__Telemetry_& c, msg::Telemetry& m) {
  from_c(c.header, m.header);
  m.sequence_number = c.sequence_number;
  m.node_path = copy_str(c.node_path);
  m.map_node = copy_str(c.map_node);
  m.edge = copy_str(c.edge);
  m.distance_m = c.distance_m;
  m.matches = c.matches;
  m.inliers = c.inliers;
  m.offset_px = c.offset_px;
  m.linear_mps = c.linear_mps;
  m.angular_radps = c.angular_radps;
  m.status = copy_str(c.status);
}

void to_c(const msg::Control& m, visnav_msg_dds__Control_& c) {
  to_c(m.header, c.header);
  c.sequence_number = m.sequence_number;
  c.command = m.command;
  c.argument = borrow(m.argument);
}
void from_c(const visnav_msg_dds__Control_& c, msg::Control& m) {
  from_c(c.header, m.header);
  m.sequence_number = c.sequence_number;
  m.command = c.command;
  m.argument = copy_str(c.argument);
}

template <typename M> struct Binding;
#define VISNAV_DDS_BIND_(M, C)                                                  \
  template <> struct Binding<msg::M> {                                          \
    using CType = C;                                                            \
    static const dds_topic_descriptor_t* descriptor() { return &C##_desc; }     \
  };
VISNAV_DDS_BIND_(Twist, geometry_msgs_msg_dds__Twist_)
VISNAV_DDS_BIND_(Odometry, nav_msgs_msg_dds__Odometry_)
VISNAV_DDS_BIND_(Image, sensor_msgs_msg_dds__Image_)
VISNAV_DDS_BIND_(CompressedImage, sensor_msgs_msg_dds__CompressedImage_)
VISNAV_DDS_BIND_(Joy, sensor_msgs_msg_dds__Joy_)
VISNAV_DDS_BIND_(Telemetry, visnav_msg_dds__Telemetry_)
VISNAV_DDS_BIND_(Control, visnav_msg_dds__Control_)
#undef VISNAV_DDS_BIND_

/// Owns a dds_qos_t.
class QosHandle {
 public:
  QosHandle() : qos_(dds_create_qos()) {}
  ~QosHandle() { dds_delete_qos(qos_); }
  QosHandle(const QosHandle&) = delete;
  QosHandle& operator=(const QosHandle&) = delete;
  dds_qos_t* get() const { return qos_; }

 private:
  dds_qos_t* qos_;
};

void apply_endpoint_qos(const Qos& q, dds_qos_t* qos) {
  dds_qset_reliability(qos, q.reliability == Reliability::reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT,
                       DDS_MSECS(100));
  dds_qset_durability(qos, q.durability == Durability::transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL
                                                                        : DDS_DURABILITY_VOLATILE);
  if (q.history_depth <= 0) dds_qset_history(qos, DDS_HISTORY_KEEP_ALL, 0);
  else dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, q.history_depth);
  if (q.deadline_s > 0.0) dds_qset_deadline(qos, to_duration(q.deadline_s));
  // Plain CDR (XCDR1), like rmw_cyclonedds_cpp.
  const dds_data_representation_id_t xcdr1 = DDS_DATA_REPRESENTATION_XCDR1;
  dds_qset_data_representation(qos, 1, &xcdr1);
}

Status check_options(const EndpointOptions& options) {
  if (options.topic.empty()) return fail(ErrorCode::invalid_value, {{}, 0, "topic"}, "empty DDS topic name");
  if (options.qos.history_depth < 0) return fail("topic '" + options.topic + "': history depth must be >= 0");
  if (options.qos.deadline_s < 0.0) return fail("topic '" + options.topic + "': deadline must be >= 0");
  return ok();
}

bool poll_until(double timeout_s, const std::function<bool()>& done) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!done()) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

}  // namespace

namespace detail {

struct ParticipantCore {
  dds_entity_t participant = 0;
  int domain_id = 0;
  ~ParticipantCore() {
    if (participant > 0) dds_delete(participant);
  }
};

/// Topic + publisher/subscriber + endpoint; deleted endpoint-first.
struct EndpointCore {
  std::shared_ptr<ParticipantCore> participant;
  std::string topic_name;
  dds_entity_t topic = 0;
  dds_entity_t group = 0;  // publisher or subscriber
  dds_entity_t endpoint = 0;

  EndpointCore() = default;
  EndpointCore(const EndpointCore&) = delete;
  EndpointCore& operator=(const EndpointCore&) = delete;
  ~EndpointCore() {
    if (endpoint > 0) dds_delete(endpoint);
    if (group > 0) dds_delete(group);
    if (topic > 0) dds_delete(topic);
  }

  Status make(std::shared_ptr<ParticipantCore> p, const dds_topic_descriptor_t* descriptor, const char* type_name,
              const EndpointOptions& options, bool writer) {
    VISNAV_TRY(check_options(options));
    if (std::strcmp(descriptor->m_typename, type_name) != 0)  // MessageTraits and the IDL disagree: a bug
      return fail(std::string("internal: generated type '") + descriptor->m_typename + "' != '" + type_name + "'");
    participant = std::move(p);
    topic_name = options.topic;
    const std::string what = std::string(writer ? "DDS writer" : "DDS reader") + " on topic '" + options.topic + "'";
    topic = dds_create_topic(participant->participant, descriptor, options.topic.c_str(), nullptr, nullptr);
    if (topic < 0) return dds_error(what + ": create topic (type " + descriptor->m_typename + ")", topic);
    QosHandle group_qos;
    if (!options.partition.empty()) dds_qset_partition1(group_qos.get(), options.partition.c_str());
    group = writer ? dds_create_publisher(participant->participant, group_qos.get(), nullptr)
                   : dds_create_subscriber(participant->participant, group_qos.get(), nullptr);
    if (group < 0) return dds_error(what + ": create publisher/subscriber", group);
    QosHandle qos;
    apply_endpoint_qos(options.qos, qos.get());
    endpoint = writer ? dds_create_writer(group, topic, qos.get(), nullptr) : dds_create_reader(group, topic, qos.get(), nullptr);
    if (endpoint < 0) return dds_error(what, endpoint);
    return ok();
  }
};

struct WriterCore : EndpointCore {
  int matched() const {
    dds_publication_matched_status_t st{};
    if (dds_get_publication_matched_status(endpoint, &st) < 0) return 0;
    return static_cast<int>(st.current_count);
  }
};

std::string guid_hex(const dds_guid_t& guid) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  for (unsigned char b : guid.v) {
    out += kHex[b >> 4];
    out += kHex[b & 0xf];
  }
  return out;
}

struct ReaderCore : EndpointCore {
  dds_entity_t waitset = 0;
  dds_entity_t condition = 0;
  std::map<dds_instance_handle_t, std::string> writer_participants;  // take thread only

  /// Participant GUID of a matched writer (cached per publication handle; bounded).
  const std::string& participant_of(dds_instance_handle_t writer) {
    auto it = writer_participants.find(writer);
    if (it != writer_participants.end()) return it->second;
    if (writer_participants.size() > 4096) writer_participants.clear();
    std::string hex;
    if (dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(endpoint, writer); ep != nullptr) {
      hex = guid_hex(ep->participant_key);
      dds_builtintopic_free_endpoint(ep);
      return writer_participants.emplace(writer, std::move(hex)).first->second;
    }
    static const std::string kUnknown;
    return kUnknown;  // not cached: discovery data may arrive later
  }
  ~ReaderCore() {
    if (waitset > 0) dds_delete(waitset);
    if (condition > 0) dds_delete(condition);
  }
  int matched() const {
    dds_subscription_matched_status_t st{};
    if (dds_get_subscription_matched_status(endpoint, &st) < 0) return 0;
    return static_cast<int>(st.current_count);
  }
  Status make_waitset() {
    condition = dds_create_readcondition(endpoint, DDS_ANY_STATE);
    if (condition < 0) return dds_error("topic '" + topic_name + "': create read condition", condition);
    waitset = dds_create_waitset(participant->participant);
    if (waitset < 0) return dds_error("topic '" + topic_name + "': create waitset", waitset);
    dds_return_t rc = dds_waitset_attach(waitset, condition, 1);
    if (rc < 0) return dds_error("topic '" + topic_name + "': attach read condition", rc);
    return ok();
  }

  /// Takes everything available; calls `fn(const CType&, SampleInfo)` for valid samples.
  template <typename CType, typename Fn>
  Result<std::size_t> take_all(Fn&& fn) {
    constexpr int kBatch = 16;
    std::size_t valid = 0;
    for (;;) {
      void* samples[kBatch] = {};
      dds_sample_info_t infos[kBatch];
      const dds_return_t n = dds_take(endpoint, samples, infos, kBatch, kBatch);
      if (n < 0) return dds_error("topic '" + topic_name + "': take", n);
      if (n == 0) break;
      const double now_s = epoch_now_s();
      for (int i = 0; i < n; ++i) {
        if (!infos[i].valid_data) continue;
        SampleInfo info;
        info.source_time_s = to_seconds(infos[i].source_timestamp);
        info.receive_time_s = now_s;
        info.writer_handle = infos[i].publication_handle;
        info.writer_participant = participant_of(infos[i].publication_handle);
        ++valid;
        fn(*static_cast<const CType*>(samples[i]), info);
      }
      dds_return_loan(endpoint, samples, n);
      if (n < kBatch) break;
    }
    return valid;
  }
};

/// A reader + waitset + guard condition + DCPSPublication watcher + thread.
struct SubscriptionCore {
  ReaderCore reader;
  std::string expected_type;
  dds_entity_t guard = 0;
  dds_entity_t builtin_reader = 0;
  dds_entity_t builtin_condition = 0;
  std::thread thread;
  std::atomic<bool> stop{false};
  std::atomic<std::uint64_t> samples{0};
  std::atomic<std::uint64_t> wrong_type_writers{0};
  std::set<std::string> wrong_writer_guids;  // subscription thread only
  std::function<void(const std::string&)> on_warning;
  std::function<Result<std::size_t>()> take_samples;  // set by the typed Subscription

  ~SubscriptionCore() {
    halt();
    if (builtin_condition > 0) dds_delete(builtin_condition);
    if (builtin_reader > 0) dds_delete(builtin_reader);
    if (guard > 0) dds_delete(guard);
  }

  void halt() {
    if (!thread.joinable()) return;
    stop = true;
    if (guard > 0) dds_set_guardcondition(guard, true);
    thread.join();
  }

  Status make_extras() {
    VISNAV_TRY(reader.make_waitset());
    guard = dds_create_guardcondition(reader.participant->participant);
    if (guard < 0) return dds_error("topic '" + reader.topic_name + "': create guard condition", guard);
    dds_return_t rc = dds_waitset_attach(reader.waitset, guard, 2);
    if (rc < 0) return dds_error("topic '" + reader.topic_name + "': attach guard condition", rc);
    builtin_reader = dds_create_reader(reader.participant->participant, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr);
    if (builtin_reader < 0) return dds_error("create DCPSPublication reader", builtin_reader);
    builtin_condition = dds_create_readcondition(builtin_reader, DDS_ANY_STATE);
    if (builtin_condition < 0) return dds_error("create DCPSPublication read condition", builtin_condition);
    rc = dds_waitset_attach(reader.waitset, builtin_condition, 3);
    if (rc < 0) return dds_error("attach DCPSPublication read condition", rc);
    return ok();
  }

  void warn(const std::string& message) {
    if (on_warning) on_warning(message);
  }

  void check_publications() {
    constexpr int kBatch = 8;
    for (;;) {
      void* buffers[kBatch] = {};
      dds_sample_info_t infos[kBatch];
      const dds_return_t n = dds_take(builtin_reader, buffers, infos, kBatch, kBatch);
      if (n <= 0) break;
      for (int i = 0; i < n; ++i) {
        if (!infos[i].valid_data || infos[i].instance_state != DDS_IST_ALIVE) continue;
        const auto* ep = static_cast<const dds_builtintopic_endpoint_t*>(buffers[i]);
        if (ep->topic_name == nullptr || ep->type_name == nullptr) continue;
        if (reader.topic_name != ep->topic_name || expected_type == ep->type_name) continue;
        std::string guid(reinterpret_cast<const char*>(ep->key.v), sizeof(ep->key.v));
        if (!wrong_writer_guids.insert(guid).second) continue;
        ++wrong_type_writers;
        warn("topic '" + reader.topic_name + "': ignoring a writer with type '" + ep->type_name + "' (expected '" +
             expected_type + "'); its samples are never delivered (" + std::to_string(wrong_type_writers.load()) +
             " such writer(s) so far)");
      }
      dds_return_loan(builtin_reader, buffers, n);
      if (n < kBatch) break;
    }
  }

  void run() {
    dds_attach_t triggered[4];
    while (!stop) {
      const dds_return_t n = dds_waitset_wait(reader.waitset, triggered, 4, DDS_MSECS(500));
      if (stop) break;
      if (n < 0) {
        warn("topic '" + reader.topic_name + "': waitset wait failed: " + dds_strretcode(n));
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        continue;
      }
      auto taken = take_samples();
      if (!taken) warn(taken.error().message);
      else samples += *taken;
      check_publications();
    }
  }
};

}  // namespace detail

// ---- Participant ---------------------------------------------------------------------------

namespace {

/// Folder of Cyclone's builtin security plugins (libdds_security_{auth,crypto,ac}.so). Debian
/// installs them outside the linker path; VISNAV_DDS_SECURITY_LIB_DIR overrides.
std::string security_library_dir() {
  if (const char* env = std::getenv("VISNAV_DDS_SECURITY_LIB_DIR"); env != nullptr && *env != '\0') return env;
  for (const char* dir : {"/usr/lib/x86_64-linux-gnu/libddsc0debian", "/usr/lib/aarch64-linux-gnu/libddsc0debian",
                          "/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/local/lib", "/usr/lib"}) {
    if (::access((std::string(dir) + "/libdds_security_auth.so").c_str(), R_OK) == 0) return dir;
  }
  return {};
}

std::string file_uri(const std::string& path) {
  std::error_code ec;
  const auto abs = std::filesystem::absolute(path, ec);
  return "file:" + (ec ? path : abs.lexically_normal().string());
}

}  // namespace

Result<Participant> Participant::create(int domain_id) { return create(domain_id, detail::default_security()); }

Result<Participant> Participant::create(int domain_id, const std::optional<SecurityFiles>& security) {
  if (domain_id < 0 || domain_id > 232) return fail("DDS domain id " + std::to_string(domain_id) + " is out of range [0, 232]");
  QosHandle qos;
  if (security) {
    VISNAV_TRY(security->validate());
    const std::string dir = security_library_dir();
    if (dir.empty())
      return fail("DDS Security: Cyclone's security plugins (libdds_security_auth.so) were not found; install the "
                  "Debian package libddsc0debian or set VISNAV_DDS_SECURITY_LIB_DIR");
    const std::pair<const char*, std::string> props[] = {
        {"dds.sec.auth.library.path", dir + "/libdds_security_auth.so"},
        {"dds.sec.auth.library.init", "init_authentication"},
        {"dds.sec.auth.library.finalize", "finalize_authentication"},
        {"dds.sec.crypto.library.path", dir + "/libdds_security_crypto.so"},
        {"dds.sec.crypto.library.init", "init_crypto"},
        {"dds.sec.crypto.library.finalize", "finalize_crypto"},
        {"dds.sec.access.library.path", dir + "/libdds_security_ac.so"},
        {"dds.sec.access.library.init", "init_access_control"},
        {"dds.sec.access.library.finalize", "finalize_access_control"},
        {"dds.sec.auth.identity_ca", file_uri(security->ca)},
        {"dds.sec.auth.identity_certificate", file_uri(security->identity_cert)},
        {"dds.sec.auth.private_key", file_uri(security->private_key)},
        {"dds.sec.access.permissions_ca", file_uri(security->ca)},
        {"dds.sec.access.governance", file_uri(security->governance)},
        {"dds.sec.access.permissions", file_uri(security->permissions)},
    };
    for (const auto& [name, value] : props) dds_qset_prop(qos.get(), name, value.c_str());
  }
  auto core = std::make_shared<detail::ParticipantCore>();
  core->domain_id = domain_id;
  core->participant = dds_create_participant(static_cast<dds_domainid_t>(domain_id), qos.get(), nullptr);
  if (core->participant < 0) {
    const dds_return_t rc = core->participant;
    core->participant = 0;
    return dds_error("create DDS participant in domain " + std::to_string(domain_id) +
                         (security ? " with DDS Security (identity " + security->identity_cert +
                                         "; check that the CA signed it, the key matches and governance/permissions "
                                         "are signed by the CA and name this identity)"
                                   : std::string(" (check CYCLONEDDS_URI and the network configuration)")),
                     rc);
  }
  return Participant(std::move(core));
}

int Participant::domain_id() const { return core_->domain_id; }

std::string Participant::guid() const {
  dds_guid_t guid{};
  if (dds_get_guid(core_->participant, &guid) < 0) return {};
  return detail::guid_hex(guid);
}

// ---- Writer --------------------------------------------------------------------------------

template <typename M>
Result<Writer<M>> Writer<M>::create(const Participant& participant, const EndpointOptions& options) {
  auto core = std::make_unique<detail::WriterCore>();
  VISNAV_TRY(core->make(participant.core_, Binding<M>::descriptor(), MessageTraits<M>::type_name, options, true));
  return Writer(std::move(core));
}
template <typename M> Writer<M>::Writer(std::unique_ptr<detail::WriterCore> core) : core_(std::move(core)) {}
template <typename M> Writer<M>::Writer(Writer&&) noexcept = default;
template <typename M> Writer<M>& Writer<M>::operator=(Writer&&) noexcept = default;
template <typename M> Writer<M>::~Writer() = default;

template <typename M>
Status Writer<M>::write(const M& sample) {
  typename Binding<M>::CType c{};
  to_c(sample, c);
  const dds_return_t rc = dds_write(core_->endpoint, &c);
  if (rc < 0) return dds_error("topic '" + core_->topic_name + "': write", rc);
  return ok();
}
template <typename M> int Writer<M>::matched_readers() const { return core_->matched(); }
template <typename M>
bool Writer<M>::wait_for_readers(int count, double timeout_s) const {
  return poll_until(timeout_s, [&] { return core_->matched() >= count; });
}
template <typename M> const std::string& Writer<M>::topic() const { return core_->topic_name; }

// ---- Reader --------------------------------------------------------------------------------

template <typename M>
Result<Reader<M>> Reader<M>::create(const Participant& participant, const EndpointOptions& options) {
  auto core = std::make_unique<detail::ReaderCore>();
  VISNAV_TRY(core->make(participant.core_, Binding<M>::descriptor(), MessageTraits<M>::type_name, options, false));
  VISNAV_TRY(core->make_waitset());
  return Reader(std::move(core));
}
template <typename M> Reader<M>::Reader(std::unique_ptr<detail::ReaderCore> core) : core_(std::move(core)) {}
template <typename M> Reader<M>::Reader(Reader&&) noexcept = default;
template <typename M> Reader<M>& Reader<M>::operator=(Reader&&) noexcept = default;
template <typename M> Reader<M>::~Reader() = default;

template <typename M>
Result<std::size_t> Reader<M>::take(const Handler& handler) {
  using C = typename Binding<M>::CType;
  return core_->take_all<C>([&](const C& c, const SampleInfo& info) {
    M m;
    from_c(c, m);
    if (handler) handler(std::move(m), info);
  });
}

template <typename M>
Result<bool> Reader<M>::wait(double timeout_s) {
  dds_attach_t triggered[1];
  const dds_return_t n = dds_waitset_wait(core_->waitset, triggered, 1, to_duration(timeout_s));
  if (n < 0) return dds_error("topic '" + core_->topic_name + "': wait", n);
  return n > 0;
}
template <typename M> int Reader<M>::matched_writers() const { return core_->matched(); }
template <typename M>
bool Reader<M>::wait_for_writers(int count, double timeout_s) const {
  return poll_until(timeout_s, [&] { return core_->matched() >= count; });
}
template <typename M> const std::string& Reader<M>::topic() const { return core_->topic_name; }

// ---- Subscription --------------------------------------------------------------------------

template <typename M>
Result<std::unique_ptr<Subscription<M>>> Subscription<M>::create(const Participant& participant,
                                                                  const EndpointOptions& options, Handler on_sample,
                                                                  WarningHandler on_warning) {
  if (!on_sample) return fail("topic '" + options.topic + "': subscription without a sample handler");
  auto core = std::make_unique<detail::SubscriptionCore>();
  VISNAV_TRY(core->reader.make(participant.core_, Binding<M>::descriptor(), MessageTraits<M>::type_name, options, false));
  VISNAV_TRY(core->make_extras());
  core->expected_type = MessageTraits<M>::type_name;
  core->on_warning = std::move(on_warning);
  detail::ReaderCore* reader = &core->reader;
  core->take_samples = [reader, handler = std::move(on_sample)]() -> Result<std::size_t> {
    using C = typename Binding<M>::CType;
    M m;  // reused: strings and byte buffers keep their capacity between samples
    return reader->take_all<C>([&](const C& c, const SampleInfo& info) {
      from_c(c, m);
      handler(std::move(m), info);
    });
  };
  detail::SubscriptionCore* raw = core.get();
  core->thread = std::thread([raw] { raw->run(); });
  return std::unique_ptr<Subscription>(new Subscription(std::move(core)));
}
template <typename M> Subscription<M>::Subscription(std::unique_ptr<detail::SubscriptionCore> core) : core_(std::move(core)) {}
template <typename M> Subscription<M>::~Subscription() { if (core_) core_->halt(); }

template <typename M>
SubscriptionStats Subscription<M>::stats() const {
  SubscriptionStats s;
  s.samples = core_->samples.load();
  s.wrong_type_writers = core_->wrong_type_writers.load();
  s.matched_writers = core_->reader.matched();
  dds_requested_deadline_missed_status_t dl{};
  if (dds_get_requested_deadline_missed_status(core_->reader.endpoint, &dl) >= 0) s.deadline_missed = dl.total_count;
  return s;
}
template <typename M> const std::string& Subscription<M>::topic() const { return core_->reader.topic_name; }

#endif  // VISNAV_HAVE_DDS

// ---- explicit instantiations: the message types of visnav/dds.hpp ------------------------
#define VISNAV_DDS_INSTANTIATE_(M) \
  template class Writer<msg::M>;   \
  template class Reader<msg::M>;   \
  template class Subscription<msg::M>;
VISNAV_DDS_INSTANTIATE_(Twist)
VISNAV_DDS_INSTANTIATE_(Odometry)
VISNAV_DDS_INSTANTIATE_(Image)
VISNAV_DDS_INSTANTIATE_(CompressedImage)
VISNAV_DDS_INSTANTIATE_(Joy)
VISNAV_DDS_INSTANTIATE_(Telemetry)
VISNAV_DDS_INSTANTIATE_(Control)
#undef VISNAV_DDS_INSTANTIATE_

}  // namespace visnav::dds
