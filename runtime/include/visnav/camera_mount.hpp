// visnav SDK — the camera mount keys every camera plugin reads the same way.
//
// A camera's `params:` block may declare where the camera sits on the robot (CameraMount,
// devices.hpp) with these optional keys:
//   hfov_deg              horizontal field of view, (1, 179) deg
//   mount_height_m        lens height above the ground, > 0 m
//   mount_pitch_down_deg  downward tilt of the optical axis, (-89, 89) deg
//   mount_forward_m       lens ahead of the robot origin, m (default 0)
//   mount_lateral_m       lens left of the robot origin, m (default 0)
// All or nothing: hfov_deg, mount_height_m and mount_pitch_down_deg together declare a mount
// (forward/lateral default to 0); none of the five declares no mount; any other set is an error
// naming the first missing key (code `missing`). A given value outside its range is an error
// naming the key and the value (code `out_of_range`).
//
// A camera's params struct derives from CameraMountOptions (like recorded::ImageOptions) and adds
// the keys to its schema with add_camera_mount_fields(), so `visnav validate`, `visnav plugins
// --params` and the factory all see the same keys; validate() of the struct calls
// CameraMountOptions::validate(), and the camera returns mount() from Camera::mount():
//   struct MyParams : visnav::CameraMountOptions {
//     std::string device;
//     visnav::Status validate() const { return CameraMountOptions::validate(); }
//     static const visnav::ParamSchema<MyParams>& schema() {
//       static const auto s = [] { visnav::ParamSchema<MyParams> p; p.field("device", ...);
//                                  visnav::add_camera_mount_fields(p); return p; }();
//       return s; } };
//   std::optional<visnav::CameraMount> mount() const override { return params_.mount(); }
// Thread-safety: value types; no shared state.
#pragma once

#include <concepts>
#include <optional>

#include "visnav/devices.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav {

/// The camera-config key of each CameraMount field.
inline constexpr const char* kMountKeyHfov = "hfov_deg";
inline constexpr const char* kMountKeyHeight = "mount_height_m";
inline constexpr const char* kMountKeyPitch = "mount_pitch_down_deg";
inline constexpr const char* kMountKeyForward = "mount_forward_m";
inline constexpr const char* kMountKeyLateral = "mount_lateral_m";
/// "hfov_deg, mount_height_m, mount_pitch_down_deg": the keys that must be given together.
inline constexpr const char* kMountRequiredKeys = "hfov_deg, mount_height_m, mount_pitch_down_deg";

/// The optional mount keys of a camera's params (the file comment). Unset = not in the config.
struct CameraMountOptions {
  std::optional<double> hfov_deg;
  std::optional<double> mount_height_m;
  std::optional<double> mount_pitch_down_deg;
  std::optional<double> mount_forward_m;
  std::optional<double> mount_lateral_m;

  /// ok() for no mount keys or a complete valid mount; else an error whose message and
  /// where.key name the first missing key (`missing`) or the bad key and value (`out_of_range`):
  ///   "key 'mount_pitch_down_deg' is missing: a camera mount needs hfov_deg, mount_height_m, ..."
  [[nodiscard]] Status validate() const;
  /// The declared mount (validated), nullopt when no mount key is given, or validate()'s error.
  [[nodiscard]] Result<std::optional<CameraMount>> declared() const;
  /// declared() for options that passed validate() (a camera's parsed params): the mount or nullopt.
  [[nodiscard]] std::optional<CameraMount> mount() const;
};

/// Adds the five mount keys to a camera's schema (documented, type- and range-checked).
template <typename P>
  requires std::derived_from<P, CameraMountOptions>
ParamSchema<P>& add_camera_mount_fields(ParamSchema<P>& s) {
  // Explicit field types: &P::hfov_deg names CameraMountOptions::hfov_deg, converted to a member of P.
  using Opt = std::optional<double>;
  s.template field<Opt>(kMountKeyHfov, &P::hfov_deg,
                        "camera mount: horizontal field of view, deg; with mount_height_m and mount_pitch_down_deg "
                        "(all three or none); unset = the camera declares no mount")
      .range(1, 179)
      .template field<Opt>(kMountKeyHeight, &P::mount_height_m, "camera mount: lens height above the ground, m (> 0)")
      .range(0, 1000)
      .template field<Opt>(kMountKeyPitch, &P::mount_pitch_down_deg, "camera mount: downward tilt of the optical axis, deg")
      .range(-89, 89)
      .template field<Opt>(kMountKeyForward, &P::mount_forward_m, "camera mount: lens ahead of the robot origin, m; unset = 0")
      .template field<Opt>(kMountKeyLateral, &P::mount_lateral_m, "camera mount: lens left of the robot origin, m; unset = 0");
  return s;
}

}  // namespace visnav
