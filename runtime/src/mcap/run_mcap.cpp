// Recorded runs as MCAP and back (visnav/mcap.hpp, docs/recorded_runs.md "MCAP").
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "visnav/mcap.hpp"
#include "visnav/file_io.hpp"
#include "visnav/runtime_host.hpp"  // json_escape

namespace visnav::mcap {
namespace fs = std::filesystem;

namespace {

std::uint64_t to_ns(double t_s) { return t_s <= 0.0 ? 0 : static_cast<std::uint64_t>(std::llround(t_s * 1e9)); }
double from_ns(std::uint64_t ns) { return static_cast<double>(ns) * 1e-9; }

dds::msg::Header header_at(double t_s, const char* frame) {
  dds::msg::Header h;
  h.stamp = dds::msg::Time::from_seconds(t_s);
  h.frame_id = frame;
  return h;
}

std::string num(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

std::vector<std::uint8_t> bytes(const std::string& s) { return {s.begin(), s.end()}; }

/// Numbers of a flat JSON object written by RunMcapWriter ({"a":1,"b":2.5}).
std::map<std::string, double> parse_flat_json(const std::vector<std::uint8_t>& data) {
  std::map<std::string, double> out;
  const std::string s(data.begin(), data.end());
  std::size_t i = 0;
  while ((i = s.find('"', i)) != std::string::npos) {
    const std::size_t end = s.find('"', i + 1);
    if (end == std::string::npos) break;
    const std::string key = s.substr(i + 1, end - i - 1);
    std::size_t colon = s.find(':', end);
    if (colon == std::string::npos) break;
    out[key] = std::strtod(s.c_str() + colon + 1, nullptr);
    i = s.find_first_of(",}", colon);
    if (i == std::string::npos) break;
  }
  return out;
}

// ---- a minimal CSV table (the folder format's dialect: header first, '#' comments) --------

struct Table {
  std::vector<std::string> columns;
  std::vector<std::vector<std::string>> rows;
  [[nodiscard]] int column(const std::string& name) const {
    for (std::size_t i = 0; i < columns.size(); ++i)
      if (columns[i] == name) return static_cast<int>(i);
    return -1;
  }
};

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  for (std::string cell; std::getline(ss, cell, ',');) out.push_back(cell);
  return out;
}

Result<Table> read_table(const fs::path& p, bool required, const std::vector<std::string>& needed) {
  Table t;
  std::error_code ec;
  if (!required && !fs::exists(p, ec)) return t;
  VISNAV_TRY(check_input_file(p.string(), kMaxTableFileBytes, "table"));
  std::ifstream in(p);
  if (!in) return fail(ErrorCode::io, {p.string()}, "cannot open");
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    if (t.columns.empty()) {
      t.columns = split(line);
      for (const auto& c : needed)
        if (t.column(c) < 0) return fail(ErrorCode::missing, {p.string(), n, c}, "missing column '" + c + "'");
      continue;
    }
    auto cells = split(line);
    if (cells.size() != t.columns.size()) break;  // an unterminated last line of a killed recording
    t.rows.push_back(std::move(cells));
  }
  return t;
}

double cell_d(const Table& t, const std::vector<std::string>& row, const std::string& c) {
  const int i = t.column(c);
  return i < 0 ? 0.0 : std::strtod(row[static_cast<std::size_t>(i)].c_str(), nullptr);
}

Result<std::string> read_text(const fs::path& p) { return read_text_file(p.string(), kMaxConfigFileBytes, "text"); }

Status write_text(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out << text;
  if (!out) return fail(ErrorCode::io, {p.string()}, "cannot be written");
  return ok();
}

}  // namespace

// ---- RunMcapWriter -----------------------------------------------------------------------

