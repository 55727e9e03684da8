// visnav IPT obstacles — persistence of contact points over robot positions ([ours]; issue 16,
// docs/obstacles.md "False contacts and the persistence filter").
//
// A real obstacle's ground contact is a fixed ground point: pairs taken from different robot
// positions put it at the same place (up to ranging noise). The false contacts of a replay on a
// paved square are not: a sliding track along a straight texture border (a paver joint, the
// gravel/paver border) survives RANSAC (spec §3.9) and its trace is re-found at about the same
// image position in every pair, so its ground point travels with the robot. ContactPersistence
// keeps every sighting with the robot position it was seen from and confirms a point only when
// another sighting, taken from a robot position at least min_baseline_m away, lies within
//   min(max_radius_m, radius_ratio · |c_a − c_b|)
// of it (c: the robot positions of the two sightings). A point that moves with the robot moves
// by |c_a − c_b| between them, so with radius_ratio < 1 it never confirms itself, however far
// the robot drove; a fixed point confirms itself after min_baseline_m of travel. Besides, the
// point must have been seen from min_views distinct robot positions (pairs) within
// min(max_radius_m, radius_ratio · max(|c_a − c_b|, min_baseline_m)): a real obstacle's contact
// is found in most pairs while it is in view, a mis-tracked paver corner of a periodic texture
// now and then at the same place (measured on the campus square: 2 of about 36 pairs). With
// min_view_share, those views must also be that share of all the pairs made between the first
// and the last of them.
// Frames: ground frame (odom), metres. Pure; not thread-safe.
#pragma once

#include <functional>
#include <span>
#include <vector>

#include <opencv2/core/types.hpp>

#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav::ipt {

struct ContactPersistenceParams {
  double min_baseline_m = 0.3;  ///< robot positions of two sightings at least this far apart
  double max_radius_m = 0.3;    ///< two sightings of one ground point at most this far apart ...
  double radius_ratio = 0.5;    ///< ... and at most this fraction of the robot travel between them
  int min_views = 3;            ///< distinct robot positions (2 cm apart) that saw the point
  /// ... and at least this share of the pairs made from robot positions between the first and the
  /// last of those views saw it (0 = off): a real obstacle's contact is found by most pairs while
  /// it is in view; the ends of traces from noise obstacle features on a tiled floor now and then
  /// (campus hall, session 14: 3 of 11-17 pairs).
  double min_view_share = 0.0;

  [[nodiscard]] Status validate() const;
  static const ParamSchema<ContactPersistenceParams>& schema();
};

class ContactPersistence {
 public:
  /// Params must validate().
  explicit ContactPersistence(ContactPersistenceParams params) : params_(params) {}

  /// New limits for the next confirmed(); the kept sightings stay. Params must validate().
  void set_params(const ContactPersistenceParams& params) { params_ = params; }
  /// Sightings of one pair: ground points seen with the robot at `robot_m`, odometer reading
  /// `odom_distance_m` (for forget()). Call it for every pair, also one without points: the pairs
  /// count for min_view_share.
  void add(std::span<const cv::Point2d> points_m, const cv::Point2d& robot_m, double odom_distance_m);
  /// Drops sightings made more than memory_m of travel away from `odom_distance_m`.
  void forget(double odom_distance_m, double memory_m);
  void clear() {
    sightings_.clear();
    pairs_m_.clear();
  }
  /// The sightings confirmed by another sighting from a different robot position (see above);
  /// with `candidate`, only the sightings it accepts are tested (the corridor ahead).
  [[nodiscard]] std::vector<cv::Point2d> confirmed(const std::function<bool(const cv::Point2d&)>& candidate = {}) const;
  /// The confirmed ones among the sightings from index `first` on (in the order added, e.g. the
  /// last pair's: size() before its add()); call before forget().
  [[nodiscard]] std::vector<cv::Point2d> confirmed_since(std::size_t first) const;
  /// Every kept sighting, confirmed or not.
  [[nodiscard]] std::vector<cv::Point2d> all() const;
  [[nodiscard]] std::size_t size() const { return sightings_.size(); }

 private:
  struct Sighting {
    cv::Point2d point_m, robot_m;
    double odom_m;
  };
  [[nodiscard]] bool is_confirmed(std::size_t i) const;

  ContactPersistenceParams params_;
  std::vector<Sighting> sightings_;
  std::vector<double> pairs_m_;  ///< odometer readings of the pairs added (ascending), for min_view_share
  mutable std::vector<cv::Point2d> views_scratch_;  ///< is_confirmed's robot positions, kept to avoid reallocating
};

}  // namespace visnav::ipt
