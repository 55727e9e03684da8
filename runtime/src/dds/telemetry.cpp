// DDS telemetry publisher and mission-control endpoints (visnav/dds.hpp), built on the typed
// Writer/Subscription layer only.
#include <algorithm>
#include <atomic>
#include <deque>
#include <mutex>

#include "visnav/dds.hpp"

namespace visnav::dds {

namespace {

Qos telemetry_qos() { return Qos{Reliability::reliable, Durability::volatile_data, 10, 0.0}; }
Qos control_qos() { return Qos{Reliability::reliable, Durability::volatile_data, 32, 0.0}; }

msg::Header stamped_now(const char* frame_id) {
  msg::Header h;
  h.stamp = msg::Time::from_seconds(epoch_now_s());
  h.frame_id = frame_id;
  return h;
}

}  // namespace

// ---- DdsTelemetry ---------------------------------------------------------------------------

struct DdsTelemetry::Impl {
  Participant participant;
  Writer<msg::Telemetry> writer;
  Logger* logger;
  msg::Telemetry sample;  // reused between publishes
  std::uint64_t published = 0;
  WarningLimiter limiter{5.0};
};

DdsTelemetry::DdsTelemetry(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
DdsTelemetry::~DdsTelemetry() = default;

Result<std::unique_ptr<DdsTelemetry>> DdsTelemetry::create(const TelemetryParams& params, Logger& logger) {
  VISNAV_TRY(params.validate());
  VISNAV_ASSIGN(auto participant, Participant::create(params.domain_id));
  VISNAV_ASSIGN(auto writer, Writer<msg::Telemetry>::create(
                                 participant, EndpointOptions{params.telemetry_topic, telemetry_qos(), params.partition}));
  auto impl = std::unique_ptr<Impl>(new Impl{std::move(participant), std::move(writer), &logger, {}, 0, WarningLimiter{5.0}});
  return std::unique_ptr<DdsTelemetry>(new DdsTelemetry(std::move(impl)));
}

void DdsTelemetry::publish(const NavStatus& status) {
  auto& s = impl_->sample;
  s.header = stamped_now("visnav");
  s.sequence_number = ++impl_->published;
  fill_telemetry_message(status, s);
  auto st = impl_->writer.write(s);
  if (!st && impl_->limiter.allow(epoch_now_s())) impl_->logger->warn("dds.telemetry", st.error().message);
}

std::uint64_t DdsTelemetry::published() const { return impl_->published; }
int DdsTelemetry::matched_readers() const { return impl_->writer.matched_readers(); }

// ---- ControlSubscriber ----------------------------------------------------------------------

std::string log_safe(std::string_view text, std::size_t max_bytes) {
  static constexpr char kHex[] = "0123456789abcdef";
  const std::size_t shown = std::min(text.size(), max_bytes);
  std::string out;
  out.reserve(shown + 16);
  for (std::size_t i = 0; i < shown; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 || c >= 0x7f || c == '\\') {
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 0xf];
    } else {
      out += static_cast<char>(c);
    }
  }
  if (shown < text.size()) out += "...(" + std::to_string(text.size()) + " bytes)";
  return out;
}

bool valid_control_argument(msg::ControlCommand command, std::string_view argument) {
  if (command != msg::ControlCommand::swap_detector) return argument.empty();
  if (argument.empty() || argument.size() > kMaxControlArgumentBytes) return false;
  for (char ch : argument) {
    const bool ok_char = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') ||
                         ch == '_' || ch == '.' || ch == '-';
    if (!ok_char) return false;
  }
  return true;
}

struct ControlSubscriber::Impl {
  static constexpr std::size_t kMaxPending = 256;
  Participant participant;
  Logger* logger = nullptr;
  WarningLimiter limiter{1.0};
  std::mutex mutex;
  std::deque<ControlRequest> pending;
  std::atomic<std::uint64_t> rejected{0};
  // Token bucket of accepted requests (listener thread only).
  double tokens = kMaxControlRequestsPerS;
  double tokens_at_s = 0.0;
  std::unique_ptr<Subscription<msg::Control>> subscription;  // last: stopped first

  void reject(double now_s, const std::string& why) {
    const std::uint64_t n = ++rejected;
    if (limiter.allow(now_s)) {
      const std::uint64_t hidden = limiter.suppressed_before_last();
      logger->warn("dds.control", "dropped a control request: " + why + " (" + std::to_string(n) + " rejected so far" +
                                      (hidden > 0 ? ", " + std::to_string(hidden) + " warnings suppressed" : "") + ")");
    }
  }
  bool take_token(double now_s) {
    if (tokens_at_s > 0.0 && now_s > tokens_at_s)
      tokens = std::min(kMaxControlRequestsPerS, tokens + (now_s - tokens_at_s) * kMaxControlRequestsPerS);
    tokens_at_s = now_s;
    if (tokens < 1.0) return false;
    tokens -= 1.0;
    return true;
  }

