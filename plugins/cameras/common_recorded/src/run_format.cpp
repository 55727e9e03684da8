// Recorded-run folder and image-folder frame lists (run_format.hpp).
#include "visnav/recorded/run_format.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "visnav/file_io.hpp"
#include "visnav/config_node.hpp"
#include "visnav/recorded/csv.hpp"

namespace visnav::recorded {

namespace fs = std::filesystem;

namespace {

std::string fmt(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

bool is_image_name(const std::string& name) {
  const auto dot = name.rfind('.');
  if (dot == std::string::npos) return false;
  std::string ext = name.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  static const char* const kExt[] = {"png", "jpg", "jpeg", "bmp", "tif", "tiff", "pgm", "ppm", "webp"};
  return std::any_of(std::begin(kExt), std::end(kExt), [&](const char* e) { return ext == e; });
}

/// Natural order: digit runs compare by value ("img2" < "img10").
bool natural_less(const std::string& a, const std::string& b) {
  std::size_t i = 0;
  std::size_t j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) && std::isdigit(static_cast<unsigned char>(b[j]))) {
      std::size_t i2 = i;
      std::size_t j2 = j;
      while (i2 < a.size() && std::isdigit(static_cast<unsigned char>(a[i2]))) ++i2;
      while (j2 < b.size() && std::isdigit(static_cast<unsigned char>(b[j2]))) ++j2;
      std::string da = a.substr(i, i2 - i);
      std::string db = b.substr(j, j2 - j);
      da.erase(0, std::min(da.find_first_not_of('0'), da.size()));
      db.erase(0, std::min(db.find_first_not_of('0'), db.size()));
      if (da.size() != db.size()) return da.size() < db.size();
      if (da != db) return da < db;
      i = i2;
      j = j2;
      continue;
    }
    if (a[i] != b[j]) return a[i] < b[j];
    ++i;
    ++j;
  }
  if ((a.size() - i) != (b.size() - j)) return (a.size() - i) < (b.size() - j);
  return a < b;
}

Status check_order(const FrameList& list) {
  for (std::size_t i = 1; i < list.frames.size(); ++i)
    if (list.frames[i].t_s < list.frames[i - 1].t_s)
      return fail(ErrorCode::inconsistent, {list.file, list.frames[i].line},
                  "time " + fmt(list.frames[i].t_s) + " s is earlier than the previous frame's " +
                  fmt(list.frames[i - 1].t_s) + " s: frame times must not decrease");
  return ok();
}

}  // namespace

std::vector<TimedLine> FrameList::times() const {
  std::vector<TimedLine> out;
  out.reserve(frames.size());
  for (const auto& f : frames) out.push_back(TimedLine{f.t_s, f.line});
  return out;
}

Status check_run_folder(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return fail(ErrorCode::not_found, {dir}, "not a recorded-run folder (no such directory)");
  const fs::path info = fs::path(dir) / kRunInfoFile;
  if (fs::exists(info, ec)) {
    VISNAV_ASSIGN(ConfigNode root, parse_yaml_file(info.string()));
    const ConfigNode* format = root.is_map() ? root.find("format") : nullptr;
    if (format == nullptr || !format->is_scalar() || format->scalar() != kRunFormatName)
      return fail(ErrorCode::invalid_value, {info.string(), format != nullptr ? format->where().line : 0, "format"},
                  "not a visnav recorded run (expected 'format: " + std::string(kRunFormatName) + "')");
    const ConfigNode* version = root.find("version");
    if (version == nullptr || !version->is_scalar() || version->scalar() != std::to_string(kRunFormatVersion))
      return version != nullptr
                 ? fail(ErrorCode::out_of_range, {info.string(), version->where().line, "version"},
                        "unsupported recorded-run version '" + (version->is_scalar() ? version->scalar() : std::string("?")) +
                            "' (this build reads " + std::to_string(kRunFormatVersion) + ")")
                 : fail(ErrorCode::missing, {info.string(), 0, "version"}, "key 'version' is missing");
  }
  if (!fs::exists(fs::path(dir) / kFramesFile, ec))
    return fail(ErrorCode::not_found, {dir}, "not a recorded-run folder (" + std::string(kFramesFile) + " is missing)");
  return ok();
}

