// MapStore: the map folder, crash-safe writes, lazy payload reads.
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <unordered_map>

#include "map/graph_io.hpp"
#include "visnav/file_io.hpp"
#include "visnav/map.hpp"

namespace visnav {

namespace fs = std::filesystem;

namespace {

std::string errno_text(int err) { return std::strerror(err); }

std::string join(const std::string& dir, std::string_view name) {
  if (dir.empty()) return std::string(name);
  return dir.back() == '/' ? dir + std::string(name) : dir + "/" + std::string(name);
}

bool is_temp_name(std::string_view name) {
  return name.size() > 1 && name.front() == '.' && name.find(".tmp.") != std::string_view::npos;
}

Status fsync_dir(const std::string& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return fail(ErrorCode::io, dir + ": cannot open folder to sync: " + errno_text(errno));
  const int rc = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0 && err != EINVAL) return fail(ErrorCode::io, dir + ": fsync failed: " + errno_text(err));
  return ok();
}

/// Writes `bytes` to dir/name atomically and durably: dir/.name.tmp.<pid>, fsync, rename,
/// fsync(dir). On failure the target is untouched and the temporary file removed.
Status write_file_atomic(const std::string& dir, const std::string& name, std::span<const std::uint8_t> bytes,
                         bool sync) {
  const std::string target = join(dir, name);
  const std::string temp = join(dir, "." + name + ".tmp." + std::to_string(::getpid()));
  const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return fail(ErrorCode::io, temp + ": cannot create: " + errno_text(errno));
  auto abort_with = [&](const std::string& what, int err) {
    ::close(fd);
    ::unlink(temp.c_str());
    return fail(ErrorCode::io, temp + ": " + what + ": " + errno_text(err));
  };
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return abort_with("write failed", errno);
    }
    done += static_cast<std::size_t>(n);
  }
  if (sync && ::fsync(fd) != 0) return abort_with("fsync failed", errno);
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(temp.c_str());
    return fail(ErrorCode::io, temp + ": close failed: " + errno_text(err));
  }
  if (::rename(temp.c_str(), target.c_str()) != 0) {
    const int err = errno;
    ::unlink(temp.c_str());
    return fail(ErrorCode::io, target + ": rename from temporary file failed: " + errno_text(err));
  }
  return sync ? fsync_dir(dir) : ok();
}

/// Reads a whole regular file; refuses files larger than `max_bytes` (a foreign or runaway file
/// must not exhaust memory).
Result<std::vector<std::uint8_t>> read_file(const std::string& path, std::uint64_t max_bytes) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return fail(ErrorCode::io, path + ": cannot open: " + errno_text(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int err = errno;
    ::close(fd);
    return fail(ErrorCode::io, path + ": cannot stat: " + errno_text(err));
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    return fail(ErrorCode::invalid_value, path + ": not a regular file");
  }
  if (static_cast<std::uint64_t>(st.st_size) > max_bytes) {
    ::close(fd);
    return fail(ErrorCode::limit, path + ": file of " + std::to_string(st.st_size) + " bytes is larger than expected (at most " +
                std::to_string(max_bytes) + ")");
  }
  std::vector<std::uint8_t> data(static_cast<std::size_t>(st.st_size));
  std::size_t done = 0;
  while (done < data.size()) {
    const ssize_t n = ::read(fd, data.data() + done, data.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      return fail(ErrorCode::io, path + ": read failed: " + errno_text(err));
    }
    if (n == 0) break;  // shrank while reading
    done += static_cast<std::size_t>(n);
  }
  ::close(fd);
  data.resize(done);
  return data;
}

// graph.yaml is parsed whole by yaml-cpp (~6x its size in memory); 64 MB holds ~100k edges.
constexpr std::uint64_t kMaxGraphBytes = kMaxGraphFileBytes;
constexpr std::uint64_t kMaxUnrecordedPayloadBytes = 1ULL << 34;

