// visnav behaviour trees — node status, node kinds, typed ports and string conversion.
//
// The XML dialect is BehaviorTree.CPP v4. A port value written in XML is either
//  * a literal, converted from its string once at load time (cached; no per-tick parsing), or
//  * a blackboard reference: `{key}` (this tree's blackboard, following SubTree remapping),
//    `{@key}` (the root blackboard) or `{=}` (the key with the same name as the port).
//
// Supported literal types out of the box: int, double, bool, std::string, registered enums
// (see NodeRegistry::register_enum), and `a;b;c` lists as std::vector<int|double|std::string>.
// Other types: specialise `visnav::bt::PortConverter<T>` (static `parse` and `type_name`).
//
// Thread-safety: all types here are values; EnumTables is immutable while trees run.
#pragma once

#include <any>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <typeindex>
#include <utility>
#include <vector>

#include "visnav/result.hpp"

namespace visnav::bt {

/// Status of a node. `idle`: not started or reset; `running`: asynchronous work in progress;
/// `success` / `failure`: finished; `skipped`: the node chose not to execute this tick (only
/// RunOnce with then_skip="true" among the built-ins); parents treat a skipped child as if it
/// were not there (BehaviorTree.CPP v4 SKIPPED).
enum class NodeStatus : std::uint8_t { idle, running, success, failure, skipped };

/// "IDLE", "RUNNING", "SUCCESS", "FAILURE", "SKIPPED" (as in BehaviorTree.CPP and the trace).
[[nodiscard]] const char* to_string(NodeStatus status) noexcept;
/// True for success and failure.
[[nodiscard]] constexpr bool is_completed(NodeStatus s) noexcept {
  return s == NodeStatus::success || s == NodeStatus::failure;
}

/// Category of a registered node type (the element name used in a TreeNodesModel).
enum class NodeKind : std::uint8_t { action, condition, control, decorator, subtree };
/// "Action", "Condition", "Control", "Decorator", "SubTree".
[[nodiscard]] const char* to_string(NodeKind kind) noexcept;

enum class PortDirection : std::uint8_t { input, output, inout };
/// "input_port", "output_port", "inout_port" (the TreeNodesModel element names).
[[nodiscard]] const char* to_string(PortDirection direction) noexcept;

/// Named integer values of enum types usable as port types (registered through
/// NodeRegistry::register_enum). Also a flat name -> value table, used by Switch to compare
/// an enum-valued variable with a case written as a name.
class EnumTables {
 public:
  struct Table {
    std::type_index type;
    std::string type_name;
    std::vector<std::pair<std::string, int>> values;
  };

  /// Adds a table; fails if the type or one of the names is already registered.
  Status add(std::type_index type, std::string type_name, std::vector<std::pair<std::string, int>> values);
  /// Table of `type`, or nullptr.
  [[nodiscard]] const Table* find(std::type_index type) const noexcept;
  /// Value of an enum name of any registered enum.
  [[nodiscard]] std::optional<int> lookup(std::string_view name) const noexcept;
  [[nodiscard]] const std::vector<Table>& tables() const noexcept { return tables_; }

