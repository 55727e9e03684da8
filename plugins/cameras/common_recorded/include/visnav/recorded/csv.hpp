// visnav recorded-run helpers — the small CSV dialect of every recorded-run file.
//
// Dialect: comma-separated, no quoting (fields never contain commas), first non-comment line is
// the header, blank lines and lines starting with '#' are skipped, fields are trimmed of spaces.
// A last line without a terminating newline is dropped as incomplete (a recording killed in the
// middle of a write); `CsvTable::dropped_partial_line` tells the caller.
// Errors name the file and the 1-based line ("run/odometry.csv:17: ...").
// Thread-safety: pure functions over value types.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "visnav/result.hpp"

namespace visnav::recorded {

struct CsvRow {
  int line = 0;                     ///< 1-based line number in the file
  std::vector<std::string> fields;  ///< trimmed
};

struct CsvTable {
  std::string file;                 ///< path as given
  int header_line = 0;
  std::vector<std::string> header;  ///< trimmed column names
  std::vector<CsvRow> rows;
  bool dropped_partial_line = false;

  /// Index of the first column named any of `names`, or nullopt.
  [[nodiscard]] std::optional<std::size_t> column(std::initializer_list<std::string_view> names) const;
  /// The row's file and line (and `column` as the key), for errors about it.
  [[nodiscard]] ErrorLocation where(const CsvRow& row, std::string column = {}) const {
    return {file, row.line, std::move(column)};
  }
};

/// Reads a CSV file. Errors: not_found (missing/unreadable file, naming the path), io, parse_error
/// (no header; a row with a different number of fields than the header, at its file:line).
[[nodiscard]] Result<CsvTable> read_csv(const std::string& path);
/// Parses CSV text (`file_label` is used in error messages).
[[nodiscard]] Result<CsvTable> parse_csv(std::string_view text, const std::string& file_label);

/// Parses a finite double; the error (invalid_value) is at `where` with the column as its key.
[[nodiscard]] Result<double> csv_number(const std::string& text, const ErrorLocation& where, std::string_view column);

}  // namespace visnav::recorded
