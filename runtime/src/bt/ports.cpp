// Port conversion, status names and enum tables.
#include "visnav/bt/ports.hpp"

#include <algorithm>
#include <limits>
#include <sstream>

namespace visnav::bt {

const char* to_string(NodeStatus status) noexcept {
  switch (status) {
    case NodeStatus::idle: return "IDLE";
    case NodeStatus::running: return "RUNNING";
    case NodeStatus::success: return "SUCCESS";
    case NodeStatus::failure: return "FAILURE";
    case NodeStatus::skipped: return "SKIPPED";
  }
  return "UNKNOWN";
}

Result<NodeStatus> PortConverter<NodeStatus>::parse(std::string_view text, const EnumTables*) {
  const std::string_view t = detail::trim(text);
  for (NodeStatus s : {NodeStatus::idle, NodeStatus::running, NodeStatus::success, NodeStatus::failure, NodeStatus::skipped})
    if (t == to_string(s)) return s;
  return fail(ErrorCode::invalid_value, detail::quoted(text) + " is not a status (SUCCESS, FAILURE, SKIPPED, RUNNING, IDLE)");
}

const char* to_string(NodeKind kind) noexcept {
  switch (kind) {
    case NodeKind::action: return "Action";
    case NodeKind::condition: return "Condition";
    case NodeKind::control: return "Control";
    case NodeKind::decorator: return "Decorator";
    case NodeKind::subtree: return "SubTree";
  }
  return "Unknown";
}

const char* to_string(PortDirection direction) noexcept {
  switch (direction) {
    case PortDirection::input: return "input_port";
    case PortDirection::output: return "output_port";
    case PortDirection::inout: return "inout_port";
  }
  return "unknown_port";
}

Status EnumTables::add(std::type_index type, std::string type_name, std::vector<std::pair<std::string, int>> values) {
  if (find(type) != nullptr) return fail(ErrorCode::inconsistent, "enum type '" + type_name + "' is already registered");
  if (values.empty()) return fail("enum type '" + type_name + "' has no values");
  for (std::size_t i = 0; i < values.size(); ++i) {
    const std::string& name = values[i].first;
    if (name.empty()) return fail("enum type '" + type_name + "': empty value name");
    for (std::size_t j = 0; j < i; ++j)
      if (values[j].first == name) return fail("enum type '" + type_name + "': duplicate value name '" + name + "'");
    for (const Table& t : tables_)
      for (const auto& [other, v] : t.values)
        if (other == name && v != values[i].second)
          return fail("enum type '" + type_name + "': value name '" + name + "' is already used by enum '" +
                      t.type_name + "' with a different value");
  }
  tables_.push_back(Table{type, std::move(type_name), std::move(values)});
  return ok();
}

const EnumTables::Table* EnumTables::find(std::type_index type) const noexcept {
  for (const Table& t : tables_)
    if (t.type == type) return &t;
  return nullptr;
}

std::optional<int> EnumTables::lookup(std::string_view name) const noexcept {
  for (const Table& t : tables_)
    for (const auto& [n, v] : t.values)
      if (n == name) return v;
  return std::nullopt;
}

namespace detail {

std::string_view trim(std::string_view text) noexcept {
  const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; };
  while (!text.empty() && is_space(text.front())) text.remove_prefix(1);
  while (!text.empty() && is_space(text.back())) text.remove_suffix(1);
  return text;
}

std::string quoted(std::string_view text) {
  std::string out;
  out.reserve(text.size() + 2);
  out.push_back('\'');
  out.append(text);
  out.push_back('\'');
  return out;
}

Result<int> parse_int(std::string_view text) {
  std::string_view t = trim(text);
  const char* b = t.data();
  const char* e = b + t.size();
  if (b != e && *b == '+') ++b;
  long long v = 0;
  auto [p, ec] = std::from_chars(b, e, v);
  if (b == e || ec != std::errc{} || p != e) return fail(ErrorCode::invalid_value, quoted(text) + " is not an integer");
  if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
    return fail(ErrorCode::out_of_range, quoted(text) + " is out of the int range");
  return static_cast<int>(v);
}

Result<unsigned> parse_unsigned(std::string_view text) {
  std::string_view t = trim(text);
  const char* b = t.data();
  const char* e = b + t.size();
  if (b != e && *b == '+') ++b;
  if (b != e && *b == '-') return fail(ErrorCode::invalid_value, quoted(text) + " is negative (the port is unsigned)");
  unsigned long long v = 0;
  auto [p, ec] = std::from_chars(b, e, v);
  if (b == e || ec != std::errc{} || p != e) return fail(ErrorCode::invalid_value, quoted(text) + " is not an unsigned integer");
  if (v > std::numeric_limits<unsigned>::max()) return fail(ErrorCode::out_of_range, quoted(text) + " is out of the unsigned int range");
  return static_cast<unsigned>(v);
}

Result<double> parse_double(std::string_view text) {
  std::string_view t = trim(text);
  const char* b = t.data();
  const char* e = b + t.size();
  if (b != e && *b == '+') ++b;
  double v = 0.0;
  auto [p, ec] = std::from_chars(b, e, v);
  if (b == e || ec != std::errc{} || p != e || !std::isfinite(v)) return fail(ErrorCode::invalid_value, quoted(text) + " is not a number");
  return v;
}

Result<bool> parse_bool(std::string_view text) {
  std::string_view t = trim(text);
  if (t == "true" || t == "True" || t == "TRUE" || t == "1") return true;
  if (t == "false" || t == "False" || t == "FALSE" || t == "0") return false;
  return fail(ErrorCode::invalid_value, quoted(text) + " is not a boolean (true/false)");
}

std::vector<std::string_view> split_list(std::string_view text) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (;;) {
    const std::size_t pos = text.find(';', start);
    if (pos == std::string_view::npos) {
      out.push_back(text.substr(start));
      break;
    }
    out.push_back(text.substr(start, pos - start));
    start = pos + 1;
  }
  return out;
}

