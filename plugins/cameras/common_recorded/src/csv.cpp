// CSV dialect of the recorded-run files (csv.hpp).
#include "visnav/recorded/csv.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include "visnav/file_io.hpp"

namespace visnav::recorded {

namespace {

std::string trim(std::string_view s) {
  std::size_t b = 0;
  std::size_t e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r')) --e;
  return std::string(s.substr(b, e - b));
}

std::vector<std::string> split(std::string_view line) {
  std::vector<std::string> out;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    if (comma == std::string_view::npos) {
      out.push_back(trim(line.substr(start)));
      break;
    }
    out.push_back(trim(line.substr(start, comma - start)));
    start = comma + 1;
  }
  return out;
}

}  // namespace

std::optional<std::size_t> CsvTable::column(std::initializer_list<std::string_view> names) const {
  for (std::string_view n : names)
    for (std::size_t i = 0; i < header.size(); ++i)
      if (header[i] == n) return i;
  return std::nullopt;
}

Result<CsvTable> parse_csv(std::string_view text, const std::string& file_label) {
  CsvTable table;
  table.file = file_label;
  int line_no = 0;
  std::size_t pos = 0;
  while (pos < text.size()) {
    const std::size_t nl = text.find('\n', pos);
    const bool complete = nl != std::string_view::npos;
    std::string_view raw = text.substr(pos, complete ? nl - pos : std::string_view::npos);
    pos = complete ? nl + 1 : text.size();
    ++line_no;
    const std::string line = trim(raw);
    if (line.empty() || line[0] == '#') continue;
    if (!complete && !table.header.empty()) {
      // A recording killed in the middle of a write leaves an unterminated last line.
      table.dropped_partial_line = true;
      break;
    }
    std::vector<std::string> fields = split(line);
    if (table.header.empty()) {
      table.header = std::move(fields);
      table.header_line = line_no;
      continue;
    }
    if (fields.size() != table.header.size())
      return fail(ErrorCode::parse_error, {file_label, line_no},
                  "expected " + std::to_string(table.header.size()) + " fields (as the header on line " +
                      std::to_string(table.header_line) + "), got " + std::to_string(fields.size()));
    table.rows.push_back(CsvRow{line_no, std::move(fields)});
  }
  if (table.header.empty()) return fail(ErrorCode::parse_error, {file_label}, "no header line (empty file)");
  return table;
}

Result<CsvTable> read_csv(const std::string& path) {
  VISNAV_ASSIGN(const std::string text, read_text_file(path, kMaxTableFileBytes, "CSV"));
  return parse_csv(text, path);
}

Result<double> csv_number(const std::string& text, const ErrorLocation& where, std::string_view column) {
  double v = 0.0;
  const char* b = text.data();
  const char* e = b + text.size();
  if (b != e && *b == '+') ++b;
  auto [p, ec] = std::from_chars(b, e, v);
  if (ec != std::errc{} || p != e || b == e || !std::isfinite(v))
    return fail(ErrorCode::invalid_value, {where.file, where.line, std::string(column)},
                "column '" + std::string(column) + "': '" + text + "' is not a number");
  return v;
}

}  // namespace visnav::recorded
