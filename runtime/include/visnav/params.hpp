// visnav SDK — typed, validated plugin parameters.
//
// A plugin declares its parameters as a plain struct with defaults (units in the
// names) and a schema; `ParamSchema::parse` turns the plugin's `params:` ConfigNode
// into the struct and rejects, with file:line, unknown keys, wrong types and
// out-of-range values, then calls the struct's own `validate()` for cross-field rules.
//
//   struct OrbParams {
//     int target_keypoints = 500;
//     bool upright = false;
//     [[nodiscard]] visnav::Status validate() const { return visnav::ok(); }
//     static const visnav::ParamSchema<OrbParams>& schema() {
//       static const auto s = visnav::ParamSchema<OrbParams>{}
//           .field("target_keypoints", &OrbParams::target_keypoints, "keypoints per frame").range(10, 20000)
//           .field("upright", &OrbParams::upright, "skip orientation (faster, for planar motion)");
//       return s;
//     }
//   };
//
// Supported field types: int, double, bool, std::string, std::vector<double>,
// std::vector<std::string> (YAML sequences, or a scalar "a;b;c"), and std::optional<double> for a
// key whose absence means something (its default is nullopt, documented as "unset"; range() checks
// a given value only; e.g. the camera mount keys of camera_mount.hpp).
// Thread-safety: schemas are immutable after construction and may be shared.
#pragma once

#include <charconv>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <string>
#include <type_traits>
#include <vector>

#include "visnav/config_node.hpp"
#include "visnav/result.hpp"

namespace visnav {

/// Human-facing description of one parameter (for `visnav plugins --params` and docs).
struct ParamDoc {
  std::string name;
  std::string type;           ///< "int", "double", "bool", "string", "list<double>", "list<string>"
  std::string default_value;  ///< rendered default
  std::string description;
  std::string constraint;     ///< e.g. "[10, 20000]" or "one of: a, b"; empty if none
};

namespace detail {

inline Result<double> parse_double(const std::string& text) {
  double v = 0.0;
  const char* b = text.data();
  const char* e = b + text.size();
  auto [p, ec] = std::from_chars(b, e, v);
  if (ec != std::errc{} || p != e || !std::isfinite(v)) return fail(ErrorCode::invalid_value, "'" + text + "' is not a number");
  return v;
}
inline Result<int> parse_int(const std::string& text) {
  long long v = 0;
  const char* b = text.data();
  const char* e = b + text.size();
  if (b != e && *b == '+') ++b;
  auto [p, ec] = std::from_chars(b, e, v);
  if (ec != std::errc{} || p != e || b == e) return fail(ErrorCode::invalid_value, "'" + text + "' is not an integer");
  if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
    return fail(ErrorCode::out_of_range, "'" + text + "' is out of the int range");
  return static_cast<int>(v);
}
inline Result<bool> parse_bool(const std::string& text) {
  if (text == "true" || text == "True" || text == "TRUE" || text == "yes" || text == "on" || text == "1") return true;
  if (text == "false" || text == "False" || text == "FALSE" || text == "no" || text == "off" || text == "0") return false;
  return fail(ErrorCode::invalid_value, "'" + text + "' is not a boolean (true/false)");
}
inline std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : text) {
    if (c == ';') { out.push_back(cur); cur.clear(); } else { cur.push_back(c); }
  }
  if (!cur.empty() || !out.empty()) out.push_back(cur);
  return out;
}

template <typename T> struct TypeName;
template <> struct TypeName<int> { static constexpr const char* value = "int"; };
template <> struct TypeName<double> { static constexpr const char* value = "double"; };
template <> struct TypeName<bool> { static constexpr const char* value = "bool"; };
template <> struct TypeName<std::string> { static constexpr const char* value = "string"; };
template <> struct TypeName<std::vector<double>> { static constexpr const char* value = "list<double>"; };
template <> struct TypeName<std::vector<std::string>> { static constexpr const char* value = "list<string>"; };
template <> struct TypeName<std::optional<double>> { static constexpr const char* value = "double"; };

