// Parts of visnav/dds.hpp that do not touch Cyclone DDS (built with or without DDS).
#include <chrono>
#include <cmath>
#include <cstring>
#include <string>

#include "visnav/dds.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <mutex>
#include <utility>

namespace visnav::dds {

namespace msg {
Time Time::from_seconds(double t_s) {
  Time t;
  double whole = std::floor(t_s);
  double frac = t_s - whole;
  auto ns = static_cast<std::int64_t>(std::llround(frac * 1e9));
  if (ns >= 1000000000) { whole += 1.0; ns -= 1000000000; }
  t.sec = static_cast<std::int32_t>(whole);
  t.nanosec = static_cast<std::uint32_t>(ns);
  return t;
}
}  // namespace msg

std::string ros_topic(std::string_view ros_name) {
  if (ros_name.rfind("rt/", 0) == 0) return std::string(ros_name);
  while (!ros_name.empty() && ros_name.front() == '/') ros_name.remove_prefix(1);
  return "rt/" + std::string(ros_name);
}

std::string loopback_config_xml() {
  return "<CycloneDDS><Domain Id=\"any\"><General><Interfaces><NetworkInterface address=\"127.0.0.1\"/>"
         "</Interfaces><AllowMulticast>false</AllowMulticast></General>"
         "<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>100</MaxAutoParticipantIndex>"
         "<Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery></Domain></CycloneDDS>";
}

double epoch_now_s() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

Result<Reliability> parse_reliability(std::string_view text) {
  if (text == "best_effort") return Reliability::best_effort;
  if (text == "reliable") return Reliability::reliable;
  return fail("reliability '" + std::string(text) + "' is not one of: best_effort reliable");
}

Result<Durability> parse_durability(std::string_view text) {
  if (text == "volatile") return Durability::volatile_data;
  if (text == "transient_local") return Durability::transient_local;
  return fail("durability '" + std::string(text) + "' is not one of: volatile transient_local");
}

const char* to_string(Reliability r) { return r == Reliability::reliable ? "reliable" : "best_effort"; }
const char* to_string(Durability d) { return d == Durability::transient_local ? "transient_local" : "volatile"; }

double yaw_from_quaternion(const msg::Quaternion& q) {
  return std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
}

msg::Quaternion quaternion_from_yaw(double yaw_rad) {
  return msg::Quaternion{0.0, 0.0, std::sin(0.5 * yaw_rad), std::cos(0.5 * yaw_rad)};
}

Status fill_image_message(const cv::Mat& image, msg::Image& out) {
  if (image.empty() || (image.type() != CV_8UC1 && image.type() != CV_8UC3))
    return fail("fill_image_message: expected a non-empty CV_8UC1 or CV_8UC3 image");
  const int channels = image.channels();
  out.height = static_cast<std::uint32_t>(image.rows);
  out.width = static_cast<std::uint32_t>(image.cols);
  out.encoding = channels == 1 ? "mono8" : "bgr8";
  out.is_bigendian = 0;
  out.step = static_cast<std::uint32_t>(image.cols * channels);
  out.data.resize(static_cast<std::size_t>(out.step) * out.height);
  for (int r = 0; r < image.rows; ++r)
    std::memcpy(out.data.data() + static_cast<std::size_t>(r) * out.step, image.ptr(r), out.step);
  return ok();
}

const char* to_string(msg::ControlCommand command) {
  switch (command) {
    case msg::ControlCommand::pause: return "pause";
    case msg::ControlCommand::resume: return "resume";
    case msg::ControlCommand::abort: return "abort";
    case msg::ControlCommand::swap_detector: return "swap_detector";
  }
  return "unknown";
}

Result<msg::ControlCommand> parse_control_command(std::string_view text) {
  for (auto c : {msg::ControlCommand::pause, msg::ControlCommand::resume, msg::ControlCommand::abort,
                 msg::ControlCommand::swap_detector})
    if (text == to_string(c)) return c;
  return fail("control command '" + std::string(text) + "' is not one of: pause resume abort swap_detector");
}

Status SecurityFiles::validate() const {
  const std::pair<const char*, const std::string*> files[] = {{"ca", &ca},
                                                              {"identity_cert", &identity_cert},
                                                              {"private_key", &private_key},
                                                              {"governance", &governance},
                                                              {"permissions", &permissions}};
  for (const auto& [key, path] : files) {
    if (path->empty()) return fail(std::string("security.") + key + ": missing (docs/security.md)");
    if (::access(path->c_str(), R_OK) != 0)
      return fail(std::string("security.") + key + ": " + *path + ": cannot read (" + std::strerror(errno) + ")");
  }
  return ok();
}

SecurityFiles keystore_identity(const std::string& keystore, const std::string& name) {
  const std::string k = keystore.empty() || keystore.back() == '/' ? keystore : keystore + "/";
  return SecurityFiles{k + "ca.pem", k + name + "/cert.pem", k + name + "/key.pem", k + "governance.p7s",
                       k + name + "/permissions.p7s"};
}

namespace {
std::mutex g_security_mutex;
std::optional<SecurityFiles> g_security;
}  // namespace

Status set_default_security(std::optional<SecurityFiles> files) {
  if (files) VISNAV_TRY(files->validate());
  std::lock_guard lock(g_security_mutex);
  g_security = std::move(files);
  return ok();
}

bool default_security_enabled() {
  std::lock_guard lock(g_security_mutex);
  return g_security.has_value();
}

std::optional<SecurityFiles> detail::default_security() {
  std::lock_guard lock(g_security_mutex);
  return g_security;
}

Status TelemetryParams::validate() const {
  if (telemetry_topic.empty()) return Error{"telemetry_topic must not be empty", ErrorCode::invalid_value, {{}, 0, "telemetry_topic"}};
  if (control_topic.empty()) return Error{"control_topic must not be empty", ErrorCode::invalid_value, {{}, 0, "control_topic"}};
  if (telemetry_topic == control_topic)
    return Error{"telemetry_topic and control_topic must differ", ErrorCode::inconsistent, {{}, 0, "control_topic"}};
  return ok();
}

const ParamSchema<TelemetryParams>& TelemetryParams::schema() {
  static const auto s = ParamSchema<TelemetryParams>{}
      .field("domain_id", &TelemetryParams::domain_id, "DDS domain id").range(0, 232)
      .field("partition", &TelemetryParams::partition, "DDS partition (empty = default partition)")
      .field("telemetry_topic", &TelemetryParams::telemetry_topic, "DDS topic of visnav/msg/Telemetry")
      .field("control_topic", &TelemetryParams::control_topic, "DDS topic of visnav/msg/Control");
  return s;
}

bool is_participant_guid(std::string_view text) {
  return text.size() == 32 && text.find_first_not_of("0123456789abcdef") == std::string_view::npos;
}

Result<WriterArbiter> WriterArbiter::parse(std::string_view rule) {
  if (!rule.empty() && rule != "first" && !is_participant_guid(rule))
    return fail(ErrorCode::invalid_value, "expected a participant GUID (32 lowercase hex digits) or 'first', got '" +
                                              log_safe(rule) + "'");
  WriterArbiter arbiter;
  arbiter.rule_ = std::string(rule);
  if (rule != "first") arbiter.allowed_ = std::string(rule);
  return arbiter;
}

// Moves happen while the arbiter is being set up (before any subscription can call admit), but
// the lock keeps a late call on the source well-defined.
WriterArbiter::WriterArbiter(WriterArbiter&& other) noexcept {
  std::lock_guard lock(other.mutex_);
  rule_ = std::move(other.rule_);
  allowed_ = std::move(other.allowed_);
  refused_ = other.refused_;
}

WriterArbiter& WriterArbiter::operator=(WriterArbiter&& other) noexcept {
  if (this != &other) {
    std::scoped_lock lock(mutex_, other.mutex_);
    rule_ = std::move(other.rule_);
    allowed_ = std::move(other.allowed_);
    refused_ = other.refused_;
  }
  return *this;
}

WriterArbiter::Verdict WriterArbiter::admit(std::string_view writer_participant) {
  std::lock_guard lock(mutex_);
  if (rule_.empty()) return {true, false};
  // An unknown sender never drives and never becomes the locked writer: "first" locks onto a GUID.
  if (allowed_.empty() && !writer_participant.empty()) {
    allowed_ = std::string(writer_participant);
    return {true, true};
  }
  if (!writer_participant.empty() && writer_participant == allowed_) return {true, false};
  ++refused_;
  return {false, false};
}

std::string WriterArbiter::allowed() const {
  std::lock_guard lock(mutex_);
  return allowed_;
}

std::uint64_t WriterArbiter::refused() const {
  std::lock_guard lock(mutex_);
  return refused_;
}

std::string WriterArbiter::describe() const {
  std::lock_guard lock(mutex_);
  if (rule_.empty()) return "any participant";
  if (allowed_.empty()) return "the first sender (not yet locked)";
  return "only participant " + allowed_ + (rule_ == "first" ? " (the first sender)" : "");
}

}  // namespace visnav::dds
