// graph.yaml reading and writing.
#include "map/graph_io.hpp"

#include <charconv>
#include <cmath>
#include <ctime>
#include <map>
#include <set>

#include <yaml-cpp/yaml.h>

namespace visnav::map_detail {

namespace {

class Reader {
 public:
  explicit Reader(const std::string& file, std::size_t entry_budget = 0) : file_(file), entries_left_(entry_budget) {}

  /// An error about node `n` of the graph file: "<file>:<line>: <message>", with the code
  /// (parse_error unless said: the graph is a file format) and the location.
  [[nodiscard]] Error at(const YAML::Node& n, const std::string& message, ErrorCode code = ErrorCode::parse_error) const {
    return at_line(n.Mark().line, message, code);
  }
  [[nodiscard]] Error at_line(int zero_based_line, const std::string& message,
                              ErrorCode code = ErrorCode::parse_error) const {
    return fail(code, {file_, zero_based_line < 0 ? 0 : zero_based_line + 1}, message);
  }

  /// Iterates a map's entries, rejecting duplicate and unknown keys. `fn(key, key_node, value)`.
  template <typename Fn>
  Status entries(const YAML::Node& n, const std::string& what, std::initializer_list<const char*> known, Fn&& fn) const {
    if (!n.IsMap()) return at(n, what + ": expected a map");
    VISNAV_TRY(first_visit(n, what));
    std::set<std::string> seen;
    for (auto it = n.begin(); it != n.end(); ++it) {
      VISNAV_TRY(spend(it->first, what));
      if (!it->first.IsScalar()) return at(it->first, what + ": keys must be plain text");
      const std::string key = it->first.Scalar();
      bool ok_key = false;
      for (const char* k : known) ok_key = ok_key || key == k;
      if (!ok_key) {
        std::string list;
        for (const char* k : known) list += (list.empty() ? "" : ", ") + std::string(k);
        return at(it->first, what + ": unknown key '" + key + "' (known keys: " + list + ")", ErrorCode::unknown_key);
      }
      if (!seen.insert(key).second) return at(it->first, what + ": duplicate key '" + key + "'", ErrorCode::inconsistent);
      VISNAV_TRY(fn(key, it->first, it->second));
    }
    return ok();
  }

  /// Counts one visited entry. Without aliases every entry costs at least two bytes of text, so
  /// a walk visiting more entries than the file has bytes is expanding aliases (issue 17: alias
  /// bombs cost time and memory only when walked).
  [[nodiscard]] Status spend(const YAML::Node& n, const std::string& what) const {
    if (entries_left_ == 0)
      return at(n, what + ": the graph expands to more entries than its text holds (YAML aliases are not allowed "
                          "in a map graph)",
                ErrorCode::limit);
    --entries_left_;
    return ok();
  }

  /// Refuses a list or map met a second time. yaml-cpp resolves an alias to the anchored node
  /// itself, so a second visit carries the anchor's text position: two distinct collections
  /// never start at the same place. This names an alias at its first use, before walking the
  /// anchored collection again (`spend` remains the bound for anything this misses).
  [[nodiscard]] Status first_visit(const YAML::Node& n, const std::string& what) const {
    const YAML::Mark m = n.Mark();
    if (m.is_null()) return ok();  // a node built in memory has no place in the text
    if (!collections_seen_.emplace(m.line, m.column).second) {
      return at(n, what + ": the list or map written here is used again through a YAML alias (aliases are not allowed in a map graph)",
                ErrorCode::limit);
    }
    return ok();
  }

  [[nodiscard]] Result<std::string> text(const YAML::Node& key, const YAML::Node& v, const std::string& what) const {
    if (v.IsNull()) return at(key, what + ": key '" + key.Scalar() + "' has no value");
    if (!v.IsScalar()) return at(v, what + ": key '" + key.Scalar() + "' must be a single value");
    return v.Scalar();
  }

  [[nodiscard]] Result<double> number(const YAML::Node& key, const YAML::Node& v, const std::string& what) const {
    VISNAV_ASSIGN(std::string s, text(key, v, what));
    const auto out = parse_finite_number(s);
    if (!out) return at(v, what + ": key '" + key.Scalar() + "': expected a finite number, got '" + s + "'");
    return *out;
  }