 private:
  std::vector<Table> tables_;
};

namespace detail {
std::string_view trim(std::string_view text) noexcept;
Result<int> parse_int(std::string_view text);
Result<unsigned> parse_unsigned(std::string_view text);
Result<double> parse_double(std::string_view text);
Result<bool> parse_bool(std::string_view text);
std::vector<std::string_view> split_list(std::string_view text);
Result<int> parse_enum(std::string_view text, std::type_index type, const EnumTables* enums);
std::string quoted(std::string_view text);
}  // namespace detail

/// String conversion of a port type. Specialise for your own types:
///   template <> struct visnav::bt::PortConverter<MyPose> {
///     static visnav::Result<MyPose> parse(std::string_view text, const EnumTables*);
///     static std::string type_name() { return "MyPose"; }
///   };
template <typename T, typename Enable = void>
struct PortConverter;

template <>
struct PortConverter<int> {
  static Result<int> parse(std::string_view text, const EnumTables*) { return detail::parse_int(text); }
  static std::string type_name() { return "int"; }
};
template <>
struct PortConverter<unsigned> {
  static Result<unsigned> parse(std::string_view text, const EnumTables*) { return detail::parse_unsigned(text); }
  static std::string type_name() { return "unsigned int"; }
};
template <>
struct PortConverter<double> {
  static Result<double> parse(std::string_view text, const EnumTables*) { return detail::parse_double(text); }
  static std::string type_name() { return "double"; }
};
template <>
struct PortConverter<bool> {
  static Result<bool> parse(std::string_view text, const EnumTables*) { return detail::parse_bool(text); }
  static std::string type_name() { return "bool"; }
};
template <>
struct PortConverter<std::string> {
  static Result<std::string> parse(std::string_view text, const EnumTables*) { return std::string(text); }
  static std::string type_name() { return "std::string"; }
};
template <typename E>
struct PortConverter<E, std::enable_if_t<std::is_enum_v<E>>> {
  static Result<E> parse(std::string_view text, const EnumTables* enums) {
    auto v = detail::parse_enum(text, std::type_index(typeid(E)), enums);
    if (!v) return std::move(v).error();
    return static_cast<E>(*v);
  }
  /// Replaced by the registered enum name in the nodes model.
  static std::string type_name() { return "enum"; }
};
template <typename T>
struct PortConverter<std::vector<T>> {
  static Result<std::vector<T>> parse(std::string_view text, const EnumTables* enums) {
    std::vector<T> out;
    if (detail::trim(text).empty()) return out;
    for (std::string_view item : detail::split_list(text)) {
      auto v = PortConverter<T>::parse(std::is_same_v<T, std::string> ? item : detail::trim(item), enums);
      if (!v) return Error{"list item " + detail::quoted(item) + ": " + v.error().message, v.error().code, v.error().where};
      out.push_back(std::move(*v));
    }
    return out;
  }
  static std::string type_name() { return "std::vector<" + PortConverter<T>::type_name() + ">"; }
};

/// Port type that accepts an entry of any type (BehaviorTree.CPP's AnyTypeAllowed): such a
/// port does not fix the type of the blackboard entry it names. Literals are kept as text.
struct AnyTypeAllowed {
  std::string text;
};
template <>
struct PortConverter<AnyTypeAllowed> {
  static constexpr bool strongly_typed = false;
  static Result<AnyTypeAllowed> parse(std::string_view text, const EnumTables*) { return AnyTypeAllowed{std::string(text)}; }
  static std::string type_name() { return "BT::AnyTypeAllowed"; }
};

/// NodeStatus as a port type ("SUCCESS", "FAILURE", "SKIPPED", "RUNNING", "IDLE").
template <>
struct PortConverter<NodeStatus> {
  static Result<NodeStatus> parse(std::string_view text, const EnumTables*);
  static std::string type_name() { return "BT::NodeStatus"; }
};

/// Converts a string to T with PortConverter<T>.
template <typename T>
Result<T> convert_from_string(std::string_view text, const EnumTables* enums = nullptr) {
  return PortConverter<T>::parse(text, enums);
}

/// Declaration of one port of a node type.
struct PortInfo {
  /// Type-erased literal parser: text -> std::any holding the port type.
  using Parser = Result<std::any> (*)(std::string_view text, const EnumTables* enums);

  std::string name;
  PortDirection direction = PortDirection::input;
  std::type_index type = std::type_index(typeid(std::string));
  std::string type_name = "std::string";
  std::optional<std::string> default_value;  ///< as it would be written in XML; may be "{key}"
  std::string description;
  Parser parse = nullptr;
  /// False for AnyTypeAllowed (and scripts): the port does not fix its entry's type.
  bool strongly_typed = true;
  /// Constraint beyond the type (e.g. a range from a primitive's ParamSchema): checked on every
  /// literal value when a tree is validated or loaded, so a bad literal fails before the first
  /// tick with file:line. Receives the literal text (already parsed by `parse`); empty: none.
  std::function<Status(std::string_view text)> check;
  /// Text of that constraint for the nodes model and docs ("[0, 3]", "one of: a b"); may be empty.
  std::string constraint;

