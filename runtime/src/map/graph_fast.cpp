// Fast reader for graph.yaml in exactly the layout emit_graph() writes (see graph_io.hpp).
// It declines (nullopt) at the first byte it does not expect, so hand-edited or damaged files go
// through the full YAML reader, which produces the error messages. fuzz_graph_reader checks that
// whatever this reader accepts, the full reader accepts with the same result.
#include <charconv>
#include <cmath>

#include "map/graph_io.hpp"

namespace visnav::map_detail {

namespace {

class Lines {
 public:
  explicit Lines(std::string_view text) : text_(text) {}

  /// Next line that is not blank and not a column-0 comment; false at the end.
  bool next(std::string_view& line) {
    while (pos_ < text_.size()) {
      const std::size_t end = text_.find('\n', pos_);
      const std::size_t stop = end == std::string_view::npos ? text_.size() : end;
      line = text_.substr(pos_, stop - pos_);
      line_no_ = next_no_++;
      pos_ = end == std::string_view::npos ? text_.size() : end + 1;
      if (line.empty() || line.front() == '#') continue;
      return true;
    }
    return false;
  }
  /// Looks at the next significant line without consuming it.
  bool peek(std::string_view& line) {
    const std::size_t pos = pos_;
    const int no = next_no_, cur = line_no_;
    const bool got = next(line);
    pos_ = pos;
    next_no_ = no;
    line_no_ = cur;
    return got;
  }
  [[nodiscard]] int line_no() const { return line_no_; }  ///< 0-based line of the last next()

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  int next_no_ = 0;
  int line_no_ = -1;
};

bool take(std::string_view& s, std::string_view prefix) {
  if (s.substr(0, prefix.size()) != prefix) return false;
  s.remove_prefix(prefix.size());
  return true;
}

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

/// A double-quoted string as emit_graph() writes it.
bool quoted(std::string_view& s, std::string& out) {
  out.clear();
  if (!take(s, "\"")) return false;
  std::size_t i = 0;
  while (i < s.size()) {
    const char c = s[i];
    const auto u = static_cast<unsigned char>(c);
    if (c == '"') {
      s.remove_prefix(i + 1);
      return true;
    }
    if (c == '\\') {
      if (i + 1 >= s.size()) return false;
      const char e = s[i + 1];
      if (e == '"' || e == '\\') out += e;
      else if (e == 'n') out += '\n';
      else if (e == 't') out += '\t';
      else if (e == 'r') out += '\r';
      else if (e == 'x') {
        if (i + 3 >= s.size()) return false;
        const int hi = hex_digit(s[i + 2]), lo = hex_digit(s[i + 3]);
        if (hi < 0 || lo < 0) return false;
        const int v = hi * 16 + lo;
        if (v >= 0x80) return false;
        out += static_cast<char>(v);
        i += 2;
      } else {
        return false;
      }
      i += 2;
      continue;
    }
    if (u < 0x20 || u == 0x7f) return false;
    if (u >= 0x80) {
      const std::size_t n = utf8_text_sequence(s.substr(i));
      if (n == 0) return false;
      out.append(s.substr(i, n));
      i += n;
      continue;
    }
    out += c;
    ++i;
  }
  return false;
}

/// A plain number token (characters of [0-9+-.eE]) followed by one of `stops` or the end.
bool number(std::string_view& s, double& out) {
  std::size_t n = 0;
  while (n < s.size() && ((s[n] >= '0' && s[n] <= '9') || s[n] == '+' || s[n] == '-' || s[n] == '.' || s[n] == 'e' ||
                          s[n] == 'E')) {
    ++n;
  }
  if (n == 0) return false;
  auto v = parse_finite_number(s.substr(0, n));
  if (!v) return false;
  out = *v;
  s.remove_prefix(n);
  return true;
}

bool id_field(std::string_view line, std::string_view prefix, std::string& out) {
  return take(line, prefix) && quoted(line, out) && line.empty() && map_format::valid_id(out);
}

bool text_field(std::string_view line, std::string_view prefix, std::string& out) {
  return take(line, prefix) && quoted(line, out) && line.empty();
}

bool number_field(std::string_view line, std::string_view prefix, double& out) {
  return take(line, prefix) && number(line, out) && line.empty();
}

bool parse_node(Lines& in, std::string_view first, RawGraph& raw) {
  NodeRecord n;
  const int line = in.line_no();
  if (!id_field(first, "  - id: ", n.id)) return false;
  std::string_view l;
  if (!in.next(l) || !text_field(l, "    name: ", n.name)) return false;
  if (!in.next(l)) return false;
  if (take(l, "    position_hint: {x_m: ")) {
    Pose2D p;
    if (!number(l, p.x_m) || !take(l, ", y_m: ") || !number(l, p.y_m) || !take(l, ", heading_rad: ") ||
        !number(l, p.heading_rad) || l != "}") {
      return false;
    }
    n.position_hint = p;
    if (!in.next(l)) return false;
  }
  std::vector<std::tuple<std::string, double, int>> outs;
  if (l != "    outgoing: []") {
    if (l != "    outgoing:") return false;
    std::string_view o;
    while (in.peek(o) && o.substr(0, 8) == "      - ") {
      in.next(o);
      std::string edge;
      double az = 0.0;
      if (!take(o, "      - {edge: ") || !quoted(o, edge) || !map_format::valid_id(edge) || !take(o, ", azimuth_rad: ") ||
          !number(o, az) || o != "}") {
        return false;
      }
      outs.emplace_back(std::move(edge), az, in.line_no());
    }
    if (outs.empty()) return false;  // "outgoing:" alone is null in YAML: leave it to the full reader
  }
  raw.g.nodes.push_back(std::move(n));
  raw.node_lines.push_back(line);
  raw.listed_outgoing.push_back(std::move(outs));
  return true;
}

bool parse_edge(Lines& in, std::string_view first, RawGraph& raw) {
  EdgeRecord e;
  const int line = in.line_no();
  std::string_view l;
  double bytes = 0.0;
  if (!id_field(first, "  - id: ", e.id)) return false;
  if (!in.next(l) || !id_field(l, "    from: ", e.from)) return false;
  if (!in.next(l) || !id_field(l, "    to: ", e.to)) return false;
  if (!in.next(l) || !text_field(l, "    kind: ", e.kind) || !map_format::valid_kind(e.kind)) return false;
  if (!in.next(l) || !number_field(l, "    length_m: ", e.length_m) || e.length_m < 0.0) return false;
  if (!in.next(l) || !number_field(l, "    azimuth_rad: ", e.azimuth_rad)) return false;
  if (!in.next(l) || !text_field(l, "    created: ", e.created) || !valid_utc_timestamp(e.created)) return false;
  if (!in.next(l) || !text_field(l, "    payload: ", e.payload_file) ||
      e.payload_file != std::string(map_format::kEdgeFolder) + "/" + e.id + ".bin") {
    return false;
  }
  if (!in.next(l) || !number_field(l, "    payload_bytes: ", bytes) || bytes < 0.0 || bytes != std::floor(bytes) ||
      bytes > 9.0e15) {
    return false;
  }
  e.payload_bytes = static_cast<std::uint64_t>(bytes);
  if (!in.next(l) || !take(l, "    statistics: {")) return false;
  if (l != "}") {
    for (;;) {
      std::string key;
      double v = 0.0;
      if (!quoted(l, key) || !map_format::valid_kind(key) || !take(l, ": ") || !number(l, v)) return false;
      if (!e.statistics.emplace(std::move(key), v).second) return false;
      if (l == "}") break;
      if (!take(l, ", ")) return false;
    }
  }
  raw.g.edges.push_back(std::move(e));
  raw.edge_lines.push_back(line);
  return true;
}

/// True when every byte of `text` is printable text or a line break: no C0 control other than
/// tab and newline (emit_graph() escapes them), and valid UTF-8. Comment lines are skipped
/// unread, so without this a comment could hold bytes the full reader sees differently: a file
/// opening with "#\0" is taken by yaml-cpp for UTF-16 (found by fuzz_graph_reader).
bool plain_text(std::string_view text) {
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if ((u < 0x20 && c != '\n' && c != '\t') || u == 0x7f) return false;
  }
  return valid_text(text);
}

}  // namespace