Result<std::unique_ptr<RunMcapWriter>> RunMcapWriter::create(const std::string& path, bool with_truth,
                                                             WriterOptions options) {
  std::unique_ptr<RunMcapWriter> w(new RunMcapWriter());
  VISNAV_ASSIGN(w->writer_, Writer::create(path, std::move(options)));
  Writer& m = *w->writer_;
  auto schema = [&](const char* name) { return m.add_schema(name, "ros2msg", ros2::schema_text(name)); };
  const auto compressed = schema("sensor_msgs/msg/CompressedImage");
  const auto odometry = schema("nav_msgs/msg/Odometry");
  const auto twist = schema("geometry_msgs/msg/Twist");
  w->image_ = m.add_channel(compressed, "/camera/image_raw/compressed", "cdr");
  w->odom_ = m.add_channel(odometry, "/odom", "cdr");
  w->cmd_ = m.add_channel(twist, "/cmd_vel", "cdr");
  const auto json_schema = m.add_schema("visnav.RunRow", "jsonschema", "{\"type\":\"object\"}");
  if (with_truth) {
    w->truth_ = m.add_channel(odometry, "/visnav/ground_truth", "cdr");
    w->truth_json_ = m.add_channel(json_schema, "/visnav/truth", "json");
  }
  w->frame_json_ = m.add_channel(json_schema, "/visnav/frame", "json");
  w->odom_json_ = m.add_channel(json_schema, "/visnav/odometry", "json");
  w->tick_json_ = m.add_channel(json_schema, "/visnav/tick", "json");
  w->telemetry_ = m.add_channel(schema("visnav/msg/Telemetry"), "/visnav/telemetry", "cdr");
  w->status_json_ = m.add_channel(json_schema, "/visnav/status", "json");
  return w;
}

std::string telemetry_json(double t_s, const NavStatus& s) {
  return "{\"t_s\":" + num(t_s) + ",\"node_path\":\"" + json_escape(s.node_path) + "\",\"map_node\":\"" +
         json_escape(s.map_node) + "\",\"edge\":\"" + json_escape(s.edge) + "\",\"distance_m\":" + num(s.distance_m) +
         ",\"matches\":" + std::to_string(s.matches) + ",\"inliers\":" + std::to_string(s.inliers) +
         ",\"offset_px\":" + num(s.offset_px) + ",\"linear_mps\":" + num(s.command.linear_mps) +
         ",\"angular_radps\":" + num(s.command.angular_radps) + ",\"confidence\":" + num(s.confidence) +
         ",\"blind_m\":" + num(s.blind_m) + ",\"status\":\"" + json_escape(s.status) + "\"}";
}

Result<std::pair<double, NavStatus>> parse_telemetry_json(std::string_view line) {
  // A flat object of strings and numbers, as telemetry_json writes it.
  std::map<std::string, std::string> strings;
  std::map<std::string, double> numbers;
  std::size_t i = 0;
  auto skip = [&] { while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i; };
  auto read_string = [&](std::string& out) -> bool {
    if (i >= line.size() || line[i] != '"') return false;
    for (++i; i < line.size(); ++i) {
      const char c = line[i];
      if (c == '"') { ++i; return true; }
      if (c != '\\') { out.push_back(c); continue; }
      if (++i >= line.size()) return false;
      switch (line[i]) {
        case 'n': out.push_back('\n'); break;
        case 't': out.push_back('\t'); break;
        case 'r': out.push_back('\r'); break;
        case 'b': out.push_back('\b'); break;
        case 'f': out.push_back('\f'); break;
        case 'u': {
          if (i + 4 >= line.size()) return false;
          const unsigned long code = std::strtoul(std::string(line.substr(i + 1, 4)).c_str(), nullptr, 16);
          if (code > 0x7F) return false;  // json_escape only escapes control characters
          out.push_back(static_cast<char>(code));
          i += 4;
          break;
        }
        default: out.push_back(line[i]);
      }
    }
    return false;
  };
  skip();
  if (i >= line.size() || line[i++] != '{') return fail(ErrorCode::parse_error, "telemetry line: expected '{'");
  for (;;) {
    skip();
    if (i < line.size() && line[i] == '}') break;
    std::string key;
    if (!read_string(key)) return fail(ErrorCode::parse_error, "telemetry line: expected a \"key\" at column " + std::to_string(i + 1));
    skip();
    if (i >= line.size() || line[i++] != ':') return fail(ErrorCode::parse_error, "telemetry line: expected ':' after '" + key + "'");
    skip();
    if (i < line.size() && line[i] == '"') {
      std::string value;
      if (!read_string(value)) return fail(ErrorCode::parse_error, "telemetry line: unterminated string for '" + key + "'");
      strings[key] = std::move(value);
    } else {
      const std::string rest(line.substr(i));
      char* end = nullptr;
      const double v = std::strtod(rest.c_str(), &end);
      if (end == rest.c_str()) return fail(ErrorCode::parse_error, "telemetry line: '" + key + "' is not a number or string");
      numbers[key] = v;
      i += static_cast<std::size_t>(end - rest.c_str());
    }
    skip();
    if (i < line.size() && line[i] == ',') { ++i; continue; }
    if (i < line.size() && line[i] == '}') break;
    return fail(ErrorCode::parse_error, "telemetry line: expected ',' or '}' at column " + std::to_string(i + 1));
  }
  if (numbers.count("t_s") == 0) return fail(ErrorCode::missing, "telemetry line: no t_s");
  NavStatus s;
  s.node_path = strings["node_path"];
  s.map_node = strings["map_node"];
  s.edge = strings["edge"];
  s.status = strings["status"];
  s.distance_m = numbers["distance_m"];
  s.matches = static_cast<int>(numbers["matches"]);
  s.inliers = static_cast<int>(numbers["inliers"]);
  s.offset_px = numbers["offset_px"];
  s.command = {numbers["linear_mps"], numbers["angular_radps"]};
  s.confidence = numbers["confidence"];
  s.blind_m = numbers["blind_m"];
  return std::make_pair(numbers["t_s"], std::move(s));
}

