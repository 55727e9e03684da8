// feature_replay core — experience files, selection and view registration (experience.hpp).
#include "visnav/feature_replay/experience.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <chrono>
#include <ctime>

#include "visnav/byte_io.hpp"
#include "visnav/feature_replay/local_map.hpp"
#include "visnav/file_io.hpp"
#include "visnav/feature_replay/segment_map.hpp"
#include "visnav/map.hpp"

namespace visnav::feature_replay {
namespace fs = std::filesystem;
namespace io = visnav::byte_io;

namespace {

constexpr char kMagic[4] = {'F', 'R', 'E', 'X'};
// A learned experience is a feature body of one edge: far below this; the cap keeps a damaged
// length field from allocating gigabytes.
constexpr std::uint64_t kMaxFileBytes = 1ull << 30;

bool get_text(io::Reader& r, std::string& s) {
  std::uint16_t n = 0;
  if (!r.get(n) || n > r.remaining()) return false;
  s.resize(n);
  return r.bytes(s.data(), n);
}


}  // namespace

// ------------------------------------------------------------------------------ the set

std::vector<std::uint8_t> ExperienceSet::serialize() const {
  // Exact size, then filled in place (GCC 12 misreads grow-by-insert here as an overflow).
  std::size_t size = 4 + 2 + 4 + 4 + 4;
  for (const auto& e : learned)
    size += 4 + 2 + std::min<std::size_t>(e.created.size(), 0xffff) + 2 + std::min<std::size_t>(e.source.size(), 0xffff) +
            8 + e.body.size();
  std::vector<std::uint8_t> out(size);
  std::size_t at = 0;
  auto raw = [&](const void* data, std::size_t n) {
    if (n > 0) std::memcpy(out.data() + at, data, n);
    at += n;
  };
  auto put = [&](auto value) { raw(&value, sizeof value); };
  auto text = [&](const std::string& s) {
    const std::size_t n = std::min<std::size_t>(s.size(), 0xffff);
    put(static_cast<std::uint16_t>(n));
    raw(s.data(), n);
  };
  raw(kMagic, 4);
  put(kFormatVersion);
  put(teach_crc32);
  put(next_number);
  put(static_cast<std::uint32_t>(learned.size()));
  for (const auto& e : learned) {
    put(e.number);
    text(e.created);
    text(e.source);
    put(static_cast<std::uint64_t>(e.body.size()));
    raw(e.body.data(), e.body.size());
  }
  return out;
}

Result<ExperienceSet> ExperienceSet::deserialize(std::span<const std::uint8_t> body) {
  auto bad = [](const std::string& what) { return fail(ErrorCode::parse_error, "experience set: " + what); };
  io::Reader r(body);
  char magic[4];
  if (!r.bytes(magic, 4) || std::memcmp(magic, kMagic, 4) != 0) return bad("bad magic (not an experience set)");
  std::uint16_t version = 0;
  std::uint32_t count = 0;
  ExperienceSet set;
  if (!r.get(version)) return bad("truncated header");
  if (version != kFormatVersion)
    return bad("format version " + std::to_string(version) + " is not supported (expected " +
               std::to_string(kFormatVersion) + ")");
  if (!r.get(set.teach_crc32) || !r.get(set.next_number) || !r.get(count)) return bad("truncated header");
  // Each experience takes at least 16 bytes: a count above that cannot be honest.
  if (static_cast<std::uint64_t>(count) * 16 > r.remaining()) return bad("count " + std::to_string(count) + " exceeds the body");
  set.learned.resize(count);
  std::uint32_t previous = 0;
  for (std::uint32_t i = 0; i < count; ++i) {
    Experience& e = set.learned[i];
    std::uint64_t n = 0;
    if (!r.get(e.number) || !get_text(r, e.created) || !get_text(r, e.source) || !r.get(n))
      return bad("truncated in experience " + std::to_string(i));
    if (n > r.remaining()) return bad("body of experience " + std::to_string(i) + " runs past the end");
    e.body.resize(static_cast<std::size_t>(n));
    r.bytes(e.body.data(), e.body.size());
    if (e.number == 0 || e.number <= previous || e.number >= set.next_number)
      return bad("experience numbers out of order (" + std::to_string(e.number) + " after " + std::to_string(previous) +
                 ", next " + std::to_string(set.next_number) + ")");
    previous = e.number;
  }
  if (r.remaining() != 0) return bad(std::to_string(r.remaining()) + " trailing bytes");
  return set;
}

std::vector<std::uint32_t> ExperienceSet::add(Experience e, int max_experiences) {
  e.number = next_number++;
  learned.push_back(std::move(e));
  std::vector<std::uint32_t> evicted;
  const std::size_t keep = static_cast<std::size_t>(std::max(1, max_experiences) - 1);
  while (learned.size() > keep) {
    evicted.push_back(learned.front().number);
    learned.erase(learned.begin());
  }
  return evicted;
}

// ------------------------------------------------------------------------------ files

std::string experience_path(const std::string& map_dir, const std::string& edge_id) {
  return (fs::path(map_dir) / kExperienceFolder / (edge_id + ".bin")).string();
}

Result<ExperienceSet> read_experience_file(const std::string& path, const std::string& edge_id) {
  VISNAV_ASSIGN(const std::string text, read_text_file(path, kMaxFileBytes, "experiences"));
  const std::vector<std::uint8_t> bytes(text.begin(), text.end());
  auto view = map_format::parse_payload(bytes, path);
  if (!view) return Error{view.error().message, ErrorCode::parse_error, ErrorLocation(path)};
  if (view->kind != kExperienceKind)
    return fail(ErrorCode::parse_error, ErrorLocation(path),
                "holds kind '" + view->kind + "', not " + kExperienceKind);
  if (view->edge_id != edge_id)
    return fail(ErrorCode::parse_error, ErrorLocation(path, 0, edge_id),
                "belongs to edge '" + view->edge_id + "', not '" + edge_id + "'");
  auto set = ExperienceSet::deserialize(view->body);
  if (!set) return fail(ErrorCode::parse_error, ErrorLocation(path, 0, edge_id), set.error().message);
  return set;
}

Result<ExperienceSet> load_experiences(const std::string& map_dir, const std::string& edge_id,
                                       std::span<const std::uint8_t> teach_body) {
  const std::string path = experience_path(map_dir, edge_id);
  const std::uint32_t crc = map_format::crc32(teach_body);
  std::error_code ec;
  if (!fs::exists(path, ec)) {
    ExperienceSet empty;
    empty.teach_crc32 = crc;
    return empty;
  }
  VISNAV_ASSIGN(ExperienceSet set, read_experience_file(path, edge_id));
  if (set.teach_crc32 != crc)
    return fail(ErrorCode::inconsistent, ErrorLocation(path, 0, edge_id),
                "stale: learned for another teach payload of edge " + edge_id +
                    " (re-taught?); delete the file to start again");
  return set;
}

Status save_experiences(const std::string& map_dir, const std::string& edge_id, const ExperienceSet& set) {
  const std::string folder = (fs::path(map_dir) / kExperienceFolder).string();
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec) return fail(ErrorCode::io, ErrorLocation(folder), "cannot create: " + ec.message());
  const std::vector<std::uint8_t> body = set.serialize();
  const std::vector<std::uint8_t> file = map_format::encode_payload(kExperienceKind, edge_id, body);
  return write_file_durably(folder, fs::path(experience_path(map_dir, edge_id)).filename().string(), file);
}