  explicit Impl(Participant p) : participant(std::move(p)) {}
  ~Impl() { subscription.reset(); }
};

ControlSubscriber::ControlSubscriber(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ControlSubscriber::~ControlSubscriber() = default;

Result<std::unique_ptr<ControlSubscriber>> ControlSubscriber::create(const TelemetryParams& params, Logger& logger) {
  VISNAV_TRY(params.validate());
  VISNAV_ASSIGN(auto participant, Participant::create(params.domain_id));
  auto impl = std::make_unique<Impl>(participant);
  impl->logger = &logger;
  Impl* raw = impl.get();
  auto on_sample = [raw](msg::Control&& c, const SampleInfo& info) {
    // Everything here comes from any participant on the domain: validate before logging or
    // queuing, and never log the argument unescaped (issue 17).
    const double now_s = info.receive_time_s;
    const auto code = c.command;
    if (code < static_cast<std::uint8_t>(msg::ControlCommand::pause) ||
        code > static_cast<std::uint8_t>(msg::ControlCommand::swap_detector)) {
      raw->reject(now_s, "unknown command code " + std::to_string(code));
      return;
    }
    const auto command = static_cast<msg::ControlCommand>(code);
    if (!valid_control_argument(command, c.argument)) {
      raw->reject(now_s, std::string(to_string(command)) + " with an invalid argument '" + log_safe(c.argument) + "'");
      return;
    }
    if (!raw->take_token(now_s)) {
      raw->reject(now_s, "more than " + std::to_string(static_cast<int>(kMaxControlRequestsPerS)) +
                             " requests per second (" + to_string(command) + ")");
      return;
    }
    ControlRequest r{command, std::move(c.argument), now_s};
    std::lock_guard lock(raw->mutex);
    if (raw->pending.size() >= Impl::kMaxPending) raw->pending.pop_front();
    raw->pending.push_back(std::move(r));
  };
  auto on_warning = [raw](const std::string& message) { raw->logger->warn("dds.control", message); };
  VISNAV_ASSIGN(impl->subscription, Subscription<msg::Control>::create(
                                         participant, EndpointOptions{params.control_topic, control_qos(), params.partition},
                                         on_sample, on_warning));
  return std::unique_ptr<ControlSubscriber>(new ControlSubscriber(std::move(impl)));
}

std::vector<ControlRequest> ControlSubscriber::take_pending() {
  std::lock_guard lock(impl_->mutex);
  std::vector<ControlRequest> out(std::make_move_iterator(impl_->pending.begin()),
                                  std::make_move_iterator(impl_->pending.end()));
  impl_->pending.clear();
  return out;
}

int ControlSubscriber::matched_writers() const { return impl_->subscription->stats().matched_writers; }
std::uint64_t ControlSubscriber::rejected() const { return impl_->rejected.load(); }

// ---- ControlPublisher -----------------------------------------------------------------------

struct ControlPublisher::Impl {
  Participant participant;
  Writer<msg::Control> writer;
  std::uint64_t sequence = 0;
};

ControlPublisher::ControlPublisher(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ControlPublisher::~ControlPublisher() = default;

Result<std::unique_ptr<ControlPublisher>> ControlPublisher::create(const TelemetryParams& params) {
  VISNAV_TRY(params.validate());
  VISNAV_ASSIGN(auto participant, Participant::create(params.domain_id));
  VISNAV_ASSIGN(auto writer, Writer<msg::Control>::create(
                                 participant, EndpointOptions{params.control_topic, control_qos(), params.partition}));
  auto impl = std::unique_ptr<Impl>(new Impl{std::move(participant), std::move(writer), 0});
  return std::unique_ptr<ControlPublisher>(new ControlPublisher(std::move(impl)));
}

Status ControlPublisher::send(msg::ControlCommand command, const std::string& argument) {
  msg::Control c;
  c.header = stamped_now("visnav");
  c.sequence_number = ++impl_->sequence;
  c.command = static_cast<std::uint8_t>(command);
  c.argument = argument;
  return impl_->writer.write(c);
}

bool ControlPublisher::wait_for_subscribers(int count, double timeout_s) const {
  return impl_->writer.wait_for_readers(count, timeout_s);
}

void fill_telemetry_message(const NavStatus& status, msg::Telemetry& out) {
  out.node_path = status.node_path;
  out.map_node = status.map_node;
  out.edge = status.edge;
  out.distance_m = status.distance_m;
  out.matches = status.matches;
  out.inliers = status.inliers;
  out.offset_px = status.offset_px;
  out.linear_mps = status.command.linear_mps;
  out.angular_radps = status.command.angular_radps;
  out.status = status.status;
}

}  // namespace visnav::dds