Status RunMcapWriter::telemetry(double t_s, const NavStatus& s) {
  dds::msg::Telemetry m;
  m.header = header_at(t_s, "");
  m.sequence_number = ++telemetry_seq_;
  dds::fill_telemetry_message(s, m);
  const std::uint64_t ns = to_ns(t_s);
  VISNAV_TRY(writer_->write({telemetry_, seq_++, ns, ns, ros2::encode(m)}));
  return writer_->write({status_json_, seq_++, ns, ns, bytes(telemetry_json(t_s, s))});
}

Status RunMcapWriter::frame(long index, double t_s, std::uint64_t sequence, const std::vector<std::uint8_t>& encoded,
                            const std::string& format) {
  dds::msg::CompressedImage img;
  img.header = header_at(t_s, "camera");
  img.format = format;
  img.data = encoded;
  const std::uint64_t ns = to_ns(t_s);
  VISNAV_TRY(writer_->write({image_, seq_++, ns, ns, ros2::encode(img)}));
  const std::string j = "{\"index\":" + std::to_string(index) + ",\"t_s\":" + num(t_s) +
                        ",\"sequence\":" + std::to_string(sequence) + "}";
  return writer_->write({frame_json_, seq_++, ns, ns, bytes(j)});
}

Status RunMcapWriter::odometry(const Odometry& o) {
  dds::msg::Odometry m;
  m.header = header_at(o.timestamp_s, "odom");
  m.child_frame_id = "base_link";
  m.pose.pose.position.x = o.pose.x_m;
  m.pose.pose.position.y = o.pose.y_m;
  m.pose.pose.orientation = dds::quaternion_from_yaw(o.pose.heading_rad);
  m.twist.twist.linear.x = o.twist.linear_mps;
  m.twist.twist.angular.z = o.twist.angular_radps;
  const std::uint64_t ns = to_ns(o.timestamp_s);
  VISNAV_TRY(writer_->write({odom_, seq_++, ns, ns, ros2::encode(m)}));
  const std::string j = "{\"t_s\":" + num(o.timestamp_s) + ",\"x_m\":" + num(o.pose.x_m) + ",\"y_m\":" + num(o.pose.y_m) +
                        ",\"heading_rad\":" + num(o.pose.heading_rad) + ",\"distance_m\":" + num(o.distance_m) +
                        ",\"linear_mps\":" + num(o.twist.linear_mps) + ",\"angular_radps\":" + num(o.twist.angular_radps) + "}";
  return writer_->write({odom_json_, seq_++, ns, ns, bytes(j)});
}

Status RunMcapWriter::tick(std::uint64_t tick, double t_s, long frame_index, const Twist& c, std::uint64_t sent) {
  dds::msg::Twist t;
  t.linear.x = c.linear_mps;
  t.angular.z = c.angular_radps;
  const std::uint64_t ns = to_ns(t_s);
  VISNAV_TRY(writer_->write({cmd_, seq_++, ns, ns, ros2::encode(t)}));
  const std::string j = "{\"tick\":" + std::to_string(tick) + ",\"t_s\":" + num(t_s) + ",\"frame_index\":" +
                        std::to_string(frame_index) + ",\"linear_mps\":" + num(c.linear_mps) + ",\"angular_radps\":" +
                        num(c.angular_radps) + ",\"commands_sent\":" + std::to_string(sent) + "}";
  return writer_->write({tick_json_, seq_++, ns, ns, bytes(j)});
}

