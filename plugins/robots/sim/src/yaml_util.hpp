// Private helpers of visnav_sim: typed access to ConfigNode maps with file:line errors.
#pragma once

#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core/types.hpp>

#include "visnav/config_node.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav::sim::detail {

/// "<file>:<line>: <message>" with the code and the location (file, line and `key` when given).
inline Error node_error(const ConfigNode& node, const std::string& message, ErrorCode code = ErrorCode::invalid_value,
                        std::string key = {}) {
  return Error{node.where().str() + ": " + message, code, {node.where().file, node.where().line, std::move(key)}};
}

/// Fails on the first key of `map` not in `known`.
inline Status check_keys(const ConfigNode& map, std::initializer_list<std::string_view> known, const std::string& what) {
  if (!map.is_map()) return node_error(map, what + ": expected a map");
  for (const auto& [key, value] : map.entries()) {
    bool found = false;
    for (auto k : known) found = found || k == key;
    if (!found) {
      std::string list;
      for (auto k : known) list += (list.empty() ? "" : ", ") + std::string(k);
      return node_error(value, "unknown key '" + key + "' in " + what + " (known keys: " + list + ")", ErrorCode::unknown_key, key);
    }
  }
  return ok();
}

inline std::string show(const ConfigNode& node) {
  if (node.is_scalar()) return "'" + node.scalar() + "'";
  if (node.is_map()) return "a map";
  if (node.is_sequence()) return "a list";
  return "null";
}

inline Result<double> as_double(const ConfigNode& node, const std::string& key) {
  if (!node.is_scalar())
    return node_error(node, "key '" + key + "': expected a number, got " + show(node), ErrorCode::invalid_value, key);
  auto v = visnav::detail::parse_double(node.scalar());
  if (!v) return node_error(node, "key '" + key + "': value '" + node.scalar() + "' is not a number", ErrorCode::invalid_value, key);
  return *v;
}

inline Result<double> get_double(const ConfigNode& map, const std::string& key, double fallback,
                                 double min_value = -1e300, double max_value = 1e300) {
  const ConfigNode* n = map.find(key);
  if (n == nullptr) return fallback;
  auto v = as_double(*n, key);
  if (!v) return v;
  if (*v < min_value || *v > max_value)
    return node_error(*n, "key '" + key + "': value " + n->scalar() + " is out of range [" +
                              std::to_string(min_value) + ", " + std::to_string(max_value) + "]",
                      ErrorCode::out_of_range, key);
  return v;
}

inline Result<double> require_double(const ConfigNode& map, const std::string& key, const std::string& what,
                                     double min_value = -1e300, double max_value = 1e300) {
  if (map.find(key) == nullptr) return node_error(map, what + ": missing key '" + key + "'", ErrorCode::missing, key);
  return get_double(map, key, 0.0, min_value, max_value);
}

inline Result<std::string> get_string(const ConfigNode& map, const std::string& key, const std::string& fallback) {
  const ConfigNode* n = map.find(key);
  if (n == nullptr) return fallback;
  if (!n->is_scalar()) return node_error(*n, "key '" + key + "': expected a string, got " + show(*n), ErrorCode::invalid_value, key);
  return n->scalar();
}

inline Result<bool> get_bool(const ConfigNode& map, const std::string& key, bool fallback) {
  const ConfigNode* n = map.find(key);
  if (n == nullptr) return fallback;
  if (!n->is_scalar()) return node_error(*n, "key '" + key + "': expected true/false, got " + show(*n), ErrorCode::invalid_value, key);
  auto v = visnav::detail::parse_bool(n->scalar());
  if (!v) return node_error(*n, "key '" + key + "': value '" + n->scalar() + "' is not a boolean", ErrorCode::invalid_value, key);
  return *v;
}

/// A list of `count` numbers ([a, b, c]).
inline Result<std::vector<double>> as_numbers(const ConfigNode& node, const std::string& key, size_t count) {
  if (!node.is_sequence() || (count != 0 && node.items().size() != count))
    return node_error(node, "key '" + key + "': expected a list of " + std::to_string(count) + " numbers, got " +
                                (node.is_sequence() ? "a list of " + std::to_string(node.items().size()) : show(node)));
  std::vector<double> out;
  for (const auto& item : node.items()) {
    auto v = as_double(item, key);
    if (!v) return v.error();
    out.push_back(*v);
  }
  return out;
}

inline Result<cv::Point2d> as_point(const ConfigNode& node, const std::string& key) {
  auto v = as_numbers(node, key, 2);
  if (!v) return v.error();
  return cv::Point2d((*v)[0], (*v)[1]);
}

inline Result<std::vector<cv::Point2d>> as_points(const ConfigNode& node, const std::string& key, size_t min_count) {
  if (!node.is_sequence()) return node_error(node, "key '" + key + "': expected a list of [x, y] points, got " + show(node));
  if (node.items().size() < min_count)
    return node_error(node, "key '" + key + "': needs at least " + std::to_string(min_count) + " points, got " +
                                std::to_string(node.items().size()));
  std::vector<cv::Point2d> out;
  for (const auto& item : node.items()) {
    auto p = as_point(item, key);
    if (!p) return p.error();
    out.push_back(*p);
  }
  return out;
}

}  // namespace visnav::sim::detail
