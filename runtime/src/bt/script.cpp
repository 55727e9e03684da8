// The scripting language: a tokenizer, a recursive-descent parser into a flat node array
// (depth-limited so evaluation recursion is bounded) and a tree-walking evaluator.
#include "visnav/bt/script.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>

namespace visnav::bt {

using Op = detail::ScriptNode::Op;
using Kind = ScriptValue::Kind;

namespace {

constexpr int kMaxNesting = 64;
constexpr std::size_t kMaxNodes = 8192;
constexpr int kMaxDepth = 256;

std::string number_text(double v) {
  char buf[64];
  auto [p, ec] = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, ec == std::errc{} ? p : buf);
}

}  // namespace

Result<bool> ScriptValue::truth() const {
  switch (kind) {
    case Kind::boolean: return b;
    case Kind::integer: return i != 0;
    case Kind::real: return d != 0.0;
    case Kind::string: {
      auto v = detail::parse_bool(s);
      if (!v) return fail("the string '" + s + "' is not a boolean");
      return *v;
    }
    case Kind::empty: break;
  }
  return fail("no value");
}

std::string ScriptValue::text() const {
  switch (kind) {
    case Kind::boolean: return b ? "true" : "false";
    case Kind::integer: return std::to_string(i);
    case Kind::real: return number_text(d);
    case Kind::string: return s;
    case Kind::empty: break;
  }
  return {};
}

// ---- parser --------------------------------------------------------------------------------

class ScriptParser {
 public:
  explicit ScriptParser(std::string_view src) : src_(src) {}

  Result<Script> run() {
    Script script;
    script.source_ = std::string(src_);
    out_ = &script;
    next();
    while (tok_.kind != T::end) {
      if (tok_.kind == T::op && tok_.text == ";") {  // empty statement
        next();
        continue;
      }
      auto e = expression(0);
      if (!e) return std::move(e).error();
      script.statements_.push_back(*e);
      if (tok_.kind == T::end) break;
      if (!(tok_.kind == T::op && tok_.text == ";")) return error_here("expected ';' or the end of the script");
      next();
    }
    if (!error_.empty()) return fail(error_);
    if (script.statements_.empty()) return fail("column 1: empty script");
    return script;
  }

 private:
  enum class T : std::uint8_t { end, number, string, ident, op, bad };
  struct Token {
    T kind = T::end;
    std::string_view text;
    std::size_t pos = 0;
    ScriptValue value;
  };

  Error error_at(std::size_t pos, const std::string& what) const {
    return Error{"column " + std::to_string(pos + 1) + ": " + what};
  }
  Error error_here(const std::string& what) const {
    if (tok_.kind == T::end) return error_at(tok_.pos, what + ", found the end of the script");
    return error_at(tok_.pos, what + ", found '" + std::string(tok_.text) + "'");
  }