  /// An input or inout port without a default must be given in the XML.
  [[nodiscard]] bool required() const noexcept {
    return direction != PortDirection::output && !default_value.has_value();
  }
};

/// Ports of a node type, in declaration order.
using PortsList = std::vector<PortInfo>;

namespace detail {
template <typename T>
Result<std::any> parse_as_any(std::string_view text, const EnumTables* enums) {
  auto v = PortConverter<T>::parse(text, enums);
  if (!v) return std::move(v).error();
  return std::any(std::move(*v));
}
template <typename T>
PortInfo make_port(PortDirection dir, std::string name, std::optional<std::string> def, std::string description) {
  PortInfo p;
  p.name = std::move(name);
  p.direction = dir;
  p.type = std::type_index(typeid(T));
  p.type_name = PortConverter<T>::type_name();
  p.default_value = std::move(def);
  p.description = std::move(description);
  p.parse = &parse_as_any<T>;
  if constexpr (requires { PortConverter<T>::strongly_typed; }) p.strongly_typed = PortConverter<T>::strongly_typed;
  return p;
}
}  // namespace detail

/// Required input port: `input_port<double>("speed_mps", "forward speed")`.
template <typename T = std::string>
PortInfo input_port(std::string name, std::string description = {}) {
  return detail::make_port<T>(PortDirection::input, std::move(name), std::nullopt, std::move(description));
}
/// Input port with a default (written as in XML, literal or "{key}"):
/// `input_port<double>("speed_mps", "0.3", "forward speed")`.
template <typename T = std::string>
PortInfo input_port(std::string name, std::string default_value, std::string description) {
  return detail::make_port<T>(PortDirection::input, std::move(name), std::move(default_value), std::move(description));
}
/// Output port (optional in XML; if given it must be a blackboard reference).
template <typename T = std::string>
PortInfo output_port(std::string name, std::string description = {}) {
  return detail::make_port<T>(PortDirection::output, std::move(name), std::nullopt, std::move(description));
}
/// Output port with a default blackboard reference, e.g. `output_port<int>("n", "{count}", "...")`.
template <typename T = std::string>
PortInfo output_port(std::string name, std::string default_value, std::string description) {
  return detail::make_port<T>(PortDirection::output, std::move(name), std::move(default_value), std::move(description));
}
/// Bidirectional port (read and written); required unless it has a default.
template <typename T = std::string>
PortInfo inout_port(std::string name, std::string description = {}) {
  return detail::make_port<T>(PortDirection::inout, std::move(name), std::nullopt, std::move(description));
}
template <typename T = std::string>
PortInfo inout_port(std::string name, std::string default_value, std::string description) {
  return detail::make_port<T>(PortDirection::inout, std::move(name), std::move(default_value), std::move(description));
}

/// Gives `port` an inclusive numeric range (its `check` and `constraint`), for a port whose
/// type parses as a number: `with_range(input_port<double>("speed_mps", "0.3", "..."), 0.0, 1.5)`.
/// A literal outside it fails validation with ErrorCode::out_of_range ("value 9 is out of
/// range [0, 1.5]"); values read from the blackboard are the node's to check.
[[nodiscard]] PortInfo with_range(PortInfo port, double min_value, double max_value);

/// If `text` is a blackboard reference `{key}` returns the key (with a leading '@' kept for
/// root references, "=" for `{=}`); otherwise nullopt.
[[nodiscard]] std::optional<std::string_view> blackboard_key(std::string_view text) noexcept;

}  // namespace visnav::bt
