// visnav IPT obstacles — obstacle profiles: from obstacle features down their edges to the
// obstacle-to-ground contact points (thesis §4.4; spec §4), and those points' distances by
// the IPT (spec §1.4, §1.6).
//
//  1. Reduced Canny (thesis §4.4.1): one 1-D derivative-of-Gaussian along the rows (d/du,
//     so vertical borders respond; spec §10.7), then hysteresis: |g| > high is an edge, a pixel
//     with low < |g| ≤ high is an edge when 8-connected to a strong one. No non-maximum
//     suppression. The thesis gives no σ or thresholds; the [spec I] defaults are below.
//  2. For each OBSTACLE feature, the edge pixels in a window taller than wide around it are
//     followed downwards (to (u−1, v+1), (u, v+1) or (u+1, v+1), straight down preferred,
//     bridging up to max_gap_rows missing rows) until the edge ends or a GROUND feature lies
//     within ground_reach_px. The last pixel is a contact point. Edges reached from no
//     obstacle feature are never followed (floor texture, shadows, tile lines).
//  3. Contact points below the horizon guard band are back-projected; range and bearing are
//     from the robot centre.
//
// Units: pixels and metres; frames as in ipt.hpp. Pure; scratch is the caller's (EdgeMap).
#pragma once

#include <span>
#include <vector>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include "visnav/ipt_obstacles/classifier.hpp"
#include "visnav/ipt_obstacles/ipt.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::ipt {

struct ProfileParams {
  double sigma_px = 1.0;            ///< derivative-of-Gaussian σ [spec §4.1 I]
  double high_threshold = 40.0;     ///< |g| (grey levels per pixel) of a strong edge pixel [spec §4.1 I]
  double low_ratio = 0.4;           ///< low threshold = low_ratio · high [spec §4.1 I]
  int window_width_px = 5;          ///< window around an obstacle feature [spec §4.2 I, 5×15 at 256×192]
  int window_height_px = 15;
  int max_gap_rows = 2;             ///< missing edge rows bridged while tracing down [spec §4.2 I]
  double ground_reach_px = 2.0;     ///< a ground feature this close stops the trace [spec §4.2 I]
  double guard_band_px = 3.0;       ///< contact points this close below the horizon are dropped (as the classifier)
  double max_range_m = 3.0;         ///< contact points farther are dropped
  int min_vertical_run_px = 9;      ///< keep only edge pixels in vertical runs this long (1 = off) [ours, measured]
  int min_supporting_features = 2;  ///< a contact needs traces from this many obstacle features ending within
                                    ///< support_radius_px (1 = off) [ours, measured]
  double support_radius_px = 10.0;
  double foot_radius_px = 0.0;       ///< correct_contact_ranges(): obstacle features this many columns from a
                                    ///< contact (and above it) bound its range (0 = off, the thesis; ReplayAvoiding 10) [ours, measured]
  // Obstacle spans (fill_obstacle_spans) [ours, measured in docs/obstacles.md]:
  double span_max_m = 0.0;          ///< neighbouring contacts at most this far apart may bound one obstacle (0 = off,
                                    ///< the thesis; the nodes 2.2)
  double span_step_m = 0.15;        ///< spacing of the points filled in between
  double span_min_obstacle_share = 0.2;  ///< OBSTACLE share of the labelled features between them that fills

  [[nodiscard]] Status validate() const;
  static const ParamSchema<ProfileParams>& schema();
};

/// Binary edge map of the reduced Canny (CV_8UC1, 255 = edge). `grey` is CV_8UC1.
/// `scratch` holds the gradient between calls (no allocation once sizes are stable).
struct EdgeScratch {
  cv::Mat gradient;   ///< CV_32F |d/du G_σ * I|
  cv::Mat strong;
  cv::Mat labels;
};
void reduced_canny(const cv::Mat& grey, const ProfileParams& params, cv::Mat& edges, EdgeScratch& scratch);

struct ContactPoint {
  cv::Point2d pixel;        ///< where the trace ended (frame k)
  cv::Point2d ground_m;     ///< its IPT ground position (ground frame of the poses)
  double range_m = 0.0;     ///< from the robot centre
  double bearing_rad = 0.0; ///< CCW positive, 0 = robot heading
  int feature = -1;         ///< index of the obstacle feature the trace started from
};

/// Contact points of the obstacle features in `features` over `edges`. One per distinct end
/// pixel (several seeds of one edge end at one pixel). `robot` is frame k's pose. With
/// min_supporting_features > 1 a contact is kept only when traces started from that many
/// different obstacle features end within support_radius_px of it.
[[nodiscard]] std::vector<ContactPoint> contact_points(const cv::Mat& edges,
                                                       std::span<const ClassifiedFeature> features,
                                                       const IptCamera& camera, const Pose2D& robot,
                                                       const ProfileParams& params);

/// A trace that ends above the ground (the border fades, or the obstacle's low part was
/// labelled GROUND and stopped it) back-projects beyond the obstacle: a point at height h
/// projects to s = Z0/(Z0 − h) times its distance from the lens foot. The pair measures s for
/// each feature below the horizon: IPT_k − IPT_{k−1} = (1 − s)(L_k − L_{k−1}), so
/// s = 1 + D/|L_k − L_{k−1}| and the feature's foot is L_k + (IPT_k − L_k)/s (exact for any
/// motion of the lens). Each contact's range from the lens is cut to the nearest foot of the
/// OBSTACLE features with a D within foot_radius_px columns of it and above it (its own
/// border), keeping its bearing. `lens_travel_m` is |L_k − L_{k−1}| of the pair. In place.
void correct_contact_ranges(std::vector<ContactPoint>& contacts, std::span<const ClassifiedFeature> features,
                            const LensPose& lens, double lens_travel_m, const Pose2D& robot,
                            const ProfileParams& params);

/// Points on the ground between neighbouring contact points (in image column order) that bound
/// one obstacle. Contacts come from vertical borders only (spec §4.3), so a wide obstacle — a
/// van's rear — yields its two corners and nothing between; the Ch. 6 strategy then sees a gap
/// inside it. Two neighbours with |ground_a − ground_b| ≤ span_max_m bound one obstacle when the
/// features labelled below the horizon guard band, between their columns and above the image
/// line joining them (where a real gap shows the ground behind) are at least
/// span_min_obstacle_share OBSTACLE (of OBSTACLE + GROUND), or there are none (a plain face).
/// Then points every span_step_m on the ground segment between them are returned (ends
/// excluded). Pure; ground frame of the contacts.
[[nodiscard]] std::vector<cv::Point2d> fill_obstacle_spans(std::span<const ContactPoint> contacts,
                                                           std::span<const ClassifiedFeature> features,
                                                           const IptCamera& camera, const ProfileParams& params);

}  // namespace visnav::ipt