Result<FrameList> read_run_frames(const std::string& run_dir) {
  VISNAV_TRY(check_run_folder(run_dir));
  const std::string path = (fs::path(run_dir) / kFramesFile).string();
  VISNAV_ASSIGN(CsvTable table, read_csv(path));
  const auto ct = table.column({"t_s", "t", "timestamp"});
  const auto cf = table.column({"file"});
  const auto cs = table.column({"sequence"});
  if (!ct || !cf) return fail(ErrorCode::missing, {path, table.header_line}, "needs columns t_s and file");
  FrameList list;
  list.file = path;
  for (const CsvRow& row : table.rows) {
    FrameEntry e;
    e.line = row.line;
    VISNAV_ASSIGN(e.t_s, csv_number(row.fields[*ct], table.where(row), "t_s"));
    if (cs) {
      VISNAV_ASSIGN(double seq, csv_number(row.fields[*cs], table.where(row), "sequence"));
      e.sequence = static_cast<std::uint64_t>(seq);
    } else {
      e.sequence = list.frames.size();
    }
    e.path = (fs::path(run_dir) / row.fields[*cf]).string();
    std::error_code ec;
    if (!fs::exists(e.path, ec)) return fail(ErrorCode::not_found, table.where(row, "file"), "image '" + e.path + "' does not exist");
    list.frames.push_back(std::move(e));
  }
  if (list.frames.empty()) return fail(ErrorCode::missing, {path}, "the run has no frames");
  VISNAV_TRY(check_order(list));
  return list;
}

