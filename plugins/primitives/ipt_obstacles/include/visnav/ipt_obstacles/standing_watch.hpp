// visnav IPT obstacles — a standing obstacle on the path found while the replay drives ([ours];
// issue 16, docs/obstacles.md "A van the path follower keeps the path up to").
//
// Where a path follower keeps the path up to a plain, path-coloured face (the campus's concrete
// van standing on the path's edge, its left part in view), the IPT finds no ground contact on it
// before 1 m and the frame difference fires too late (0.6 m) or not at all. The longer-baseline
// triangulation (near_triangulation.hpp) does place corners of such a face above the ground from
// 4 m away, but while driving a single triangulation is a handful of points, sometimes a stray
// one on bare ground or the path's own kerb, and only the part of the face with texture. The
// watch keeps the triangulated points of the last `memory_m` of travel (odom frame, each tagged
// with its triangulation) and judges them in the robot's frame every time new ones arrive: the
// points in the corridor ahead (|lateral| <= corridor_half_width_m, forward <= max_range_m) are
// sorted by forward distance and the densest window of `depth_band_m` is the candidate face; it
// fires when that window holds at least `min_points` points from at least `min_batches`
// triangulations (a face is seen again from the next baseline; a stray point is not), or at
// least `one_batch_points` from fewer (one triangulation that places many corners on one
// face: on a path edge the follower's steering often leaves no second straight baseline before
// the face is reached), and the
// face's points span at least `min_width_m` across (a van's rear, not a bunch of stray corners). The
// verdict gives the face's distance (the median of the window's points), its lateral extent (every
// remembered point in the window's depth band within `extent_half_width_m`, in or out of the
// corridor: a van is wider than the corridor) and those points, for the lane detour.
// Frames: odom (x, y, heading), metres, radians. Pure; not thread-safe.
#pragma once

#include <span>
#include <vector>

#include <opencv2/core/types.hpp>

#include "visnav/ipt_obstacles/near_triangulation.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::ipt {

struct StandingWatchParams {
  double corridor_half_width_m = 0.45;  ///< the corridor's half width about the robot's heading
  double max_range_m = 4.0;             ///< points farther ahead are ignored
  double depth_band_m = 0.6;            ///< a face's points lie within this forward depth
  int min_points = 6;                   ///< points of the face in the corridor that fire
  int min_batches = 2;                  ///< ... from at least this many triangulations
  int one_batch_points = 0;             ///< or at least this many from one triangulation (a wide textured face
                                        ///< seen once before the robot is on it: campus seed 9, 11 corners
                                        ///< 3.1 m ahead, then none until contact); 0 = off
  double memory_m = 1.5;                ///< points are kept for this much travel (odometer)
  double extent_half_width_m = 2.5;     ///< the lateral extent counts points within this of the heading
  double min_width_m = 0.5;             ///< the face's points must span this much laterally (stray
                                        ///< corners on the obstacle-free campus bunched within 0.2 m)

  [[nodiscard]] Status validate() const;
  static const ParamSchema<StandingWatchParams>& schema();
};

struct StandingVerdict {
  bool found = false;
  int in_face = 0;        ///< corridor points in the densest depth window
  int batches = 0;        ///< distinct triangulations among them
  double range_m = 0.0;   ///< forward distance of the face: the window's median point (in_face > 0)
  double left_m = 0.0;    ///< largest lateral offset (left +) of the face's points (in_face > 0)
  double right_m = 0.0;   ///< smallest lateral offset of the face's points (in_face > 0)
  std::vector<cv::Point2d> points;  ///< the face's points, odom frame (in the depth band, within the extent)
};

class StandingWatch {
 public:
  /// Params must validate().
  explicit StandingWatch(StandingWatchParams params) : params_(params) {}
  /// Forgets every point.
  void reset();
  /// One triangulation's obstacle points (odom frame; may be empty: it still ages the memory)
  /// at odometer reading `odometer_m`, then the verdict seen from `pose`.
  [[nodiscard]] StandingVerdict add(std::span<const cv::Point2d> points_m, const Pose2D& pose, double odometer_m);
  /// The verdict for the remembered points seen from `pose` (no new points, no ageing).
  [[nodiscard]] StandingVerdict judge(const Pose2D& pose) const;
  [[nodiscard]] const StandingWatchParams& params() const { return params_; }
  /// The triangulation the watch is meant to be fed by while driving: a longer baseline than the
  /// probe's (0.6 m: a corner 4 m ahead near the focus of expansion moves too little over 0.3 m)
  /// and more, weaker corners (a plain face's texture is weaker than the grass around it); only
  /// while nearly straight (0.02 rad over the baseline) and corners at least 0.3 m high.
  [[nodiscard]] static NearTriangulationParams triangulation_params();

 private:
  struct Kept {
    cv::Point2d p;
    double odometer_m;
    int batch;
  };
  StandingWatchParams params_;
  std::vector<Kept> kept_;
  int batch_ = 0;
};

}  // namespace visnav::ipt
