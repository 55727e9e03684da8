// visnav behaviour trees — the scripting language of BehaviorTree.CPP v4 (Script,
// ScriptCondition, Precondition and the `_skipIf` / `_onSuccess` ... attributes).
//
// A script is one or more expressions separated by ';'. Its value is the last one's.
//   literals     42  3.5  1e-3  'text' "text"  true false
//   variables    blackboard keys: x, goal_id, @root_key (root blackboard); a name registered
//                as an enum value (NodeRegistry::register_enum) reads as that integer first
//   assignment   x := 1 (creates x if missing)   x = 2 (x must exist)   x += 1  -= *= /=
//   arithmetic   + - * /  (a + b of two strings concatenates)   unary -
//   strings      a .. b  (concatenation; numbers are written in their shortest form)
//   bitwise      & | ^ ~  (integers)
//   comparison   == != < <= > >=  (a number and a numeric string compare as numbers)
//   logic        && || !   (short-circuit)
//   conditional  c ? a : b
// Precedence, loosest first: assignment, ?:, ||, &&, comparison, | ^ &, .., + -, * /, unary.
//
// Values are booleans, 64-bit integers, doubles and strings. Integer + - * integer stays an
// integer (a double on overflow); '/' always gives a double (5 / 2 == 2.5).
// Writing a blackboard entry converts to the entry's type: its declared port type (typed
// blackboard), else the type of the value it holds; a new entry stores bool, int (double when
// it does not fit), double or std::string.
//
// Errors: parse errors name the column (1-based) of the script text; evaluation errors name the
// variable or operator (e.g. "variable 'x' is not set").
// Limits: nesting deeper than 64 (parentheses, unary, conditional and assignment chains), an
// expression tree deeper than 256 operators or more than 8192 terms are parse errors, so the
// evaluator's recursion stays bounded.
//
// Thread-safety: a parsed Script is immutable; evaluate() may run concurrently on different
// blackboards.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "visnav/bt/blackboard.hpp"
#include "visnav/result.hpp"

namespace visnav::bt {

/// A script value.
struct ScriptValue {
  enum class Kind : std::uint8_t { empty, boolean, integer, real, string };
  Kind kind = Kind::empty;
  bool b = false;
  std::int64_t i = 0;
  double d = 0.0;
  std::string s;

  static ScriptValue boolean(bool v) { ScriptValue x; x.kind = Kind::boolean; x.b = v; return x; }
  static ScriptValue integer(std::int64_t v) { ScriptValue x; x.kind = Kind::integer; x.i = v; return x; }
  static ScriptValue real(double v) { ScriptValue x; x.kind = Kind::real; x.d = v; return x; }
  static ScriptValue string(std::string v) { ScriptValue x; x.kind = Kind::string; x.s = std::move(v); return x; }

  [[nodiscard]] bool is_number() const noexcept {
    return kind == Kind::boolean || kind == Kind::integer || kind == Kind::real;
  }
  /// Truth value: booleans; numbers != 0; the strings "true"/"false"/"1"/"0". Error otherwise.
  [[nodiscard]] Result<bool> truth() const;
  /// Text form ("true", "42", "2.5", the string itself).
  [[nodiscard]] std::string text() const;
};

namespace detail {
/// One node of a parsed script (internal; flat array, children by index).
struct ScriptNode {
  enum class Op : std::uint8_t {
    literal, variable, neg, lnot, bnot, add, sub, mul, div, concat, band, bor, bxor, land, lor,
    eq, ne, lt, le, gt, ge, ternary, assign, assign_new, add_assign, sub_assign, mul_assign, div_assign
  };
  Op op = Op::literal;
  std::uint32_t a = 0, b = 0, c = 0;  // operands
  std::uint32_t column = 0;           // 1-based, for errors
  ScriptValue value;                  // literal
  std::string name;                   // variable (assignment target)
};
}  // namespace detail

/// A parsed script (see file comment).
class Script {
 public:
  /// Parses `source`. Error message: "column C: what" (C 1-based, in `source`).
  [[nodiscard]] static Result<Script> parse(std::string_view source);

  /// Runs the script on `blackboard` (reads and writes entries through its scope rules).
  [[nodiscard]] Result<ScriptValue> evaluate(Blackboard& blackboard, const EnumTables* enums) const;

  [[nodiscard]] const std::string& source() const noexcept { return source_; }
  [[nodiscard]] const std::vector<detail::ScriptNode>& nodes() const noexcept { return nodes_; }
  [[nodiscard]] const std::vector<std::uint32_t>& statements() const noexcept { return statements_; }

 private:
  std::string source_;
  std::vector<detail::ScriptNode> nodes_;
  std::vector<std::uint32_t> statements_;  // roots, in order
  friend class ScriptParser;
};

namespace detail {
/// `value` converted for storing into `entry`: unchanged when the entry is untyped or of the
/// same type; a string parsed with the entry's declared type; numbers converted when exact
/// (3.0 -> int 3, not 3.5; negative -> unsigned fails). Error names both types.
Result<std::any> convert_for_entry(const std::any& value, const Blackboard::Entry& entry, const EnumTables* enums);
}  // namespace detail

/// A script given as a port value (Script/ScriptCondition `code`, Precondition `if`): parsed
/// once at load time, so errors are validation errors.
struct ScriptCode {
  std::shared_ptr<const Script> script;
};
template <>
struct PortConverter<ScriptCode> {
  static constexpr bool strongly_typed = false;
  static Result<ScriptCode> parse(std::string_view text, const EnumTables*);
  static std::string type_name() { return "std::string"; }
};

}  // namespace visnav::bt
