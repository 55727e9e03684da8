// visnav SDK — the one error model.
//
// Every failure caused by input, the environment or a plugin is returned as a
// `Result<T>` holding an `Error`. Exceptions are reserved for programming bugs and
// never cross the extern "C" plugin boundary.
//
// Thread-safety: value types; no shared state.
#pragma once

#include <cassert>
#include <optional>
#include <string>
#include <utility>
#include <variant>

namespace visnav {

/// A failure with a human-readable message. The message names the offending
/// file, line, key or value where one exists ("config.yaml:12: key 'speed_mps': ...").
struct Error {
  std::string message;

  /// Returns a copy whose message is prefixed with `context + ": "` — used to add the
  /// outer location (file, node path, plugin name) as an error travels up.
  [[nodiscard]] Error with_context(const std::string& context) const {
    return Error{context + ": " + message};
  }
};

/// Marker used to construct a failed Result: `return fail("bad value");`
[[nodiscard]] inline Error fail(std::string message) { return Error{std::move(message)}; }

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