// ------------------------------------------------------------------ supervised experiences

std::string utc_now_iso() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

Result<std::vector<std::uint8_t>> experience_from_drive(const std::string& kind, std::span<const std::uint8_t> teach_body,
                                                        std::span<const std::uint8_t> drive_body,
                                                        double max_length_mismatch) {
  auto scale_of = [&](double teach_m, double drive_m) -> Result<double> {
    // Both runs drive between the same places: a drive much longer or shorter than the taught
    // edge is another stretch of route (or a drive that was cut short), not an odometry error.
    if (!(teach_m > 0.0) || !(drive_m > 0.0) || std::abs(teach_m / drive_m - 1.0) > max_length_mismatch)
      return fail(ErrorCode::inconsistent, "driven length " + std::to_string(drive_m) + " m does not fit the taught " +
                                               std::to_string(teach_m) + " m (more than " +
                                               std::to_string(static_cast<int>(max_length_mismatch * 100.0)) +
                                               " % apart)");
    return teach_m / drive_m;
  };
  if (kind == kSegmentKind) {
    auto teach = SegmentMap::deserialize(teach_body);
    if (!teach) return fail(ErrorCode::parse_error, "taught body: " + teach.error().message);
    auto drive = SegmentMap::deserialize(drive_body);
    if (!drive) return fail(ErrorCode::parse_error, "driven body: " + drive.error().message);
    VISNAV_ASSIGN(const double s, scale_of(teach->length_m, drive->length_m));
    SegmentMap out = std::move(*drive);
    const auto sf = static_cast<float>(s);
    for (Landmark& l : out.landmarks) {
      l.first_distance_m *= sf;
      l.last_distance_m *= sf;
    }
    out.max_span_m *= s;
    out.length_m = teach->length_m;
    out.azimuth_rad = teach->azimuth_rad;
    if (auto st = out.validate(); !st) return fail(ErrorCode::inconsistent, "aligned body: " + st.error().message);
    return out.serialize();
  }
  if (kind == kLocalMapsKind) {
    auto teach = LocalMapPath::deserialize(teach_body);
    if (!teach) return fail(ErrorCode::parse_error, "taught body: " + teach.error().message);
    auto drive = LocalMapPath::deserialize(drive_body);
    if (!drive) return fail(ErrorCode::parse_error, "driven body: " + drive.error().message);
    VISNAV_ASSIGN(const double s, scale_of(teach->length_m, drive->length_m));
    LocalMapPath out = std::move(*drive);
    for (LocalMap& m : out.maps) m.distance_m = std::min(m.distance_m * s, teach->length_m);
    out.length_m = teach->length_m;
    out.commands = teach->commands;  // the route stays the taught one; only the appearance is new
    if (auto st = out.validate(); !st) return fail(ErrorCode::inconsistent, "aligned body: " + st.error().message);
    return out.serialize();
  }
  return fail(ErrorCode::out_of_range, "edge kind '" + kind + "' has no appearance experiences (expected " +
                                           kSegmentKind + " or " + kLocalMapsKind + ")");
}

