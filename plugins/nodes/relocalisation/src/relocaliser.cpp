// Sequence decision of the relocaliser (see relocaliser.hpp for the rules).
#include "visnav/relocalisation/relocaliser.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>
#include <utility>

namespace visnav::reloc {

namespace {

double wrap(double a) {
  const double r = std::remainder(a, 2.0 * std::numbers::pi);
  return r <= -std::numbers::pi ? r + 2.0 * std::numbers::pi : r;
}

std::string fmt(double v, int digits = 2) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

/// The nearest-place cell of a vote whose neighbours are known: this fraction of the gap to the
/// previous place behind it, of the gap to the next one ahead.
constexpr double kCellBehind = 0.5;
constexpr double kCellAhead = 0.75;

/// The stretch covered by the most intervals: [lo_m, hi_m], how many cover it.
struct Overlap {
  double lo_m = 0.0;
  double hi_m = 0.0;
  int depth = 0;
};

/// The deepest stretch of `intervals` (of equally deep ones, the one whose middle is nearest
/// `near`); nullopt when no interval has a positive length.
std::optional<Overlap> deepest_overlap(const std::vector<std::pair<double, double>>& intervals, double near) {
  std::vector<std::pair<double, int>> events;
  for (const auto& [lo, hi] : intervals)
    if (hi > lo) {
      events.emplace_back(lo, +1);
      events.emplace_back(hi, -1);
    }
  if (events.empty()) return std::nullopt;
  // Ends before starts at one position: touching cells do not overlap.
  std::sort(events.begin(), events.end(),
            [](const auto& a, const auto& b) { return a.first != b.first ? a.first < b.first : a.second < b.second; });
  int depth = 0;
  std::optional<Overlap> best;
  for (std::size_t i = 0; i + 1 < events.size(); ++i) {
    depth += events[i].second;
    const double lo = events[i].first, hi = events[i + 1].first;
    if (depth <= 0 || !(hi > lo)) continue;
    const double mid = 0.5 * (lo + hi);
    if (!best || depth > best->depth ||
        (depth == best->depth && std::abs(mid - near) < std::abs(0.5 * (best->lo_m + best->hi_m) - near)))
      best = Overlap{lo, hi, depth};
  }
  return best;
}

}  // namespace

const char* to_string(RelocStatus s) {
  switch (s) {
    case RelocStatus::pending: return "pending";
    case RelocStatus::localised: return "localised";
    case RelocStatus::ambiguous: return "ambiguous";
    case RelocStatus::not_on_map: return "not_on_map";
    case RelocStatus::camera_blocked: return "camera_blocked";
  }
  return "pending";
}

const ParamSchema<RelocaliseParams>& RelocaliseParams::schema() {
  using P = RelocaliseParams;
  static const auto s =
      ParamSchema<P>{}
          .field("frames", &P::frames, "usable frames that must agree before answering (never one frame)")
          .range(3, 100)
          .field("max_frames", &P::max_frames, "usable frames after which an undecided sequence is answered")
          .range(3, 1000)
          .field("candidates", &P::candidates, "places proposed by the index and verified per frame")
          .range(1, 200)
          .field("min_confidence", &P::min_confidence, "histogram-voting confidence of a verified place")
          .range(0.01, 1.0)
          .field("place_tolerance_m", &P::place_tolerance_m, "votes this close along the route are one place, m")
          .range(0.05, 20.0)
          .field("max_runner_up_ratio", &P::max_runner_up_ratio,
                 "a distinct place scoring above this fraction of the best makes the answer ambiguous")
          .range(0.0, 1.0)
          .field("min_agreement", &P::min_agreement, "fraction of usable frames that must support the answer")
          .range(0.0, 1.0)
          .field("min_answer_confidence", &P::min_answer_confidence,
                 "a localised answer below this confidence waits for more frames, then is ambiguous")
          .range(0.0, 1.0)
          .field("min_features", &P::min_features, "a frame with fewer features is blank (covered, dark)")
          .range(0, 100000)
          .field("min_image_stddev", &P::min_image_stddev,
                 "a frame whose grey-level standard deviation is below this is blank (covered lens)")
          .range(0.0, 128.0)
          .field("prior_sigma_m", &P::prior_sigma_m,
                 "odometry prior: spread along the route around the believed position, m (0 = no prior)")
          .range(0.0, 100000.0)
          .field("thumbnail_candidates", &P::thumbnail_candidates,
                 "thumbnail places (path_following edges) voting per frame, the most alike first")
          .range(0, 100)
          .field("min_thumbnail_ncc", &P::min_thumbnail_ncc,
                 "normalised cross-correlation from which a thumbnail place votes")
          .range(0.0, 1.0)
          .field("thumbnail_confident_ncc", &P::thumbnail_confident_ncc,
                 "correlation of a fully confident thumbnail vote (its confidence is ncc / this, at most 1)")
          .range(0.05, 1.0)
          .field("thumbnail_vote_weight", &P::thumbnail_vote_weight,
                 "a thumbnail vote scores confidence x this (a feature vote scores inliers x confidence)")
          .range(0.0, 1000.0)
          .field("thumbnail_max_shift_deg", &P::thumbnail_max_shift_deg,
                 "heading offsets searched when comparing thumbnails, deg")
          .range(0.0, 90.0)
          .field("thumbnail_coarse_candidates", &P::thumbnail_coarse_candidates,
                 "thumbnail places kept by the half-resolution first pass for the full-resolution comparison "
                 "(0 = compare every place at full resolution)")
          .range(0, 100000)
          .field("thumbnail_index_candidates", &P::thumbnail_index_candidates,
                 "thumbnail places the inverted file of thumbnail signatures hands to the two passes (0 = every "
                 "place; a map with no more places than this searches every place)")
          .range(0, 1000000)
          .field("min_cell_agreement", &P::min_cell_agreement,
                 "places with known gaps (visual_memory references): fraction of the answer's frames whose "
                 "nearest-place cells must overlap where it is, else ambiguous")
          .range(0.0, 1.0)
          .field("max_cell_uncertainty_m", &P::max_cell_uncertainty_m,
                 "places with known gaps (visual_memory references): an answer the frames' nearest-place cells "
                 "place only within more than +- this is ambiguous, m")
          .range(0.05, 1000.0)
          .field("max_along_uncertainty_m", &P::max_along_uncertainty_m,
                 "an answer less certain along the route than this (place spacing, spread of the votes) is "
                 "ambiguous, m (0 = no limit)")
          .range(0.0, 1000.0);
  return s;
}

Status RelocaliseParams::validate() const {
  VISNAV_TRY(schema().check(*this));
  if (max_frames < frames)
    return fail(ErrorCode::inconsistent, {"", 0, "max_frames"},
                "max_frames " + std::to_string(max_frames) + " is below frames " + std::to_string(frames));
  return ok();
}

Relocaliser::Relocaliser(const RelocaliseParams& params, std::vector<RouteEdge> edges)
    : params_(params), edges_(std::move(edges)) {}

void Relocaliser::set_prior(std::uint32_t edge, double distance_m) { prior_ = std::make_pair(edge, distance_m); }

void Relocaliser::add(FrameVotes frame) { frames_.push_back(std::move(frame)); }

std::optional<double> Relocaliser::route_distance_m(std::uint32_t a, double da, std::uint32_t b, double db) const {
  if (a >= edges_.size() || b >= edges_.size()) return std::nullopt;
  const RouteEdge& ea = edges_[a];
  const RouteEdge& eb = edges_[b];
  std::optional<double> best;
  auto take = [&](double v) {
    if (!best || std::abs(v) < std::abs(*best)) best = v;
  };
  if (a == b) {
    take(db - da);
    if (ea.from == ea.to && ea.length_m > 0.0) {  // a closed one-edge loop: its two ends are one place
      take(db - da - ea.length_m);
      take(db - da + ea.length_m);
    }
  }
  if (ea.to == eb.from) take((ea.length_m - da) + db);
  if (eb.to == ea.from) take(-((eb.length_m - db) + da));
  return best;
}

namespace {

/// What the steps of Relocaliser::decide() read of the relocaliser.
struct DecideContext {
  const RelocaliseParams& params;
  const std::vector<RouteEdge>& edges;
  const Relocaliser& reloc;  ///< for route_distance_m
  const std::optional<std::pair<std::uint32_t, double>>& prior;
  bool held;
};

/// A vote moved to the newest frame by the robot's own motion.
struct Moved {
  std::uint32_t edge;
  double distance_m;
  double heading_rad;
  double confidence;
  double score;
  int frame;
  double along_uncertainty_m;
  double gap_before_m;
  double gap_after_m;
};

/// One place the votes name, and what every usable frame says of it.
struct Hypothesis {
  std::uint32_t edge;
  double centre_m;       // on `edge`
  double weight = 0.0;   // sum of vote confidences
  double offset_sum = 0.0;
  double sin_sum = 0.0, cos_sum = 0.0;
  std::vector<double> best;        // per usable frame: best vote score
  std::vector<double> confidence;  // per usable frame: best vote confidence
  std::vector<double> peak_m;      // per usable frame: position of its best vote (on `edge`)
  std::vector<double> peak_uncertainty_m;  // per usable frame: its best vote's along_uncertainty_m
  std::vector<std::pair<double, double>> peak_gaps_m;  // per usable frame: its best vote's gaps
  double score = 0.0;
  int support = 0;
};

/// Votes moved to the newest frame by the robot's own motion (in frame order); `usable` is the
/// number of non-blank frames.
std::vector<Moved> moved_votes(const std::vector<FrameVotes>& frames, const FrameVotes& newest, const DecideContext& c,
                               int& usable) {
  std::vector<Moved> votes;
  int frame_index = 0;
  for (const auto& f : frames) {
    if (f.blank) continue;
    const double moved_m = newest.odom_distance_m - f.odom_distance_m;
    const double turned_rad = wrap(newest.odom_heading_rad - f.odom_heading_rad);
    for (const auto& v : f.votes)
      if (v.edge < c.edges.size() && v.confidence >= c.params.min_confidence) {
        // Along the edge: the path travelled projected with the mean of the vote's heading offset
        // then and now (a robot creeping 30 deg off the taught heading advances 0.87 m per metre).
        const double along_m = moved_m * std::cos(v.heading_offset_rad + 0.5 * turned_rad);
        votes.push_back({v.edge, v.distance_m + along_m, wrap(v.heading_offset_rad + turned_rad), v.confidence,
                         v.score > 0.0 ? v.score : v.confidence, frame_index, v.along_uncertainty_m, v.gap_before_m,
                         v.gap_after_m});
      }
    ++frame_index;
  }
  usable = frame_index;
  return votes;
}

/// The votes (strongest first) gathered into places.
std::vector<Hypothesis> cluster_votes(const std::vector<Moved>& votes, int usable, const DecideContext& c) {
  std::vector<Hypothesis> hyps;
  for (const Moved& v : votes) {
    Hypothesis* into = nullptr;
    double into_delta = 0.0;
    // A place with known gaps (a visual_memory reference) is one of a row of places as far apart
    // as the gaps: its votes join a place within the larger gap (adjacent references are one
    // stretch, placed by the cells below), other votes within place_tolerance_m.
    const double tolerance_m = std::max(c.params.place_tolerance_m, std::max(v.gap_before_m, v.gap_after_m));
    for (auto& h : hyps) {
      auto d = c.reloc.route_distance_m(h.edge, h.centre_m, v.edge, v.distance_m);
      if (d && std::abs(*d) <= tolerance_m && (into == nullptr || std::abs(*d) < std::abs(into_delta))) {
        into = &h;
        into_delta = *d;
      }
    }
    if (into == nullptr) {
      const auto n = static_cast<std::size_t>(usable);
      hyps.push_back(Hypothesis{v.edge, v.distance_m, 0.0, 0.0, 0.0, 0.0, std::vector<double>(n, 0.0),
                                std::vector<double>(n, 0.0), std::vector<double>(n, 0.0), std::vector<double>(n, 0.0),
                                std::vector<std::pair<double, double>>(n, {0.0, 0.0})});
      into = &hyps.back();
      into_delta = 0.0;
    }
    // Position relative to the hypothesis' edge (a vote across a node is counted past its end).
    const double on_edge_m = into->centre_m + into_delta;
    // Weighted by the vote scores: the strongest places pull the centre.
    into->offset_sum += v.score * on_edge_m;
    into->weight += v.score;
    into->centre_m = into->offset_sum / into->weight;
    into->sin_sum += v.score * std::sin(v.heading_rad);
    into->cos_sum += v.score * std::cos(v.heading_rad);
    auto& b = into->best[static_cast<std::size_t>(v.frame)];
    if (v.score > b) {
      into->peak_m[static_cast<std::size_t>(v.frame)] = on_edge_m;
      into->peak_uncertainty_m[static_cast<std::size_t>(v.frame)] = v.along_uncertainty_m;
      into->peak_gaps_m[static_cast<std::size_t>(v.frame)] = {v.gap_before_m, v.gap_after_m};
    }
    b = std::max(b, v.score);
    auto& conf = into->confidence[static_cast<std::size_t>(v.frame)];
    conf = std::max(conf, v.confidence);
  }
  return hyps;
}

/// Each place's support (frames that see it) and score (their best votes, weighted by the prior).
void score_hypotheses(std::vector<Hypothesis>& hyps, const DecideContext& c) {
  for (auto& h : hyps) {
    double sum = 0.0;
    for (double b : h.best)
      if (b > 0.0) {
        sum += b;
        ++h.support;
      }
    double weight = 1.0;
    if (c.prior && c.params.prior_sigma_m > 0.0) {
      auto d = c.reloc.route_distance_m(c.prior->first, c.prior->second, h.edge, h.centre_m);
      weight = d ? std::exp(-0.5 * (*d / c.params.prior_sigma_m) * (*d / c.params.prior_sigma_m)) : 0.0;
    }
    h.score = sum * weight;
  }
}

std::string place_name(const Hypothesis& h, const std::vector<RouteEdge>& edges) {
  return "edge " + edges[h.edge].id + " at " + fmt(std::clamp(h.centre_m, 0.0, edges[h.edge].length_m)) + " m";
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

/// Where along the best place's edge, and how sure: centre_m, uncertainty_m, and the deepest
/// overlap of the frames' nearest-place cells (of `cells` cells) when every vote has one.
struct AlongEstimate {
  double centre_m = 0.0;
  double uncertainty_m = 0.0;
  std::optional<Overlap> overlap;
  std::size_t cells = 0;
};

AlongEstimate estimate_along(const Hypothesis& best) {
  // Along the edge: the median of the frames' best votes (the centre of all votes within the
  // tolerance leans towards the side with more, weaker neighbours).
  std::vector<double> peaks, spacing;
  std::vector<std::pair<double, double>> cells;  // per frame: the nearest-place cell of its best vote
  bool all_cells = true;
  for (std::size_t i = 0; i < best.best.size(); ++i)
    if (best.best[i] > 0.0) {
      peaks.push_back(best.peak_m[i]);
      spacing.push_back(best.peak_uncertainty_m[i]);
      auto [before_m, after_m] = best.peak_gaps_m[i];
      if (before_m <= 0.0) before_m = after_m;  // the first or last place of its edge
      if (after_m <= 0.0) after_m = before_m;
      if (before_m <= 0.0) all_cells = false;
      cells.emplace_back(best.peak_m[i] - kCellBehind * before_m, best.peak_m[i] + kCellAhead * after_m);
    }
  double centre_m = peaks.empty() ? best.centre_m : median(peaks);
  // Places far apart (visual_memory references): the median of the votes lands where the
  // sequence's middle frame was, up to half the creep behind the robot, and off by up to half
  // the gap between places. Each vote says the robot was then about nearest its place — its
  // cell reaches kCellAhead of the gap forwards, further than kCellBehind backwards, because a
  // forward camera's view is contained in the view of the reference behind it, which keeps
  // winning past the midpoint (campus traces, docs/relocalisation.md). The answer is the middle
  // of the stretch most of those cells (moved to the newest frame) cover, so it follows the
  // frames where the best place changes.
  std::optional<Overlap> overlap;
  if (all_cells && !cells.empty()) overlap = deepest_overlap(cells, centre_m);
  if (overlap) centre_m = 0.5 * (overlap->lo_m + overlap->hi_m);
  std::vector<double> deviation;
  for (double x : peaks) deviation.push_back(std::abs(x - centre_m));
  // With cells: half the stretch they overlap on (the frames say no more); else the place
  // spacing or the spread of the votes.
  const double uncertainty_m = overlap ? 0.5 * (overlap->hi_m - overlap->lo_m)
                                       : std::max(median(spacing), 1.4826 * median(deviation));
  return AlongEstimate{centre_m, uncertainty_m, overlap, cells.size()};
}

/// Why the frames' cells do not pin the place down (empty when they do).
std::string cell_disagreement(const AlongEstimate& along, const RelocaliseParams& params) {
  const Overlap& overlap = *along.overlap;
  const double agreeing = static_cast<double>(overlap.depth) / static_cast<double>(along.cells);
  std::string why;
  if (agreeing < params.min_cell_agreement)
    why = "the frames disagree where along it (their nearest-place cells overlap in " + std::to_string(overlap.depth) +
          " of " + std::to_string(along.cells) + " frames)";
  else if (along.uncertainty_m > params.max_cell_uncertainty_m)
    why = "the frames place it only within +-" + fmt(along.uncertainty_m) + " m (> " + fmt(params.max_cell_uncertainty_m) +
          " m: no change of the nearest place seen between places far apart)";
  return why;
}

/// Votes moved past the end of the edge (the robot crept over its end node) or before its start:
/// the answer is on the edge that continues there, when exactly one does (clamping would put it
/// back on the node, as far off as the robot went past it).
void continue_across_node(RelocAnswer& answer, std::uint32_t best_edge, double centre_m,
                          const std::vector<RouteEdge>& edges) {
  const RouteEdge& e = edges[best_edge];
  auto only = [&](auto&& pred) -> std::optional<std::uint32_t> {
    std::optional<std::uint32_t> found;
    for (std::uint32_t i = 0; i < edges.size(); ++i)
      if (i != best_edge && pred(edges[i])) {
        if (found) return std::nullopt;
        found = i;
      }
    return found;
  };
  if (centre_m > e.length_m) {
    if (auto next = only([&](const RouteEdge& x) { return x.from == e.to; })) {
      answer.edge = *next;
      answer.distance_m = std::clamp(centre_m - e.length_m, 0.0, edges[*next].length_m);
    }
  } else if (centre_m < 0.0) {
    if (auto prev = only([&](const RouteEdge& x) { return x.to == e.from; })) {
      answer.edge = *prev;
      answer.distance_m = std::clamp(edges[*prev].length_m + centre_m, 0.0, edges[*prev].length_m);
    }
  }
}

/// The best place, once the runner-up, support and confidence checks passed: where along its
/// edge, or ambiguous when that is too uncertain.
RelocAnswer localise(RelocAnswer answer, const Hypothesis& best, const Hypothesis* runner_up, double ratio,
                     double confidence, int usable, bool final_frame, const DecideContext& c) {
  const RouteEdge& e = c.edges[best.edge];
  const AlongEstimate along = estimate_along(best);
  const double centre_m = along.centre_m;
  const double uncertainty_m = along.uncertainty_m;
  answer.along_uncertainty_m = uncertainty_m;
  if (along.overlap) {
    const std::string why = cell_disagreement(along, c.params);
    if (!why.empty()) {
      if (!final_frame) return answer;
      answer.status = RelocStatus::ambiguous;
      answer.reason = "ambiguous: the best place, " + place_name(best, c.edges) + ", but " + why;
      return answer;
    }
  }
  if (c.params.max_along_uncertainty_m > 0.0 && uncertainty_m > c.params.max_along_uncertainty_m) {
    if (!final_frame) return answer;
    answer.status = RelocStatus::ambiguous;
    answer.reason = "ambiguous: the best place, " + place_name(best, c.edges) + ", is uncertain along the route (+-" +
                    fmt(uncertainty_m) + " m > " + fmt(c.params.max_along_uncertainty_m) +
                    " m: places too far apart or frames disagreeing where)";
    return answer;
  }
  answer.status = RelocStatus::localised;
  answer.edge = best.edge;
  answer.distance_m = std::clamp(centre_m, 0.0, e.length_m);
  continue_across_node(answer, best.edge, centre_m, c.edges);
  answer.heading_offset_rad = std::atan2(best.sin_sum, best.cos_sum);
  answer.confidence = confidence;
  answer.reason = "localised: " + place_name(best, c.edges) + ", " + std::to_string(best.support) + " of " +
                  std::to_string(usable) + " frames agree, +-" + fmt(uncertainty_m) + " m along" +
                  (runner_up != nullptr && ratio > 0.0 ? ", next place " + place_name(*runner_up, c.edges) + " at " + fmt(ratio) + " of the score"
                                        : std::string());
  return answer;
}

/// The answer from the places (strongest first): pending, not_on_map, ambiguous or localised.
RelocAnswer judge_places(RelocAnswer answer, const std::vector<Hypothesis>& hyps, int usable, const DecideContext& c) {
  const Hypothesis& best = hyps.front();
  if (!(best.score > 0.0)) {
    answer.status = usable >= c.params.max_frames && !c.held ? RelocStatus::not_on_map : RelocStatus::pending;
    answer.reason = "not on the map: the places seen are outside the odometry prior (" +
                    fmt(c.params.prior_sigma_m) + " m)";
    return answer;
  }
  // The strongest place that is not the same stretch of route as the best.
  const Hypothesis* runner_up = nullptr;
  for (std::size_t i = 1; i < hyps.size(); ++i) {
    auto d = c.reloc.route_distance_m(best.edge, best.centre_m, hyps[i].edge, hyps[i].centre_m);
    if (!d || std::abs(*d) > 2.0 * c.params.place_tolerance_m) {
      runner_up = &hyps[i];
      break;
    }
  }
  const double ratio = runner_up != nullptr ? runner_up->score / best.score : 0.0;
  const bool final_frame = usable >= c.params.max_frames;
  answer.support = best.support;
  // The best place so far (provisional while pending).
  answer.has_best = true;
  answer.edge = best.edge;
  answer.distance_m = std::clamp(best.centre_m, 0.0, c.edges[best.edge].length_m);
  answer.heading_offset_rad = std::atan2(best.sin_sum, best.cos_sum);
  if (c.held) return answer;
  if (ratio > c.params.max_runner_up_ratio) {
    if (!final_frame) return answer;
    answer.status = RelocStatus::ambiguous;
    answer.reason = "ambiguous: " + place_name(best, c.edges) + " (score " + fmt(best.score) + ") and " +
                    place_name(*runner_up, c.edges) + " (score " + fmt(runner_up->score) + ") both match";
    return answer;
  }
  const double needed = std::max<double>(c.params.frames, c.params.min_agreement * usable);
  if (best.support < needed) {
    if (!final_frame) return answer;
    answer.status = RelocStatus::not_on_map;
    answer.reason = "not on the map: the best place, " + place_name(best, c.edges) + ", is supported by only " +
                    std::to_string(best.support) + " of " + std::to_string(usable) + " frames";
    return answer;
  }
  const double mean_confidence = [&] {
    double s = 0.0;
    for (double conf : best.confidence) s += conf;
    return s / std::max(1, best.support);
  }();
  const double confidence =
      std::clamp(static_cast<double>(best.support) / usable * mean_confidence * (1.0 - ratio), 0.0, 1.0);
  if (confidence < c.params.min_answer_confidence) {
    if (!final_frame) return answer;
    answer.status = RelocStatus::ambiguous;
    answer.reason = "ambiguous: the best place, " + place_name(best, c.edges) + ", is too weak (confidence " +
                    fmt(confidence) + " < " + fmt(c.params.min_answer_confidence) + ")";
    return answer;
  }
  return localise(std::move(answer), best, runner_up, ratio, confidence, usable, final_frame, c);
}

}  // namespace

RelocAnswer Relocaliser::decide() const {
  RelocAnswer answer;
  const FrameVotes* newest = nullptr;
  for (const auto& f : frames_) {
    if (f.blank) {
      ++answer.blank_frames;
    } else {
      ++answer.usable_frames;
      newest = &f;
    }
  }
  if (answer.usable_frames < params_.frames) {
    if (answer.blank_frames >= params_.frames) {
      answer.status = RelocStatus::camera_blocked;
      answer.reason = "camera blocked: " + std::to_string(answer.blank_frames) + " of " +
                      std::to_string(frames_.size()) +
                      " frames were blank (too few features or a flat image: covered lens, darkness)";
    }
    return answer;
  }

  const DecideContext c{params_, edges_, *this, prior_, held_};
  // Votes moved to the newest frame by the robot's own motion, strongest first.
  int usable = 0;
  std::vector<Moved> votes = moved_votes(frames_, *newest, c, usable);
  if (votes.empty()) {
    if (held_ && hold_unseen_) return answer;
    answer.status = RelocStatus::not_on_map;
    answer.reason = "not on the map: no place of the map was verified in " + std::to_string(usable) + " frames";
    return answer;
  }
  std::stable_sort(votes.begin(), votes.end(), [](const Moved& x, const Moved& y) { return x.score > y.score; });

  std::vector<Hypothesis> hyps = cluster_votes(votes, usable, c);
  score_hypotheses(hyps, c);
  std::stable_sort(hyps.begin(), hyps.end(), [](const Hypothesis& x, const Hypothesis& y) { return x.score > y.score; });
  return judge_places(std::move(answer), hyps, usable, c);
}

}  // namespace visnav::reloc
