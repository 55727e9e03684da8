// relocalisation core — one frame against the place index: lookup, then histogram verification.
//
// votes(): the frame's features are coded with the index vocabulary, the `candidates` nearest
// places by Hamming distance are fetched, and each is verified with the feature primitive's
// matching and histogram voting (visnav/histogram_voting.hpp, the SDK's) against that place's reference
// features (PlaceSource). A place whose estimate is valid and reaches min_confidence becomes a
// PlaceVote carrying the estimate's heading offset (robot heading minus taught heading, rad).
// blank_reason(): why a frame is unusable (a covered or dark camera), or empty.
//
// Thread-safety: single-threaded (owns the estimator's buffers and the payload cache).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "visnav/devices.hpp"
#include "visnav/histogram_voting.hpp"
#include "visnav/relocalisation/place_index.hpp"
#include "visnav/relocalisation/relocaliser.hpp"

namespace visnav::reloc {

/// Empty when `image` and `features` are usable, else one line saying why not (grey-level standard
/// deviation below min_image_stddev, fewer than min_features features).
[[nodiscard]] std::string blank_reason(const cv::Mat& image, const Features& features, const RelocaliseParams& params);

class PlaceVerifier {
 public:
  /// `index` and `map` must outlive the verifier; `detector` (the one the frames are described
  /// with) describes visual_memory reference images (PlaceSource), may be nullptr for a map without.
  PlaceVerifier(const PlaceIndex& index, const MapStore& map, const feature_replay::HeadingParams& heading,
                Detector* detector = nullptr);
  /// The run's detector changed (live reload): used for edges not described yet.
  void set_detector(Detector* detector) { source_.set_detector(detector); }
  /// Verified places of one frame (see the file comment). Errors: features of the wrong type,
  /// a payload that cannot be read.
  Result<std::vector<PlaceVote>> votes(const Features& current, double image_width_px, int candidates,
                                       double min_confidence);
  /// Verified thumbnail places of one frame (path_following edges): the frame's thumbnail
  /// (path_payload::make_thumbnail, normalise_thumbnail) against every thumbnail place, each at
  /// its best horizontal shift within thumbnail_max_shift_deg; the thumbnail_candidates best
  /// reaching min_thumbnail_ncc vote with confidence = min(1, ncc / thumbnail_confident_ncc),
  /// score = confidence x thumbnail_vote_weight
  /// and heading offset = shift x horizontal_fov / thumbnail width. Empty when the index has no
  /// thumbnail place. Error: an image make_thumbnail refuses.
  Result<std::vector<PlaceVote>> thumbnail_votes(const cv::Mat& image, const RelocaliseParams& params);
  /// The index's edges as the Relocaliser's route graph (from/to taken from the map).
  [[nodiscard]] std::vector<RouteEdge> route_edges() const;
  /// Hits of the last lookup (before verification).
  [[nodiscard]] const std::vector<PlaceCandidate>& last_candidates() const { return candidates_; }

 private:
  const PlaceIndex& index_;
  const MapStore& map_;
  PlaceSource source_;
  feature_replay::HeadingEstimator estimator_;
  std::vector<std::uint64_t> code_;
  std::vector<PlaceCandidate> candidates_;
  std::vector<ThumbnailHit> thumbnail_hits_;
  std::vector<double> place_uncertainty_m_;      ///< per place: PlaceVote::along_uncertainty_m
  std::vector<double> thumbnail_uncertainty_m_;  ///< per thumbnail place
  /// per place: PlaceVote::gap_before_m / gap_after_m (visual_memory references only, else 0)
  std::vector<std::pair<double, double>> place_gaps_m_;
  double horizontal_fov_deg_ = 60.0;
};

}  // namespace visnav::reloc