Status RunMcapWriter::truth(double t_s, const Pose2D& p) {
  if (truth_ == 0) return ok();
  dds::msg::Odometry m;
  m.header = header_at(t_s, "world");
  m.pose.pose.position.x = p.x_m;
  m.pose.pose.position.y = p.y_m;
  m.pose.pose.orientation = dds::quaternion_from_yaw(p.heading_rad);
  const std::uint64_t ns = to_ns(t_s);
  VISNAV_TRY(writer_->write({truth_, seq_++, ns, ns, ros2::encode(m)}));
  const std::string j = "{\"t_s\":" + num(t_s) + ",\"x_m\":" + num(p.x_m) + ",\"y_m\":" + num(p.y_m) +
                        ",\"heading_rad\":" + num(p.heading_rad) + "}";
  return writer_->write({truth_json_, seq_++, ns, ns, bytes(j)});
}

Status RunMcapWriter::attach(const std::string& name, const std::string& text, double t_s) {
  const std::string media = name.size() > 5 && name.substr(name.size() - 5) == ".yaml" ? "application/yaml" : "text/plain";
  return writer_->write_attachment({to_ns(t_s), to_ns(t_s), name, media, text});
}

Status RunMcapWriter::close() { return writer_->close(); }

// ---- MCAP -> folder ----------------------------------------------------------------------

namespace {

/// What a bag holds that the folder format stores, as read (times in s of the run clock).
struct BagContents {
  struct FrameRow { double t_s; std::uint64_t sequence; std::string file; };
  struct OdomRow { double t_s, x, y, h, d, v, w; };
  struct TickRow { std::uint64_t tick; double t_s; long frame; double v, w; std::uint64_t sent; };
  std::vector<FrameRow> frames;
  std::vector<std::map<std::string, double>> frame_json;  ///< /visnav/frame: exact times of a visnav bag
  std::vector<OdomRow> odom, odom_json;
  std::vector<TickRow> ticks;
  std::vector<std::array<double, 4>> truth, truth_json;
  std::vector<std::string> telemetry_lines;
  std::string run_yaml, config_yaml;
  std::set<std::string> seen_topics;
  long image_count = 0;

