// relocalisation core — deciding where the robot is from a short sequence of frames (issue 21).
//
// Each frame contributes votes: the places the index proposed whose reference features the
// feature primitive's histogram voting verified (confidence >= min_confidence), each with the
// place's edge and distance and the heading offset the histogram found. Votes of earlier frames
// are moved to the newest frame with the robot's own odometric motion (the distance travelled,
// projected on the edge with the vote's heading offset, is added along the edge; the heading
// change is added to the offset), so a sequence taken while the robot creeps forward or turns in
// place is compared in one frame of reference (the SeqSLAM idea: a place is accepted only when a
// sequence of frames agrees with the motion between them; votes for a look-alike place that do
// not advance with the robot spread out and stop supporting one place).
//
// Votes are grouped into hypotheses: votes on one edge within place_tolerance_m, and places at
// the two sides of a node (end of one edge, start of the next) within place_tolerance_m of it
// are one physical place. A hypothesis' score sums, per frame, the best vote score it got; an
// optional odometry prior (an edge and distance where the robot is believed to be) weighs every
// hypothesis by exp(-0.5 (route distance / prior_sigma_m)^2), route distance counted along the
// edge or over one node into the next or previous edge (farther: weight 0).
//
// The answer (decide()):
//   * pending      — fewer than `frames` usable frames so far;
//   * camera_blocked — `frames` frames were blank (too few features or a flat image: covered
//     lens, darkness) and not enough usable ones came;
//   * not_on_map   — `frames` usable frames and no verified vote at all, or the best hypothesis
//     is supported by fewer than min_agreement of the frames once max_frames are used;
//   * ambiguous    — a second, distinct place scores more than max_runner_up_ratio of the best
//     (e.g. the two ends of a repetitive loop) once max_frames are used;
//   * ambiguous also — the answer's along-track uncertainty (place spacing, spread of the frames'
//     votes) exceeds max_along_uncertainty_m (> 0): places too far apart to say where between them;
//   * localised    — the best hypothesis is supported by at least `frames` frames and by
//     min_agreement of the usable frames, no distinct place comes close, and the answer's
//     confidence reaches min_answer_confidence (a weaker one waits for more frames and is
//     answered ambiguous at max_frames: in the campus experiment the answers below 0.5 were
//     wrong as often as right).
// Where along the edge (localised): the median of the frames' best votes in the best hypothesis;
// when those votes carry the gaps to their neighbouring places (visual_memory references), the
// middle of the stretch covered by most of the frames' nearest-place cells (from half the gap
// behind the place to three quarters of the gap ahead, moved to the newest frame), and then
// ambiguous also when fewer than min_cell_agreement of the frames' cells cover it or it is
// longer than +-max_cell_uncertainty_m.
// Never from one frame: `frames` >= 3.
//
// Held (hold(true), while the robot still has to creep forward): only the answers that must stop
// the robot before it moves are given (camera_blocked; not_on_map when no place was verified at
// all, unless held even_unseen); everything else stays pending. A pending answer with a best place carries it in edge /
// distance_m / heading_offset_rad (provisional, e.g. to steer the creep; has_best) — never an
// answer.
//
// Frames: distances in metres along an edge from its start; heading offsets in radians, the
// robot's heading minus the taught heading at that place (CCW positive).
// Thread-safety: a Relocaliser is single-threaded.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav::reloc {

struct RelocaliseParams {
  int frames = 5;                     ///< usable frames that must agree before answering (>= 3)
  int max_frames = 12;                ///< usable frames after which an undecided sequence is answered
  int candidates = 12;                ///< index hits verified per frame
  double min_confidence = 0.3;        ///< histogram confidence for a verified vote
  double place_tolerance_m = 1.0;     ///< votes this close (along the route) are one place
  double max_runner_up_ratio = 0.6;   ///< a distinct place scoring above this fraction of the best: ambiguous
  double min_agreement = 0.7;         ///< fraction of usable frames that must support the answer
  double min_answer_confidence = 0.5;   ///< a localised answer weaker than this waits, then is ambiguous
  int min_features = 25;              ///< a frame with fewer features is blank
  double min_image_stddev = 6.0;      ///< a frame whose grey-level standard deviation is below is blank
  double prior_sigma_m = 0.0;         ///< odometry prior spread along the route, m (0 = no prior)
  // Thumbnail places (path_following edges; PlaceVerifier::thumbnail_votes).
  int thumbnail_candidates = 3;       ///< best thumbnail places voting per frame
  double min_thumbnail_ncc = 0.4;     ///< a thumbnail place votes from this correlation up
  double thumbnail_confident_ncc = 0.6;  ///< correlation of a fully confident thumbnail vote (confidence = ncc / this, <= 1)
  double thumbnail_vote_weight = 40.0;  ///< a thumbnail vote's score is confidence x this (a feature vote's is inliers x confidence)
  double thumbnail_max_shift_deg = 30.0;  ///< heading offsets searched when comparing thumbnails, deg
  /// Two-pass thumbnail search: the places kept by the half-resolution pass for the full one
  /// (PlaceIndex::query_thumbnails; 0 = one exhaustive pass).
  int thumbnail_coarse_candidates = 32;
  /// Sub-linear first stage: only the thumbnail places PlaceIndex::thumbnail_first_stage returns
  /// (signature nearest neighbours from the inverted file) are searched by the two passes
  /// (0 = search every place; a map with no more places than this searches every place).
  int thumbnail_index_candidates = 256;
  /// Places with known gaps (PlaceVote::gap_before_m / gap_after_m): the fraction of the answer's
  /// frames whose cells must cover the answer, else it is ambiguous (the frames disagree where).
  double min_cell_agreement = 0.8;
  /// Places with known gaps (PlaceVote::gap_before_m / gap_after_m): an answer whose frames' cells
  /// overlap over a stretch longer than twice this is ambiguous, m.
  double max_cell_uncertainty_m = 1.0;
  /// A localised answer whose along-track uncertainty (RelocAnswer::along_uncertainty_m) exceeds
  /// this is answered ambiguous instead, m (0 = no limit).
  double max_along_uncertainty_m = 0.0;

