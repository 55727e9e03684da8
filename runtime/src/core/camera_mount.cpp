// The camera mount: CameraMount::validate (devices.hpp) and the mount keys of a camera's params
// (camera_mount.hpp).
#include "visnav/camera_mount.hpp"

#include <cmath>
#include <sstream>
#include <string>

namespace visnav {

namespace {

std::string number(double v) {
  std::ostringstream os;
  os.precision(15);
  os << v;
  return os.str();
}

// "value 0 is out of range (1, 179) deg", where.key = the field's name in `keys`.
Error bad(const char* key, double value, const std::string& range) {
  return Error{"value " + number(value) + " is out of range " + range, ErrorCode::out_of_range, ErrorLocation{{}, 0, key}};
}

constexpr const char* kFieldNames[5] = {"hfov_deg", "height_m", "pitch_down_deg", "forward_m", "lateral_m"};
constexpr const char* kParamKeys[5] = {kMountKeyHfov, kMountKeyHeight, kMountKeyPitch, kMountKeyForward, kMountKeyLateral};

/// Checks `m`, naming each field by `keys` (hfov, height, pitch, forward, lateral).
Status check_camera_mount(const CameraMount& m, const char* const (&keys)[5]) {
  // Negated comparisons so that NaN is refused too.
  if (!(m.hfov_deg > 1.0 && m.hfov_deg < 179.0)) return bad(keys[0], m.hfov_deg, "(1, 179) deg");
  if (!(m.height_m > 0.0) || !std::isfinite(m.height_m)) return bad(keys[1], m.height_m, "(0, inf) m");
  if (!(m.pitch_down_deg > -89.0 && m.pitch_down_deg < 89.0)) return bad(keys[2], m.pitch_down_deg, "(-89, 89) deg");
  if (!std::isfinite(m.forward_m)) return bad(keys[3], m.forward_m, "(finite) m");
  if (!std::isfinite(m.lateral_m)) return bad(keys[4], m.lateral_m, "(finite) m");
  return ok();
}

}  // namespace

Status CameraMount::validate() const {
  auto st = check_camera_mount(*this, kFieldNames);
  if (st) return ok();
  const Error& e = st.error();
  return Error{"camera mount: " + e.where.key + " " + e.message.substr(std::string("value ").size()), e.code, e.where};
}

Result<std::optional<CameraMount>> CameraMountOptions::declared() const {
  const std::optional<double>* all[5] = {&hfov_deg, &mount_height_m, &mount_pitch_down_deg, &mount_forward_m,
                                         &mount_lateral_m};
  bool any = false;
  for (const auto* v : all) any = any || v->has_value();
  if (!any) return std::optional<CameraMount>{};
  for (int i = 0; i < 3; ++i)
    if (!all[i]->has_value()) {
      std::string given;
      for (int j = 0; j < 5; ++j)
        if (all[j]->has_value()) given += (given.empty() ? "" : ", ") + std::string(kParamKeys[j]);
      return Error{"key '" + std::string(kParamKeys[i]) + "' is missing: a camera mount needs " + kMountRequiredKeys +
                       " together (given: " + given + ")",
                   ErrorCode::missing, ErrorLocation{{}, 0, kParamKeys[i]}};
    }
  CameraMount m;
  m.hfov_deg = *hfov_deg;
  m.height_m = *mount_height_m;
  m.pitch_down_deg = *mount_pitch_down_deg;
  m.forward_m = mount_forward_m.value_or(0.0);
  m.lateral_m = mount_lateral_m.value_or(0.0);
  if (auto st = check_camera_mount(m, kParamKeys); !st) {
    const Error& e = st.error();
    return Error{"key '" + e.where.key + "': " + e.message, e.code, e.where};
  }
  return std::optional<CameraMount>{m};
}

Status CameraMountOptions::validate() const {
  auto d = declared();
  if (!d) return d.error();
  return ok();
}

std::optional<CameraMount> CameraMountOptions::mount() const {
  auto d = declared();
  if (!d) return std::nullopt;
  return *d;
}

}  // namespace visnav