std::optional<RawGraph> parse_fast(std::string_view text) {
  if (!plain_text(text)) return std::nullopt;
  Lines in(text);
  RawGraph raw;
  std::string_view l;
  double version = 0.0;
  if (!in.next(l) || l != "format: visnav-map") return std::nullopt;
  if (!in.next(l) || !number_field(l, "version: ", version) || version != std::floor(version) || version < 1 ||
      version > map_format::kGraphVersion) {
    return std::nullopt;
  }
  raw.g.version = static_cast<int>(version);
  if (!in.next(l) || !text_field(l, "name: ", raw.g.name)) return std::nullopt;

  if (!in.next(l)) return std::nullopt;
  if (l != "nodes: []") {
    if (l != "nodes:") return std::nullopt;
    std::string_view item;
    while (in.peek(item) && item.substr(0, 4) == "  - ") {
      in.next(item);
      if (!parse_node(in, item, raw)) return std::nullopt;
    }
    if (raw.g.nodes.empty()) return std::nullopt;
  }
  if (!in.next(l)) return std::nullopt;
  if (l != "edges: []") {
    if (l != "edges:") return std::nullopt;
    std::string_view item;
    while (in.peek(item) && item.substr(0, 4) == "  - ") {
      in.next(item);
      if (!parse_edge(in, item, raw)) return std::nullopt;
    }
    if (raw.g.edges.empty()) return std::nullopt;
  }
  if (in.next(l)) return std::nullopt;  // anything after the edges
  return raw;
}

}  // namespace visnav::map_detail