  [[nodiscard]] Result<std::string> id(const YAML::Node& key, const YAML::Node& v, const std::string& what) const {
    VISNAV_ASSIGN(std::string s, text(key, v, what));
    if (!map_format::valid_id(s)) {
      return at(v, what + ": key '" + key.Scalar() + "': '" + s + "' is not a valid id (1-64 of A-Z a-z 0-9 _ -)");
    }
    return s;
  }

 private:
  const std::string& file_;
  mutable std::size_t entries_left_;
  mutable std::set<std::pair<int, int>> collections_seen_;  ///< (line, column) of each list and map walked
};

std::string quoted(std::string_view s) {
  std::string out = "\"";
  for (unsigned char c : s) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      case '\r': out += "\\r"; break;
      default:
        if (c < 0x20 || c == 0x7f) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\x%02x", c);
          out += buf;
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  out += '"';
  return out;
}

bool digits(std::string_view s, std::size_t pos, std::size_t n) {
  if (pos + n > s.size()) return false;
  for (std::size_t i = pos; i < pos + n; ++i) if (s[i] < '0' || s[i] > '9') return false;
  return true;
}

}  // namespace

std::size_t utf8_text_sequence(std::string_view s) {
  if (s.empty()) return 0;
  const auto b = [&](std::size_t i) { return static_cast<unsigned char>(s[i]); };
  std::size_t n = 0;
  std::uint32_t cp = 0;
  if (b(0) >= 0xC2 && b(0) <= 0xDF) { n = 2; cp = b(0) & 0x1FU; }
  else if (b(0) >= 0xE0 && b(0) <= 0xEF) { n = 3; cp = b(0) & 0x0FU; }
  else if (b(0) >= 0xF0 && b(0) <= 0xF4) { n = 4; cp = b(0) & 0x07U; }
  else return 0;
  if (s.size() < n) return 0;
  for (std::size_t i = 1; i < n; ++i) {
    if ((b(i) & 0xC0U) != 0x80U) return 0;
    cp = (cp << 6) | (b(i) & 0x3FU);
  }
  constexpr std::uint32_t kMinCodePoint[] = {0, 0, 0x80, 0x800, 0x10000};
  if (cp < kMinCodePoint[n] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return 0;
  if (cp < 0xA0 || cp == 0xFEFF || cp == 0xFFFE || cp == 0xFFFF) return 0;
  return n;
}

bool valid_text(std::string_view text) {
  for (std::size_t i = 0; i < text.size();) {
    if (static_cast<unsigned char>(text[i]) < 0x80) {
      ++i;
      continue;
    }
    const std::size_t n = utf8_text_sequence(text.substr(i));
    if (n == 0) return false;
    i += n;
  }
  return true;
}

std::optional<double> parse_finite_number(std::string_view text) {
  const char* b = text.data();
  const char* e = text.data() + text.size();
  if (b != e && *b == '+') ++b;
  double out = 0.0;
  auto [ptr, ec] = std::from_chars(b, e, out);
  if (b == e || ec != std::errc() || ptr != e || !std::isfinite(out)) return std::nullopt;
  return out;
}

std::string format_double(double value) {
  char buf[64];
  auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, value);
  if (ec != std::errc()) return "0";
  return std::string(buf, ptr);
}

bool valid_utc_timestamp(std::string_view t) {
  // YYYY-MM-DDTHH:MM:SS[.f+]Z
  if (t.size() < 20) return false;
  if (!digits(t, 0, 4) || t[4] != '-' || !digits(t, 5, 2) || t[7] != '-' || !digits(t, 8, 2) || t[10] != 'T' ||
      !digits(t, 11, 2) || t[13] != ':' || !digits(t, 14, 2) || t[16] != ':' || !digits(t, 17, 2)) {
    return false;
  }
  std::size_t i = 19;
  if (t[i] == '.') {
    ++i;
    const std::size_t start = i;
    while (i < t.size() && t[i] >= '0' && t[i] <= '9') ++i;
    if (i == start) return false;
  }
  if (i + 1 != t.size() || t[i] != 'Z') return false;
  const int month = (t[5] - '0') * 10 + (t[6] - '0');
  const int day = (t[8] - '0') * 10 + (t[9] - '0');
  const int hour = (t[11] - '0') * 10 + (t[12] - '0');
  const int minute = (t[14] - '0') * 10 + (t[15] - '0');
  const int second = (t[17] - '0') * 10 + (t[18] - '0');
  return month >= 1 && month <= 12 && day >= 1 && day <= 31 && hour <= 23 && minute <= 59 && second <= 60;
}

std::string utc_now() {
  std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

namespace {

/// One entry of `nodes:` appended to raw (with its line and listed outgoing edges).
Status parse_node(Reader& r, const YAML::Node& item, RawGraph& raw) {
  Graph& g = raw.g;
  NodeRecord node;
  bool has_id = false;
  std::vector<std::tuple<std::string, double, int>> outs;
  const std::string what = "node #" + std::to_string(g.nodes.size() + 1);
  const Status node_status = r.entries(item, what, {"id", "name", "position_hint", "outgoing"},
                       [&](const std::string& key, const YAML::Node& k, const YAML::Node& v) -> Status {
    if (key == "id") {
      VISNAV_ASSIGN(node.id, r.id(k, v, what));
      has_id = true;
    } else if (key == "name") {
      if (!v.IsNull()) { VISNAV_ASSIGN(node.name, r.text(k, v, what)); }
      if (!valid_text(node.name)) return r.at(v, what + ": name is not valid UTF-8 text");
    } else if (key == "position_hint") {
      if (v.IsNull()) return ok();
      Pose2D pose;
      int fields = 0;
      VISNAV_TRY(r.entries(v, what + " position_hint", {"x_m", "y_m", "heading_rad"},
                           [&](const std::string& pk, const YAML::Node& pkn, const YAML::Node& pv) -> Status {
        VISNAV_ASSIGN(double d, r.number(pkn, pv, what + " position_hint"));
        if (pk == "x_m") pose.x_m = d;
        else if (pk == "y_m") pose.y_m = d;
        else pose.heading_rad = d;
        ++fields;
        return ok();
      }));
      if (fields < 2) return r.at(v, what + ": position_hint needs at least x_m and y_m");
      node.position_hint = pose;
    } else {  // outgoing
      if (v.IsNull()) return ok();
      if (!v.IsSequence()) return r.at(v, what + ": 'outgoing' must be a list of {edge, azimuth_rad}");
      if (auto first = r.first_visit(v, what + " outgoing"); !first) return first;
      for (const auto& o : v) {
        std::string edge;
        double az = 0.0;
        bool has_edge = false, has_az = false;
        VISNAV_TRY(r.entries(o, what + " outgoing", {"edge", "azimuth_rad"},
                             [&](const std::string& ok_, const YAML::Node& okn, const YAML::Node& ov) -> Status {
          if (ok_ == "edge") {
            VISNAV_ASSIGN(edge, r.id(okn, ov, what + " outgoing"));
            has_edge = true;
          } else {
            VISNAV_ASSIGN(az, r.number(okn, ov, what + " outgoing"));
            has_az = true;
          }
          return ok();
        }));
        if (!has_edge || !has_az) return r.at(o, what + ": each 'outgoing' entry needs 'edge' and 'azimuth_rad'");
        outs.emplace_back(edge, az, o.Mark().line);
      }
    }
    return ok();
  });
  if (!node_status) return node_status;
  if (!has_id) return r.at(item, what + ": missing key 'id'", ErrorCode::missing);
  g.nodes.push_back(std::move(node));
  raw.node_lines.push_back(item.Mark().line);
  raw.listed_outgoing.push_back(std::move(outs));
  return ok();
}

/// One entry of `edges:` appended to raw (with its line).
Status parse_edge(Reader& r, const YAML::Node& item, RawGraph& raw) {
  Graph& g = raw.g;
  EdgeRecord edge;
  std::set<std::string> got;
  const std::string what = "edge #" + std::to_string(g.edges.size() + 1);
  VISNAV_TRY(r.entries(item, what,
                       {"id", "from", "to", "kind", "length_m", "azimuth_rad", "created", "payload",
                        "payload_bytes", "statistics"},
                       [&](const std::string& key, const YAML::Node& k, const YAML::Node& v) -> Status {
    got.insert(key);
    if (key == "id") {
      VISNAV_ASSIGN(edge.id, r.id(k, v, what));
    } else if (key == "from") {
      VISNAV_ASSIGN(edge.from, r.id(k, v, what));
    } else if (key == "to") {
      VISNAV_ASSIGN(edge.to, r.id(k, v, what));
    } else if (key == "kind") {
      VISNAV_ASSIGN(edge.kind, r.text(k, v, what));
      if (!map_format::valid_kind(edge.kind)) {
        return r.at(v, what + ": kind '" + edge.kind + "' is not a valid primitive kind (1-64 of A-Z a-z 0-9 _ - .)");
      }
    } else if (key == "length_m") {
      VISNAV_ASSIGN(edge.length_m, r.number(k, v, what));
      if (edge.length_m < 0.0) return r.at(v, what + ": length_m must be >= 0");
    } else if (key == "azimuth_rad") {
      VISNAV_ASSIGN(edge.azimuth_rad, r.number(k, v, what));
    } else if (key == "created") {
      VISNAV_ASSIGN(edge.created, r.text(k, v, what));
      if (!valid_utc_timestamp(edge.created)) {
        return r.at(v, what + ": created '" + edge.created + "' is not an ISO-8601 UTC time (YYYY-MM-DDTHH:MM:SSZ)");
      }
    } else if (key == "payload") {
      VISNAV_ASSIGN(edge.payload_file, r.text(k, v, what));
    } else if (key == "payload_bytes") {
      VISNAV_ASSIGN(double d, r.number(k, v, what));
      if (d < 0.0 || d != std::floor(d) || d > 9.0e15) return r.at(v, what + ": payload_bytes must be a whole number >= 0");
      edge.payload_bytes = static_cast<std::uint64_t>(d);
    } else {  // statistics
      if (v.IsNull()) return ok();
      if (!v.IsMap()) return r.at(v, what + ": statistics must be a map of name: number");
      if (auto first = r.first_visit(v, what + " statistics"); !first) return first;
      for (auto it = v.begin(); it != v.end(); ++it) {
        if (auto spent = r.spend(it->first, what + " statistics"); !spent) return spent;
        if (!it->first.IsScalar() || !map_format::valid_kind(it->first.Scalar())) {
          return r.at(it->first, what + ": statistics keys must be 1-64 of A-Z a-z 0-9 _ - .");
        }
        VISNAV_ASSIGN(double d, r.number(it->first, it->second, what + " statistics"));
        if (!edge.statistics.emplace(it->first.Scalar(), d).second) {
          return r.at(it->first, what + ": duplicate statistic '" + it->first.Scalar() + "'", ErrorCode::inconsistent);
        }
      }
    }
    return ok();
  }));
  for (const char* req : {"id", "from", "to", "kind", "length_m", "azimuth_rad", "created", "payload"}) {
    if (got.count(req) == 0) {
      return r.at(item, what + (edge.id.empty() ? "" : " ('" + edge.id + "')") + ": missing key '" + req + "'", ErrorCode::missing);
    }
  }
  const std::string expected = std::string(map_format::kEdgeFolder) + "/" + edge.id + ".bin";
  if (edge.payload_file != expected) {
    return r.at(item, "edge '" + edge.id + "': payload must be '" + expected + "', got '" + edge.payload_file + "'");
  }
  g.edges.push_back(std::move(edge));
  raw.edge_lines.push_back(item.Mark().line);
  return ok();
}

}  // namespace

Result<RawGraph> parse_full(const std::string& text_in, const std::string& file_name) {
  Reader r(file_name, text_in.size());
  YAML::Node root;
  try {
    root = YAML::Load(text_in);
  } catch (const YAML::Exception& e) {
    return r.at_line(e.mark.line, "YAML syntax error: " + e.msg);
  }

  RawGraph raw;
  Graph& g = raw.g;
  bool have_format = false, have_version = false, have_name = false, have_nodes = false, have_edges = false;

  try {
    if (root.IsNull()) return r.at_line(0, "empty file (not a visnav map graph)");
    if (!root.IsMap()) return r.at(root, "expected a map with keys format, version, name, nodes, edges");

    const Status root_status = r.entries(root, "graph", {"format", "version", "name", "nodes", "edges"},
                         [&](const std::string& key, const YAML::Node& k, const YAML::Node& v) -> Status {
      if (key == "format") {
        VISNAV_ASSIGN(std::string f, r.text(k, v, "graph"));
        if (f != "visnav-map") return r.at(v, "format is '" + f + "', expected 'visnav-map' (not a visnav map graph)");
        have_format = true;
      } else if (key == "version") {
        VISNAV_ASSIGN(double ver, r.number(k, v, "graph"));
        if (ver != std::floor(ver) || ver < 1) return r.at(v, "version must be a whole number >= 1");
        if (ver > map_format::kGraphVersion) {
          return r.at(v, "unsupported graph format version " + format_double(ver) + " (this build reads version " +
                             std::to_string(map_format::kGraphVersion) + ")", ErrorCode::out_of_range);
        }
        g.version = static_cast<int>(ver);
        have_version = true;
      } else if (key == "name") {
        if (!v.IsNull()) { VISNAV_ASSIGN(g.name, r.text(k, v, "graph")); }
        if (!valid_text(g.name)) return r.at(v, "name is not valid UTF-8 text");
        have_name = true;
      } else if (key == "nodes" || key == "edges") {
        (key == "nodes" ? have_nodes : have_edges) = true;
        if (v.IsNull()) return ok();
        if (!v.IsSequence()) return r.at(v, "'" + key + "' must be a list");
        if (auto first = r.first_visit(v, "'" + key + "'"); !first) return first;
        for (const auto& item : v) VISNAV_TRY(key == "nodes" ? parse_node(r, item, raw) : parse_edge(r, item, raw));
      }
      return ok();
    });
    if (!root_status) return root_status.error();
  } catch (const YAML::Exception& e) {
    return r.at_line(e.mark.line, std::string("malformed graph: ") + e.msg);
  }
  if (!have_format) return r.at_line(0, "missing key 'format: visnav-map' (not a visnav map graph)", ErrorCode::missing);
  if (!have_version) return r.at_line(0, "missing key 'version'", ErrorCode::missing);
  if (!have_name) return r.at_line(0, "missing key 'name'", ErrorCode::missing);
  if (!have_nodes) return r.at_line(0, "missing key 'nodes'", ErrorCode::missing);
  if (!have_edges) return r.at_line(0, "missing key 'edges'", ErrorCode::missing);
  return raw;
}

Result<Graph> check_references(RawGraph raw, const std::string& file_name) {
  Reader r(file_name);
  Graph& g = raw.g;
  const auto& node_lines = raw.node_lines;
  const auto& edge_lines = raw.edge_lines;
  const auto& listed_outgoing = raw.listed_outgoing;
  // Cross references.
  std::map<std::string, std::size_t, std::less<>> node_index;
  for (std::size_t i = 0; i < g.nodes.size(); ++i) {
    auto [it, inserted] = node_index.emplace(g.nodes[i].id, i);
    if (!inserted) {
      return r.at_line(node_lines[i], "duplicate node id '" + g.nodes[i].id + "' (first defined at line " +
                                          std::to_string(node_lines[it->second] + 1) + ")", ErrorCode::inconsistent);
    }
  }
  // Names are how trees and operators address places ("start", "door"): two nodes of one name
  // would make the route depend on file order, so it is an error (empty names are allowed).
  std::map<std::string, std::size_t, std::less<>> name_index;
  for (std::size_t i = 0; i < g.nodes.size(); ++i) {
    if (g.nodes[i].name.empty()) continue;
    auto [it, inserted] = name_index.emplace(g.nodes[i].name, i);
    if (!inserted) {
      return r.at_line(node_lines[i], "node '" + g.nodes[i].id + "': duplicate node name '" + g.nodes[i].name +
                                          "' (also node '" + g.nodes[it->second].id + "' at line " +
                                          std::to_string(node_lines[it->second] + 1) + ")", ErrorCode::inconsistent);
    }
  }
  std::map<std::string, std::size_t, std::less<>> edge_index;
  for (std::size_t i = 0; i < g.edges.size(); ++i) {
    const auto& e = g.edges[i];
    auto [it, inserted] = edge_index.emplace(e.id, i);
    if (!inserted) {
      return r.at_line(edge_lines[i], "duplicate edge id '" + e.id + "' (first defined at line " +
                                          std::to_string(edge_lines[it->second] + 1) + ")", ErrorCode::inconsistent);
    }
    if (node_index.count(e.from) == 0) return r.at_line(edge_lines[i], "edge '" + e.id + "': 'from' names unknown node '" + e.from + "'", ErrorCode::not_found);
    if (node_index.count(e.to) == 0) return r.at_line(edge_lines[i], "edge '" + e.id + "': 'to' names unknown node '" + e.to + "'", ErrorCode::not_found);
  }
  // Node azimuth lists must match the edges exactly.
  std::vector<std::size_t> listed_count(g.edges.size(), 0);
  for (std::size_t n = 0; n < g.nodes.size(); ++n) {
    for (const auto& [edge_id, az, line] : listed_outgoing[n]) {
      auto it = edge_index.find(edge_id);
      if (it == edge_index.end()) {
        return r.at_line(line, "node '" + g.nodes[n].id + "': outgoing lists unknown edge '" + edge_id + "'", ErrorCode::not_found);
      }
      const auto& e = g.edges[it->second];
      if (e.from != g.nodes[n].id) {
        return r.at_line(line, "node '" + g.nodes[n].id + "': outgoing lists edge '" + edge_id + "', which starts at '" +
                                   e.from + "'", ErrorCode::inconsistent);
      }
      if (std::abs(e.azimuth_rad - az) > 1e-9) {
        return r.at_line(line, "node '" + g.nodes[n].id + "': azimuth " + format_double(az) + " of edge '" + edge_id +
                                   "' differs from the edge's azimuth_rad " + format_double(e.azimuth_rad), ErrorCode::inconsistent);
      }
      if (++listed_count[it->second] > 1) {
        return r.at_line(line, "node '" + g.nodes[n].id + "': edge '" + edge_id + "' listed twice in outgoing", ErrorCode::inconsistent);
      }
    }
  }
  for (std::size_t i = 0; i < g.edges.size(); ++i) {
    if (listed_count[i] == 0) {
      return r.at_line(node_lines[node_index.at(g.edges[i].from)],
                       "node '" + g.edges[i].from + "': outgoing does not list its edge '" + g.edges[i].id + "'", ErrorCode::inconsistent);
    }
  }
  return std::move(raw.g);
}

Result<Graph> parse_graph(const std::string& text, const std::string& file_name, GraphParser parser) {
  if (parser != GraphParser::full_only) {
    if (auto raw = parse_fast(text)) return check_references(std::move(*raw), file_name);
    if (parser == GraphParser::fast_only) return fail(ErrorCode::parse_error, {file_name}, "not in the canonical layout (fast parser)");
  }
  auto raw = parse_full(text, file_name);
  if (!raw) return std::move(raw).error();
  return check_references(std::move(raw).value(), file_name);
}

std::string emit_graph(const Graph& g) {
  std::string out;
  out.reserve(256 + g.nodes.size() * 120 + g.edges.size() * 300);
  out += "# visnav hybrid topological map (docs/map_format.md). Written by the map store; edit with care:\n";
  out += "# node 'outgoing' azimuths must match the edges, payloads live in edges/<id>.bin.\n";
  out += "format: visnav-map\nversion: " + std::to_string(g.version) + "\nname: " + quoted(g.name) + "\n";
  // Outgoing edges per node, in edge order.
  std::map<std::string, std::vector<const EdgeRecord*>, std::less<>> outs;
  for (const auto& e : g.edges) outs[e.from].push_back(&e);
  out += g.nodes.empty() ? "nodes: []\n" : "nodes:\n";
  for (const auto& n : g.nodes) {
    out += "  - id: " + quoted(n.id) + "\n    name: " + quoted(n.name) + "\n";
    if (n.position_hint) {
      out += "    position_hint: {x_m: " + format_double(n.position_hint->x_m) + ", y_m: " +
             format_double(n.position_hint->y_m) + ", heading_rad: " + format_double(n.position_hint->heading_rad) + "}\n";
    }
    auto it = outs.find(n.id);
    if (it == outs.end()) {
      out += "    outgoing: []\n";
    } else {
      out += "    outgoing:\n";
      for (const auto* e : it->second) {
        out += "      - {edge: " + quoted(e->id) + ", azimuth_rad: " + format_double(e->azimuth_rad) + "}\n";
      }
    }
  }
  out += g.edges.empty() ? "edges: []\n" : "edges:\n";
  for (const auto& e : g.edges) {
    out += "  - id: " + quoted(e.id) + "\n    from: " + quoted(e.from) + "\n    to: " + quoted(e.to) +
           "\n    kind: " + quoted(e.kind) + "\n    length_m: " + format_double(e.length_m) +
           "\n    azimuth_rad: " + format_double(e.azimuth_rad) + "\n    created: " + quoted(e.created) +
           "\n    payload: " + quoted(e.payload_file) + "\n    payload_bytes: " + std::to_string(e.payload_bytes) +
           "\n    statistics: {";
    bool first = true;
    for (const auto& [k, v] : e.statistics) {
      out += (first ? "" : ", ") + quoted(k) + ": " + format_double(v);
      first = false;
    }
    out += "}\n";
  }
  return out;
}

}  // namespace visnav::map_detail