std::span<const std::uint8_t> as_bytes(const std::string& s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

/// Hash of the string indices below; transparent so lookups by string_view do not allocate.
struct StringHash {
  using is_transparent = void;
  std::size_t operator()(std::string_view s) const noexcept { return std::hash<std::string_view>{}(s); }
};
/// The in-memory indices of the graph are hashed: a lookup costs the same on a 10 km map as on a
/// 100 m one (trees may query the map every tick; bench/replay measures it).
template <typename V>
using StringIndex = std::unordered_map<std::string, V, StringHash, std::equal_to<>>;

std::string next_free_id(char prefix, std::size_t start, const StringIndex<std::size_t>& used) {
  for (std::size_t k = start;; ++k) {
    std::string id = prefix + std::to_string(k);
    if (used.count(id) == 0) return id;
  }
}

}  // namespace

struct MapStore::Impl {
  std::string dir;
  map_detail::Graph graph;
  StringIndex<std::size_t> node_index;
  StringIndex<std::size_t> name_index;  // display name -> first node (insertion order) with it
  StringIndex<std::size_t> edge_index;
  StringIndex<std::vector<std::size_t>> out_edges;
  StringIndex<std::vector<std::size_t>> in_edges;
  bool autoflush = true;
  bool sync = true;
  bool dirty = false;
  std::map<std::string, PayloadBodyCheck, std::less<>> body_checks;

  void index() {
    node_index.clear();
    name_index.clear();
    edge_index.clear();
    out_edges.clear();
    in_edges.clear();
    node_index.reserve(graph.nodes.size());
    name_index.reserve(graph.nodes.size());
    edge_index.reserve(graph.edges.size());
    for (std::size_t i = 0; i < graph.nodes.size(); ++i) index_node(i);
    for (std::size_t i = 0; i < graph.edges.size(); ++i) index_edge(i);
  }
  void index_node(std::size_t i) {
    node_index.emplace(graph.nodes[i].id, i);
    name_index.emplace(graph.nodes[i].name, i);  // keeps an earlier node of the same name
  }
  void unindex_last_node() {
    const auto& n = graph.nodes.back();
    const std::size_t i = graph.nodes.size() - 1;
    node_index.erase(n.id);
    if (auto it = name_index.find(n.name); it != name_index.end() && it->second == i) name_index.erase(it);
    graph.nodes.pop_back();
  }
  void index_edge(std::size_t i) {
    const auto& e = graph.edges[i];
    edge_index.emplace(e.id, i);
    out_edges[e.from].push_back(i);
    in_edges[e.to].push_back(i);
  }
  void unindex_last_edge() {
    const auto& e = graph.edges.back();
    edge_index.erase(e.id);
    out_edges[e.from].pop_back();
    in_edges[e.to].pop_back();
    graph.edges.pop_back();
  }

  Status write_graph() {
    const std::string text = map_detail::emit_graph(graph);
    VISNAV_TRY(write_file_atomic(dir, map_format::kGraphFile, as_bytes(text), sync));
    dirty = false;
    return ok();
  }