  /// The topics seen, one per line, for an error that names a missing one.
  [[nodiscard]] std::string topic_list() const {
    std::string s;
    for (const auto& t : seen_topics) s += "\n  " + t;
    return s.empty() ? std::string(" (none)") : s;
  }
};

/// An image message as the bytes of a file (.png or .jpg). Errors carry no location.
Result<std::pair<std::vector<std::uint8_t>, std::string>> image_file_bytes(const std::string& type,
                                                                          const std::vector<std::uint8_t>& data) {
  if (type == "sensor_msgs/msg/CompressedImage") {
    VISNAV_ASSIGN(auto img, ros2::decode_compressed_image(data));
    const bool jpeg = img.format.find("jpeg") != std::string::npos || img.format.find("jpg") != std::string::npos;
    return std::make_pair(std::move(img.data), std::string(jpeg ? ".jpg" : ".png"));
  }
  if (type != "sensor_msgs/msg/Image")
    return Error{"type '" + type + "' is not sensor_msgs/msg/Image or CompressedImage", ErrorCode::invalid_value};
  VISNAV_ASSIGN(auto img, ros2::decode_image(data));
  int cv_type = 0;
  if (img.encoding == "mono8") cv_type = CV_8UC1;
  else if (img.encoding == "bgr8" || img.encoding == "rgb8") cv_type = CV_8UC3;
  else return Error{"image encoding '" + img.encoding + "' is not supported (mono8, bgr8, rgb8)", ErrorCode::invalid_value};
  const std::size_t need = static_cast<std::size_t>(img.step) * img.height;
  if (img.data.size() < need || img.step < img.width * static_cast<std::uint32_t>(CV_ELEM_SIZE(cv_type)))
    return Error{"image data is shorter than step * height", ErrorCode::invalid_value};
  cv::Mat view(static_cast<int>(img.height), static_cast<int>(img.width), cv_type, img.data.data(), img.step);
  cv::Mat bgr;
  if (img.encoding == "rgb8") cv::cvtColor(view, bgr, cv::COLOR_RGB2BGR);
  else bgr = view;
  std::vector<std::uint8_t> encoded;
  if (!cv::imencode(".png", bgr, encoded, {cv::IMWRITE_PNG_COMPRESSION, 1}))
    return Error{"cannot encode the image as PNG", ErrorCode::invalid_value};
  return std::make_pair(std::move(encoded), std::string(".png"));
}

/// Takes one message into `c` (an image is written into `dir`/frames at once).
Status take_message(BagContents& c, const std::string& dir, const RunTopics& topics, const Channel& ch, const Schema* schema,
                    const Message& m) {
  c.seen_topics.insert(ch.topic + (schema != nullptr ? " (" + schema->name + ")" : std::string()));
  const std::string type = schema != nullptr ? schema->name : std::string();
  const double t_s = from_ns(m.log_time_ns);
  if (ch.topic == topics.image || (topics.image.empty() && type.find("Image") != std::string::npos)) {
    VISNAV_ASSIGN(auto file, image_file_bytes(type, m.data));
    char name[40];
    std::snprintf(name, sizeof name, "frames/%06ld", c.image_count++);
    const std::string rel = name + file.second;
    std::ofstream out(fs::path(dir) / rel, std::ios::binary);
    out.write(reinterpret_cast<const char*>(file.first.data()), static_cast<std::streamsize>(file.first.size()));
    if (!out) return fail(ErrorCode::io, {(fs::path(dir) / rel).string()}, "cannot be written");
    c.frames.push_back({t_s, m.sequence, rel});
  } else if (ch.topic == topics.odometry) {
    if (type != "nav_msgs/msg/Odometry") return Error{"type '" + type + "' is not nav_msgs/msg/Odometry", ErrorCode::invalid_value};
    VISNAV_ASSIGN(auto o, ros2::decode_odometry(m.data));
    const auto& p = o.pose.pose;
    c.odom.push_back({t_s, p.position.x, p.position.y, dds::yaw_from_quaternion(p.orientation), 0.0, o.twist.twist.linear.x,
                      o.twist.twist.angular.z});
  } else if (ch.topic == "/visnav/frame") {
    c.frame_json.push_back(parse_flat_json(m.data));
  } else if (ch.topic == "/visnav/odometry") {
    auto j = parse_flat_json(m.data);
    c.odom_json.push_back({j["t_s"], j["x_m"], j["y_m"], j["heading_rad"], j["distance_m"], j["linear_mps"], j["angular_radps"]});
  } else if (ch.topic == "/visnav/tick") {
    auto j = parse_flat_json(m.data);
    c.ticks.push_back({static_cast<std::uint64_t>(j["tick"]), j["t_s"], static_cast<long>(j["frame_index"]), j["linear_mps"],
                       j["angular_radps"], static_cast<std::uint64_t>(j["commands_sent"])});
  } else if (ch.topic == "/visnav/status") {
    c.telemetry_lines.emplace_back(m.data.begin(), m.data.end());
  } else if (ch.topic == "/visnav/truth") {
    auto j = parse_flat_json(m.data);
    c.truth_json.push_back({j["t_s"], j["x_m"], j["y_m"], j["heading_rad"]});
  } else if (ch.topic == "/visnav/ground_truth") {
    VISNAV_ASSIGN(auto o, ros2::decode_odometry(m.data));
    c.truth.push_back({t_s, o.pose.pose.position.x, o.pose.pose.position.y, dds::yaw_from_quaternion(o.pose.pose.orientation)});
  }
  return ok();
}

/// A visnav bag's exact rows replace the ones rebuilt from ROS messages; a foreign bag gets its
/// odometric distance integrated and its frames sorted. Returns whether the rows are exact.
Result<bool> settle_rows(BagContents& c, const std::string& mcap_path, const RunTopics& topics) {
  const bool exact = !c.frame_json.empty() && c.frame_json.size() == c.frames.size() && !c.odom_json.empty();
  if (exact) {
    c.odom = std::move(c.odom_json);
    if (c.truth_json.size() == c.truth.size()) c.truth = std::move(c.truth_json);
    for (std::size_t i = 0; i < c.frames.size(); ++i) {
      c.frames[i].t_s = c.frame_json[i]["t_s"];
      c.frames[i].sequence = static_cast<std::uint64_t>(c.frame_json[i]["sequence"]);
    }
    return true;
  }
  if (c.odom.empty())
    return Error{mcap_path + ": no odometry on topic '" + topics.odometry + "' (choose it with --odom-topic); the bag has:" +
                     c.topic_list(),
                 ErrorCode::not_found, {mcap_path, 0, topics.odometry}};
  // Odometric distance: the path length of the positions (what a wheel odometer integrates).
  using OdomRow = BagContents::OdomRow;
  using FrameRow = BagContents::FrameRow;
  std::stable_sort(c.odom.begin(), c.odom.end(), [](const OdomRow& a, const OdomRow& b) { return a.t_s < b.t_s; });
  for (std::size_t i = 1; i < c.odom.size(); ++i)
    c.odom[i].d = c.odom[i - 1].d + std::hypot(c.odom[i].x - c.odom[i - 1].x, c.odom[i].y - c.odom[i - 1].y);
  std::stable_sort(c.frames.begin(), c.frames.end(), [](const FrameRow& a, const FrameRow& b) { return a.t_s < b.t_s; });
  return false;
}

/// Writes the folder format's CSV, telemetry and YAML files from `c`.
Status write_run_files(const BagContents& c, const std::string& dir, const std::string& mcap_path, bool truncated) {
  std::ostringstream fcsv, ocsv, ccsv;
  fcsv << "index,t_s,sequence,file\n";
  for (std::size_t i = 0; i < c.frames.size(); ++i)
    fcsv << i << "," << num(c.frames[i].t_s) << "," << c.frames[i].sequence << "," << c.frames[i].file << "\n";
  ocsv << "t_s,x_m,y_m,heading_rad,distance_m,linear_mps,angular_radps\n";
  for (const auto& o : c.odom)
    ocsv << num(o.t_s) << "," << num(o.x) << "," << num(o.y) << "," << num(o.h) << "," << num(o.d) << "," << num(o.v) << ","
         << num(o.w) << "\n";
  ccsv << "tick,t_s,frame_index,linear_mps,angular_radps,commands_sent\n";
  for (const auto& t : c.ticks)
    ccsv << t.tick << "," << num(t.t_s) << "," << t.frame << "," << num(t.v) << "," << num(t.w) << "," << t.sent << "\n";
  VISNAV_TRY(write_text(fs::path(dir) / "frames.csv", fcsv.str()));
  VISNAV_TRY(write_text(fs::path(dir) / "odometry.csv", ocsv.str()));
  VISNAV_TRY(write_text(fs::path(dir) / "commands.csv", ccsv.str()));
  if (!c.truth.empty()) {
    std::ostringstream g;
    g << "t_s,x_m,y_m,heading_rad\n";
    for (const auto& t : c.truth) g << num(t[0]) << "," << num(t[1]) << "," << num(t[2]) << "," << num(t[3]) << "\n";
    VISNAV_TRY(write_text(fs::path(dir) / "ground_truth.csv", g.str()));
  }
  if (!c.telemetry_lines.empty()) {
    std::string text;
    for (const auto& l : c.telemetry_lines) text += l + "\n";
    VISNAV_TRY(write_text(fs::path(dir) / "telemetry.jsonl", text));
  }
  const std::string run_yaml = !c.run_yaml.empty() ? c.run_yaml
                                                   : "format: visnav-recorded-run\nversion: 1\nsource: \"" + mcap_path +
                                                         "\"\ncomplete: " + (truncated ? "false" : "true") + "\n";
  VISNAV_TRY(write_text(fs::path(dir) / "run.yaml", run_yaml));
  if (!c.config_yaml.empty()) VISNAV_TRY(write_text(fs::path(dir) / "config.yaml", c.config_yaml));
  return ok();
}

}  // namespace