  static bool ident_start(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_' || c == '@'; }
  static bool ident_char(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_' || (c >= '0' && c <= '9'); }
  static bool digit(char c) { return c >= '0' && c <= '9'; }

  void next() {
    while (pos_ < src_.size() && (src_[pos_] == ' ' || src_[pos_] == '\t' || src_[pos_] == '\n' || src_[pos_] == '\r')) ++pos_;
    tok_ = Token{};
    tok_.pos = pos_;
    if (pos_ >= src_.size()) return;
    const char c = src_[pos_];
    if (digit(c) || (c == '.' && pos_ + 1 < src_.size() && digit(src_[pos_ + 1]))) {
      lex_number();
      return;
    }
    if (c == '\'' || c == '"') {
      const std::size_t close = src_.find(c, pos_ + 1);
      if (close == std::string_view::npos) {
        tok_.kind = T::bad;
        tok_.text = src_.substr(pos_, 1);
        error_ = error_at(pos_, "unterminated string").message;
        pos_ = src_.size();
        return;
      }
      tok_.kind = T::string;
      tok_.value = ScriptValue::string(std::string(src_.substr(pos_ + 1, close - pos_ - 1)));
      tok_.text = src_.substr(pos_, close + 1 - pos_);
      pos_ = close + 1;
      return;
    }
    if (ident_start(c)) {
      std::size_t e = pos_ + 1;
      while (e < src_.size() && ident_char(src_[e])) ++e;
      tok_.kind = T::ident;
      tok_.text = src_.substr(pos_, e - pos_);
      pos_ = e;
      return;
    }
    static constexpr std::string_view two[] = {":=", "+=", "-=", "*=", "/=", "==", "!=", "<=", ">=", "&&", "||", ".."};
    for (std::string_view op : two) {
      if (src_.substr(pos_, 2) == op) {
        tok_.kind = T::op;
        tok_.text = src_.substr(pos_, 2);
        pos_ += 2;
        return;
      }
    }
    static constexpr std::string_view one = "=+-*/<>!~&|^?:();";
    if (one.find(c) != std::string_view::npos) {
      tok_.kind = T::op;
      tok_.text = src_.substr(pos_, 1);
      ++pos_;
      return;
    }
    tok_.kind = T::bad;
    tok_.text = src_.substr(pos_, 1);
    ++pos_;
  }

  void lex_number() {
    std::size_t e = pos_;
    bool real = false;
    while (e < src_.size() && digit(src_[e])) ++e;
    if (e < src_.size() && src_[e] == '.' && e + 1 < src_.size() && digit(src_[e + 1])) {
      real = true;
      ++e;
      while (e < src_.size() && digit(src_[e])) ++e;
    }
    if (e < src_.size() && (src_[e] == 'e' || src_[e] == 'E')) {
      std::size_t f = e + 1;
      if (f < src_.size() && (src_[f] == '+' || src_[f] == '-')) ++f;
      if (f < src_.size() && digit(src_[f])) {
        real = true;
        e = f;
        while (e < src_.size() && digit(src_[e])) ++e;
      }
    }
    tok_.kind = T::number;
    tok_.text = src_.substr(pos_, e - pos_);
    const char* b = src_.data() + pos_;
    const char* end = src_.data() + e;
    pos_ = e;
    if (e < src_.size() && ident_char(src_[e])) {  // "12abc": one bad token
      while (pos_ < src_.size() && ident_char(src_[pos_])) ++pos_;
      tok_.kind = T::bad;
      tok_.text = src_.substr(tok_.pos, pos_ - tok_.pos);
      return;
    }
    if (!real) {
      std::int64_t v = 0;
      auto r = std::from_chars(b, end, v);
      if (r.ec == std::errc{} && r.ptr == end) {
        tok_.value = ScriptValue::integer(v);
        return;
      }
    }
    double d = 0.0;
    auto r = std::from_chars(b, end, d);
    if (r.ec != std::errc{} || r.ptr != end) {
      tok_.kind = T::bad;
    } else {
      tok_.value = ScriptValue::real(d);
    }
  }

  bool is_op(std::string_view op) const { return tok_.kind == T::op && tok_.text == op; }

  Result<std::uint32_t> add(detail::ScriptNode n) {
    if (out_->nodes_.size() >= kMaxNodes) return error_at(tok_.pos, "script too long (more than 8192 terms)");
    // Expression-tree depth bounds the evaluator's recursion (a+a+a+... is left-deep).
    int depth = 1;
    const bool has_a = n.op != Op::literal && n.op != Op::variable;
    const bool has_b = has_a && n.op != Op::neg && n.op != Op::lnot && n.op != Op::bnot && n.name.empty();
    if (has_a) depth = std::max(depth, depth_[n.a] + 1);
    if (has_b) depth = std::max(depth, depth_[n.b] + 1);
    if (n.op == Op::ternary) depth = std::max(depth, depth_[n.c] + 1);
    if (depth > kMaxDepth) return error_at(n.column - 1, "expression too deep (more than 256 levels of operators)");
    depth_.push_back(depth);
    out_->nodes_.push_back(std::move(n));
    return static_cast<std::uint32_t>(out_->nodes_.size() - 1);
  }
  Result<std::uint32_t> make(Op op, std::size_t pos, std::uint32_t a, std::uint32_t b = 0, std::uint32_t c = 0) {
    detail::ScriptNode n;
    n.op = op;
    n.a = a;
    n.b = b;
    n.c = c;
    n.column = static_cast<std::uint32_t>(pos + 1);
    return add(std::move(n));
  }

  // Binary precedence levels, loosest first (level 0 = assignment, handled separately).
  static int level_of(std::string_view op) {
    if (op == "||") return 2;
    if (op == "&&") return 3;
    if (op == "==" || op == "!=" || op == "<" || op == "<=" || op == ">" || op == ">=") return 4;
    if (op == "|" || op == "^" || op == "&") return 5;
    if (op == "..") return 6;
    if (op == "+" || op == "-") return 7;
    if (op == "*" || op == "/") return 8;
    return -1;
  }
  static Op binary_op(std::string_view op) {
    if (op == "||") return Op::lor;
    if (op == "&&") return Op::land;
    if (op == "==") return Op::eq;
    if (op == "!=") return Op::ne;
    if (op == "<") return Op::lt;
    if (op == "<=") return Op::le;
    if (op == ">") return Op::gt;
    if (op == ">=") return Op::ge;
    if (op == "|") return Op::bor;
    if (op == "^") return Op::bxor;
    if (op == "&") return Op::band;
    if (op == "..") return Op::concat;
    if (op == "+") return Op::add;
    if (op == "-") return Op::sub;
    if (op == "*") return Op::mul;
    return Op::div;
  }

  // expression := IDENT assign-op expression | conditional
  Result<std::uint32_t> expression(int nesting) {
    if (nesting > kMaxNesting) return error_at(tok_.pos, "expression nested more than 64 deep");
    if (tok_.kind == T::ident) {
      // Look ahead for an assignment operator without consuming.
      const std::size_t save_pos = pos_;
      const Token save = tok_;
      next();
      if (tok_.kind == T::op && (tok_.text == "=" || tok_.text == ":=" || tok_.text == "+=" || tok_.text == "-=" ||
                                 tok_.text == "*=" || tok_.text == "/=")) {
        const std::string_view op = tok_.text;
        const std::size_t op_pos = tok_.pos;
        if (save.text == "true" || save.text == "false")
          return error_at(save.pos, "cannot assign to '" + std::string(save.text) + "'");
        next();
        auto rhs = expression(nesting + 1);
        if (!rhs) return rhs;
        const Op o = op == "=" ? Op::assign : op == ":=" ? Op::assign_new : op == "+=" ? Op::add_assign
                     : op == "-=" ? Op::sub_assign : op == "*=" ? Op::mul_assign : Op::div_assign;
        detail::ScriptNode n;
        n.op = o;
        n.a = *rhs;
        n.column = static_cast<std::uint32_t>(op_pos + 1);
        n.name = std::string(save.text);
        return add(std::move(n));
      }
      pos_ = save_pos;
      tok_ = save;
    }
    return conditional(nesting + 1);
  }

  Result<std::uint32_t> conditional(int nesting) {
    if (nesting > kMaxNesting) return error_at(tok_.pos, "expression nested more than 64 deep");
    const std::size_t pos = tok_.pos;
    auto cond = binary(2, nesting);
    if (!cond) return cond;
    if (!is_op("?")) return cond;
    next();
    auto yes = expression(nesting + 1);
    if (!yes) return yes;
    if (!is_op(":")) return error_here("expected ':' of the conditional '? :'");
    next();
    auto no = expression(nesting + 1);
    if (!no) return no;
    return make(Op::ternary, pos, *cond, *yes, *no);
  }

  // Left-associative binary operators by precedence climbing (loops, not recursion, per level).
  Result<std::uint32_t> binary(int level, int nesting) {
    if (level > 8) return unary(nesting);
    auto lhs = binary(level + 1, nesting);
    if (!lhs) return lhs;
    while (tok_.kind == T::op && level_of(tok_.text) == level) {
      const std::string_view op = tok_.text;
      const std::size_t pos = tok_.pos;
      next();
      auto rhs = binary(level + 1, nesting);
      if (!rhs) return rhs;
      auto n = make(binary_op(op), pos, *lhs, *rhs);
      if (!n) return n;
      lhs = *n;
    }
    return lhs;
  }

  Result<std::uint32_t> unary(int nesting) {
    if (nesting > kMaxNesting) return error_at(tok_.pos, "expression nested more than 64 deep");
    if (is_op("-") || is_op("!") || is_op("~")) {
      const Op op = is_op("-") ? Op::neg : is_op("!") ? Op::lnot : Op::bnot;
      const std::size_t pos = tok_.pos;
      next();
      auto x = unary(nesting + 1);
      if (!x) return x;
      return make(op, pos, *x);
    }
    return primary(nesting);
  }

  Result<std::uint32_t> primary(int nesting) {
    detail::ScriptNode n;
    n.column = static_cast<std::uint32_t>(tok_.pos + 1);
    switch (tok_.kind) {
      case T::number:
      case T::string:
        n.op = Op::literal;
        n.value = std::move(tok_.value);
        next();
        return add(std::move(n));
      case T::ident:
        if (tok_.text == "true" || tok_.text == "false") {
          n.op = Op::literal;
          n.value = ScriptValue::boolean(tok_.text == "true");
        } else {
          n.op = Op::variable;
          n.name = std::string(tok_.text);
        }
        next();
        return add(std::move(n));
      case T::op:
        if (tok_.text == "(") {
          next();
          auto e = expression(nesting + 1);
          if (!e) return e;
          if (!is_op(")")) return error_here("expected ')'");
          next();
          return e;
        }
        break;
      case T::bad:
        if (!error_.empty()) return Error{error_};
        return error_at(tok_.pos, "unexpected character '" + std::string(tok_.text) + "'");
      case T::end:
        break;
    }
    return error_here("expected a value, a variable or '('");
  }

  std::string_view src_;
  std::size_t pos_ = 0;
  std::vector<int> depth_;  // per node
  Token tok_;
  Script* out_ = nullptr;
  std::string error_;
};

Result<Script> Script::parse(std::string_view source) { return ScriptParser(source).run(); }

// ---- evaluator -----------------------------------------------------------------------------

namespace {

Result<ScriptValue> from_any(const std::any& v, std::string_view name) {
  const std::type_info& t = v.type();
  if (t == typeid(bool)) return ScriptValue::boolean(std::any_cast<bool>(v));
  if (t == typeid(int)) return ScriptValue::integer(std::any_cast<int>(v));
  if (t == typeid(unsigned)) return ScriptValue::integer(std::any_cast<unsigned>(v));
  if (t == typeid(long)) return ScriptValue::integer(std::any_cast<long>(v));
  if (t == typeid(long long)) return ScriptValue::integer(std::any_cast<long long>(v));
  if (t == typeid(unsigned long) && std::any_cast<unsigned long>(v) <= static_cast<unsigned long>(std::numeric_limits<std::int64_t>::max()))
    return ScriptValue::integer(static_cast<std::int64_t>(std::any_cast<unsigned long>(v)));
  if (t == typeid(double)) return ScriptValue::real(std::any_cast<double>(v));
  if (t == typeid(float)) return ScriptValue::real(std::any_cast<float>(v));
  if (t == typeid(std::string)) return ScriptValue::string(std::any_cast<std::string>(v));
  return fail("variable '" + std::string(name) + "' holds a " + detail::any_type_name(v) + ", which scripts cannot read");
}

double as_double(const ScriptValue& v) {
  switch (v.kind) {
    case Kind::boolean: return v.b ? 1.0 : 0.0;
    case Kind::integer: return static_cast<double>(v.i);
    case Kind::real: return v.d;
    default: return 0.0;
  }
}
bool is_int_like(const ScriptValue& v) { return v.kind == Kind::integer || v.kind == Kind::boolean; }
std::int64_t as_int(const ScriptValue& v) { return v.kind == Kind::boolean ? (v.b ? 1 : 0) : v.i; }

// The value to store into `e` (converted to the entry's declared type or current value type).
Result<std::any> to_entry_value(const ScriptValue& v, const Blackboard::Entry& e, const EnumTables* enums) {
  const std::type_index declared = e.type;
  const std::type_index held = e.value.has_value() ? std::type_index(e.value.type()) : std::type_index(typeid(void));
  const std::type_index target = declared != std::type_index(typeid(void)) ? declared : held;
  auto mismatch = [&](const char* tname) {
    return fail("cannot store " + v.text() + (v.kind == Kind::string ? " (a string)" : "") + " into an entry of type " + tname);
  };
  if (target == std::type_index(typeid(void))) {
    switch (v.kind) {
      case Kind::boolean: return std::any(v.b);
      case Kind::integer:
        if (v.i >= std::numeric_limits<int>::min() && v.i <= std::numeric_limits<int>::max())
          return std::any(static_cast<int>(v.i));
        return std::any(static_cast<double>(v.i));
      case Kind::real: return std::any(v.d);
      case Kind::string: return std::any(v.s);
      case Kind::empty: break;
    }
    return fail("no value to store");
  }
  if (v.kind == Kind::string && target != std::type_index(typeid(std::string))) {
    // A string is parsed as the entry's type (BehaviorTree.CPP's convertFromString).
    if (e.parse != nullptr && declared == target) {
      auto parsed = e.parse(v.s, enums);
      if (!parsed) return fail("cannot convert '" + v.s + "' to " + e.type_name + ": " + parsed.error().message);
      return std::move(*parsed);
    }
    if (target == std::type_index(typeid(int))) {
      auto p = detail::parse_int(v.s);
      if (!p) return mismatch("int");
      return std::any(*p);
    }
    if (target == std::type_index(typeid(double))) {
      auto p = detail::parse_double(v.s);
      if (!p) return mismatch("double");
      return std::any(*p);
    }
    if (target == std::type_index(typeid(bool))) {
      auto p = detail::parse_bool(v.s);
      if (!p) return mismatch("bool");
      return std::any(*p);
    }
    return mismatch(e.type_name.empty() ? "that type" : e.type_name.c_str());
  }
  if (target == std::type_index(typeid(std::string))) return std::any(v.text());
  if (target == std::type_index(typeid(double))) {
    if (!v.is_number()) return mismatch("double");
    return std::any(as_double(v));
  }
  if (target == std::type_index(typeid(float))) {
    if (!v.is_number()) return mismatch("float");
    return std::any(static_cast<float>(as_double(v)));
  }
  if (target == std::type_index(typeid(bool))) {
    if (v.kind == Kind::boolean) return std::any(v.b);
    if (is_int_like(v) && (v.i == 0 || v.i == 1)) return std::any(v.i == 1);
    return mismatch("bool");
  }
  // Integer targets: the value must be integral and in range (no silent truncation).
  auto integral = [&](auto tag) -> Result<std::any> {
    using I = decltype(tag);
    double d = as_double(v);
    if (!v.is_number()) return mismatch(detail::any_type_name(std::any(I{})).c_str());
    if (is_int_like(v)) {
      const std::int64_t x = as_int(v);
      if (std::is_unsigned_v<I> && x < 0) return mismatch(detail::any_type_name(std::any(I{})).c_str());
      if (static_cast<long double>(x) > static_cast<long double>(std::numeric_limits<I>::max()) ||
          static_cast<long double>(x) < static_cast<long double>(std::numeric_limits<I>::lowest()))
        return mismatch(detail::any_type_name(std::any(I{})).c_str());
      return std::any(static_cast<I>(x));
    }
    if (std::trunc(d) != d || d > static_cast<double>(std::numeric_limits<I>::max()) ||
        d < static_cast<double>(std::numeric_limits<I>::lowest()))
      return mismatch(detail::any_type_name(std::any(I{})).c_str());
    return std::any(static_cast<I>(d));
  };
  if (target == std::type_index(typeid(int))) return integral(int{});
  if (target == std::type_index(typeid(unsigned))) return integral(unsigned{});
  if (target == std::type_index(typeid(long))) return integral(long{});
  if (target == std::type_index(typeid(long long))) return integral(static_cast<long long>(0));
  if (e.parse != nullptr && declared == target && enums != nullptr && enums->find(target) != nullptr && is_int_like(v)) {
    // Registered enum: store through its parser (the integer form is accepted).
    auto parsed = e.parse(std::to_string(as_int(v)), enums);
    if (parsed) return std::move(*parsed);
  }
  return mismatch(e.type_name.empty() ? detail::any_type_name(e.value).c_str() : e.type_name.c_str());
}

class Evaluator {
 public:
  Evaluator(const Script& s, Blackboard& bb, const EnumTables* enums) : nodes_(s.nodes()), bb_(bb), enums_(enums) {}

  Result<ScriptValue> eval(std::uint32_t index) {
    const detail::ScriptNode& n = nodes_[index];
    switch (n.op) {
      case Op::literal: return n.value;
      case Op::variable: return read(n);
      case Op::neg: {
        VISNAV_ASSIGN(ScriptValue x, eval(n.a));
        if (x.kind == Kind::real) return ScriptValue::real(-x.d);
        if (is_int_like(x)) {
          if (as_int(x) == std::numeric_limits<std::int64_t>::min()) return ScriptValue::real(-static_cast<double>(as_int(x)));
          return ScriptValue::integer(-as_int(x));
        }
        return error(n, "unary '-' needs a number, got " + describe(x));
      }
      case Op::lnot: {
        VISNAV_ASSIGN(ScriptValue x, eval(n.a));
        auto t = x.truth();
        if (!t) return error(n, "'!': " + t.error().message);
        return ScriptValue::boolean(!*t);
      }
      case Op::bnot: {
        VISNAV_ASSIGN(ScriptValue x, eval(n.a));
        if (!is_int_like(x)) return error(n, "'~' needs an integer, got " + describe(x));
        return ScriptValue::integer(~as_int(x));
      }
      case Op::land:
      case Op::lor: {
        VISNAV_ASSIGN(ScriptValue l, eval(n.a));
        auto lt = l.truth();
        if (!lt) return error(n, std::string(n.op == Op::land ? "'&&'" : "'||'") + ": " + lt.error().message);
        if (n.op == Op::land && !*lt) return ScriptValue::boolean(false);
        if (n.op == Op::lor && *lt) return ScriptValue::boolean(true);
        VISNAV_ASSIGN(ScriptValue r, eval(n.b));
        auto rt = r.truth();
        if (!rt) return error(n, std::string(n.op == Op::land ? "'&&'" : "'||'") + ": " + rt.error().message);
        return ScriptValue::boolean(*rt);
      }
      case Op::ternary: {
        VISNAV_ASSIGN(ScriptValue c, eval(n.a));
        auto t = c.truth();
        if (!t) return error(n, "condition of '? :': " + t.error().message);
        return eval(*t ? n.b : n.c);
      }
      case Op::assign:
      case Op::assign_new:
      case Op::add_assign:
      case Op::sub_assign:
      case Op::mul_assign:
      case Op::div_assign:
        return assign(n);
      default: {
        VISNAV_ASSIGN(ScriptValue l, eval(n.a));
        VISNAV_ASSIGN(ScriptValue r, eval(n.b));
        return binary(n, n.op, l, r);
      }
    }
  }

 private:
  static std::string describe(const ScriptValue& v) {
    switch (v.kind) {
      case Kind::string: return "the string '" + v.s + "'";
      case Kind::empty: return "no value";
      default: return v.text();
    }
  }
  static Error error(const detail::ScriptNode& n, const std::string& what) {
    return Error{"column " + std::to_string(n.column) + ": " + what};
  }

  Result<ScriptValue> read(const detail::ScriptNode& n) {
    if (enums_ != nullptr)
      if (auto e = enums_->lookup(n.name)) return ScriptValue::integer(*e);
    const std::any* v = bb_.get_any(n.name);
    if (v == nullptr) return error(n, "variable '" + n.name + "' is not set");
    auto r = from_any(*v, n.name);
    if (!r) return error(n, r.error().message);
    return r;
  }

  Result<ScriptValue> binary(const detail::ScriptNode& n, Op op, const ScriptValue& l, const ScriptValue& r) {
    const char* sym = op == Op::add ? "+" : op == Op::sub ? "-" : op == Op::mul ? "*" : op == Op::div ? "/"
                      : op == Op::concat ? ".." : op == Op::band ? "&" : op == Op::bor ? "|" : op == Op::bxor ? "^"
                      : op == Op::eq ? "==" : op == Op::ne ? "!=" : op == Op::lt ? "<" : op == Op::le ? "<="
                      : op == Op::gt ? ">" : ">=";
    switch (op) {
      case Op::add:
      case Op::sub:
      case Op::mul:
      case Op::div: {
        if (op == Op::add && l.kind == Kind::string && r.kind == Kind::string) return ScriptValue::string(l.s + r.s);
        if (!l.is_number() || !r.is_number())
          return error(n, std::string("'") + sym + "' needs two numbers" + (op == Op::add ? " or two strings" : "") +
                              ", got " + describe(l) + " and " + describe(r));
        if (op != Op::div && is_int_like(l) && is_int_like(r)) {
          std::int64_t out = 0;
          const std::int64_t a = as_int(l), b = as_int(r);
          const bool overflow = op == Op::add ? __builtin_add_overflow(a, b, &out)
                                : op == Op::sub ? __builtin_sub_overflow(a, b, &out)
                                                : __builtin_mul_overflow(a, b, &out);
          if (!overflow) return ScriptValue::integer(out);
        }
        const double a = as_double(l), b = as_double(r);
        return ScriptValue::real(op == Op::add ? a + b : op == Op::sub ? a - b : op == Op::mul ? a * b : a / b);
      }
      case Op::concat:
        if (l.kind == Kind::empty || r.kind == Kind::empty) return error(n, "'..' needs two values");
        return ScriptValue::string(l.text() + r.text());
      case Op::band:
      case Op::bor:
      case Op::bxor: {
        if (!is_int_like(l) || !is_int_like(r))
          return error(n, std::string("'") + sym + "' needs two integers, got " + describe(l) + " and " + describe(r));
        const std::int64_t a = as_int(l), b = as_int(r);
        return ScriptValue::integer(op == Op::band ? (a & b) : op == Op::bor ? (a | b) : (a ^ b));
      }
      default:
        return compare(n, op, sym, l, r);
    }
  }

  Result<ScriptValue> compare(const detail::ScriptNode& n, Op op, const char* sym, const ScriptValue& l,
                              const ScriptValue& r) {
    int c = 0;  // <0, 0, >0
    if (l.kind == Kind::string && r.kind == Kind::string) {
      c = l.s.compare(r.s);
    } else if (l.is_number() && r.is_number()) {
      if (is_int_like(l) && is_int_like(r)) {
        c = as_int(l) < as_int(r) ? -1 : as_int(l) > as_int(r) ? 1 : 0;
      } else {
        const double a = as_double(l), b = as_double(r);
        if (std::isnan(a) || std::isnan(b)) return ScriptValue::boolean(op == Op::ne);
        c = a < b ? -1 : a > b ? 1 : 0;
      }
    } else if ((l.kind == Kind::string && r.is_number()) || (l.is_number() && r.kind == Kind::string)) {
      // A numeric string compares with a number as a number.
      const ScriptValue& s = l.kind == Kind::string ? l : r;
      auto d = detail::parse_double(s.s);
      if (!d) {
        if (op == Op::eq || op == Op::ne) return ScriptValue::boolean(op == Op::ne);
        return error(n, std::string("'") + sym + "': cannot compare " + describe(l) + " with " + describe(r));
      }
      const double a = l.kind == Kind::string ? *d : as_double(l);
      const double b = r.kind == Kind::string ? *d : as_double(r);
      c = a < b ? -1 : a > b ? 1 : 0;
    } else {
      return error(n, std::string("'") + sym + "': cannot compare " + describe(l) + " with " + describe(r));
    }
    switch (op) {
      case Op::eq: return ScriptValue::boolean(c == 0);
      case Op::ne: return ScriptValue::boolean(c != 0);
      case Op::lt: return ScriptValue::boolean(c < 0);
      case Op::le: return ScriptValue::boolean(c <= 0);
      case Op::gt: return ScriptValue::boolean(c > 0);
      default: return ScriptValue::boolean(c >= 0);
    }
  }

  Result<ScriptValue> assign(const detail::ScriptNode& n) {
    VISNAV_ASSIGN(ScriptValue v, eval(n.a));
    Blackboard::Entry* e = bb_.find_entry(n.name);
    if (n.op == Op::assign_new) {
      if (e == nullptr) e = &bb_.get_or_create_entry(n.name);
    } else if (e == nullptr || (n.op != Op::assign && !e->value.has_value())) {
      return error(n, "variable '" + n.name + "' does not exist (use ':=' to create it)");
    }
    if (n.op != Op::assign && n.op != Op::assign_new) {
      auto cur = from_any(e->value, n.name);
      if (!cur) return error(n, cur.error().message);
      const Op op = n.op == Op::add_assign ? Op::add : n.op == Op::sub_assign ? Op::sub
                    : n.op == Op::mul_assign ? Op::mul : Op::div;
      VISNAV_ASSIGN(ScriptValue combined, binary(n, op, *cur, v));
      v = std::move(combined);
    }
    auto stored = to_entry_value(v, *e, enums_);
    if (!stored) return error(n, "'" + n.name + "': " + stored.error().message);
    e->value = std::move(*stored);
    ++e->sequence;
    return v;
  }

  const std::vector<detail::ScriptNode>& nodes_;
  Blackboard& bb_;
  const EnumTables* enums_;
};

}  // namespace

Result<ScriptValue> Script::evaluate(Blackboard& blackboard, const EnumTables* enums) const {
  Evaluator ev(*this, blackboard, enums);
  ScriptValue last;
  for (std::uint32_t root : statements_) {
    auto v = ev.eval(root);
    if (!v) return std::move(v).error();
    last = std::move(*v);
  }
  return last;
}

namespace detail {
Result<std::any> convert_for_entry(const std::any& value, const Blackboard::Entry& entry, const EnumTables* enums) {
  if (!value.has_value()) return fail("no value");
  const std::type_index vt(value.type());
  if (entry.type == std::type_index(typeid(void)) || entry.type == vt) return value;
  if (vt == std::type_index(typeid(std::string)) && entry.parse != nullptr) {
    const auto& text = std::any_cast<const std::string&>(value);
    auto parsed = entry.parse(text, enums);
    if (!parsed) return fail("cannot convert '" + text + "' to " + entry.type_name + ": " + parsed.error().message);
    return std::move(*parsed);
  }
  auto v = from_any(value, "value");
  if (!v) return fail("a " + any_type_name(value) + " cannot be stored into an entry of type " + entry.type_name);
  return to_entry_value(*v, entry, enums);
}
}  // namespace detail

Result<ScriptCode> PortConverter<ScriptCode>::parse(std::string_view text, const EnumTables*) {
  auto s = Script::parse(text);
  if (!s) return std::move(s).error();
  return ScriptCode{std::make_shared<const Script>(std::move(*s))};
}

}  // namespace visnav::bt