  Result<std::vector<std::uint8_t>> load_payload(const EdgeRecord& e, bool want_body) const {
    const std::string path = join(dir, e.payload_file);
    // A payload may differ from its recorded size only by damage; allow slack so that truncation
    // and trailing bytes get their precise message from the parser.
    const std::uint64_t limit = e.payload_bytes > 0 ? e.payload_bytes + (1U << 20) : kMaxUnrecordedPayloadBytes;
    VISNAV_ASSIGN(auto file, read_file(path, limit));
    VISNAV_ASSIGN(auto view, map_format::parse_payload(file, path));
    if (view.edge_id != e.id) {
      return fail(ErrorCode::inconsistent, path + ": foreign payload: it belongs to edge '" + view.edge_id + "', not '" + e.id + "'");
    }
    if (view.kind != e.kind) {
      return fail(ErrorCode::inconsistent, path + ": payload kind '" + view.kind + "' differs from the graph's kind '" + e.kind + "' for edge '" +
                  e.id + "'");
    }
    // The graph records each payload's size when it was written: a file of another size was
    // replaced or edited since, even if its own checksums were recomputed.
    if (e.payload_bytes != 0 && file.size() != e.payload_bytes) {
      return fail(ErrorCode::inconsistent, path + ": size " + std::to_string(file.size()) + " bytes differs from payload_bytes " +
                  std::to_string(e.payload_bytes) + " recorded for edge '" + e.id + "' in " +
                  join(dir, map_format::kGraphFile));
    }
    if (!want_body) return std::vector<std::uint8_t>{};
    // Move the body to the front of the file buffer instead of copying into a new vector.
    const std::size_t offset = static_cast<std::size_t>(view.body.data() - file.data());
    const std::size_t size = view.body.size();
    if (offset > 0) std::memmove(file.data(), file.data() + offset, size);
    file.resize(size);
    return file;
  }
  /// Headers, sizes and (when a reader is registered for the kind) the decoded body.
  Status check_edge(const EdgeRecord& e) const {
    const auto check = body_checks.find(e.kind);
    VISNAV_ASSIGN(auto body, load_payload(e, check != body_checks.end()));
    if (check == body_checks.end()) return ok();
    auto st = check->second(body, e);
    if (!st) return st.error().with_context(join(dir, e.payload_file) + ": edge '" + e.id + "' (" + e.kind + ")");
    return ok();
  }

  /// Deletes ".<name>.tmp.<pid>" files whose writer process is gone (kill(pid, 0) fails with
  /// ESRCH); a live writer's file, or one whose pid cannot be read, is left alone.
  void remove_stale_temp_files() const {
    std::error_code ec;
    for (const std::string& folder : {dir, join(dir, map_format::kEdgeFolder)}) {
      for (const auto& entry : fs::directory_iterator(folder, ec)) {
        const std::string name = entry.path().filename().string();
        if (!is_temp_name(name) || !entry.is_regular_file(ec)) continue;
        const std::string pid_text = name.substr(name.rfind(".tmp.") + 5);
        if (pid_text.empty() || pid_text.size() > 9 ||
            pid_text.find_first_not_of("0123456789") != std::string::npos)
          continue;
        const long pid = std::stol(pid_text);
        if (pid <= 0 || pid == static_cast<long>(::getpid())) continue;
        if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;
        std::error_code rm;
        fs::remove(entry.path(), rm);
      }
    }
  }
};

