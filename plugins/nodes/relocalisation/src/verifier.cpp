// Lookup + histogram verification of one frame (see verifier.hpp).
#include "visnav/relocalisation/verifier.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include <opencv2/core.hpp>

#include "visnav/path_payload.hpp"

namespace visnav::reloc {

std::string blank_reason(const cv::Mat& image, const Features& features, const RelocaliseParams& params) {
  if (image.empty()) return "empty frame";
  cv::Scalar mean, stddev;
  cv::meanStdDev(image, mean, stddev);
  double sd = 0.0;
  for (int c = 0; c < image.channels() && c < 4; ++c) sd = std::max(sd, stddev[c]);
  char buf[160];
  if (sd < params.min_image_stddev) {
    std::snprintf(buf, sizeof buf, "flat image: grey-level standard deviation %.1f < %.1f (covered lens or darkness)", sd,
                  params.min_image_stddev);
    return buf;
  }
  if (static_cast<int>(features.keypoints.size()) < params.min_features) {
    std::snprintf(buf, sizeof buf, "%zu features < min_features %d", features.keypoints.size(), params.min_features);
    return buf;
  }
  return {};
}

PlaceVerifier::PlaceVerifier(const PlaceIndex& index, const MapStore& map, const feature_replay::HeadingParams& heading,
                             Detector* detector)
    : index_(index), map_(map), source_(map, detector), estimator_(heading), horizontal_fov_deg_(heading.horizontal_fov_deg) {
  code_.resize(static_cast<std::size_t>(index_.code_words()));
  // Places are stored edge by edge, by increasing distance (build_place_index).
  auto spacing = [&](const std::vector<PlaceRef>& refs) {
    std::vector<double> out(refs.size(), 0.0);
    for (std::size_t i = 0; i < refs.size(); ++i) {
      const double length_m = index_.edges[refs[i].edge].length_m;
      const double d = refs[i].distance_m;
      const double before = i > 0 && refs[i - 1].edge == refs[i].edge ? d - refs[i - 1].distance_m : d;
      const double after = i + 1 < refs.size() && refs[i + 1].edge == refs[i].edge ? refs[i + 1].distance_m - d
                                                                                   : length_m - d;
      out[i] = 0.5 * std::max(0.0, std::max(before, after));
    }
    return out;
  };
  place_uncertainty_m_ = spacing(index_.places);
  // visual_memory references: the gaps to the neighbouring references of the same edge (0 at an
  // edge end), for the relocaliser's nearest-place cells.
  place_gaps_m_.assign(index_.places.size(), {0.0, 0.0});
  for (std::size_t i = 0; i < index_.places.size(); ++i) {
    const PlaceRef& p = index_.places[i];
    if (index_.edges[p.edge].kind != kMemoryKind) continue;
    if (i > 0 && index_.places[i - 1].edge == p.edge) place_gaps_m_[i].first = p.distance_m - index_.places[i - 1].distance_m;
    if (i + 1 < index_.places.size() && index_.places[i + 1].edge == p.edge)
      place_gaps_m_[i].second = index_.places[i + 1].distance_m - p.distance_m;
  }
  thumbnail_uncertainty_m_ = spacing(index_.thumbnail_places);
}

Result<std::vector<PlaceVote>> PlaceVerifier::thumbnail_votes(const cv::Mat& image, const RelocaliseParams& params) {
  std::vector<PlaceVote> out;
  thumbnail_hits_.clear();
  if (index_.thumbnail_places.empty() || params.thumbnail_candidates <= 0) return out;
  VISNAV_ASSIGN(cv::Mat thumb,
                path_payload::make_thumbnail(image, index_.thumbnail_width_px, index_.thumbnail_height_px));
  const double px_per_deg = index_.thumbnail_width_px / horizontal_fov_deg_;
  const int max_shift = static_cast<int>(std::lround(params.thumbnail_max_shift_deg * px_per_deg));
  index_.query_thumbnails(thumb, max_shift, params.thumbnail_candidates, params.min_thumbnail_ncc, thumbnail_hits_,
                          params.thumbnail_coarse_candidates, params.thumbnail_index_candidates);
  for (const ThumbnailHit& h : thumbnail_hits_) {
    const PlaceRef& ref = index_.thumbnail_places[h.place];
    // Live shifted right: the robot is turned left of the taught heading (CCW positive).
    const double offset_rad = h.shift_px / px_per_deg * std::numbers::pi / 180.0;
    const double confidence = std::min(1.0, h.ncc / params.thumbnail_confident_ncc);
    out.push_back(PlaceVote{ref.edge, ref.distance_m, confidence, offset_rad, confidence * params.thumbnail_vote_weight,
                            thumbnail_uncertainty_m_[h.place]});
  }
  return out;
}

std::vector<RouteEdge> PlaceVerifier::route_edges() const {
  std::vector<RouteEdge> out;
  for (const auto& e : index_.edges) {
    RouteEdge r{e.id, "", "", e.length_m};
    if (const EdgeRecord* rec = map_.find_edge(e.id)) {
      r.from = rec->from;
      r.to = rec->to;
      r.length_m = rec->length_m;
    }
    out.push_back(std::move(r));
  }
  return out;
}

Result<std::vector<PlaceVote>> PlaceVerifier::votes(const Features& current, double image_width_px, int candidates,
                                                    double min_confidence) {
  std::vector<PlaceVote> out;
  candidates_.clear();
  if (current.descriptors.empty()) return out;
  VISNAV_TRY(index_.encode(current.descriptors, code_));
  index_.query(code_, candidates, candidates_);
  for (const PlaceCandidate& c : candidates_) {
    const PlaceRef& ref = index_.places[c.place];
    VISNAV_ASSIGN(const PlaceFeatures* f, source_.features(index_.edges[ref.edge].id, ref.distance_m));
    if (f->descriptors.empty()) continue;
    VISNAV_ASSIGN(feature_replay::HeadingEstimate e,
                  estimator_.estimate(feature_replay::ReferenceView{f->descriptors, f->positions_px}, current,
                                      image_width_px));
    if (!e.valid || e.confidence < min_confidence) continue;
    out.push_back(PlaceVote{ref.edge, ref.distance_m, e.confidence, -e.heading_correction_rad, e.inliers * e.confidence,
                            place_uncertainty_m_[c.place], place_gaps_m_[c.place].first, place_gaps_m_[c.place].second});
  }
  return out;
}

}  // namespace visnav::reloc
