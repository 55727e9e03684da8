// visnav SDK — the one error model.
//
// Every failure caused by input, the environment or a plugin is returned as a
// `Result<T>` holding an `Error`. Exceptions are reserved for programming bugs and
// never cross the extern "C" plugin boundary.
//
// Thread-safety: value types; no shared state.
#pragma once

#include <cassert>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <variant>

namespace visnav {

/// What kind of failure an Error is, so callers and tests can tell failures apart without
/// matching message text. `unspecified` is the code of an Error made from text alone
/// (`fail("...")`, `Error{"..."}`), which every older call site still does.
enum class ErrorCode : std::uint8_t {
  unspecified = 0,  ///< made from text only; no finer class given
  invalid_value,    ///< a value of the wrong type or form ("abc" for an int, a malformed entry)
  out_of_range,     ///< a value outside its declared range, or not one of the allowed choices
  inconsistent,     ///< values fine alone but contradicting each other (a params struct's validate())
  unknown_key,      ///< a key, attribute or port that nothing declares
  missing,          ///< a required key, port, attribute or argument is absent
  not_found,        ///< a named thing does not exist (file, folder, plugin type, node type, edge)
  parse_error,      ///< broken syntax or format (YAML, XML, a payload's magic/version/checksum)
  io,               ///< the operating system refused (open, read, write, rename)
  plugin,           ///< a plugin failed to load or register, or its factory failed
  limit,            ///< a configured size limit was exceeded (tree depth, node count)
};

/// Stable lower-case name of a code ("out_of_range"), as printed by `visnav validate`.
[[nodiscard]] inline const char* to_string(ErrorCode code) noexcept {
  switch (code) {
    case ErrorCode::unspecified: return "unspecified";
    case ErrorCode::invalid_value: return "invalid_value";
    case ErrorCode::out_of_range: return "out_of_range";
    case ErrorCode::inconsistent: return "inconsistent";
    case ErrorCode::unknown_key: return "unknown_key";
    case ErrorCode::missing: return "missing";
    case ErrorCode::not_found: return "not_found";
    case ErrorCode::parse_error: return "parse_error";
    case ErrorCode::io: return "io";
    case ErrorCode::plugin: return "plugin";
    case ErrorCode::limit: return "limit";
  }
  return "unspecified";
}

/// Where the input that caused an Error is: a file and 1-based line (YAML marks, XML lines)
/// and a key (a config key path such as "detector.params.max_threshold", an XML attribute or
/// a node path). Every part is optional; empty() when nothing is known.
struct ErrorLocation {
  std::string file;  ///< as the user gave it; empty when unknown
  int line = 0;      ///< 1-based; 0 when unknown
  std::string key;   ///< key path, attribute or node path; empty when none

  ErrorLocation() = default;
  /// `{path}`, `{path, line}` or `{path, line, key}`.
  ErrorLocation(std::string file_path, int line_1based = 0, std::string key_path = {})  // NOLINT implicit
      : file(std::move(file_path)), line(line_1based), key(std::move(key_path)) {}

  [[nodiscard]] bool empty() const noexcept { return file.empty() && line == 0 && key.empty(); }
  /// "file:line: key" with the missing parts left out ("" when empty()).
  [[nodiscard]] std::string str() const {
    std::string out = file;
    if (line > 0) out += (out.empty() ? "line " : ":") + std::to_string(line);
    if (!key.empty()) out += (out.empty() ? "" : ": ") + key;
    return out;
  }
  friend bool operator==(const ErrorLocation&, const ErrorLocation&) = default;
};

/// A failure: a human-readable message, a code and (when known) the location of the input that
/// caused it. The message is always complete on its own: it names the offending file, line, key
/// or value where one exists ("config.yaml:12: key 'speed_mps': ..."), so code that prints only
/// `message` loses nothing; `code` and `where` are the same facts in a form programs and tests
/// compare.
struct Error {
  std::string message;
  ErrorCode code = ErrorCode::unspecified;
  ErrorLocation where{};

