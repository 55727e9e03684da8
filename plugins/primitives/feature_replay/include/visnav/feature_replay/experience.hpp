// feature_replay core — appearance experiences of a feature edge (issue 13, part 3).
//
// A feature edge's taught payload is its first experience (number 0, "teach"). Later replays may
// add their own view of the edge as further experiences (summer teach, winter replay, ...), like
// VT&R3's multi-experience localisation for appearance-based maps. Where the change is too large
// for any replay to succeed (summer map, winter snow), an experience comes from a supervised
// drive instead: the route taught again in the new conditions into a scratch map, whose edges are
// added to the taught ones (add_drive_experiences). On replay the experience whose reference
// matches the current frame best is used (ExperienceSelector).
//
// Storage: <map>/experiences/<edge_id>.bin, one file per edge holding every learned experience,
// in the map store's payload format (map_format::encode_payload: magic "VNAVEDGE", version, kind
// `feature_experiences`, the edge id, CRC-32 of header and body), so damage and foreign files are
// detected like an edge payload's. The body (ExperienceSet::serialize):
//   4 B magic "FREX", u16 format version (1), u32 CRC-32 of the teach body the experiences belong
//   to (a re-taught edge makes them stale), u32 next experience number, u32 count, then per
//   experience: u32 number, u16+bytes created (ISO-8601 UTC), u16+bytes source (free text),
//   u64+bytes body (a SegmentMap or LocalMapPath body, the same kind as the edge's).
// An edge without the file has one experience (maps taught before experiences existed load
// unchanged; the graph and the edge payloads are never rewritten).
//
// Writes are crash-safe: a temporary file in the experiences folder (".<edge>.bin.tmp.<pid>"),
// fsync, rename over the target, fsync of the folder. A killed process leaves the previous file.
//
// Bound: at most `max_experiences` per edge counting the teach one; adding one more evicts the
// oldest learned experience (never the teach payload).
//
// Thread-safety: pure functions and value types; ExperienceSelector is a single-threaded object.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "visnav/devices.hpp"
#include "visnav/feature_replay/heading.hpp"
#include "visnav/result.hpp"

namespace visnav::feature_replay {

/// Edge kinds written by TeachFeatureEdge and read by ReplayFeatureEdge (style A, style B).
inline constexpr const char* kSegmentKind = "feature_segment";
inline constexpr const char* kLocalMapsKind = "feature_localmaps";

inline constexpr const char* kExperienceKind = "feature_experiences";  ///< payload-header kind of the file
inline constexpr const char* kExperienceFolder = "experiences";         ///< folder inside the map

/// One learned experience.
struct Experience {
  std::uint32_t number = 0;        ///< 1, 2, ... in the order learned (0 is the teach payload, never stored)
  std::string created;             ///< ISO-8601 UTC, e.g. "2026-11-24T08:10:00Z"
  std::string source;              ///< who learned it (free text, e.g. "replay by /Patrol/ReplayFeatureEdge")
  std::vector<std::uint8_t> body;  ///< SegmentMap / LocalMapPath body of the edge's kind
};

/// Every learned experience of one edge, oldest first.
struct ExperienceSet {
  static constexpr std::uint16_t kFormatVersion = 1;

  std::uint32_t teach_crc32 = 0;   ///< map_format::crc32 of the edge's teach body
  std::uint32_t next_number = 1;   ///< number of the next experience learned
  std::vector<Experience> learned;

  [[nodiscard]] std::vector<std::uint8_t> serialize() const;
  /// Parses a body made by serialize(); garbage, truncation, trailing bytes, numbers out of order
  /// are parse_error (never a crash).
  [[nodiscard]] static Result<ExperienceSet> deserialize(std::span<const std::uint8_t> body);