  [[nodiscard]] Status validate() const;
  static const ParamSchema<RelocaliseParams>& schema();
};

/// The graph around an edge, for merging places across a node and for the prior.
struct RouteEdge {
  std::string id;
  std::string from;
  std::string to;
  double length_m = 0.0;
};

/// A verified place in one frame.
struct PlaceVote {
  std::uint32_t edge = 0;             ///< index into the Relocaliser's edges
  double distance_m = 0.0;            ///< along the edge
  double confidence = 0.0;            ///< histogram confidence [0, 1]
  double heading_offset_rad = 0.0;    ///< robot heading minus taught heading
  /// Weight of the vote in a hypothesis' score; <= 0 means `confidence`. The verifier gives
  /// inliers x confidence: the confidence saturates at a few dozen inliers, so places a few metres
  /// apart that see the same far walls would tie on it, while their inlier counts still differ.
  double score = 0.0;
  /// How far the truth may be from `distance_m` when this place is the nearest one: half the
  /// larger gap to the neighbouring places of its edge (0 = unknown). The verifier sets it.
  double along_uncertainty_m = 0.0;
  /// Distances from this place to the previous and the next place of its edge, m (0 = not given).
  /// Given (the verifier does for visual_memory references, as far apart as the teacher made
  /// them), a frame's vote says "nearer this place than its neighbours" and the answer is where
  /// most frames' cells overlap (see decide()); not given, the median of the frames' votes.
  double gap_before_m = 0.0;
  double gap_after_m = 0.0;
};

/// What one frame contributed.
struct FrameVotes {
  bool blank = false;                 ///< unusable (covered, dark, featureless)
  double odom_distance_m = 0.0;       ///< Odometry::distance_m at the frame
  double odom_heading_rad = 0.0;      ///< odometric heading at the frame
  std::vector<PlaceVote> votes;
};

enum class RelocStatus : std::uint8_t { pending, localised, ambiguous, not_on_map, camera_blocked };
[[nodiscard]] const char* to_string(RelocStatus s);

struct RelocAnswer {
  RelocStatus status = RelocStatus::pending;
  std::uint32_t edge = 0;
  double distance_m = 0.0;            ///< at the newest frame
  double heading_offset_rad = 0.0;    ///< at the newest frame
  double confidence = 0.0;            ///< [0, 1]: agreement x mean vote confidence x distinctiveness
  int support = 0;                    ///< frames that voted for the answer
  /// Along-track uncertainty of distance_m, m: the larger of the median place spacing term of the
  /// frames' best votes (PlaceVote::along_uncertainty_m) and 1.4826 x the median absolute deviation
  /// of those votes' positions (moved to the newest frame).
  double along_uncertainty_m = 0.0;
  int usable_frames = 0;
  int blank_frames = 0;
  std::string reason;                 ///< one line: why this answer (names the places for ambiguous)
  bool has_best = false;              ///< edge / distance_m / heading_offset_rad name the best place so far
};

class Relocaliser {
 public:
  /// `params` must be valid; `edges` are the edges the votes index (e.g. the place index's).
  Relocaliser(const RelocaliseParams& params, std::vector<RouteEdge> edges);
  /// The robot is believed to be at (edge, distance_m) (odometry prior; used when prior_sigma_m > 0).
  void set_prior(std::uint32_t edge, double distance_m);
  void add(FrameVotes frame);
  /// Holds the decision (see the file comment) while the robot still creeps; release with false.
  /// `even_unseen`: also hold not_on_map when no place was verified yet (the creep may bring one
  /// into view).
  void hold(bool on, bool even_unseen = false) {
    held_ = on;
    hold_unseen_ = even_unseen;
  }
  /// The answer from the frames so far (pending while more frames are needed).
  [[nodiscard]] RelocAnswer decide() const;
  /// Signed route distance from (a, da) to (b, db): along one edge, or over one node; nullopt farther.
  [[nodiscard]] std::optional<double> route_distance_m(std::uint32_t a, double da, std::uint32_t b, double db) const;

 private:
  RelocaliseParams params_;
  std::vector<RouteEdge> edges_;
  std::optional<std::pair<std::uint32_t, double>> prior_;
  std::vector<FrameVotes> frames_;
  bool held_ = false;
  bool hold_unseen_ = false;
};

}  // namespace visnav::reloc