MapStore::MapStore(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
MapStore::MapStore(MapStore&&) noexcept = default;
MapStore& MapStore::operator=(MapStore&&) noexcept = default;
MapStore::~MapStore() = default;

Result<MapStore> MapStore::create(const std::string& dir, const std::string& name) {
  if (dir.empty()) return fail(ErrorCode::missing, "map folder name is empty");
  if (!map_detail::valid_text(name)) return fail(ErrorCode::invalid_value, dir + ": map name is not valid UTF-8 text");
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return fail(ErrorCode::io, dir + ": cannot create map folder: " + ec.message());
  const std::string graph = join(dir, map_format::kGraphFile);
  if (fs::exists(graph, ec)) return fail(ErrorCode::inconsistent, graph + ": a map already exists here (open it instead)");
  const std::string edges = join(dir, map_format::kEdgeFolder);
  fs::create_directories(edges, ec);
  if (ec) return fail(ErrorCode::io, edges + ": cannot create folder: " + ec.message());
  auto impl = std::make_unique<Impl>();
  impl->dir = dir;
  impl->graph.name = name;
  VISNAV_TRY(impl->write_graph());
  const fs::path parent = fs::absolute(fs::path(dir), ec).lexically_normal().parent_path();
  if (!parent.empty()) (void)fsync_dir(parent.string());  // best effort: make the new folder durable
  return MapStore(std::move(impl));
}

Result<MapStore> MapStore::open(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return fail(ErrorCode::not_found, dir + ": no such map folder");
  const std::string graph_file = join(dir, map_format::kGraphFile);
  if (!fs::exists(graph_file, ec)) return fail(ErrorCode::not_found, dir + ": not a visnav map (no " + map_format::kGraphFile + ")");
  VISNAV_ASSIGN(auto bytes, read_file(graph_file, kMaxGraphBytes));
  VISNAV_ASSIGN(auto graph, map_detail::parse_graph(std::string(bytes.begin(), bytes.end()), graph_file));
  auto impl = std::make_unique<Impl>();
  impl->dir = dir;
  impl->graph = std::move(graph);
  impl->index();
  impl->remove_stale_temp_files();
  return MapStore(std::move(impl));
}

const std::string& MapStore::dir() const { return impl_->dir; }
const std::string& MapStore::name() const { return impl_->graph.name; }
std::string MapStore::graph_path() const { return join(impl_->dir, map_format::kGraphFile); }
std::string MapStore::payload_path(std::string_view edge_id) const {
  return join(impl_->dir, std::string(map_format::kEdgeFolder) + "/" + std::string(edge_id) + ".bin");
}

Result<std::string> MapStore::add_node(NodeRecord node) {
  auto& m = *impl_;
  if (node.id.empty()) node.id = next_free_id('n', m.graph.nodes.size(), m.node_index);
  if (!map_format::valid_id(node.id)) return fail(ErrorCode::invalid_value, graph_path() + ": node id '" + node.id + "' is not a valid id (1-64 of A-Z a-z 0-9 _ -)");
  if (m.node_index.count(node.id) != 0) return fail(ErrorCode::inconsistent, graph_path() + ": node '" + node.id + "' already exists");
  if (!map_detail::valid_text(node.name)) return fail(ErrorCode::invalid_value, graph_path() + ": node '" + node.id + "': name is not valid UTF-8 text");
  if (!node.name.empty()) {
    if (const auto it = m.name_index.find(node.name); it != m.name_index.end())
      return fail(ErrorCode::inconsistent, graph_path() + ": node name '" + node.name + "' is already used by node '" + m.graph.nodes[it->second].id +
                  "' (node names must be unique)");
  }
  if (node.position_hint && (!std::isfinite(node.position_hint->x_m) || !std::isfinite(node.position_hint->y_m) ||
                             !std::isfinite(node.position_hint->heading_rad))) {
    return fail(ErrorCode::invalid_value, graph_path() + ": node '" + node.id + "': position_hint must be finite");
  }
  const std::string id = node.id;
  m.graph.nodes.push_back(std::move(node));
  m.index_node(m.graph.nodes.size() - 1);
  m.dirty = true;
  if (m.autoflush) {
    auto st = m.write_graph();
    if (!st) {
      m.unindex_last_node();
      return std::move(st).error();
    }
  }
  return id;
}

Result<std::string> MapStore::add_edge(EdgeRecord edge, std::span<const std::uint8_t> payload) {
  auto& m = *impl_;
  const std::string gp = graph_path();
  if (edge.id.empty()) edge.id = next_free_id('e', m.graph.edges.size(), m.edge_index);
  if (!map_format::valid_id(edge.id)) return fail(ErrorCode::invalid_value, gp + ": edge id '" + edge.id + "' is not a valid id (1-64 of A-Z a-z 0-9 _ -)");
  if (m.edge_index.count(edge.id) != 0) return fail(ErrorCode::inconsistent, gp + ": edge '" + edge.id + "' already exists");
  const std::string what = gp + ": edge '" + edge.id + "': ";
  if (m.node_index.count(edge.from) == 0) return fail(ErrorCode::not_found, what + "unknown 'from' node '" + edge.from + "'");
  if (m.node_index.count(edge.to) == 0) return fail(ErrorCode::not_found, what + "unknown 'to' node '" + edge.to + "'");
  if (!map_format::valid_kind(edge.kind)) return fail(ErrorCode::invalid_value, what + "kind '" + edge.kind + "' is not a valid primitive kind (1-64 of A-Z a-z 0-9 _ - .)");
  if (!std::isfinite(edge.length_m) || edge.length_m < 0.0) return fail(ErrorCode::invalid_value, what + "length_m must be finite and >= 0");
  if (!std::isfinite(edge.azimuth_rad)) return fail(ErrorCode::invalid_value, what + "azimuth_rad must be finite");
  if (edge.created.empty()) edge.created = map_detail::utc_now();
  if (!map_detail::valid_utc_timestamp(edge.created)) return fail(ErrorCode::invalid_value, what + "created '" + edge.created + "' is not ISO-8601 UTC (YYYY-MM-DDTHH:MM:SSZ)");
  for (const auto& [k, v] : edge.statistics) {
    if (!map_format::valid_kind(k)) return fail(ErrorCode::invalid_value, what + "statistic name '" + k + "' is invalid (1-64 of A-Z a-z 0-9 _ - .)");
    if (!std::isfinite(v)) return fail(ErrorCode::invalid_value, what + "statistic '" + k + "' must be finite");
  }
  const auto file = map_format::encode_payload(edge.kind, edge.id, payload);
  edge.payload_file = std::string(map_format::kEdgeFolder) + "/" + edge.id + ".bin";
  edge.payload_bytes = file.size();
  VISNAV_TRY(write_file_atomic(join(m.dir, map_format::kEdgeFolder), edge.id + ".bin", file, m.sync));

  m.graph.edges.push_back(std::move(edge));
  m.index_edge(m.graph.edges.size() - 1);
  m.dirty = true;
  const std::string id = m.graph.edges.back().id;
  if (m.autoflush) {
    auto st = m.write_graph();
    if (!st) {
      m.unindex_last_edge();
      return std::move(st).error();
    }
  }
  return id;
}

Status MapStore::set_edge_statistic(std::string_view edge_id, const std::string& key, double value) {
  auto& m = *impl_;
  auto it = m.edge_index.find(edge_id);
  if (it == m.edge_index.end()) return fail(ErrorCode::not_found, graph_path() + ": unknown edge '" + std::string(edge_id) + "'");
  if (!map_format::valid_kind(key)) return fail(ErrorCode::invalid_value, "statistic name '" + key + "' is invalid (1-64 of A-Z a-z 0-9 _ - .)");
  if (!std::isfinite(value)) return fail(ErrorCode::invalid_value, "statistic '" + key + "' must be finite");
  auto& stats = m.graph.edges[it->second].statistics;
  const auto previous = stats.find(key) == stats.end() ? std::optional<double>{} : std::optional<double>{stats[key]};
  stats[key] = value;
  m.dirty = true;
  if (m.autoflush) {
    auto st = m.write_graph();
    if (!st) {
      if (previous) stats[key] = *previous; else stats.erase(key);
      return st;
    }
  }
  return ok();
}

void MapStore::set_autoflush(bool on) { impl_->autoflush = on; }
void MapStore::set_sync(bool on) { impl_->sync = on; }

Status MapStore::flush() {
  if (!impl_->dirty) return ok();
  return impl_->write_graph();
}

const std::vector<NodeRecord>& MapStore::nodes() const { return impl_->graph.nodes; }
const std::vector<EdgeRecord>& MapStore::edges() const { return impl_->graph.edges; }

const NodeRecord* MapStore::find_node(std::string_view id) const {
  auto it = impl_->node_index.find(id);
  return it == impl_->node_index.end() ? nullptr : &impl_->graph.nodes[it->second];
}

const NodeRecord* MapStore::find_node_by_name(std::string_view name) const {
  auto it = impl_->name_index.find(name);
  return it == impl_->name_index.end() ? nullptr : &impl_->graph.nodes[it->second];
}

const EdgeRecord* MapStore::find_edge(std::string_view id) const {
  auto it = impl_->edge_index.find(id);
  return it == impl_->edge_index.end() ? nullptr : &impl_->graph.edges[it->second];
}

Result<const NodeRecord*> MapStore::resolve_node(std::string_view id_or_name) const {
  if (const auto* n = find_node(id_or_name)) return n;
  if (const auto* n = find_node_by_name(id_or_name)) return n;
  return Error{impl_->dir + ": no node with id or name '" + std::string(id_or_name) + "'", ErrorCode::not_found,
               {impl_->dir, 0, std::string(id_or_name)}};
}

std::vector<const EdgeRecord*> MapStore::outgoing(std::string_view node_id) const {
  std::vector<const EdgeRecord*> out;
  auto it = impl_->out_edges.find(node_id);
  if (it != impl_->out_edges.end()) for (auto i : it->second) out.push_back(&impl_->graph.edges[i]);
  return out;
}

std::vector<const EdgeRecord*> MapStore::incoming(std::string_view node_id) const {
  std::vector<const EdgeRecord*> out;
  auto it = impl_->in_edges.find(node_id);
  if (it != impl_->in_edges.end()) for (auto i : it->second) out.push_back(&impl_->graph.edges[i]);
  return out;
}

std::vector<OutgoingAzimuth> MapStore::outgoing_azimuths(std::string_view node_id) const {
  std::vector<OutgoingAzimuth> out;
  for (const auto* e : outgoing(node_id)) out.push_back({e->id, e->azimuth_rad});
  return out;
}

MapStats MapStore::stats() const {
  MapStats s;
  s.nodes = impl_->graph.nodes.size();
  for (const auto& e : impl_->graph.edges) {
    for (KindStats* k : {&s.total, &s.per_kind[e.kind]}) {
      k->edges += 1;
      k->length_m += e.length_m;
      k->payload_bytes += e.payload_bytes;
    }
  }
  return s;
}

Result<std::vector<std::uint8_t>> MapStore::read_payload(std::string_view edge_id) const {
  const auto* e = find_edge(edge_id);
  if (e == nullptr) return fail(ErrorCode::not_found, graph_path() + ": unknown edge '" + std::string(edge_id) + "'");
  return impl_->load_payload(*e, true);
}

Status MapStore::check_payload(std::string_view edge_id) const {
  const auto* e = find_edge(edge_id);
  if (e == nullptr) return fail(ErrorCode::not_found, graph_path() + ": unknown edge '" + std::string(edge_id) + "'");
  return impl_->check_edge(*e);
}

Status MapStore::check_route(std::span<const std::string> edge_ids) const {
  for (const auto& id : edge_ids) VISNAV_TRY(check_payload(id));
  return ok();
}

void MapStore::set_payload_check(const std::string& kind, PayloadBodyCheck check) {
  if (check == nullptr) {
    impl_->body_checks.erase(kind);
  } else {
    impl_->body_checks[kind] = check;
  }
}

bool MapStore::has_payload_check(std::string_view kind) const { return impl_->body_checks.count(kind) != 0; }

std::vector<std::string> MapStore::validate() const {
  std::vector<std::string> problems;
  const std::string gp = graph_path();
  const map_detail::Graph* graph = &impl_->graph;
  map_detail::Graph on_disk;
  auto bytes = read_file(gp, kMaxGraphBytes);
  if (!bytes) {
    problems.push_back(bytes.error().message);
  } else {
    auto parsed = map_detail::parse_graph(std::string(bytes->begin(), bytes->end()), gp);
    if (!parsed) {
      problems.push_back(parsed.error().message);
    } else {
      on_disk = std::move(parsed).value();
      if (impl_->dirty) problems.push_back(gp + ": not up to date with the map in memory (flush() not called)");
      graph = &on_disk;
    }
  }
  for (const auto& e : graph->edges) {
    if (auto st = impl_->check_edge(e); !st) problems.push_back(st.error().message);
  }
  return problems;
}

std::vector<std::string> MapStore::leftover_files() const {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(impl_->dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (is_temp_name(name)) out.push_back(entry.path().string());
  }
  const std::string edges_dir = join(impl_->dir, map_format::kEdgeFolder);
  std::set<std::string, std::less<>> referenced;
  for (const auto& e : impl_->graph.edges) referenced.insert(fs::path(e.payload_file).filename().string());
  for (const auto& entry : fs::directory_iterator(edges_dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (is_temp_name(name) || referenced.count(name) == 0) out.push_back(entry.path().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

Status write_file_durably(const std::string& dir, const std::string& name, std::span<const std::uint8_t> bytes) {
  return write_file_atomic(dir, name, bytes, true);
}

}  // namespace visnav
