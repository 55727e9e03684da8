// visnav SDK — the hybrid topological map store and route planning.
//
// A map is a folder (see docs/map_format.md):
//   <map>/graph.yaml          human-readable graph: nodes (places) and edges (stretches of route)
//   <map>/edges/<edge_id>.bin one binary payload per edge: fixed header (magic "VNAVEDGE",
//                             format version, kind, edge id, body length, CRC-32 of header and
//                             body) followed by the opaque body the primitive produced.
//
// Nodes are places; each node lists the azimuths of its outgoing edges (heading in the odom frame
// the robot turns to before starting the edge). Edges name the primitive kind that traverses them
// ("feature_segment", "path_following", ... — free strings registered by plugins; the store never
// interprets payload bodies) and carry the odometric length used to decide when the edge is done.
//
// Teaching (a primitive adapter, tick thread):
//   auto to = map.add_node({.name = "door"});                      // graph rewritten now
//   std::vector<std::uint8_t> body = serialise_my_model(...);       // e.g. with PayloadWriter
//   auto id = map.add_edge({.from = from, .to = *to, .kind = "feature_segment",
//                           .length_m = 12.3, .azimuth_rad = 0.5,
//                           .statistics = {{"landmarks", 812}}}, body);  // payload + graph on disk now
// Replay: `auto body = map.read_payload(edge_id);` once when the edge starts (verified against its
// checksum), then parse it with PayloadReader. Opening a map reads only graph.yaml (10,000 edges:
// ~40 ms CPU); payloads are read on demand, so the cost of reading an edge does not depend on
// how many edges the map has.
//
// Crash safety: every file is written to a temporary file in the same folder (".<name>.tmp.<pid>"),
// fsync'ed, renamed over the target and the folder fsync'ed. add_node/add_edge return only when
// the payload and the graph naming it are durable. A process killed at any moment leaves a map
// that opens with every edge whose add_edge returned; at worst an unreferenced payload or a
// temporary file is left behind (reported by `leftover_files()`, ignored otherwise, and
// overwritten when the same edge id is written again).
//
// Errors: every failure is a Result error naming the file (and line for graph.yaml), e.g.
//   "maps/campus/edges/e3.bin: damaged body: checksum mismatch (stored 0x1a2b3c4d, computed 0x...)".
// Damaged, truncated or foreign files never crash the reader.
//
// Thread-safety: a MapStore is used from one thread (the tick thread). Const methods do not
// mutate shared state, so several threads may call const methods (queries, read_payload,
// check_payload, validate) concurrently as long as no thread calls a mutating method. One writer
// process per map folder (no inter-process locking).
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav {

/// A place of the map.
struct NodeRecord {
  /// Unique id: 1-64 characters of [A-Za-z0-9_-]. Empty in add_node() → assigned ("n<k>").
  std::string id;
  /// Display name (free text, may be empty); `find_node_by_name` looks it up.
  std::string name;
  /// Optional odometric position of the place (odom frame) — a layout hint for rendering.
  std::optional<Pose2D> position_hint;
};

/// A stretch of route traversed by one primitive.
struct EdgeRecord {
  /// Unique id: 1-64 characters of [A-Za-z0-9_-]; also the payload file name
  /// (edges/<id>.bin). Empty in add_edge() → assigned ("e<k>").
  std::string id;
  std::string from;  ///< node id where the edge starts
  std::string to;    ///< node id where the edge ends (may equal `from` for a loop)
  /// Primitive kind, 1-64 characters of [A-Za-z0-9_.-] ("feature_segment", "path_following").
  std::string kind;
  double length_m = 0.0;     ///< odometric length, ≥ 0
  double azimuth_rad = 0.0;  ///< heading (odom frame) at the start of the edge, in (-pi, pi]
  /// Creation time, ISO-8601 UTC ("2026-11-22T08:40:00Z"). Empty in add_edge() → now.
  std::string created;
  /// Primitive-defined figures (landmarks, traversals, ...). Keys: [A-Za-z0-9_.-]+.
  std::map<std::string, double> statistics;
  /// Set by the store: payload file relative to the map folder ("edges/<id>.bin").
  std::string payload_file;
  /// Set by the store: size of the payload file in bytes (header + body).
  std::uint64_t payload_bytes = 0;
};

/// Azimuth of one outgoing edge of a node.
struct OutgoingAzimuth {
  std::string edge_id;
  double azimuth_rad = 0.0;
};

/// Per-kind (or total) size figures.
struct KindStats {
  std::size_t edges = 0;
  double length_m = 0.0;
  std::uint64_t payload_bytes = 0;
  /// payload_bytes / length_m (0 when length_m is 0).
  [[nodiscard]] double bytes_per_m() const { return length_m > 0.0 ? static_cast<double>(payload_bytes) / length_m : 0.0; }
};

struct MapStats {
  std::size_t nodes = 0;
  KindStats total;
  std::map<std::string, KindStats> per_kind;
};

/// Payload file format constants (docs/map_format.md).
namespace map_format {
inline constexpr char kPayloadMagic[8] = {'V', 'N', 'A', 'V', 'E', 'D', 'G', 'E'};
inline constexpr std::uint32_t kPayloadVersion = 1;
inline constexpr std::size_t kPayloadFixedHeaderBytes = 32;
inline constexpr int kGraphVersion = 1;
inline constexpr const char* kGraphFile = "graph.yaml";
inline constexpr const char* kEdgeFolder = "edges";

/// A parsed payload file. `body` points into the buffer given to parse_payload().
struct PayloadView {
  std::uint32_t version = 0;
  std::string kind;
  std::string edge_id;
  std::span<const std::uint8_t> body;
};

/// Encodes a complete payload file (header + body).
[[nodiscard]] std::vector<std::uint8_t> encode_payload(std::string_view kind, std::string_view edge_id,
                                                       std::span<const std::uint8_t> body);

/// Parses and fully verifies a payload file held in memory: size, magic, version, header
/// checksum, lengths, body checksum. Never reads outside `file`. Errors are prefixed with
/// `file_name` ("edges/e3.bin: truncated: ..."). Pure; thread-safe.
[[nodiscard]] Result<PayloadView> parse_payload(std::span<const std::uint8_t> file, std::string_view file_name);

/// CRC-32 (IEEE 802.3, reflected, as zlib's crc32()). `seed` chains calls: crc32(b, crc32(a)).
[[nodiscard]] std::uint32_t crc32(std::span<const std::uint8_t> bytes, std::uint32_t seed = 0);

/// True if `id` is a valid node/edge id (1-64 of [A-Za-z0-9_-]).
[[nodiscard]] bool valid_id(std::string_view id);
/// True if `kind` is a valid primitive kind (1-64 of [A-Za-z0-9_.-], not starting with '.').
[[nodiscard]] bool valid_kind(std::string_view kind);
}  // namespace map_format

/// A primitive's reader of its own payload bodies: decodes `body` (the payload without its
/// header) as the primitive's replay would and checks it against the graph's record of the edge
/// (e.g. the length the body was taught with versus `edge.length_m`). Errors say what is wrong
/// without the file name (the store prefixes it). Must not throw; pure; thread-safe.
using PayloadBodyCheck = Status (*)(std::span<const std::uint8_t> body, const EdgeRecord& edge) noexcept;

/// The map folder. Movable, not copyable. See the file comment for the contract.
class MapStore {
 public:
  /// Creates a new, empty map in `dir` (created if missing; must not already hold a map) and
  /// writes its graph file. `name` is the map's display name.
  [[nodiscard]] static Result<MapStore> create(const std::string& dir, const std::string& name);
  /// Opens an existing map: parses and checks graph.yaml (syntax, keys, types, duplicate ids,
  /// duplicate non-empty node names, dangling references, node/edge azimuth consistency).
  /// Payloads are not read (lazy). Temporary files (".<name>.tmp.<pid>") left by a writer
  /// process that no longer runs are deleted; those of a live process are left alone.
  [[nodiscard]] static Result<MapStore> open(const std::string& dir);

  MapStore(MapStore&&) noexcept;
  MapStore& operator=(MapStore&&) noexcept;
  MapStore(const MapStore&) = delete;
  MapStore& operator=(const MapStore&) = delete;
  ~MapStore();

  [[nodiscard]] const std::string& dir() const;
  [[nodiscard]] const std::string& name() const;
  /// Path of graph.yaml.
  [[nodiscard]] std::string graph_path() const;
  /// Path of an edge's payload file (whether or not it exists).
  [[nodiscard]] std::string payload_path(std::string_view edge_id) const;

  // --- Writing (tick thread, exclusive) ---

  /// Adds a node and (with autoflush) rewrites the graph crash-safely. Returns the node id.
  /// A non-empty name already used by another node is an error.
  [[nodiscard]] Result<std::string> add_node(NodeRecord node);
  /// Writes the payload file for a new edge immediately and crash-safely, then (with autoflush)
  /// the graph. `from`/`to` must exist, the id must be new. `payload_file` and
  /// `payload_bytes` are filled in by the store. Returns the edge id. On failure the in-memory
  /// map is unchanged.
  [[nodiscard]] Result<std::string> add_edge(EdgeRecord edge, std::span<const std::uint8_t> payload);
  /// Sets one statistic of an edge (e.g. "traversals") and (with autoflush) rewrites the graph.
  [[nodiscard]] Status set_edge_statistic(std::string_view edge_id, const std::string& key, double value);
  /// With autoflush on (the default) every add_* rewrites graph.yaml before returning. Turning it
  /// off batches graph writes (payloads are still written at once) until flush(); used by tools
  /// that generate big maps. Edges added since the last flush are lost on a crash.
  void set_autoflush(bool on);
  /// With sync on (the default) every write is fsync'ed (file and folder) before it counts as
  /// done: durable across power loss. Off keeps the temporary-file-and-rename protocol (so a killed
  /// process still never leaves a half-written file in place) but skips fsync; only for
  /// generators and tests, where fsync dominates the cost (~10 ms per write on some disks).
  void set_sync(bool on);
  /// Rewrites graph.yaml crash-safely if anything changed since the last write.
  [[nodiscard]] Status flush();

  // --- Queries (const; see thread-safety above) ---

  [[nodiscard]] const std::vector<NodeRecord>& nodes() const;  ///< in insertion order
  [[nodiscard]] const std::vector<EdgeRecord>& edges() const;  ///< in insertion order
  /// nullptr if unknown. Pointers stay valid until the next mutating call. The lookups below
  /// (find_*, resolve_node, outgoing, incoming) use hashed indices: their cost does not grow with
  /// the number of nodes or edges (a tree may call them every tick).
  [[nodiscard]] const NodeRecord* find_node(std::string_view id) const;
  [[nodiscard]] const NodeRecord* find_node_by_name(std::string_view name) const;  ///< first match
  [[nodiscard]] const EdgeRecord* find_edge(std::string_view id) const;
  /// Node by id, or else by name; error naming the map if neither matches.
  [[nodiscard]] Result<const NodeRecord*> resolve_node(std::string_view id_or_name) const;
  /// Edges leaving / entering a node, in insertion order (empty for unknown nodes).
  [[nodiscard]] std::vector<const EdgeRecord*> outgoing(std::string_view node_id) const;
  [[nodiscard]] std::vector<const EdgeRecord*> incoming(std::string_view node_id) const;
  /// Azimuths of a node's outgoing edges (what graph.yaml lists under the node).
  [[nodiscard]] std::vector<OutgoingAzimuth> outgoing_azimuths(std::string_view node_id) const;
  /// Sizes per kind, totals, bytes per metre. Uses the recorded payload sizes (no file access).
  [[nodiscard]] MapStats stats() const;

  // --- Payloads ---

  /// Reads and verifies an edge payload (magic, version, kind and id match the graph, file size
  /// matches the graph's payload_bytes, checksums) and returns the body. Cost is independent of
  /// the number of edges in the map.
  [[nodiscard]] Result<std::vector<std::uint8_t>> read_payload(std::string_view edge_id) const;
  /// Same checks as read_payload, and when a body check is registered for the edge's kind
  /// (set_payload_check) the body is decoded by it too; error e.g.
  ///   "maps/m/edges/e3.bin: body does not match graph.yaml: body length 500 m, graph 6.3 m".
  [[nodiscard]] Status check_payload(std::string_view edge_id) const;
  /// check_payload of every edge of a route, in order; the first problem is the error. Missions
  /// call it on the planned route before the robot moves.
  [[nodiscard]] Status check_route(std::span<const std::string> edge_ids) const;
  /// Registers the body reader of one edge kind (replaces an earlier one). The function usually
  /// lives in a plugin library: the caller keeps that library loaded while this map is used.
  void set_payload_check(const std::string& kind, PayloadBodyCheck check);
  /// True if a body reader is registered for `kind`.
  [[nodiscard]] bool has_payload_check(std::string_view kind) const;
  /// Checks every file: re-parses graph.yaml from disk (it may have changed since open) and
  /// verifies every payload (check_payload: headers, sizes, and bodies of kinds with a registered
  /// reader). Returns one problem per line, each naming its file; empty = valid.
  [[nodiscard]] std::vector<std::string> validate() const;
  /// Files in the map folder that are not part of the map: temporary files left by an
  /// interrupted write and payloads no edge references. Harmless; listed by `visnav map info`.
  /// open() already deletes temporary files whose writer process is gone.
  [[nodiscard]] std::vector<std::string> leftover_files() const;

 private:
  struct Impl;
  explicit MapStore(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// Cost model of route planning: cost of an edge = length_m × multiplier of its kind.
struct RouteCost {
  /// Multiplier per kind; kinds not listed use `default_multiplier`. A multiplier must be > 0;
  /// +infinity forbids the kind.
  std::map<std::string, double> kind_multiplier;
  double default_multiplier = 1.0;
  /// Added to every edge's cost (prefer fewer edges among equal lengths; ≥ 0).
  double per_edge_cost = 0.0;
};

struct Route {
  std::string from;                    ///< start node id
  std::string to;                      ///< goal node id
  std::vector<std::string> edge_ids;   ///< edges to traverse, in order (empty when from == to)
  double length_m = 0.0;               ///< sum of edge lengths
  double cost = 0.0;                   ///< sum of edge costs under the RouteCost used
};

/// Cheapest directed route from node `from` to node `to` (ids or names) by Dijkstra over the
/// graph. Errors: unknown node, invalid cost model, no route ("no route from 'a' to 'b'").
/// O((V + E) log V); pure over the in-memory graph, thread-safe with other const calls.
[[nodiscard]] Result<Route> plan_route(const MapStore& map, std::string_view from, std::string_view to,
                                       const RouteCost& cost = {});

/// Little-endian serialiser for payload bodies (primitives use it to build what add_edge stores).
class PayloadWriter {
 public:
  template <typename T>
    requires std::is_arithmetic_v<T>
  void put(T value) {
    std::uint8_t raw[sizeof(T)];
    std::memcpy(raw, &value, sizeof(T));
    if constexpr (std::endian::native == std::endian::big) std::reverse(raw, raw + sizeof(T));
    bytes_.insert(bytes_.end(), raw, raw + sizeof(T));
  }
  void put_bytes(std::span<const std::uint8_t> data) {
    put<std::uint64_t>(data.size());
    bytes_.insert(bytes_.end(), data.begin(), data.end());
  }
  void put_string(std::string_view s) {
    put_bytes({reinterpret_cast<const std::uint8_t*>(s.data()), s.size()});
  }
  [[nodiscard]] const std::vector<std::uint8_t>& bytes() const { return bytes_; }
  [[nodiscard]] std::vector<std::uint8_t> take() { return std::move(bytes_); }

 private:
  std::vector<std::uint8_t> bytes_;
};

/// Bounds-checked reader of what PayloadWriter wrote. Every get returns an error (naming the
/// offset) instead of reading past the end, so a damaged body cannot crash the primitive.
/// Does not own the bytes.
class PayloadReader {
 public:
  explicit PayloadReader(std::span<const std::uint8_t> bytes) : bytes_(bytes) {}

  template <typename T>
    requires std::is_arithmetic_v<T>
  [[nodiscard]] Result<T> get() {
    if (remaining() < sizeof(T)) return short_read(sizeof(T));
    std::uint8_t raw[sizeof(T)];
    std::memcpy(raw, bytes_.data() + offset_, sizeof(T));
    if constexpr (std::endian::native == std::endian::big) std::reverse(raw, raw + sizeof(T));
    offset_ += sizeof(T);
    T value;
    std::memcpy(&value, raw, sizeof(T));
    return value;
  }
  /// A length-prefixed byte block (view into the buffer).
  [[nodiscard]] Result<std::span<const std::uint8_t>> get_bytes() {
    auto n = get<std::uint64_t>();
    if (!n) return n.error();
    if (*n > remaining()) {
      offset_ -= sizeof(std::uint64_t);
      return fail(ErrorCode::parse_error, "payload body: block of " + std::to_string(*n) + " bytes at offset " +
                  std::to_string(offset_) + " runs past the end (" + std::to_string(bytes_.size()) + " bytes)");
    }
    auto out = bytes_.subspan(offset_, static_cast<std::size_t>(*n));
    offset_ += static_cast<std::size_t>(*n);
    return out;
  }
  [[nodiscard]] Result<std::string> get_string() {
    auto b = get_bytes();
    if (!b) return b.error();
    return std::string(reinterpret_cast<const char*>(b->data()), b->size());
  }
  [[nodiscard]] std::size_t offset() const { return offset_; }
  [[nodiscard]] std::size_t remaining() const { return bytes_.size() - offset_; }
  [[nodiscard]] bool at_end() const { return offset_ == bytes_.size(); }

 private:
  Error short_read(std::size_t want) const {
    return fail(ErrorCode::parse_error, "payload body: need " + std::to_string(want) + " bytes at offset " + std::to_string(offset_) +
                " but only " + std::to_string(remaining()) + " remain");
  }
  std::span<const std::uint8_t> bytes_;
  std::size_t offset_ = 0;
};

/// Writes `bytes` to `dir`/`name` by the map store's crash-safe protocol: a temporary file in
/// the same folder, fsync, rename over the target, fsync of the folder. A reader (or a restart
/// after power loss) sees the old file or the new one, never a part of one; on failure the target
/// is untouched and the temporary file removed (ErrorCode::io, naming the file). For a plugin's
/// own files kept in a map folder (place index, learned experiences, progress checkpoints).
[[nodiscard]] Status write_file_durably(const std::string& dir, const std::string& name, std::span<const std::uint8_t> bytes);

}  // namespace visnav