  /// Appends `e` (its number is set to next_number) and evicts the oldest learned experiences
  /// until 1 + learned.size() <= max_experiences (>= 1). Returns the numbers evicted.
  std::vector<std::uint32_t> add(Experience e, int max_experiences);
};

/// Now as ISO-8601 UTC ("2026-11-24T08:10:00Z"), for Experience::created.
[[nodiscard]] std::string utc_now_iso();

/// <map_dir>/experiences/<edge_id>.bin
[[nodiscard]] std::string experience_path(const std::string& map_dir, const std::string& edge_id);

/// Loads the experiences of edge `edge_id` whose teach body is `teach_body`. No file: an empty set
/// (teach only). Errors name the file: io (unreadable), parse_error (damaged header, checksum,
/// body, or a file of another edge or kind), inconsistent (stale: made for another teach body).
[[nodiscard]] Result<ExperienceSet> load_experiences(const std::string& map_dir, const std::string& edge_id,
                                                     std::span<const std::uint8_t> teach_body);
/// Same checks on the file alone (teach_crc32 is not compared), for listings.
[[nodiscard]] Result<ExperienceSet> read_experience_file(const std::string& path, const std::string& edge_id);
/// Writes the set crash-safely (see the file comment); creates the folder if needed.
[[nodiscard]] Status save_experiences(const std::string& map_dir, const std::string& edge_id, const ExperienceSet& set);

// ------------------------------------------------------------------ supervised experiences
//
// A supervised drive (an operator, or the simulator's scripted operator, driving the taught route
// again in new conditions, e.g. once per season as VT&R3 users do) is taught into a scratch map
// with the ordinary teach tree; its feature edges are then added to the taught map's edges of the
// same id as experiences. The taught payloads and the graph are never changed.

/// The body of a supervised drive's edge (`drive_body`, of edge kind `kind`: kSegmentKind or
/// kLocalMapsKind) made into an experience of the taught edge (`teach_body`, same kind): every
/// distance is scaled by teach length / drive length (both runs go between the same places, so
/// this aligns the drive's odometry to the taught edge's), the azimuth (style A) and the recorded
/// commands (style B) are the taught ones: only the appearance is taken from the drive.
/// Errors: a body that does not decode (parse_error), kinds that are not feature kinds
/// (out_of_range), lengths whose ratio differs from 1 by more than `max_length_mismatch`
/// (inconsistent: not the same stretch of route).
[[nodiscard]] Result<std::vector<std::uint8_t>> experience_from_drive(const std::string& kind,
                                                                      std::span<const std::uint8_t> teach_body,
                                                                      std::span<const std::uint8_t> drive_body,
                                                                      double max_length_mismatch = 0.25);

/// What add_drive_experiences did to one feature edge of the taught map.
struct DriveExperienceOutcome {
  std::string edge_id;
  bool added = false;
  std::uint32_t number = 0;             ///< the experience number given (added)
  std::vector<std::uint32_t> evicted;   ///< learned experiences evicted by the bound
  double length_scale = 1.0;            ///< teach length / drive length (added)
  std::string note;                     ///< why not added ("not driven", the error), or the size added
};

/// Adds, for every feature edge of the taught map `map_dir` that the drive map `drive_map_dir`
/// has under the same id (same kind, same from/to nodes), the drive's view as a new experience
/// (experience_from_drive; at most `max_experiences` per edge counting the taught one, the
/// oldest learned evicted), each edge's file written crash-safely. `source` is stored with each
/// experience. Edges the drive lacks are reported "not driven" (not an error: a drive may cover
/// part of the route). Error: a map that does not open, or an experience file of the taught map
/// that is damaged or stale (nothing is written then for that edge; the outcome names the file).
[[nodiscard]] Result<std::vector<DriveExperienceOutcome>> add_drive_experiences(const std::string& map_dir,
                                                                                const std::string& drive_map_dir,
                                                                                const std::string& source,
                                                                                int max_experiences);

/// Which experience to use, frame by frame, without paying for every experience every frame:
/// the experience that won the last frame is tried first; only when its confidence is below
/// `recheck_below_confidence` are the others tried too, and the best (confidence, then inliers)
/// wins; a tie keeps the current one (recheck_below_confidence 1: every experience every frame).
/// With a confident current experience the per-frame cost is that of one experience.
class ExperienceSelector {
 public:
  struct Score {
    double confidence = 0.0;
    int inliers = 0;
  };

  explicit ExperienceSelector(int count = 1, double recheck_below_confidence = 0.5)
      : count_(count < 1 ? 1 : count), recheck_below_(recheck_below_confidence) {}

  /// `evaluate(i)` runs experience i on the current frame and returns its score. Returns the
  /// chosen experience (it becomes current).
  template <typename Evaluate>
  int select(Evaluate&& evaluate) {
    evaluations_ = 1;
    Score best = evaluate(current_);
    if (count_ == 1 || (recheck_below_ < 1.0 && best.confidence >= recheck_below_)) return current_;
    int chosen = current_;
    for (int i = 0; i < count_; ++i) {
      if (i == current_) continue;
      const Score s = evaluate(i);
      ++evaluations_;
      if (s.confidence > best.confidence || (s.confidence == best.confidence && s.inliers > best.inliers)) {
        best = s;
        chosen = i;
      }
    }
    if (chosen != current_) ++switches_;
    current_ = chosen;
    return current_;
  }

  [[nodiscard]] int count() const { return count_; }
  [[nodiscard]] int current() const { return current_; }
  /// Experiences evaluated in the last select() (1 while the current one is confident).
  [[nodiscard]] int evaluations() const { return evaluations_; }
  [[nodiscard]] int switches() const { return switches_; }

 private:
  int count_ = 1;
  double recheck_below_ = 0.5;
  int current_ = 0;
  int evaluations_ = 0;
  int switches_ = 0;
};

/// Registers a replay frame to the experience it is matched against, so that a view learned
/// during a replay is stored as if seen on the reference heading: keypoints are moved by the
/// frame's offset (u - offset_px) when the estimate is valid; frames without a valid estimate use
/// the last valid offset while the distance since it is at most `hold_m`, else they are not
/// registered (nullptr). With `assume_aligned_at_start`, the edge start counts as a valid offset
/// of 0 at distance 0 (the robot starts on the reference heading), so an edge on which nothing
/// matches is still learned, as seen from the odometric heading, for hold_m. Buffers are reused
/// (one Features kept).
class ViewRegistrar {
 public:
  explicit ViewRegistrar(double hold_m = 1.0) : hold_m_(hold_m) {}
  void reset(double hold_m, bool assume_aligned_at_start) {
    hold_m_ = hold_m;
    have_offset_ = assume_aligned_at_start;
    offset_px_ = 0.0;
    offset_at_m_ = 0.0;
  }
  void reset() { have_offset_ = false; }
  /// The registered features (valid until the next call), or nullptr.
  const Features* add(double distance_m, const Features& current, const HeadingEstimate& estimate);

 private:
  double hold_m_;
  bool have_offset_ = false;
  double offset_px_ = 0.0;
  double offset_at_m_ = 0.0;
  Features registered_;
};

}  // namespace visnav::feature_replay