  /// Returns a copy whose message is prefixed with `context + ": "` — used to add the
  /// outer location (file, node path, plugin name) as an error travels up. Code and
  /// location are kept.
  [[nodiscard]] Error with_context(const std::string& context) const {
    return Error{context + ": " + message, code, where};
  }
  /// Returns a copy with `code` set, when it has none yet (an inner, finer code wins).
  [[nodiscard]] Error with_default_code(ErrorCode fallback) const {
    return Error{message, code == ErrorCode::unspecified ? fallback : code, where};
  }
};

/// Marker used to construct a failed Result: `return fail("bad value");` (code unspecified).
[[nodiscard]] inline Error fail(std::string message) { return Error{std::move(message)}; }

/// A failed Result with a code; `message` already names where (a file, a key):
///   return fail(ErrorCode::io, path + ": cannot open: " + reason);
[[nodiscard]] inline Error fail(ErrorCode code, std::string message) { return Error{std::move(message), code}; }

/// A failed Result with a code and a location; the message becomes "<where.str()>: <text>"
/// (just `text` when `where` is empty), so it reads complete wherever it is printed:
///   return fail(ErrorCode::out_of_range, {file, 12, "speed_mps"}, "value 9 is out of range [0, 3]");
[[nodiscard]] inline Error fail(ErrorCode code, ErrorLocation where, const std::string& text) {
  std::string message = where.empty() ? text : where.str() + ": " + text;
  return Error{std::move(message), code, std::move(where)};
}

/// Either a value of type T or an Error. Deliberately small: `ok()`, `value()`,
/// `error()`, `operator*`, `operator->`, `value_or()`.
template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : storage_(std::in_place_index<0>, std::move(value)) {}  // NOLINT implicit
  Result(Error error) : storage_(std::in_place_index<1>, std::move(error)) {}  // NOLINT implicit

  [[nodiscard]] bool ok() const noexcept { return storage_.index() == 0; }
  explicit operator bool() const noexcept { return ok(); }

  T& value() & { assert(ok()); return std::get<0>(storage_); }
  const T& value() const& { assert(ok()); return std::get<0>(storage_); }
  T&& value() && { assert(ok()); return std::get<0>(std::move(storage_)); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  T&& operator*() && { return std::move(*this).value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }

  [[nodiscard]] const Error& error() const& { assert(!ok()); return std::get<1>(storage_); }
  [[nodiscard]] Error&& error() && { assert(!ok()); return std::get<1>(std::move(storage_)); }

  template <typename U>
  [[nodiscard]] T value_or(U&& fallback) const& {
    return ok() ? value() : static_cast<T>(std::forward<U>(fallback));
  }

 private:
  std::variant<T, Error> storage_;
};

/// Result of an operation that produces no value.
template <>
class [[nodiscard]] Result<void> {
 public:
  Result() = default;
  Result(Error error) : error_(std::move(error)) {}  // NOLINT implicit

  [[nodiscard]] bool ok() const noexcept { return !error_.has_value(); }
  explicit operator bool() const noexcept { return ok(); }
  [[nodiscard]] const Error& error() const& { assert(!ok()); return *error_; }
  [[nodiscard]] Error&& error() && { assert(!ok()); return std::move(*error_); }

 private:
  std::optional<Error> error_;
};

using Status = Result<void>;

/// Success value for Result<void>: `return ok();`
[[nodiscard]] inline Result<void> ok() { return {}; }

}  // namespace visnav

/// Propagates a failed Result from the enclosing function:
///   VISNAV_TRY(write_file(path));
#define VISNAV_TRY(expr)                                    \
  do {                                                      \
    auto visnav_try_result_ = (expr);                       \
    if (!visnav_try_result_.ok())                           \
      return std::move(visnav_try_result_).error();         \
  } while (false)

/// Binds the value of a Result or propagates its error:
///   VISNAV_ASSIGN(auto image, load_image(path));
#define VISNAV_CONCAT_INNER_(a, b) a##b
#define VISNAV_CONCAT_(a, b) VISNAV_CONCAT_INNER_(a, b)
#define VISNAV_ASSIGN(decl, expr) VISNAV_ASSIGN_IMPL_(VISNAV_CONCAT_(visnav_assign_, __LINE__), decl, expr)
#define VISNAV_ASSIGN_IMPL_(tmp, decl, expr)               \
  auto tmp = (expr);                                        \
  if (!tmp.ok()) return std::move(tmp).error();             \
  decl = std::move(tmp).value()
