// Host services: logger, telemetry, RuntimeHost.
#include <cerrno>
#include <cstring>

#include "visnav/runtime_host.hpp"

#include "visnav/camera_mount.hpp"

namespace visnav {

Result<LogLevel> parse_log_level(std::string_view text) {
  if (text == "debug") return LogLevel::debug;
  if (text == "info") return LogLevel::info;
  if (text == "warn" || text == "warning") return LogLevel::warn;
  if (text == "error") return LogLevel::error;
  return fail("unknown log level '" + std::string(text) + "' (one of: debug, info, warn, error)");
}

const char* to_string(LogLevel level) {
  switch (level) {
    case LogLevel::debug: return "debug";
    case LogLevel::info: return "info";
    case LogLevel::warn: return "warn";
    case LogLevel::error: return "error";
  }
  return "?";
}

StderrLogger::StderrLogger(LogLevel min_level, std::FILE* out) : min_level_(min_level), out_(out) {}

void StderrLogger::log(LogLevel level, std::string_view component, std::string_view message) {
  if (static_cast<int>(level) < static_cast<int>(min_level_.load())) return;
  static constexpr const char* kTag[] = {"D", "I", "W", "E"};
  std::string line = "visnav [";
  line += kTag[static_cast<int>(level)];
  line += "] ";
  line += component;
  line += ": ";
  line += message;
  line += '\n';
  std::lock_guard lock(mutex_);
  std::fwrite(line.data(), 1, line.size(), out_);
  std::fflush(out_);
}

std::string json_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size() + 8);
  for (char c : text) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out;
}

Result<std::unique_ptr<JsonLinesTelemetry>> JsonLinesTelemetry::open(const std::string& path, const Clock& clock) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) return fail(ErrorCode::io, {path}, std::string("cannot open telemetry file: ") + std::strerror(errno));
  return std::unique_ptr<JsonLinesTelemetry>(new JsonLinesTelemetry(f, clock));
}

JsonLinesTelemetry::~JsonLinesTelemetry() {
  if (file_ != nullptr) std::fclose(file_);
}

void JsonLinesTelemetry::publish(const NavStatus& s) {
  char numbers[256];
  std::snprintf(numbers, sizeof numbers,
                "\"distance_m\":%.4f,\"matches\":%d,\"inliers\":%d,\"offset_px\":%.3f,\"linear_mps\":%.4f,"
                "\"angular_radps\":%.4f,\"confidence\":%.3f,\"blind_m\":%.3f,",
                s.distance_m, s.matches, s.inliers, s.offset_px, s.command.linear_mps, s.command.angular_radps,
                s.confidence, s.blind_m);
  char time[48];
  std::snprintf(time, sizeof time, "{\"t_s\":%.4f,", clock_->now_s());
  std::string line = time;
  line += "\"node_path\":\"" + json_escape(s.node_path) + "\",";
  line += "\"map_node\":\"" + json_escape(s.map_node) + "\",";
  line += "\"edge\":\"" + json_escape(s.edge) + "\",";
  line += numbers;
  line += "\"status\":\"" + json_escape(s.status) + "\"}\n";
  std::fwrite(line.data(), 1, line.size(), file_);
  std::fflush(file_);
  ++published_;
}

RuntimeHost::RuntimeHost(PluginLoader& loader, Logger& logger, const Clock& clock)
    : loader_(&loader), logger_(&logger), clock_(&clock) {}

Result<std::unique_ptr<Detector>> RuntimeHost::create_detector(std::string_view type, const ConfigNode& params) {
  VISNAV_ASSIGN(PluginPtr<Detector> made, loader_->create<Detector>(type, params, *this));
  // The loader keeps the library loaded for its own lifetime, which outlives this object.
  return std::unique_ptr<Detector>(made.release());
}

Result<CameraMount> RuntimeHost::camera_mount() {
  if (camera_ == nullptr) return fail(ErrorCode::missing, "no camera mount: not running");
  const std::string who = camera_described_.empty() ? std::string("the camera") : camera_described_;
  std::optional<CameraMount> mount = camera_->mount();
  if (!mount)
    return Error{who + " declares no mount: add " + kMountRequiredKeys +
                     " to camera.params (mount_forward_m, mount_lateral_m optional, default 0; docs/cameras.md)",
                 ErrorCode::missing, ErrorLocation{{}, 0, "camera.params"}};
  if (auto st = mount->validate(); !st) return st.error().with_context(who);
  return *mount;
}

}  // namespace visnav
