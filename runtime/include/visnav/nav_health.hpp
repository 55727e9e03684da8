// visnav SDK — lost detection shared by every navigation primitive.
//
// A replaying primitive feeds NavHealthMonitor once per processed frame with the odometric
// distance, the frame, its own per-frame confidence in [0, 1] (feature replay: the histogram
// vote's confidence; path following: 1 when the path is seen) and whether its correction is
// saturated. The monitor answers with one policy for all primitives (docs/navigation.md,
// "Lost detection"):
//
//   * confidence window: the mean of the last `window_frames` confidences. Whenever it is at
//     least `min_confidence` the robot is "seeing": the odometric distance of that frame is
//     remembered (confident_at_m).
//   * blind: distance since the robot last saw. Up to slow_after_m the primitive goes on as
//     usual (on odometry: seed 002's field runs survived short outages); beyond it the
//     forward speed is scaled by slow_speed_factor; beyond max_blind_m the verdict is `lost`.
//   * uninformative frames: where the map itself expects little to see (the teach run saw
//     fewer than the primitive's minimum of landmarks there: open grass, a featureless
//     corner), a frame without a match is no evidence of being lost. Such frames neither
//     refresh nor grow the blind distance (the count pauses), so short connector edges that
//     were taught nearly blind are driven on odometry as they were taught. Frozen-camera,
//     saturation and heading checks still apply.
//   * frozen camera: the frame's pixels are identical to the previous frame's while the
//     robot travelled more than max_frozen_m: `frozen`. A stationary robot's identical frames
//     are not counted (nothing moved).
//   * saturated: the correction was at its clamp continuously for more than max_saturated_m
//     (the robot cannot turn back onto the route; large heading drift or a wrong world): `lost`.
//   * heading: the odometric heading differs from the edge's taught heading at this distance
//     (linear between the edge's start azimuth and end heading, both relative to where the
//     edge started) by more than max_heading_deviation_rad: `lost` (turned by an outside
//     command). 0 disables the check.
//
// The two distances (confident_at_m, changed_at_m) are absolute Odometry::distance_m values,
// so a tree can carry them from one edge to the next on the blackboard: an edge shorter than
// max_blind_m cannot be driven blind just because it is a new edge.
//
// Units: metres of odometric distance, radians. Pure: no I/O, no clock.
// Thread-safety: one monitor per node, tick thread only. No allocation per update.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include <opencv2/core/mat.hpp>

#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav {

struct LostPolicy {
  double min_confidence = 0.2;      ///< window mean at or above: the robot sees the route
  int window_frames = 5;            ///< frames in the confidence window
  double slow_after_m = 2.0;        ///< blind distance after which the speed is reduced
  double slow_speed_factor = 0.5;   ///< forward speed factor while slowing, (0, 1]
  double max_blind_m = 5.0;         ///< blind distance after which the robot is lost
  double max_frozen_m = 0.5;        ///< travel with unchanged pixels after which the camera is frozen
  double max_saturated_m = 4.0;     ///< travel with a saturated correction after which the robot is lost
  double max_heading_deviation_rad = 1.3;  ///< odometry vs taught heading; 0 = off

  [[nodiscard]] Status validate() const;
};

enum class NavHealthState : std::uint8_t {
  seeing,    ///< confident within the window
  blind,     ///< not seeing, within slow_after_m: going on on odometry
  slowing,   ///< not seeing beyond slow_after_m: reduced speed
  lost,      ///< stop: see reason
  frozen,    ///< stop: the camera delivers the same image
};
[[nodiscard]] const char* to_string(NavHealthState state);

struct NavHealthVerdict {
  NavHealthState state = NavHealthState::seeing;
  double speed_factor = 1.0;      ///< multiply the forward speed by this
  double window_confidence = 0.0; ///< mean confidence over the window
  double blind_m = 0.0;           ///< distance since the robot last saw
  double frozen_m = 0.0;          ///< distance with identical pixels
  int identical_frames = 0;       ///< consecutive frames identical to their predecessor
  /// Why the robot stops (state lost/frozen), e.g. "no confident frame for 3.02 m"; else empty.
  std::string reason;
  [[nodiscard]] bool must_stop() const { return state == NavHealthState::lost || state == NavHealthState::frozen; }
};

/// The taught heading profile of an edge, relative to its start: 0 at distance 0, end_turn_rad
/// at length_m (linear in between).
struct TaughtHeading {
  double length_m = 0.0;
  double end_turn_rad = 0.0;
};

class NavHealthMonitor {
 public:
  explicit NavHealthMonitor(LostPolicy policy = {});

  /// Starts an edge at odometric distance `odom_distance_m` with odometric heading
  /// `odom_heading_rad`. `confident_at_m` / `changed_at_m` carry the previous edge's state
  /// (nullopt or non-finite: count from here). `taught` enables the heading check.
  void begin(double odom_distance_m, double odom_heading_rad, std::optional<double> confident_at_m,
             std::optional<double> changed_at_m, std::optional<TaughtHeading> taught = std::nullopt);

  /// One processed frame. `image` may be empty (an unusable frame: confidence should be 0).
  /// `edge_distance_m` is the distance along the edge (for the taught heading).
  const NavHealthVerdict& update(double odom_distance_m, double odom_heading_rad, double edge_distance_m,
                                 const cv::Mat& image, double confidence, bool saturated, bool informative = true);

  /// The latest verdict (also returned by update()).
  [[nodiscard]] const NavHealthVerdict& verdict() const { return verdict_; }
  /// Odometric distance at which the robot last saw the route (carry to the next edge).
  [[nodiscard]] double confident_at_m() const { return confident_at_m_; }
  /// Odometric distance at which the image last changed (carry to the next edge).
  [[nodiscard]] double changed_at_m() const { return changed_at_m_; }
  [[nodiscard]] const LostPolicy& policy() const { return policy_; }

  /// 64-bit hash of an image's pixels (rows may be padded); equal images hash equal.
  [[nodiscard]] static std::uint64_t image_hash(const cv::Mat& image);

 private:
  LostPolicy policy_;
  static constexpr int kMaxWindow = 64;
  std::array<double, kMaxWindow> window_{};
  int window_size_ = 0;
  int window_next_ = 0;
  double confident_at_m_ = 0.0;
  double changed_at_m_ = 0.0;
  double saturated_since_m_ = -1.0;  // < 0: not saturated
  double last_odom_m_ = 0.0;         // odometric distance of the previous update
  double start_heading_rad_ = 0.0;
  std::optional<TaughtHeading> taught_;
  std::uint64_t last_hash_ = 0;
  bool have_hash_ = false;
  int identical_frames_ = 0;
  NavHealthVerdict verdict_;
};

}  // namespace visnav
