// Behaviour-tree ports generated from a params schema (visnav/bt/param_ports.hpp): used by the
// primitive adapter (src/primitive/primitive_nodes.cpp) and by hand-written nodes in plugins.
#include "visnav/bt/param_ports.hpp"

#include <algorithm>
#include <sstream>
#include <type_traits>
#include <utility>

namespace visnav::bt {
namespace {

std::string render_exact(double v) {
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}

template <typename T>
std::string join(const std::vector<T>& items) {
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (i != 0) out += ';';
    if constexpr (std::is_same_v<T, double>) out += render_exact(items[i]);
    else out += items[i];
  }
  return out;
}

}  // namespace

Status append_param_ports(PortsList& ports, const ParamPorts& params) {
  for (const ParamDoc& d : params.docs) {
    PortInfo p;
    if (d.type == "int") p = input_port<int>(d.name, d.default_value, d.description);
    else if (d.type == "double") p = input_port<double>(d.name, d.default_value, d.description);
    else if (d.type == "bool") p = input_port<bool>(d.name, d.default_value, d.description);
    else if (d.type == "string") p = input_port<std::string>(d.name, d.default_value, d.description);
    else if (d.type == "list<double>") p = input_port<std::vector<double>>(d.name, d.default_value, d.description);
    else if (d.type == "list<string>") p = input_port<std::vector<std::string>>(d.name, d.default_value, d.description);
    else return fail("parameter '" + d.name + "' has unsupported type " + d.type);
    if (!d.constraint.empty()) p.description += " " + d.constraint;
    p.constraint = d.constraint;
    p.check = [check = params.check, name = d.name](std::string_view text) {
      return check(name, ConfigNode::make_scalar(std::string(text)));
    };
    ports.push_back(std::move(p));
  }
  return ok();
}

Result<ConfigNode> read_param_ports(const TreeNode& node, const std::vector<ParamDoc>& docs) {
  ConfigNode map = ConfigNode::make_map(node.where());
  for (const ParamDoc& d : docs) {
    const PortBinding* b = node.port(d.name);
    std::string text;
    if (b != nullptr && b->source == PortBinding::Source::literal) {
      text = b->text;
    } else if (d.type == "int") {
      VISNAV_ASSIGN(int v, node.get_input<int>(d.name));
      text = std::to_string(v);
    } else if (d.type == "double") {
      VISNAV_ASSIGN(double v, node.get_input<double>(d.name));
      text = render_exact(v);
    } else if (d.type == "bool") {
      VISNAV_ASSIGN(bool v, node.get_input<bool>(d.name));
      text = v ? "true" : "false";
    } else if (d.type == "list<double>") {
      VISNAV_ASSIGN(auto v, node.get_input<std::vector<double>>(d.name));
      text = join(v);
    } else if (d.type == "list<string>") {
      VISNAV_ASSIGN(auto v, node.get_input<std::vector<std::string>>(d.name));
      text = join(v);
    } else {
      VISNAV_ASSIGN(text, node.get_input<std::string>(d.name));
    }
    map.set(d.name, ConfigNode::make_scalar(std::move(text), node.where()));
  }
  return map;
}

namespace {
std::string_view trim(std::string_view t) {
  while (!t.empty() && (t.front() == ' ' || t.front() == '\t' || t.front() == '\n' || t.front() == '\r')) t.remove_prefix(1);
  while (!t.empty() && (t.back() == ' ' || t.back() == '\t' || t.back() == '\n' || t.back() == '\r')) t.remove_suffix(1);
  return t;
}
}  // namespace

Result<ConfigNode> parse_param_group_text(std::string_view text, const SourceLocation& where) {
  ConfigNode map = ConfigNode::make_map(where);
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t end = std::min(text.find(';', start), text.size());
    const std::string_view entry = trim(text.substr(start, end - start));
    start = end + 1;
    if (entry.empty()) continue;  // "a=1;" and "" are fine
    const std::size_t eq = entry.find('=');
    if (eq == std::string_view::npos)
      return Error{"entry '" + std::string(entry) + "' is not key=value (entries are separated by ';')",
                   ErrorCode::invalid_value};
    const std::string key(trim(entry.substr(0, eq)));
    if (key.empty()) return Error{"entry '" + std::string(entry) + "' has no key", ErrorCode::invalid_value};
    if (map.find(key) != nullptr) return Error{"key '" + key + "' is given twice", ErrorCode::invalid_value, {{}, 0, key}};
    map.set(key, ConfigNode::make_scalar(std::string(trim(entry.substr(eq + 1))), where));
  }
  return map;
}

std::string param_group_description(std::string_view what, const std::vector<ParamDoc>& docs) {
  std::string out(what);
  out += " Keys:";
  for (std::size_t i = 0; i < docs.size(); ++i) {
    const ParamDoc& d = docs[i];
    out += (i == 0 ? " " : "; ") + d.name + " (" + d.type + ", default " + (d.default_value.empty() ? "\"\"" : d.default_value);
    if (!d.constraint.empty()) out += ", " + d.constraint;
    out += "): " + d.description;
  }
  return out;
}

}  // namespace visnav::bt