Result<std::vector<DriveExperienceOutcome>> add_drive_experiences(const std::string& map_dir,
                                                                  const std::string& drive_map_dir,
                                                                  const std::string& source, int max_experiences) {
  VISNAV_ASSIGN(MapStore map, MapStore::open(map_dir));
  VISNAV_ASSIGN(MapStore drive, MapStore::open(drive_map_dir));
  std::vector<DriveExperienceOutcome> outcomes;
  for (const EdgeRecord& edge : map.edges()) {
    if (edge.kind != kSegmentKind && edge.kind != kLocalMapsKind) continue;
    DriveExperienceOutcome o;
    o.edge_id = edge.id;
    const EdgeRecord* driven = drive.find_edge(edge.id);
    if (driven == nullptr) {
      o.note = "not driven (the drive map has no edge " + edge.id + ")";
    } else if (driven->kind != edge.kind || driven->from != edge.from || driven->to != edge.to) {
      o.note = "not the same edge: driven " + driven->from + " -> " + driven->to + " (" + driven->kind + "), taught " +
               edge.from + " -> " + edge.to + " (" + edge.kind + ")";
    } else if (auto teach = map.read_payload(edge.id); !teach) {
      o.note = teach.error().message;
    } else if (auto driven_body = drive.read_payload(edge.id); !driven_body) {
      o.note = driven_body.error().message;
    } else if (auto set = load_experiences(map_dir, edge.id, *teach); !set) {
      o.note = set.error().message;
    } else if (auto body = experience_from_drive(edge.kind, *teach, *driven_body); !body) {
      o.note = drive_map_dir + ": edge " + edge.id + ": " + body.error().message;
    } else {
      o.length_scale = edge.length_m > 0.0 && driven->length_m > 0.0 ? edge.length_m / driven->length_m : 1.0;
      Experience e;
      e.created = utc_now_iso();
      e.source = source;
      e.body = std::move(*body);
      o.note = std::to_string(e.body.size()) + " bytes";
      o.evicted = set->add(std::move(e), max_experiences);
      if (auto st = save_experiences(map_dir, edge.id, *set); !st) {
        o.note = st.error().message;
      } else {
        o.added = true;
        o.number = set->learned.empty() ? 0 : set->learned.back().number;
      }
    }
    outcomes.push_back(std::move(o));
  }
  return outcomes;
}

// ------------------------------------------------------------------------------ registration

const Features* ViewRegistrar::add(double distance_m, const Features& current, const HeadingEstimate& estimate) {
  if (estimate.valid && std::isfinite(estimate.offset_px)) {
    have_offset_ = true;
    offset_px_ = estimate.offset_px;
    offset_at_m_ = distance_m;
  } else if (!have_offset_ || std::abs(distance_m - offset_at_m_) > hold_m_) {
    return nullptr;
  }
  registered_.keypoints.assign(current.keypoints.begin(), current.keypoints.end());
  const auto shift = static_cast<float>(offset_px_);
  for (auto& k : registered_.keypoints) k.pt.x -= shift;
  registered_.descriptors = current.descriptors;  // shared, read-only
  registered_.norm = current.norm;
  return &registered_;
}

}  // namespace visnav::feature_replay