Result<ConversionReport> mcap_to_run_folder(const std::string& mcap_path, const std::string& dir, const RunTopics& topics) {
  std::error_code ec;
  fs::create_directories(fs::path(dir) / "frames", ec);
  if (ec) return fail(ErrorCode::io, {dir}, "cannot create the run folder: " + ec.message());
  BagContents c;
  ReadHandlers h;
  h.on_message = [&](const Channel& ch, const Schema* schema, const Message& m) -> Status {
    auto taken = take_message(c, dir, topics, ch, schema, m);
    if (taken || !taken.error().where.file.empty()) return taken;
    // A message's problem, located at the bag and its topic.
    const Error& e = taken.error();
    return Error{mcap_path + ": topic " + ch.topic + ": " + e.message, e.with_default_code(ErrorCode::parse_error).code,
                 {mcap_path, 0, ch.topic}};
  };
  h.on_attachment = [&](const Attachment& a) -> Status {
    if (a.name == "run.yaml") c.run_yaml = a.data;
    if (a.name == "config.yaml") c.config_yaml = a.data;
    return ok();
  };
  VISNAV_ASSIGN(ReadReport read, read_file(mcap_path, h));
  if (c.frames.empty())
    return Error{mcap_path + ": no image messages on topic '" + topics.image + "' (choose it with --image-topic); the bag has:" +
                     c.topic_list(),
                 ErrorCode::not_found, {mcap_path, 0, topics.image}};
  ConversionReport report;
  report.truncated = read.truncated;
  VISNAV_ASSIGN(report.exact, settle_rows(c, mcap_path, topics));
  VISNAV_TRY(write_run_files(c, dir, mcap_path, read.truncated));
  report.telemetry = static_cast<long>(c.telemetry_lines.size());
  report.frames = static_cast<long>(c.frames.size());
  report.odometry_samples = static_cast<long>(c.odom.size());
  report.ticks = static_cast<long>(c.ticks.size());
  return report;
}

