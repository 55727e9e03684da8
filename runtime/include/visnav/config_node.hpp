// visnav SDK — a parsed configuration tree that remembers where every value came from.
//
// The runtime parses YAML into ConfigNode (so plugins never depend on a YAML library)
// and hands each plugin the node of its `params:` block. Every node carries its
// source location so errors can say "robot.yaml:14: key 'max_speed_mps' ...".
//
// Thread-safety: immutable value type once built.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "visnav/result.hpp"

namespace visnav {

struct SourceLocation {
  std::string file;  ///< path as given by the user; empty for values set in code
  int line = 0;      ///< 1-based; 0 when unknown

  [[nodiscard]] std::string str() const {
    if (file.empty()) return line > 0 ? "line " + std::to_string(line) : "<built-in>";
    return line > 0 ? file + ":" + std::to_string(line) : file;
  }
};

class ConfigNode {
 public:
  enum class Kind { null, scalar, map, sequence };

  ConfigNode() = default;
  static ConfigNode make_scalar(std::string value, SourceLocation where = {}) {
    ConfigNode n; n.kind_ = Kind::scalar; n.scalar_ = std::move(value); n.where_ = std::move(where); return n;
  }
  static ConfigNode make_map(SourceLocation where = {}) {
    ConfigNode n; n.kind_ = Kind::map; n.where_ = std::move(where); return n;
  }
  static ConfigNode make_sequence(SourceLocation where = {}) {
    ConfigNode n; n.kind_ = Kind::sequence; n.where_ = std::move(where); return n;
  }

  [[nodiscard]] Kind kind() const { return kind_; }
  [[nodiscard]] bool is_null() const { return kind_ == Kind::null; }
  [[nodiscard]] bool is_scalar() const { return kind_ == Kind::scalar; }
  [[nodiscard]] bool is_map() const { return kind_ == Kind::map; }
  [[nodiscard]] bool is_sequence() const { return kind_ == Kind::sequence; }
  [[nodiscard]] const SourceLocation& where() const { return where_; }
  void set_where(SourceLocation where) { where_ = std::move(where); }

  /// Scalar text (valid when is_scalar()).
  [[nodiscard]] const std::string& scalar() const { return scalar_; }

  /// Map entries in file order (valid when is_map()).
  [[nodiscard]] const std::vector<std::pair<std::string, ConfigNode>>& entries() const { return entries_; }
  /// Child by key, or nullptr.
  [[nodiscard]] const ConfigNode* find(std::string_view key) const {
    for (const auto& [k, v] : entries_) if (k == key) return &v;
    return nullptr;
  }
  /// Inserts or replaces a map entry (turns a null node into a map).
  ConfigNode& set(const std::string& key, ConfigNode value) {
    if (kind_ == Kind::null) kind_ = Kind::map;
    for (auto& [k, v] : entries_) if (k == key) { v = std::move(value); return v; }
    entries_.emplace_back(key, std::move(value));
    return entries_.back().second;
  }

  /// Sequence items (valid when is_sequence()).
  [[nodiscard]] const std::vector<ConfigNode>& items() const { return items_; }
  void push_back(ConfigNode item) {
    if (kind_ == Kind::null) kind_ = Kind::sequence;
    items_.push_back(std::move(item));
  }

 private:
  Kind kind_ = Kind::null;
  std::string scalar_;
  std::vector<std::pair<std::string, ConfigNode>> entries_;
  std::vector<ConfigNode> items_;
  SourceLocation where_;
};

/// Parses YAML text. `file_label` is used in locations ("setup.yaml:3"). Scalars keep their
/// text; YAML null (`~`, `null`, empty value) becomes a null node. Duplicate map keys and
/// syntax errors are errors with file:line.
[[nodiscard]] Result<ConfigNode> parse_yaml_string(std::string_view text, const std::string& file_label);
/// Reads and parses a YAML file (missing/unreadable file is an error naming the path).
[[nodiscard]] Result<ConfigNode> parse_yaml_file(const std::string& path);

}  // namespace visnav