template <typename T>
std::string render(const T& v) {
  if constexpr (std::is_same_v<T, std::optional<double>>) return v ? render(*v) : std::string("unset");
  else if constexpr (std::is_same_v<T, bool>) return v ? "true" : "false";
  else if constexpr (std::is_same_v<T, std::string>) return v;
  else if constexpr (std::is_same_v<T, std::vector<double>> || std::is_same_v<T, std::vector<std::string>>) {
    std::ostringstream os;
    for (size_t i = 0; i < v.size(); ++i) { if (i) os << ';'; os << v[i]; }
    return os.str();
  } else {
    std::ostringstream os; os << v; return os.str();
  }
}

template <typename T>
Result<T> convert(const ConfigNode& node) {
  if constexpr (std::is_same_v<T, std::optional<double>>) {
    auto v = convert<double>(node);
    if (!v) return v.error();
    return T{*v};
  } else if constexpr (std::is_same_v<T, std::vector<double>> || std::is_same_v<T, std::vector<std::string>>) {
    std::vector<std::string> texts;
    if (node.is_sequence()) {
      for (const auto& item : node.items()) {
        if (!item.is_scalar()) return fail(ErrorCode::invalid_value, "expected a list of scalars");
        texts.push_back(item.scalar());
      }
    } else if (node.is_scalar()) {
      texts = split_list(node.scalar());
    } else {
      return fail(ErrorCode::invalid_value, "expected a list");
    }
    T out;
    for (const auto& t : texts) {
      if constexpr (std::is_same_v<T, std::vector<double>>) {
        auto v = parse_double(t);
        if (!v) return v.error();
        out.push_back(*v);
      } else {
        out.push_back(t);
      }
    }
    return out;
  } else {
    if (!node.is_scalar()) return fail(ErrorCode::invalid_value, std::string("expected a scalar of type ") + TypeName<T>::value);
    const std::string& s = node.scalar();
    if constexpr (std::is_same_v<T, int>) return parse_int(s);
    else if constexpr (std::is_same_v<T, double>) return parse_double(s);
    else if constexpr (std::is_same_v<T, bool>) return parse_bool(s);
    else return s;
  }
}

/// A field's value(s) as text, one per list element (what range() and one_of() check).
template <typename T>
std::vector<std::string> values_of(const T& v) {
  if constexpr (std::is_same_v<T, std::optional<double>>) {
    return v ? values_of(*v) : std::vector<std::string>{};  // unset: nothing to check
  } else if constexpr (std::is_same_v<T, std::vector<double>> || std::is_same_v<T, std::vector<std::string>>) {
    std::vector<std::string> out;
    for (const auto& item : v) out.push_back(render(item));
    return out;
  } else if constexpr (std::is_same_v<T, double>) {
    std::ostringstream os;
    os.precision(15);
    os << v;
    return {os.str()};
  } else {
    return {render(v)};
  }
}

}  // namespace detail

template <typename P>
class ParamSchema {
 public:
  template <typename T>
  ParamSchema& field(std::string name, T P::*member, std::string description) {
    Field f;
    f.doc.name = std::move(name);
    f.doc.type = detail::TypeName<T>::value;
    f.doc.description = std::move(description);
    f.render_default = [member](const P& p) { return detail::render(p.*member); };
    f.assign = [member](P& p, const ConfigNode& node) -> Status {
      auto v = detail::convert<T>(node);
      if (!v) return v.error();
      p.*member = std::move(*v);
      return ok();
    };
    f.values = [member](const P& p) { return detail::values_of(p.*member); };
    fields_.push_back(std::move(f));
    return *this;
  }

  /// Adds the fields `names` of a nested struct `Sub` (member `outer` of P) with their
  /// description, default and constraint taken from `sub`, the nested struct's own schema, so a
  /// parameter is declared once. Each entry is {key in `sub`, key here} (rename, e.g. a node port
  /// that predates the core name). Unknown sub keys are a bug: std::logic_error.
  template <typename Sub>
  ParamSchema& include(Sub P::*outer, const ParamSchema<Sub>& sub,
                       const std::vector<std::pair<std::string, std::string>>& names) {
    for (const auto& [sub_name, name] : names) {
      const auto* sf = sub.find(sub_name);
      if (sf == nullptr) throw std::logic_error("ParamSchema::include: no field '" + sub_name + "'");
      Field f;
      f.doc = sf->doc;
      f.doc.name = name;
      f.render_default = [outer, g = sf->render_default](const P& p) { return g(p.*outer); };
      f.assign = [outer, a = sf->assign](P& p, const ConfigNode& node) { return a(p.*outer, node); };
      f.values = [outer, v = sf->values](const P& p) { return v(p.*outer); };
      f.check = [outer, c = sf->check](const P& p) { return c(p.*outer); };
      fields_.push_back(std::move(f));
    }
    return *this;
  }