// ---- gamepad marks ----------------------------------------------------------------------

Result<std::vector<std::pair<double, std::string>>> joy_marks(
    const std::string& mcap_path, const std::string& joy_topic, const std::vector<std::pair<int, std::string>>& primitive_buttons) {
  std::vector<std::pair<double, std::string>> marks;
  std::vector<std::int32_t> previous;
  long messages = 0;
  ReadHandlers h;
  h.on_message = [&](const Channel& ch, const Schema*, const Message& m) -> Status {
    if (ch.topic != joy_topic) return ok();
    auto joy = ros2::decode_joy(m.data);
    if (!joy) return Error{mcap_path + ": topic " + joy_topic + ": " + joy.error().message, ErrorCode::parse_error, {mcap_path, 0, joy_topic}};
    ++messages;
    for (const auto& [button, kind] : primitive_buttons) {
      const auto b = static_cast<std::size_t>(button);
      const bool now = b < joy->buttons.size() && joy->buttons[b] != 0;
      const bool before = b < previous.size() && previous[b] != 0;
      if (now && !before) marks.emplace_back(from_ns(m.log_time_ns), kind);
    }
    previous = std::move(joy->buttons);
    return ok();
  };
  VISNAV_TRY(read_file(mcap_path, h));
  if (messages == 0)
    return Error{mcap_path + ": no sensor_msgs/msg/Joy messages on topic '" + joy_topic + "'", ErrorCode::not_found,
                 {mcap_path, 0, joy_topic}};
  std::stable_sort(marks.begin(), marks.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  return marks;
}

// ---- folder -> MCAP ----------------------------------------------------------------------

Result<ConversionReport> run_folder_to_mcap(const std::string& dir, const std::string& mcap_path, WriterOptions options) {
  const fs::path d(dir);
  VISNAV_ASSIGN(Table frames, read_table(d / "frames.csv", true, {"t_s", "file"}));
  VISNAV_ASSIGN(Table odom, read_table(d / "odometry.csv", true, {"t_s", "x_m", "y_m", "heading_rad"}));
  VISNAV_ASSIGN(Table ticks, read_table(d / "commands.csv", false, {}));
  VISNAV_ASSIGN(Table truth, read_table(d / "ground_truth.csv", false, {}));
  std::vector<std::pair<double, NavStatus>> telemetry;
  if (auto text = read_text(d / "telemetry.jsonl")) {
    std::istringstream lines(*text);
    int n = 0;
    for (std::string line; std::getline(lines, line);) {
      ++n;
      if (line.empty()) continue;
      auto row = parse_telemetry_json(line);
      if (!row) {
        if (lines.peek() == std::char_traits<char>::eof()) break;  // the cut last line of a killed recording
        return fail(row.error().code, {(d / "telemetry.jsonl").string(), n}, row.error().message);
      }
      telemetry.push_back(std::move(*row));
    }
  }
  VISNAV_ASSIGN(auto w, RunMcapWriter::create(mcap_path, !truth.rows.empty(), std::move(options)));
  // Merge the five streams by time (stable: telemetry, frames, odometry, ticks, truth at equal
  // times, as `visnav record` writes them: statuses during the tick, the rest after it).
  struct Item { double t_s; int kind; std::size_t row; };
  std::vector<Item> items;
  for (std::size_t i = 0; i < telemetry.size(); ++i) items.push_back({telemetry[i].first, -1, i});
  for (std::size_t i = 0; i < frames.rows.size(); ++i) items.push_back({cell_d(frames, frames.rows[i], "t_s"), 0, i});
  for (std::size_t i = 0; i < odom.rows.size(); ++i) items.push_back({cell_d(odom, odom.rows[i], "t_s"), 1, i});
  for (std::size_t i = 0; i < ticks.rows.size(); ++i) items.push_back({cell_d(ticks, ticks.rows[i], "t_s"), 2, i});
  for (std::size_t i = 0; i < truth.rows.size(); ++i) items.push_back({cell_d(truth, truth.rows[i], "t_s"), 3, i});
  std::stable_sort(items.begin(), items.end(), [](const Item& a, const Item& b) {
    return a.t_s < b.t_s || (a.t_s == b.t_s && a.kind < b.kind);
  });
  ConversionReport report;
  report.exact = true;
  const int file_col = frames.column("file");
  for (const auto& it : items) {
    if (it.kind == -1) {
      VISNAV_TRY(w->telemetry(it.t_s, telemetry[it.row].second));
      ++report.telemetry;
    } else if (it.kind == 0) {
      const auto& row = frames.rows[it.row];
      const fs::path image = d / row[static_cast<std::size_t>(file_col)];
      VISNAV_ASSIGN(std::string data, read_text(image));
      const std::string ext = image.extension().string();
      const std::string format = ext == ".jpg" || ext == ".jpeg" ? "jpeg" : "png";
      if (format == "png" && ext != ".png") return fail(ErrorCode::invalid_value, {image.string()}, "only .png and .jpg frames can go into MCAP");
      const long index = frames.column("index") >= 0 ? static_cast<long>(cell_d(frames, row, "index")) : report.frames;
      VISNAV_TRY(w->frame(index, it.t_s, static_cast<std::uint64_t>(cell_d(frames, row, "sequence")),
                          std::vector<std::uint8_t>(data.begin(), data.end()), format));
      ++report.frames;
    } else if (it.kind == 1) {
      const auto& row = odom.rows[it.row];
      Odometry o;
      o.timestamp_s = it.t_s;
      o.pose = {cell_d(odom, row, "x_m"), cell_d(odom, row, "y_m"), cell_d(odom, row, "heading_rad")};
      o.distance_m = cell_d(odom, row, "distance_m");
      o.twist = {cell_d(odom, row, "linear_mps"), cell_d(odom, row, "angular_radps")};
      VISNAV_TRY(w->odometry(o));
      ++report.odometry_samples;
    } else if (it.kind == 2) {
      const auto& row = ticks.rows[it.row];
      VISNAV_TRY(w->tick(static_cast<std::uint64_t>(cell_d(ticks, row, "tick")), it.t_s,
                         static_cast<long>(cell_d(ticks, row, "frame_index")),
                         {cell_d(ticks, row, "linear_mps"), cell_d(ticks, row, "angular_radps")},
                         static_cast<std::uint64_t>(cell_d(ticks, row, "commands_sent"))));
      ++report.ticks;
    } else {
      const auto& row = truth.rows[it.row];
      VISNAV_TRY(w->truth(it.t_s, {cell_d(truth, row, "x_m"), cell_d(truth, row, "y_m"), cell_d(truth, row, "heading_rad")}));
    }
  }
  const double end_s = items.empty() ? 0.0 : items.back().t_s;
  if (auto text = read_text(d / "config.yaml")) VISNAV_TRY(w->attach("config.yaml", *text, end_s));
  if (auto text = read_text(d / "run.yaml")) VISNAV_TRY(w->attach("run.yaml", *text, end_s));
  VISNAV_TRY(w->close());
  return report;
}

}  // namespace visnav::mcap
