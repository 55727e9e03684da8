// Internal: graph.yaml parsing and writing (see docs/map_format.md). Pure functions over text.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

#include "visnav/map.hpp"
#include "visnav/result.hpp"

namespace visnav::map_detail {

struct Graph {
  std::string name;
  int version = map_format::kGraphVersion;
  std::vector<NodeRecord> nodes;
  std::vector<EdgeRecord> edges;
};

/// A parsed graph before the cross-reference checks, with the (0-based) lines of its records.
struct RawGraph {
  Graph g;
  std::vector<int> node_lines;
  std::vector<int> edge_lines;
  /// Per node: the outgoing list as written (edge id, azimuth_rad, 0-based line).
  std::vector<std::vector<std::tuple<std::string, double, int>>> listed_outgoing;
};

/// Which reader parse_graph() uses.
enum class GraphParser {
  automatic,  ///< fast reader for the layout emit_graph() writes, full YAML (yaml-cpp) otherwise
  fast_only,  ///< fast reader only; anything else is an error "(fast parser)" — for tests/fuzzing
  full_only,  ///< yaml-cpp only — for tests/fuzzing
};

/// Parses and checks a graph file: YAML syntax, required keys, unknown keys, types, id syntax,
/// duplicate ids, dangling node references, payload file names, node azimuth lists consistent
/// with the edges. Errors read "<file_name>:<line>: ...".
/// The fast reader accepts only the exact layout emit_graph() writes (10,000 edges in tens of
/// ms instead of ~1 s with yaml-cpp); on anything else, including every kind of damage, it
/// declines and the full YAML reader parses the file and produces the error message. Both give
/// the same Graph for any text the fast reader accepts (checked by fuzz_graph_reader).
[[nodiscard]] Result<Graph> parse_graph(const std::string& text, const std::string& file_name,
                                        GraphParser parser = GraphParser::automatic);

/// The fast reader: nullopt when `text` is not exactly in emit_graph()'s layout or a field value is
/// invalid (the full reader then reports it). Does not check cross references.
[[nodiscard]] std::optional<RawGraph> parse_fast(std::string_view text);

/// Writes the graph as YAML text that parse_graph() reads back exactly (doubles round-trip).
[[nodiscard]] std::string emit_graph(const Graph& graph);

/// Shortest decimal text that parses back to the same double ("0.1", "12", "1e-07"); "nan"/"inf"
/// are never written (records are validated before).
[[nodiscard]] std::string format_double(double value);

/// A finite number in plain decimal/scientific notation (one leading '+' allowed); nullopt otherwise.
/// Both graph readers use it, so they agree on every number.
[[nodiscard]] std::optional<double> parse_finite_number(std::string_view text);

/// Length (2-4) of the well-formed UTF-8 sequence at the start of `s` if it encodes a code point
/// the graph file may hold raw (≥ U+00A0, not U+FEFF/U+FFFE/U+FFFF), else 0.
[[nodiscard]] std::size_t utf8_text_sequence(std::string_view s);

/// True if `text` may be a node or map name: ASCII (control characters are written escaped) or
/// UTF-8 sequences accepted by utf8_text_sequence(). Invalid UTF-8 is refused because YAML
/// cannot carry it.
[[nodiscard]] bool valid_text(std::string_view text);

/// True for "YYYY-MM-DDTHH:MM:SS[.fff]Z".
[[nodiscard]] bool valid_utc_timestamp(std::string_view text);

/// The current time as "YYYY-MM-DDTHH:MM:SSZ".
[[nodiscard]] std::string utc_now();

}  // namespace visnav::map_detail
