// YAML → ConfigNode with file:line for every value, and `--set key.path=value` overrides.
#include <yaml-cpp/yaml.h>

#include <fstream>
#include <set>
#include <sstream>

#include "visnav/config.hpp"
#include "visnav/file_io.hpp"

namespace visnav {

namespace {

SourceLocation location_of(const YAML::Mark& mark, const std::string& file, const SourceLocation& fallback) {
  if (mark.line < 0) return fallback.line > 0 ? fallback : SourceLocation{file, 0};
  return SourceLocation{file, mark.line + 1};
}

/// Bounds of one parsed document (issue 17). yaml-cpp keeps an alias as a reference to its
/// anchor, so a 1.3 kB file of nested aliases ("billion laughs") expands to ~10^9 values only
/// when walked; the walk below counts every value it produces and stops at the limit.
constexpr std::size_t kMaxYamlValues = 100000;  // run configs have hundreds
constexpr std::size_t kMaxYamlDepth = 64;
constexpr std::size_t kMaxYamlTextBytes = 16U << 20;

struct Budget {
  std::size_t values_left = kMaxYamlValues;
};

Result<ConfigNode> convert(const YAML::Node& node, const std::string& file, const SourceLocation& fallback,
                           Budget& budget, std::size_t depth) {
  const SourceLocation where = location_of(node.Mark(), file, fallback);
  if (budget.values_left == 0)
    return fail(ErrorCode::limit, {where.file, where.line, {}},
                "document expands to more than " + std::to_string(kMaxYamlValues) + " values (nested aliases?); refused");
  --budget.values_left;
  if (depth > kMaxYamlDepth)
    return fail(ErrorCode::limit, {where.file, where.line, {}},
                "nested deeper than " + std::to_string(kMaxYamlDepth) + " levels; refused");
  switch (node.Type()) {
    case YAML::NodeType::Undefined:
    case YAML::NodeType::Null: {
      ConfigNode n;
      n.set_where(where);
      return n;
    }
    case YAML::NodeType::Scalar:
      return ConfigNode::make_scalar(node.Scalar(), where);
    case YAML::NodeType::Sequence: {
      ConfigNode n = ConfigNode::make_sequence(where);
      for (const auto& item : node) {
        VISNAV_ASSIGN(ConfigNode child, convert(item, file, where, budget, depth + 1));
        n.push_back(std::move(child));
      }
      return n;
    }
    case YAML::NodeType::Map: {
      ConfigNode n = ConfigNode::make_map(where);
      std::set<std::string> seen;
      for (const auto& entry : node) {
        const SourceLocation key_where = location_of(entry.first.Mark(), file, where);
        if (!entry.first.IsScalar())
          return Error{key_where.str() + ": map keys must be plain scalars", ErrorCode::parse_error,
                       {key_where.file, key_where.line, {}}};
        const std::string key = entry.first.Scalar();
        if (!seen.insert(key).second)
          return Error{key_where.str() + ": duplicate key '" + key + "'", ErrorCode::parse_error,
                       {key_where.file, key_where.line, key}};
        VISNAV_ASSIGN(ConfigNode child, convert(entry.second, file, key_where, budget, depth + 1));
        if (child.is_null() || child.where().line == 0) child.set_where(key_where);
        n.set(key, std::move(child));
      }
      return n;
    }
  }
  return fail(ErrorCode::parse_error, {where.file, where.line, {}}, "unsupported YAML node");
}

/// Sets keys[index..] below `node` to `value`, creating maps on the way (copies each
/// child, edits it and stores it back; configs are small).
Status set_path(ConfigNode& node, const std::vector<std::string>& keys, std::size_t index, ConfigNode value,
                const std::string& text) {
  if (node.is_null()) {
    SourceLocation where = node.where();
    node = ConfigNode::make_map(std::move(where));
  }
  if (!node.is_map()) {
    std::string walked;
    for (std::size_t i = 0; i < index; ++i) walked += (i ? "." : "") + keys[i];
    return Error{"--set " + text + ": '" + walked + "' at " + node.where().str() + " is not a map",
                 ErrorCode::invalid_value, {node.where().file, node.where().line, walked}};
  }
  if (index + 1 == keys.size()) {
    node.set(keys[index], std::move(value));
    return ok();
  }
  const ConfigNode* existing = node.find(keys[index]);
  ConfigNode child = existing != nullptr ? *existing : ConfigNode::make_map(value.where());
  VISNAV_TRY(set_path(child, keys, index + 1, std::move(value), text));
  node.set(keys[index], std::move(child));
  return ok();
}

}  // namespace

Result<ConfigNode> parse_yaml_string(std::string_view text, const std::string& file_label) {
  if (text.size() > kMaxYamlTextBytes)
    return fail(ErrorCode::limit, {file_label, 0, {}},
                std::to_string(text.size()) + " bytes is more than a configuration may have (" +
                    std::to_string(kMaxYamlTextBytes) + ")");
  try {
    YAML::Node doc = YAML::Load(std::string(text));
    Budget budget;
    return convert(doc, file_label, SourceLocation{file_label, 1}, budget, 0);
  } catch (const YAML::Exception& e) {
    SourceLocation where{file_label, e.mark.line >= 0 ? e.mark.line + 1 : 0};
    std::string detail = e.msg;
    if (e.mark.column >= 0) detail += " (column " + std::to_string(e.mark.column + 1) + ")";
    return Error{where.str() + ": YAML syntax error: " + detail, ErrorCode::parse_error, {where.file, where.line, {}}};
  }
}

Result<ConfigNode> parse_yaml_file(const std::string& path) {
  VISNAV_ASSIGN(const std::string text, read_text_file(path, kMaxConfigFileBytes, "config"));
  return parse_yaml_string(text, path);
}

Status apply_override(ConfigNode& root, std::string_view assignment) {
  const std::string text(assignment);
  const auto eq = text.find('=');
  if (eq == std::string::npos)
    return fail(ErrorCode::invalid_value, {"--set " + text, 0, {}}, "expected key.path=value");
  const std::string path = text.substr(0, eq);
  const std::string value = text.substr(eq + 1);
  if (path.empty()) return fail(ErrorCode::invalid_value, {"--set " + text, 0, {}}, "empty key");
  const SourceLocation where{"--set " + text, 0};

  std::vector<std::string> keys;
  std::string current;
  for (char c : path) {
    if (c == '.') {
      keys.push_back(current);
      current.clear();
    } else {
      current.push_back(c);
    }
  }
  keys.push_back(current);
  for (const auto& k : keys)
    if (k.empty())
      return fail(ErrorCode::invalid_value, {"--set " + text, 0, path}, "empty component in key path '" + path + "'");

  ConfigNode value_node;
  if (!value.empty() && (value.front() == '[' || value.front() == '{')) {
    VISNAV_ASSIGN(value_node, parse_yaml_string(value, where.file));
  } else {
    value_node = ConfigNode::make_scalar(value, where);
  }
  value_node.set_where(where);

  return set_path(root, keys, 0, std::move(value_node), text);
}

bool same_config(const ConfigNode& a, const ConfigNode& b) {
  if (a.kind() != b.kind()) return false;
  switch (a.kind()) {
    case ConfigNode::Kind::null: return true;
    case ConfigNode::Kind::scalar: return a.scalar() == b.scalar();
    case ConfigNode::Kind::sequence:
      if (a.items().size() != b.items().size()) return false;
      for (std::size_t i = 0; i < a.items().size(); ++i)
        if (!same_config(a.items()[i], b.items()[i])) return false;
      return true;
    case ConfigNode::Kind::map:
      if (a.entries().size() != b.entries().size()) return false;
      for (const auto& [k, v] : a.entries()) {
        const ConfigNode* other = b.find(k);
        if (other == nullptr || !same_config(v, *other)) return false;
      }
      return true;
  }
  return false;
}

}  // namespace visnav