Result<int> parse_enum(std::string_view text, std::type_index type, const EnumTables* enums) {
  const EnumTables::Table* table = enums != nullptr ? enums->find(type) : nullptr;
  if (table == nullptr) return fail("enum type " + std::string(type.name()) + " is not registered");
  const std::string_view t = trim(text);
  for (const auto& [name, value] : table->values)
    if (name == t) return value;
  if (auto as_int = parse_int(t)) {
    for (const auto& [name, value] : table->values)
      if (value == *as_int) return value;
  }
  std::string names;
  for (const auto& [name, value] : table->values) names += (names.empty() ? "" : ", ") + name;
  return fail(ErrorCode::invalid_value, quoted(text) + " is not a value of enum " + table->type_name + " (one of: " + names + ")");
}

}  // namespace detail

std::optional<std::string_view> blackboard_key(std::string_view text) noexcept {
  const std::string_view t = detail::trim(text);
  if (t.size() < 3 || t.front() != '{' || t.back() != '}') return std::nullopt;
  const std::string_view key = detail::trim(t.substr(1, t.size() - 2));
  if (key.empty() || key == "@") return std::nullopt;
  return key;
}

}  // namespace visnav::bt

namespace visnav::bt {

PortInfo with_range(PortInfo port, double min_value, double max_value) {
  std::ostringstream os;
  os.precision(15);  // integer bounds print in full ("2147483647", not "2.14748e+09")
  os << "[" << min_value << ", " << max_value << "]";
  port.constraint = os.str();
  port.check = [min_value, max_value, c = port.constraint](std::string_view text) -> Status {
    auto v = convert_from_string<double>(text);
    if (!v) return Error{v.error().message, ErrorCode::invalid_value};
    if (*v < min_value || *v > max_value)
      return Error{"value " + std::string(detail::trim(text)) + " is out of range " + c, ErrorCode::out_of_range};
    return ok();
  };
  return port;
}

}  // namespace visnav::bt
