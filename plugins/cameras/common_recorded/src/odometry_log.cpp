// Timestamped odometry from CSV/YAML and its synchronisation with frame times (odometry_log.hpp).
#include "visnav/recorded/odometry_log.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "visnav/config_node.hpp"
#include "visnav/recorded/csv.hpp"

namespace visnav::recorded {

namespace {

std::string fmt(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

double wrap_pi(double a) {
  while (a > std::numbers::pi) a -= 2.0 * std::numbers::pi;
  while (a <= -std::numbers::pi) a += 2.0 * std::numbers::pi;
  return a;
}

/// One parsed sample plus which fields were present.
struct RawSample {
  Odometry odo;
  bool has_pose = false;
  bool has_heading = false;
  bool has_distance = false;
  bool has_twist = false;
  ErrorLocation where;  // the sample's file and line
};

const std::initializer_list<std::string_view> kT = {"t_s", "t", "time", "timestamp"};
const std::initializer_list<std::string_view> kX = {"x_m", "x"};
const std::initializer_list<std::string_view> kY = {"y_m", "y"};
const std::initializer_list<std::string_view> kHeading = {"heading_rad", "theta", "yaw", "heading"};
const std::initializer_list<std::string_view> kDistance = {"distance_m", "distance", "d"};
const std::initializer_list<std::string_view> kV = {"linear_mps", "v"};
const std::initializer_list<std::string_view> kW = {"angular_radps", "omega", "w"};

/// Fills derived fields and checks ordering.
Result<std::vector<Odometry>> finish(std::vector<RawSample>& raw, const std::string& file) {
  std::vector<Odometry> out;
  out.reserve(raw.size());
  if (raw.empty()) return fail(ErrorCode::missing, {file}, "no odometry samples");
  for (std::size_t i = 1; i < raw.size(); ++i) {
    if (!(raw[i].odo.timestamp_s > raw[i - 1].odo.timestamp_s))
      return fail(ErrorCode::inconsistent, raw[i].where,
                  "timestamp " + fmt(raw[i].odo.timestamp_s) + " is not after the previous one (" +
                      fmt(raw[i - 1].odo.timestamp_s) + " at " + raw[i - 1].where.str() +
                      "): odometry must be in time order");
  }
  double path_m = 0.0;
  for (std::size_t i = 0; i < raw.size(); ++i) {
    RawSample& s = raw[i];
    if (!s.has_pose && !s.has_distance)
      return fail(ErrorCode::missing, s.where, "needs x_m and y_m, or distance_m");
    if (i > 0 && s.has_pose) path_m += std::hypot(s.odo.pose.x_m - raw[i - 1].odo.pose.x_m, s.odo.pose.y_m - raw[i - 1].odo.pose.y_m);
    if (!s.has_distance) s.odo.distance_m = path_m;
    if (!s.has_pose) {
      s.odo.pose.x_m = s.odo.distance_m;
      s.odo.pose.y_m = 0.0;
      if (!s.has_heading) s.odo.pose.heading_rad = 0.0;
    }
    if (!s.has_twist && i > 0) {
      const double dt = s.odo.timestamp_s - raw[i - 1].odo.timestamp_s;
      s.odo.twist.linear_mps = (s.odo.distance_m - raw[i - 1].odo.distance_m) / dt;
      s.odo.twist.angular_radps = wrap_pi(s.odo.pose.heading_rad - raw[i - 1].odo.pose.heading_rad) / dt;
    }
    out.push_back(s.odo);
  }
  return out;
}

Result<std::vector<RawSample>> parse_csv_log(const std::string& path) {
  VISNAV_ASSIGN(CsvTable table, read_csv(path));
  const auto ct = table.column(kT);
  if (!ct) return fail(ErrorCode::missing, {path, table.header_line}, "no time column (t_s, t, time or timestamp)");
  const auto cx = table.column(kX);
  const auto cy = table.column(kY);
  const auto ch = table.column(kHeading);
  const auto cd = table.column(kDistance);
  const auto cv = table.column(kV);
  const auto cw = table.column(kW);
  if ((cx.has_value() != cy.has_value()) || (!cx && !cd))
    return fail(ErrorCode::missing, {path, table.header_line}, "needs columns x_m and y_m, or distance_m");
  std::vector<RawSample> raw;
  raw.reserve(table.rows.size());
  for (const CsvRow& row : table.rows) {
    RawSample s;
    s.where = table.where(row);
    auto num = [&](std::size_t col, std::string_view name) { return csv_number(row.fields[col], s.where, name); };
    VISNAV_ASSIGN(s.odo.timestamp_s, num(*ct, "t_s"));
    if (cx) {
      VISNAV_ASSIGN(s.odo.pose.x_m, num(*cx, "x_m"));
      VISNAV_ASSIGN(s.odo.pose.y_m, num(*cy, "y_m"));
      s.has_pose = true;
    }
    if (ch) {
      VISNAV_ASSIGN(s.odo.pose.heading_rad, num(*ch, "heading_rad"));
      s.has_heading = true;
    }
    if (cd) {
      VISNAV_ASSIGN(s.odo.distance_m, num(*cd, "distance_m"));
      s.has_distance = true;
    }
    if (cv && cw) {
      VISNAV_ASSIGN(s.odo.twist.linear_mps, num(*cv, "linear_mps"));
      VISNAV_ASSIGN(s.odo.twist.angular_radps, num(*cw, "angular_radps"));
      s.has_twist = true;
    }
    raw.push_back(std::move(s));
  }
  return raw;
}

Result<std::vector<RawSample>> parse_yaml_log(const std::string& path) {
  VISNAV_ASSIGN(ConfigNode root, parse_yaml_file(path));
  const ConfigNode* seq = &root;
  if (root.is_map()) {
    seq = root.find("odometry");
    if (seq == nullptr)
      return fail(ErrorCode::missing, {root.where().file, root.where().line, "odometry"},
                  "expected a sequence of samples or a key 'odometry'");
  }
  if (!seq->is_sequence())
    return fail(ErrorCode::invalid_value, {seq->where().file, seq->where().line}, "expected a sequence of odometry samples");
  std::vector<RawSample> raw;
  for (const ConfigNode& item : seq->items()) {
    RawSample s;
    s.where = {item.where().file, item.where().line};
    if (!item.is_map()) return fail(ErrorCode::invalid_value, s.where, "expected a map {t_s: ..., x_m: ..., ...}");
    bool has_t = false;
    bool has_x = false;
    bool has_y = false;
    bool has_v = false;
    bool has_w = false;
    for (const auto& [key, value] : item.entries()) {
      const ErrorLocation where{value.where().file, value.where().line, key};
      if (!value.is_scalar()) return fail(ErrorCode::invalid_value, where, "key '" + key + "': expected a number");
      VISNAV_ASSIGN(double v, csv_number(value.scalar(), where, key));
      const std::string_view key_view = key;  // (clang 14 cannot capture a structured binding)
      auto is = [&](std::initializer_list<std::string_view> names) {
        return std::find(names.begin(), names.end(), key_view) != names.end();
      };
      if (is(kT)) { s.odo.timestamp_s = v; has_t = true; }
      else if (is(kX)) { s.odo.pose.x_m = v; has_x = true; }
      else if (is(kY)) { s.odo.pose.y_m = v; has_y = true; }
      else if (is(kHeading)) { s.odo.pose.heading_rad = v; s.has_heading = true; }
      else if (is(kDistance)) { s.odo.distance_m = v; s.has_distance = true; }
      else if (is(kV)) { s.odo.twist.linear_mps = v; has_v = true; }
      else if (is(kW)) { s.odo.twist.angular_radps = v; has_w = true; }
      else return fail(ErrorCode::unknown_key, where, "unknown key '" + key + "' (known: t_s, x_m, y_m, heading_rad, distance_m, linear_mps, angular_radps)");
    }
    if (!has_t) return fail(ErrorCode::missing, {s.where.file, s.where.line, "t_s"}, "key 't_s' is missing");
    if (has_x != has_y) return fail(ErrorCode::missing, s.where, "give both x_m and y_m");
    s.has_pose = has_x;
    s.has_twist = has_v && has_w;
    raw.push_back(std::move(s));
  }
  return raw;
}

bool is_yaml(const std::string& path) {
  auto ends = [&](const char* ext) {
    const std::string e(ext);
    return path.size() >= e.size() && path.compare(path.size() - e.size(), e.size(), e) == 0;
  };
  return ends(".yaml") || ends(".yml");
}

}  // namespace

Result<OdometryLog> OdometryLog::load(const std::string& path) {
  std::vector<RawSample> raw;
  if (is_yaml(path)) {
    VISNAV_ASSIGN(raw, parse_yaml_log(path));
  } else {
    VISNAV_ASSIGN(raw, parse_csv_log(path));
  }
  OdometryLog log;
  log.file_ = path;
  VISNAV_ASSIGN(log.samples_, finish(raw, path));
  return log;
}

Result<OdometryLog> OdometryLog::from_samples(std::vector<Odometry> samples, std::string label) {
  for (std::size_t i = 1; i < samples.size(); ++i)
    if (!(samples[i].timestamp_s > samples[i - 1].timestamp_s))
      return fail(ErrorCode::inconsistent, {label}, "sample " + std::to_string(i) + " is not after the previous one");
  OdometryLog log;
  log.file_ = std::move(label);
  log.samples_ = std::move(samples);
  return log;
}

std::optional<Odometry> OdometryLog::sample_at(double t_s, OdometrySync sync) const {
  constexpr double kEps = 1e-9;
  // First sample with timestamp > t (+eps): the one before it is at or before t.
  auto it = std::upper_bound(samples_.begin(), samples_.end(), t_s + kEps,
                             [](double t, const Odometry& o) { return t < o.timestamp_s; });
  if (it == samples_.begin()) return std::nullopt;
  const Odometry& a = *(it - 1);
  if (sync == OdometrySync::latest || it == samples_.end() || std::abs(a.timestamp_s - t_s) <= kEps) return a;
  const Odometry& b = *it;
  const double f = (t_s - a.timestamp_s) / (b.timestamp_s - a.timestamp_s);
  Odometry o;
  o.timestamp_s = t_s;
  o.pose.x_m = a.pose.x_m + f * (b.pose.x_m - a.pose.x_m);
  o.pose.y_m = a.pose.y_m + f * (b.pose.y_m - a.pose.y_m);
  o.pose.heading_rad = wrap_pi(a.pose.heading_rad + f * wrap_pi(b.pose.heading_rad - a.pose.heading_rad));
  o.distance_m = a.distance_m + f * (b.distance_m - a.distance_m);
  o.twist.linear_mps = a.twist.linear_mps + f * (b.twist.linear_mps - a.twist.linear_mps);
  o.twist.angular_radps = a.twist.angular_radps + f * (b.twist.angular_radps - a.twist.angular_radps);
  return o;
}

Status OdometryLog::check_coverage(const std::vector<TimedLine>& times, const std::string& times_file, double max_gap_s,
                                   OdometrySync sync) const {
  if (samples_.empty()) return fail(ErrorCode::missing, {file_}, "no odometry samples");
  const double first = samples_.front().timestamp_s;
  const double last = samples_.back().timestamp_s;
  const std::string covers = " (" + file_ + " covers t = " + fmt(first) + " .. " + fmt(last) + " s)";
  for (const TimedLine& tl : times) {
    const ErrorLocation where{times_file, tl.line};
    auto before = std::upper_bound(samples_.begin(), samples_.end(), tl.t_s + 1e-9,
                                   [](double t, const Odometry& o) { return t < o.timestamp_s; });
    if (before == samples_.begin())
      return fail(ErrorCode::inconsistent, where, "frame at t = " + fmt(tl.t_s) + " s is before the first odometry sample" + covers);
    const double gap_before = tl.t_s - (before - 1)->timestamp_s;
    if (gap_before > max_gap_s)
      return fail(ErrorCode::inconsistent, where, "frame at t = " + fmt(tl.t_s) + " s is " + fmt(gap_before) +
                  " s after the nearest earlier odometry sample (max_frame_gap_s = " + fmt(max_gap_s) + ")" + covers);
    if (sync == OdometrySync::interpolate && before != samples_.end() && before->timestamp_s - tl.t_s > max_gap_s &&
        gap_before > 1e-9)
      return fail(ErrorCode::inconsistent, where, "frame at t = " + fmt(tl.t_s) + " s has no odometry sample within max_frame_gap_s = " +
                  fmt(max_gap_s) + " s after it to interpolate with" + covers);
  }
  return ok();
}

}  // namespace visnav::recorded