  /// Inclusive numeric range for the last int/double field (or for each element of a list<double>).
  /// After include() it narrows the included field's range (both are enforced by parse()).
  ParamSchema& range(double min_value, double max_value) {
    Field& f = fields_.back();
    std::ostringstream os; os << "[" << min_value << ", " << max_value << "]";
    f.doc.constraint = os.str();
    auto previous = f.assign;
    f.assign = [previous, min_value, max_value, c = f.doc.constraint](P& p, const ConfigNode& node) -> Status {
      // This range first (unparsable text is left to `previous`), so a range that narrows an
      // included field's is the one an error names.
      auto check = [&](const std::string& text) -> Status {
        auto v = detail::parse_double(text);
        if (v && (*v < min_value || *v > max_value))
          return Error{"value " + text + " is out of range " + c, ErrorCode::out_of_range};
        return ok();
      };
      if (node.is_scalar() && node.scalar().find(';') == std::string::npos) {
        VISNAV_TRY(check(node.scalar()));
      } else if (node.is_sequence()) {
        for (const auto& it : node.items()) VISNAV_TRY(check(it.scalar()));
      } else if (node.is_scalar()) {
        for (const auto& t : detail::split_list(node.scalar())) VISNAV_TRY(check(t));
      }
      return previous(p, node);
    };
    f.check = [values = f.values, min_value, max_value, c = f.doc.constraint](const P& p) -> Status {
      for (const std::string& text : values(p)) {
        auto v = detail::parse_double(text);
        if (!v || *v < min_value || *v > max_value)
          return Error{"value " + text + " is out of range " + c, ErrorCode::out_of_range};
      }
      return ok();
    };
    return *this;
  }

  /// Allowed values for the last string field.
  ParamSchema& one_of(std::vector<std::string> allowed) {
    Field& f = fields_.back();
    std::string c = "one of:";
    for (const auto& a : allowed) c += " " + a;
    f.doc.constraint = c;
    auto previous = f.assign;
    f.assign = [previous, allowed, c](P& p, const ConfigNode& node) -> Status {
      VISNAV_TRY(previous(p, node));
      for (const auto& a : allowed) if (node.is_scalar() && node.scalar() == a) return ok();
      return Error{"value '" + (node.is_scalar() ? node.scalar() : std::string("?")) + "' is not " + c,
                   ErrorCode::out_of_range};
    };
    f.check = [values = f.values, allowed, c](const P& p) -> Status {
      for (const std::string& text : values(p)) {
        bool found = false;
        for (const auto& a : allowed) found = found || text == a;
        if (!found) return Error{"value '" + text + "' is not " + c, ErrorCode::out_of_range};
      }
      return ok();
    };
    return *this;
  }

  /// Checks every field of `p` (a struct filled in code, not parsed) against its constraint:
  /// the same ranges and choices parse() enforces. Structs call this from their validate(), so
  /// a constraint is written once, in the schema. Error: "key 'laps': value 0 is out of range [1, 100000]".
  [[nodiscard]] Status check(const P& p) const {
    for (const auto& f : fields_)
      if (auto st = f.check(p); !st)
        return Error{"key '" + f.doc.name + "': " + st.error().message, st.error().with_default_code(ErrorCode::out_of_range).code,
                     ErrorLocation{{}, 0, f.doc.name}};
    return ok();
  }

  /// Parses and checks one value of field `name` alone (type and constraint, not the
  /// cross-field rules of validate()), e.g. a literal behaviour-tree port generated from this schema.
  [[nodiscard]] Status check_field(std::string_view name, const ConfigNode& value) const {
    const Field* f = find(name);
    if (f == nullptr) return fail(ErrorCode::unknown_key, "unknown key '" + std::string(name) + "'");
    P p{};
    return f->assign(p, value);
  }

