// Expectations on a failed Result: its ErrorCode and ErrorLocation, not its message text.
//
//   EXPECT_TRUE(fails_with(r, ErrorCode::parse_error, At{"odo.csv", 4}));
//   EXPECT_TRUE(fails_with(r, ErrorCode::out_of_range, At{"setup.yaml", 7, "run.rate_hz"}));
//
// `At::file` matches the end of the error's file (tests write into temporary folders), a zero
// line or an empty key is not compared. On a mismatch the whole error is printed.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <string_view>

#include "visnav/result.hpp"

namespace visnav::test {

struct At {
  std::string file;  ///< suffix of Error::where.file; empty: not compared
  int line = 0;      ///< 0: not compared
  std::string key;   ///< empty: not compared

  At() = default;
  explicit At(std::string file_suffix, int line_1based = 0, std::string key_path = {})
      : file(std::move(file_suffix)), line(line_1based), key(std::move(key_path)) {}
};

/// Only the key is compared (errors with no file, e.g. a node's literal port).
inline At key_only(std::string key_path) { return At{{}, 0, std::move(key_path)}; }

inline std::string describe(const Error& e) {
  return "got code " + std::string(to_string(e.code)) + " at {file '" + e.where.file + "', line " +
         std::to_string(e.where.line) + ", key '" + e.where.key + "'}: " + e.message;
}

inline ::testing::AssertionResult error_is(const Error& e, ErrorCode code, const At& at = {}) {
  const auto ends_with = [](std::string_view s, std::string_view suffix) {
    return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
  };
  if (e.code != code)
    return ::testing::AssertionFailure() << "expected code " << to_string(code) << ", " << describe(e);
  if (!at.file.empty() && !ends_with(e.where.file, at.file))
    return ::testing::AssertionFailure() << "expected file ending '" << at.file << "', " << describe(e);
  if (at.line != 0 && e.where.line != at.line)
    return ::testing::AssertionFailure() << "expected line " << at.line << ", " << describe(e);
  if (!at.key.empty() && e.where.key != at.key)
    return ::testing::AssertionFailure() << "expected key '" << at.key << "', " << describe(e);
  return ::testing::AssertionSuccess();
}

/// Success when `r` failed with `code` at `at` (see At for what is compared).
template <typename R>
::testing::AssertionResult fails_with(const R& r, ErrorCode code, const At& at = {}) {
  if (r.ok()) return ::testing::AssertionFailure() << "expected a failure with code " << to_string(code) << ", got success";
  return error_is(r.error(), code, at);
}

}  // namespace visnav::test