Result<FrameList> list_image_folder(const std::string& folder, const std::string& timestamps_file, double default_rate_hz) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) return fail(ErrorCode::not_found, {folder}, "no such image folder");
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    if (!entry.is_regular_file(ec)) continue;
    const std::string name = entry.path().filename().string();
    if (is_image_name(name)) names.push_back(name);
  }
  if (ec) return fail(ErrorCode::io, {folder}, "cannot list the folder: " + ec.message());
  if (names.empty())
    return fail(ErrorCode::missing, {folder}, "the folder holds no images (png, jpg, jpeg, bmp, tif, tiff, pgm, ppm, webp)");
  std::sort(names.begin(), names.end(), natural_less);

  FrameList list;
  list.file = folder;
  list.frames.resize(names.size());
  for (std::size_t i = 0; i < names.size(); ++i) {
    list.frames[i].path = (fs::path(folder) / names[i]).string();
    list.frames[i].sequence = i;
    list.frames[i].t_s = static_cast<double>(i) / default_rate_hz;
  }

  std::string ts = timestamps_file;
  if (ts.empty()) {
    for (const char* candidate : {"timestamps.csv", "timestamps.txt"})
      if (fs::exists(fs::path(folder) / candidate, ec)) {
        ts = (fs::path(folder) / candidate).string();
        break;
      }
  }
  if (ts.empty()) return list;
  list.file = ts;
  const bool csv = ts.size() >= 4 && ts.compare(ts.size() - 4, 4, ".csv") == 0;
  if (csv) {
    VISNAV_ASSIGN(CsvTable table, read_csv(ts));
    const auto ct = table.column({"t_s", "t", "timestamp", "time"});
    const auto cf = table.column({"file", "name", "image"});
    if (!ct) return fail(ErrorCode::missing, {ts, table.header_line}, "needs a column t_s (and optionally file)");
    if (cf) {
      std::map<std::string, std::size_t> index;
      for (std::size_t i = 0; i < names.size(); ++i) index[names[i]] = i;
      std::vector<bool> seen(names.size(), false);
      for (const CsvRow& row : table.rows) {
        auto it = index.find(row.fields[*cf]);
        if (it == index.end())
          return fail(ErrorCode::not_found, table.where(row, "file"), "image '" + row.fields[*cf] + "' is not in " + folder);
        VISNAV_ASSIGN(list.frames[it->second].t_s, csv_number(row.fields[*ct], table.where(row), "t_s"));
        list.frames[it->second].line = row.line;
        seen[it->second] = true;
      }
      for (std::size_t i = 0; i < names.size(); ++i)
        if (!seen[i]) return fail(ErrorCode::missing, {ts}, "no time for image '" + names[i] + "'");
      VISNAV_TRY(check_order(list));
      return list;
    }
    if (table.rows.size() != names.size())
      return fail(ErrorCode::inconsistent, {ts},
                  std::to_string(table.rows.size()) + " times for " + std::to_string(names.size()) + " images in " + folder);
    for (std::size_t i = 0; i < names.size(); ++i) {
      VISNAV_ASSIGN(list.frames[i].t_s, csv_number(table.rows[i].fields[*ct], table.where(table.rows[i]), "t_s"));
      list.frames[i].line = table.rows[i].line;
    }
    VISNAV_TRY(check_order(list));
    return list;
  }
  // Text: one time per line, or "name time".
  VISNAV_TRY(check_input_file(ts, kMaxTableFileBytes, "timestamps"));
  std::ifstream in(ts);
  if (!in) return fail(ErrorCode::not_found, {ts}, "cannot open (missing or unreadable)");
  std::string line;
  int line_no = 0;
  std::size_t k = 0;
  while (std::getline(in, line)) {
    ++line_no;
    std::istringstream fields(line);
    std::vector<std::string> parts;
    for (std::string p; fields >> p;) parts.push_back(p);
    if (parts.empty() || parts[0][0] == '#') continue;
    if (k >= names.size())
      return fail(ErrorCode::inconsistent, {ts, line_no},
                  "more times than the " + std::to_string(names.size()) + " images in " + folder);
    VISNAV_ASSIGN(list.frames[k].t_s, csv_number(parts.back(), {ts, line_no}, "time"));
    list.frames[k].line = line_no;
    ++k;
  }
  if (k != names.size())
    return fail(ErrorCode::inconsistent, {ts}, std::to_string(k) + " times for " + std::to_string(names.size()) + " images in " + folder);
  VISNAV_TRY(check_order(list));
  return list;
}

Result<std::vector<std::pair<double, Pose2D>>> read_ground_truth(const std::string& run_dir) {
  std::vector<std::pair<double, Pose2D>> out;
  const std::string path = (fs::path(run_dir) / kGroundTruthFile).string();
  std::error_code ec;
  if (!fs::exists(path, ec)) return out;
  VISNAV_ASSIGN(CsvTable table, read_csv(path));
  const auto ct = table.column({"t_s"});
  const auto cx = table.column({"x_m"});
  const auto cy = table.column({"y_m"});
  const auto ch = table.column({"heading_rad"});
  if (!ct || !cx || !cy || !ch) return fail(ErrorCode::missing, {path, table.header_line}, "needs columns t_s, x_m, y_m, heading_rad");
  for (const CsvRow& row : table.rows) {
    Pose2D p;
    VISNAV_ASSIGN(double t, csv_number(row.fields[*ct], table.where(row), "t_s"));
    VISNAV_ASSIGN(p.x_m, csv_number(row.fields[*cx], table.where(row), "x_m"));
    VISNAV_ASSIGN(p.y_m, csv_number(row.fields[*cy], table.where(row), "y_m"));
    VISNAV_ASSIGN(p.heading_rad, csv_number(row.fields[*ch], table.where(row), "heading_rad"));
    out.emplace_back(t, p);
  }
  return out;
}

}  // namespace visnav::recorded