  /// Parses `node` (a map, or null for all defaults) on top of `base` (defaults when omitted).
  /// Errors name the location and key: "robot.yaml:14: key 'max_speed_mps': value 9 is out of range [0, 3]",
  /// with a code (unknown_key, invalid_value, out_of_range; inconsistent when validate() fails
  /// without a code of its own) and a location {file, line, key}. The first of problems().
  [[nodiscard]] Result<P> parse(const ConfigNode& node, P base = P{}) const {
    std::vector<Error> all;
    parse_into(node, base, all, /*first_only=*/true);
    if (!all.empty()) return std::move(all.front());
    return base;
  }

  /// Every problem parse() would find in `node`, not just the first: each unknown key and bad
  /// value, then validate()'s verdict when all keys were fine. Empty: parse() succeeds. This is
  /// what `visnav validate` and the check before `visnav run` report for a params block.
  [[nodiscard]] std::vector<Error> problems(const ConfigNode& node, P base = P{}) const {
    std::vector<Error> all;
    parse_into(node, base, all, /*first_only=*/false);
    return all;
  }

  /// The fields' docs with the defaults of `defaults` (a node whose tuned values differ from
  /// the struct's own initialisers renders those as its defaults).
  [[nodiscard]] std::vector<ParamDoc> docs(const P& defaults = P{}) const {
    std::vector<ParamDoc> out;
    for (const auto& f : fields_) {
      ParamDoc d = f.doc;
      d.default_value = f.render_default(defaults);
      out.push_back(std::move(d));
    }
    return out;
  }

 private:
  template <typename> friend class ParamSchema;  // include() reads another schema's fields
  struct Field {
    ParamDoc doc;
    std::function<std::string(const P&)> render_default;
    std::function<Status(P&, const ConfigNode&)> assign;              ///< convert + constraint
    std::function<std::vector<std::string>(const P&)> values;         ///< the value(s) as text
    std::function<Status(const P&)> check = [](const P&) { return ok(); };  ///< constraint on a value
  };
  void parse_into(const ConfigNode& node, P& out, std::vector<Error>& errors, bool first_only) const {
    const SourceLocation& at = node.where();
    if (!node.is_null() && !node.is_map()) {
      errors.push_back(Error{at.str() + ": expected a map of parameters", ErrorCode::invalid_value, {at.file, at.line, {}}});
      return;
    }
    if (node.is_map()) {
      for (const auto& [key, value] : node.entries()) {
        const SourceLocation& vat = value.where();
        const Field* f = find(key);
        if (f == nullptr) {
          std::string known;
          for (const auto& ff : fields_) known += (known.empty() ? "" : ", ") + ff.doc.name;
          errors.push_back(Error{vat.str() + ": unknown key '" + key + "' (known keys: " + known + ")",
                                 ErrorCode::unknown_key, {vat.file, vat.line, key}});
        } else if (auto st = f->assign(out, value); !st) {
          errors.push_back(Error{vat.str() + ": key '" + key + "': " + st.error().message,
                                 st.error().with_default_code(ErrorCode::invalid_value).code, {vat.file, vat.line, key}});
        }
        if (first_only && !errors.empty()) return;
      }
    }
    if (!errors.empty()) return;  // validate() assumes every field parsed
    if (auto valid = out.validate(); !valid) {
      const Error& e = valid.error();
      // validate() knows the key at most; the file and line are the params map's, or the
      // key's own line when the map gives that key.
      ErrorLocation where = e.where;
      if (where.file.empty()) {
        where.file = at.file;
        where.line = at.line;
        const ConfigNode* value = where.key.empty() || !node.is_map() ? nullptr : node.find(where.key);
        if (value != nullptr) where.line = value->where().line;
      }
      SourceLocation shown{where.file, where.line};
      errors.push_back(Error{shown.str() + ": " + e.message, e.with_default_code(ErrorCode::inconsistent).code, where});
    }
  }
  const Field* find(std::string_view key) const {
    for (const auto& f : fields_) if (f.doc.name == key) return &f;
    return nullptr;
  }
  std::vector<Field> fields_;
};

}  // namespace visnav
