// `visnav record`: record a run (frames, odometry, commands, times) from any camera and robot
// plugin, optionally while running a mission tree. Format: docs/recorded_runs.md; played back by
// `visnav play` (robot and camera type `recorded`).
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "args.hpp"
#include "command.hpp"
#include "session_args.hpp"
#include "visnav/mcap.hpp"
#include "visnav/file_io.hpp"
#include "visnav/runner.hpp"

namespace {

namespace fs = std::filesystem;

constexpr const char* kUsage =
    "usage: visnav record --config C -o RUN [--tree T] [--bb key=value]... [--duration-s S] [--map M [--create]] [--set k=v]...\n"
    "                     [--format folder|mcap] [--compression zstd|lz4|none] [--image-format png|jpg]\n"
    "                     [--jpeg-quality Q] [--force]\n"
    "                     [--plugin-path DIR]... [--log-level L]\n"
    "\n"
    "Builds the robot and camera named in the config C (any plugins: sim, v4l2, video, dds, ...)\n"
    "and records into the folder RUN (docs/recorded_runs.md): every frame the run used (PNG,\n"
    "lossless, or JPEG), every odometry reading, one line per tick with the command sent, every\n"
    "telemetry status the mission publishes, and the simulator's ground truth when the robot is simulated. Every line and image is flushed as it\n"
    "is written, so a killed recording keeps everything before the kill.\n"
    "\n"
    "With --tree the mission runs exactly as `visnav run` runs it and is recorded tick by tick;\n"
    "without, frames and odometry are recorded until --duration-s or Ctrl-C.\n"
    "\n"
    "  --config C           run configuration (docs/config.md)\n"
    "  -o RUN               output folder (created; must be empty unless --force), or file RUN.mcap\n"
    "  --format F           folder (default; lossless) or mcap: one ROS 2 bag file (CompressedImage,\n"
    "                       Odometry, Twist in CDR; `ros2 bag info`, Foxglove) that `visnav play`,\n"
    "                       `visnav evaluate` and `visnav convert` read back exactly\n"
    "  --compression C      mcap: chunk compression zstd (default), lz4 or none\n"
    "  --tree T             mission tree to run while recording\n"
    "  --bb key=value       blackboard entry before the first tick (as `visnav run --bb`; kept in run.yaml)\n"
    "  --duration-s S       stop after S s of run time (0 = until the tree ends / Ctrl-C)\n"
    "  --map M              map folder for the tree (as `visnav run --map`: a bare name is maps/M; must exist\n"
    "                       unless --create)\n"
    "  --create             with --map: create M as an empty map if missing\n"
    "  --set k=v            config override (repeatable)\n"
    "  --image-format F     png (default, lossless: bit-exact playback) or jpg\n"
    "  --jpeg-quality Q     1..100 (default 95)\n"
    "  --force              write into a non-empty RUN (files of an earlier recording are replaced)\n"
    "  --plugin-path DIR    extra plugin directory\n"
    "  --log-level L        overrides run.log_level\n"
    "\n"
    "Play it back with: visnav play RUN --tree T\n"
    "Exit status: as `visnav run` (0 success/stopped by duration, 1 failure/error, 2 usage,\n"
    "3 safety stop, 130 interrupted — the recording is complete up to that moment in every case).\n";

std::string iso_now() {
  const std::time_t now = std::time(nullptr);
  std::tm tm {};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::string yaml_quote(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out.push_back('\\');
    out.push_back(c);
  }
  return out + "\"";
}

struct FileCloser {
  void operator()(std::FILE* f) const noexcept {
    if (f != nullptr) std::fclose(f);
  }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

/// Where a recording goes: the folder format or an MCAP file.
class RunSink {
 public:
  virtual ~RunSink() = default;
  /// Writes the frame unless it is the one written last. Returns its index.
  virtual visnav::Result<long> frame(const visnav::Frame& f) = 0;
  virtual void odometry(const visnav::Odometry& o) = 0;
  virtual void command(std::uint64_t tick, double t_s, long frame_index, const visnav::Twist& c, std::uint64_t sent) = 0;
  virtual void truth(double t_s, const visnav::Pose2D& p) = 0;
  /// A NavStatus the mission published at run-clock time t_s.
  virtual void telemetry(double t_s, const visnav::NavStatus& s) = 0;
  /// Stores run.yaml (`complete` says whether this is the final one) and, at the end, finishes.
  virtual visnav::Status run_info(const std::string& text, bool complete) = 0;
  /// First write error of odometry/command/truth (they cannot fail the tick), or empty.
  [[nodiscard]] virtual std::string error() const { return {}; }
  [[nodiscard]] virtual long frames() const = 0;
  [[nodiscard]] virtual long odometry_rows() const = 0;
};

visnav::Status write_run_info(const std::string& dir, const std::string& text);

/// Writes the recorded-run files; every row is flushed at once (crash safety).
class RunWriter final : public RunSink {
 public:
  static visnav::Result<std::unique_ptr<RunWriter>> create(const std::string& dir, const std::string& image_format,
                                                           int jpeg_quality, bool with_truth) {
    std::unique_ptr<RunWriter> w(new RunWriter());
    w->dir_ = dir;
    w->ext_ = image_format == "jpg" ? ".jpg" : ".png";
    w->jpeg_quality_ = jpeg_quality;
    std::error_code ec;
    fs::create_directories(fs::path(dir) / "frames", ec);
    if (ec) return visnav::fail(dir + ": cannot create the run folder: " + ec.message());
    auto open = [&](const char* name, const char* header, FilePtr& f) -> visnav::Status {
      const std::string path = (fs::path(dir) / name).string();
      f.reset(std::fopen(path.c_str(), "w"));
      if (!f) return visnav::fail(path + ": cannot be written: " + std::strerror(errno));
      std::fputs(header, f.get());
      std::fflush(f.get());
      return visnav::ok();
    };
    VISNAV_TRY(open("frames.csv", "index,t_s,sequence,file\n", w->frames_));
    VISNAV_TRY(open("odometry.csv", "t_s,x_m,y_m,heading_rad,distance_m,linear_mps,angular_radps\n", w->odometry_));
    VISNAV_TRY(open("commands.csv", "tick,t_s,frame_index,linear_mps,angular_radps,commands_sent\n", w->commands_));
    if (with_truth) VISNAV_TRY(open("ground_truth.csv", "t_s,x_m,y_m,heading_rad\n", w->truth_));
    VISNAV_TRY(open("telemetry.jsonl", "", w->telemetry_));
    return w;
  }

  visnav::Result<long> frame(const visnav::Frame& f) override {
    if (last_frame_ && last_frame_->first == f.sequence && last_frame_->second == f.timestamp_s) return frame_index_ - 1;
    char name[32];
    std::snprintf(name, sizeof name, "%06ld", frame_index_);
    const std::string rel = std::string("frames/") + name + ext_;
    const fs::path final_path = fs::path(dir_) / rel;
    const fs::path tmp = fs::path(dir_) / "frames" / (std::string(".") + name + ".tmp" + ext_);
    std::vector<int> params;
    if (ext_ == ".jpg") params = {cv::IMWRITE_JPEG_QUALITY, jpeg_quality_};
    else params = {cv::IMWRITE_PNG_COMPRESSION, 1};
    bool written = false;
    try {
      written = cv::imwrite(tmp.string(), f.image, params);
    } catch (const cv::Exception& e) {
      return visnav::fail(tmp.string() + ": cannot encode the frame: " + e.what());
    }
    if (!written) return visnav::fail(tmp.string() + ": cannot write the frame");
    std::error_code ec;
    fs::rename(tmp, final_path, ec);
    if (ec) return visnav::fail(final_path.string() + ": cannot rename the frame into place: " + ec.message());
    std::fprintf(frames_.get(), "%ld,%.17g,%llu,%s\n", frame_index_, f.timestamp_s,
                 static_cast<unsigned long long>(f.sequence), rel.c_str());
    std::fflush(frames_.get());
    last_frame_ = std::make_pair(f.sequence, f.timestamp_s);
    return frame_index_++;
  }

  void odometry(const visnav::Odometry& o) override {
    if (last_odometry_s_ && *last_odometry_s_ == o.timestamp_s) return;
    std::fprintf(odometry_.get(), "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", o.timestamp_s, o.pose.x_m, o.pose.y_m,
                 o.pose.heading_rad, o.distance_m, o.twist.linear_mps, o.twist.angular_radps);
    std::fflush(odometry_.get());
    last_odometry_s_ = o.timestamp_s;
    ++odometry_rows_;
  }

  void command(std::uint64_t tick, double t_s, long frame_index, const visnav::Twist& c, std::uint64_t sent) override {
    std::fprintf(commands_.get(), "%llu,%.17g,%ld,%.17g,%.17g,%llu\n", static_cast<unsigned long long>(tick), t_s, frame_index,
                 c.linear_mps, c.angular_radps, static_cast<unsigned long long>(sent));
    std::fflush(commands_.get());
  }

  void truth(double t_s, const visnav::Pose2D& p) override {
    if (!truth_) return;
    std::fprintf(truth_.get(), "%.17g,%.17g,%.17g,%.17g\n", t_s, p.x_m, p.y_m, p.heading_rad);
    std::fflush(truth_.get());
  }

  void telemetry(double t_s, const visnav::NavStatus& s) override {
    std::fputs((visnav::mcap::telemetry_json(t_s, s) + "\n").c_str(), telemetry_.get());
    std::fflush(telemetry_.get());
  }

  visnav::Status run_info(const std::string& text, bool /*complete*/) override { return write_run_info(dir_, text); }
  [[nodiscard]] long frames() const override { return frame_index_; }
  [[nodiscard]] long odometry_rows() const override { return odometry_rows_; }

 private:
  RunWriter() = default;
  std::string dir_;
  std::string ext_;
  int jpeg_quality_ = 95;
  FilePtr frames_, odometry_, commands_, truth_, telemetry_;
  long frame_index_ = 0;
  long odometry_rows_ = 0;
  std::optional<std::pair<std::uint64_t, double>> last_frame_;
  std::optional<double> last_odometry_s_;
};

/// Writes the recording as one MCAP file (visnav/mcap.hpp, "Recorded runs as MCAP"). Chunks are
/// flushed as they fill, so a killed recording keeps every complete chunk.
class McapSink final : public RunSink {
 public:
  static visnav::Result<std::unique_ptr<McapSink>> create(const std::string& path, const std::string& config_file,
                                                          const std::string& image_format, int jpeg_quality, bool with_truth,
                                                          const std::string& compression) {
    std::unique_ptr<McapSink> s(new McapSink());
    visnav::mcap::WriterOptions options;
    options.compress = compression != "none";
    if (options.compress) options.compression = compression;
    VISNAV_ASSIGN(s->writer_, visnav::mcap::RunMcapWriter::create(path, with_truth, options));
    VISNAV_ASSIGN(s->config_text_, visnav::read_text_file(config_file, visnav::kMaxConfigFileBytes, "config"));
    s->jpg_ = image_format == "jpg";
    s->jpeg_quality_ = jpeg_quality;
    return s;
  }
  visnav::Result<long> frame(const visnav::Frame& f) override {
    if (last_frame_ && last_frame_->first == f.sequence && last_frame_->second == f.timestamp_s) return frame_index_ - 1;
    std::vector<int> params = jpg_ ? std::vector<int>{cv::IMWRITE_JPEG_QUALITY, jpeg_quality_}
                                   : std::vector<int>{cv::IMWRITE_PNG_COMPRESSION, 1};
    try {
      if (!cv::imencode(jpg_ ? ".jpg" : ".png", f.image, buffer_, params)) return visnav::fail("cannot encode the frame");
    } catch (const cv::Exception& e) {
      return visnav::fail(std::string("cannot encode the frame: ") + e.what());
    }
    VISNAV_TRY(writer_->frame(frame_index_, f.timestamp_s, f.sequence, buffer_, jpg_ ? "jpeg" : "png"));
    last_frame_ = std::make_pair(f.sequence, f.timestamp_s);
    last_t_s_ = f.timestamp_s;
    return frame_index_++;
  }
  void odometry(const visnav::Odometry& o) override {
    if (last_odometry_s_ && *last_odometry_s_ == o.timestamp_s) return;
    keep(writer_->odometry(o));
    last_odometry_s_ = o.timestamp_s;
    ++odometry_rows_;
  }
  void command(std::uint64_t tick, double t_s, long frame_index, const visnav::Twist& c, std::uint64_t sent) override {
    keep(writer_->tick(tick, t_s, frame_index, c, sent));
    last_t_s_ = t_s;
  }
  void truth(double t_s, const visnav::Pose2D& p) override { keep(writer_->truth(t_s, p)); }
  void telemetry(double t_s, const visnav::NavStatus& s) override { keep(writer_->telemetry(t_s, s)); }
  visnav::Status run_info(const std::string& text, bool complete) override {
    if (!complete) return visnav::ok();  // the final run.yaml is attached at the end
    VISNAV_TRY(writer_->attach("config.yaml", config_text_, last_t_s_));
    VISNAV_TRY(writer_->attach("run.yaml", text, last_t_s_));
    return writer_->close();
  }
  [[nodiscard]] std::string error() const override { return error_; }
  [[nodiscard]] long frames() const override { return frame_index_; }
  [[nodiscard]] long odometry_rows() const override { return odometry_rows_; }

 private:
  McapSink() = default;
  void keep(const visnav::Status& st) {
    if (!st && error_.empty()) error_ = st.error().message;
  }
  std::unique_ptr<visnav::mcap::RunMcapWriter> writer_;
  std::string config_text_;
  bool jpg_ = false;
  int jpeg_quality_ = 95;
  std::vector<std::uint8_t> buffer_;
  long frame_index_ = 0;
  long odometry_rows_ = 0;
  double last_t_s_ = 0.0;
  std::optional<std::pair<std::uint64_t, double>> last_frame_;
  std::optional<double> last_odometry_s_;
  std::string error_;
};

/// Records every NavStatus the mission publishes: one more telemetry sink of the session, beside
/// run.telemetry_file, DDS and the live view, while it exists.
class TelemetryTap final : public visnav::Telemetry {
 public:
  TelemetryTap(visnav::Session& session, RunSink& sink) : session_(session), sink_(sink) {
    session_.add_telemetry_sink(this);
  }
  ~TelemetryTap() override { session_.remove_telemetry_sink(this); }
  TelemetryTap(const TelemetryTap&) = delete;
  TelemetryTap& operator=(const TelemetryTap&) = delete;
  void publish(const visnav::NavStatus& s) override { sink_.telemetry(session_.clock().now_s(), s); }

 private:
  visnav::Session& session_;
  RunSink& sink_;
};

/// Writes run.yaml crash-safely (temporary file + rename).
visnav::Status write_run_info(const std::string& dir, const std::string& text) {
  const fs::path final_path = fs::path(dir) / "run.yaml";
  const fs::path tmp = fs::path(dir) / ".run.yaml.tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << text;
    out.flush();
    if (!out) return visnav::fail(tmp.string() + ": cannot be written");
  }
  std::error_code ec;
  fs::rename(tmp, final_path, ec);
  if (ec) return visnav::fail(final_path.string() + ": " + ec.message());
  return visnav::ok();
}

/// The command line of `visnav record`, checked.
struct RecordOptions {
  std::string out_dir;
  std::string config_file;
  std::vector<std::string> overrides;  ///< --set
  std::vector<std::string> bb;         ///< --bb
  std::string tree_file;               ///< empty: record without a mission
  double duration_s = 0.0;             ///< 0: until the tree ends / Ctrl-C
  int jpeg_quality = 95;
  std::string image_format = "png";    ///< png | jpg
  std::string format = "folder";       ///< folder | mcap
  std::string compression = "zstd";    ///< mcap: zstd | lz4 | none
  bool force = false;
};

/// Parses and checks the options; an error is a usage error (exit 2).
visnav::Result<RecordOptions> parse_record_options(const std::vector<std::string>& args, visnav::cli::Args& a) {
  using visnav::cli::Opt;
  VISNAV_TRY(a.parse(args, {{"--config", Opt::value}, {"-o", Opt::value}, {"--out", Opt::value}, {"--tree", Opt::value},
                            {"--duration-s", Opt::value}, {"--map", Opt::value}, {"--create", Opt::flag}, {"--set", Opt::repeated},
                            {"--bb", Opt::repeated}, {"--image-format", Opt::value}, {"--jpeg-quality", Opt::value},
                            {"--force", Opt::flag}, {"--format", Opt::value}, {"--compression", Opt::value},
                            {"--plugin-path", Opt::repeated}, {"--log-level", Opt::value}}));
  VISNAV_TRY(a.require({"--config"}));
  RecordOptions o;
  o.out_dir = a.get("-o", a.get("--out"));
  if (o.out_dir.empty()) return visnav::fail(visnav::ErrorCode::missing, "missing required option: -o RUN");
  try {
    o.duration_s = std::stod(a.get("--duration-s", "0"));
    o.jpeg_quality = std::stoi(a.get("--jpeg-quality", "95"));
  } catch (...) {
    return visnav::fail(visnav::ErrorCode::invalid_value, "--duration-s and --jpeg-quality need numbers");
  }
  using visnav::ErrorCode;
  if (o.duration_s < 0.0) return visnav::fail(ErrorCode::out_of_range, "--duration-s must be >= 0");
  if (o.jpeg_quality < 1 || o.jpeg_quality > 100) return visnav::fail(ErrorCode::out_of_range, "--jpeg-quality must be in [1, 100]");
  o.image_format = a.get("--image-format", "png");
  if (o.image_format != "png" && o.image_format != "jpg")
    return visnav::fail(ErrorCode::out_of_range, "--image-format must be png or jpg, got '" + o.image_format + "'");
  o.format = a.get("--format", "folder");
  if (o.format != "folder" && o.format != "mcap")
    return visnav::fail(ErrorCode::out_of_range, "--format must be folder or mcap, got '" + o.format + "'");
  o.compression = a.get("--compression", "zstd");
  if (o.compression != "zstd" && o.compression != "lz4" && o.compression != "none")
    return visnav::fail(ErrorCode::out_of_range, "--compression must be zstd, lz4 or none, got '" + o.compression + "'");
  if (a.has("--compression") && o.format != "mcap") return visnav::fail(ErrorCode::inconsistent, "--compression needs --format mcap");
  if (a.has("--log-level")) VISNAV_TRY(visnav::parse_log_level(a.get("--log-level")));
  o.config_file = a.get("--config");
  o.overrides = a.all("--set");
  o.bb = a.all("--bb");
  o.tree_file = a.get("--tree");
  o.force = a.has("--force");
  return o;
}

/// The output must not overwrite an earlier recording unless --force.
visnav::Status check_output_free(const RecordOptions& o) {
  std::error_code ec;
  if (o.force || !fs::exists(o.out_dir, ec)) return visnav::ok();
  if (o.format == "mcap") return visnav::fail(o.out_dir + " exists (use --force to overwrite it)");
  if (!fs::is_empty(o.out_dir, ec))
    return visnav::fail(o.out_dir + " exists and is not empty (use --force to record into it)");
  return visnav::ok();
}

/// The sink of the chosen format; the folder format also keeps a copy of the config.
visnav::Result<std::unique_ptr<RunSink>> make_sink(const RecordOptions& o, bool with_truth) {
  if (o.format == "mcap") {
    VISNAV_ASSIGN(auto made, McapSink::create(o.out_dir, o.config_file, o.image_format, o.jpeg_quality, with_truth, o.compression));
    return std::unique_ptr<RunSink>(std::move(made));
  }
  VISNAV_ASSIGN(auto made, RunWriter::create(o.out_dir, o.image_format, o.jpeg_quality, with_truth));
  // The configuration used, so `visnav play RUN` can rebuild the same detector and nodes.
  std::error_code ec;
  fs::copy_file(o.config_file, fs::path(o.out_dir) / "config.yaml", fs::copy_options::overwrite_existing, ec);
  if (ec) return visnav::fail(visnav::ErrorCode::io, "cannot copy " + o.config_file + " into " + o.out_dir + ": " + ec.message());
  return std::unique_ptr<RunSink>(std::move(made));
}

/// run.yaml's fixed part: what was recorded and how.
std::string run_info_header(const RecordOptions& o, const visnav::Session& session) {
  std::ostringstream info;
  info << "format: visnav-recorded-run\nversion: 1\ncreated: " << iso_now() << "\n"
       << "config: " << yaml_quote(fs::absolute(o.config_file).lexically_normal().string()) << "\n"
       << "overrides: [";
  for (std::size_t i = 0; i < o.overrides.size(); ++i) info << (i ? ", " : "") << yaml_quote(o.overrides[i]);
  info << "]\nblackboard: [";
  for (std::size_t i = 0; i < o.bb.size(); ++i) info << (i ? ", " : "") << yaml_quote(o.bb[i]);
  info << "]\n"
       << "robot: " << yaml_quote(session.config().robot.type) << "\ncamera: " << yaml_quote(session.config().camera.type) << "\n"
       << "tree: " << yaml_quote(o.tree_file.empty() ? std::string() : fs::absolute(o.tree_file).lexically_normal().string())
       << "\n"
       << "lockstep: " << (session.lockstep() ? "true" : "false") << "\n"
       << "image_format: " << o.image_format << "\n";
  return info.str();
}

/// Writes what the run used this tick: the newest frame and odometry, the command (with a
/// mission) and the simulator's ground truth. False when a frame could not be written.
class TickRecorder {
 public:
  TickRecorder(visnav::Session& session, RunSink& sink) : session_(session), sink_(sink), sim_(session.robot().simulation()) {}
  bool record(std::uint64_t tick, double t_s, bool with_command) {
    visnav::FrameBus& bus = session_.frame_bus();
    long frame_index = -1;
    if (auto f = bus.latest_frame()) {
      auto idx = sink_.frame(*f);
      if (!idx) {
        error_ = idx.error().message;
        return false;
      }
      frame_index = *idx;
    }
    if (auto o = bus.latest_odometry()) sink_.odometry(*o);
    if (with_command)
      sink_.command(tick, t_s, frame_index, session_.robot().last_command(), session_.robot().commands_sent());
    if (sim_ != nullptr) sink_.truth(sim_->time_s(), sim_->ground_truth_pose());
    return true;
  }
  [[nodiscard]] const std::string& error() const { return error_; }

 private:
  visnav::Session& session_;
  RunSink& sink_;
  visnav::SimulationControl* sim_;
  std::string error_;
};

/// No mission: grab and record until the duration, the camera's end or a signal.
visnav::RunReport record_without_mission(visnav::Session& session, RunSink& sink, TickRecorder& recorder, double duration_s) {
  visnav::RunReport report;
  visnav::Camera& camera = session.camera();
  visnav::SimulationControl* sim = session.robot().simulation();
  const double start_s = session.clock().now_s();
  const double period_s = 1.0 / session.config().run.rate_hz;
  report.outcome = visnav::RunOutcome::stopped;
  report.exit_code = 0;
  for (;;) {
    if (visnav::signal_flag().load() != 0) {
      report.outcome = visnav::RunOutcome::interrupted;
      report.exit_code = 128 + visnav::signal_flag().load();
      break;
    }
    if (duration_s > 0.0 && session.clock().now_s() - start_s >= duration_s) break;
    if (session.lockstep()) {
      if (auto st = sim->step(period_s); !st) {
        report.reason = "simulation step failed: " + st.error().message;
        break;
      }
    }
    auto grabbed = camera.grab(session.lockstep() ? 0.0 : 0.05);
    if (!grabbed) {
      report.reason = "camera: " + grabbed.error().message;  // e.g. the end of a video
      break;
    }
    auto odo = session.robot().latest_odometry();
    if (odo) session.frame_bus().publish_odometry(*odo);
    if (grabbed->has_value() && odo) {
      session.frame_bus().publish_frame(std::move(**grabbed));
      ++report.ticks;
      if (!recorder.record(report.ticks, session.clock().now_s(), false)) break;
    } else if (odo) {
      sink.odometry(*odo);
    }
  }
  report.run_time_s = session.clock().now_s() - start_s;
  (void)session.robot().stop();
  return report;
}

int record(const std::vector<std::string>& args) {
  visnav::cli::Args a;
  auto parsed = parse_record_options(args, a);
  if (!parsed) return visnav::cli::usage_error("record", parsed.error().message);
  const RecordOptions& o = *parsed;
  auto report_error = [](const visnav::Error& e) {
    std::cerr << "visnav record: " << e.message << "\n";
    return 1;
  };
  if (auto st = check_output_free(o); !st) return report_error(st.error());
  auto session_made = visnav::cli::open_session(a, o.config_file, o.overrides);
  if (!session_made) return report_error(session_made.error());
  visnav::Session& session = **session_made;
  std::optional<visnav::bt::Tree> tree;
  if (!o.tree_file.empty()) {
    auto loaded = session.load_tree(o.tree_file);
    if (!loaded) return report_error(loaded.error());
    tree.emplace(std::move(*loaded));
    if (auto st = visnav::set_blackboard_values(*tree, o.bb); !st) return report_error(st.error());
  }
  auto sink = make_sink(o, session.robot().simulation() != nullptr);
  if (!sink) return report_error(sink.error());
  RunSink& writer = **sink;
  const std::string header = run_info_header(o, session);
  if (auto st = writer.run_info(header + "complete: false\n", false); !st) return report_error(st.error());

  visnav::install_signal_handlers();
  TickRecorder recorder(session, writer);
  visnav::RunReport report;
  if (tree) {
    const double start_s = session.clock().now_s();
    visnav::RunOptions ro;
    TelemetryTap tap(session, writer);
    ro.after_tick = [&](const visnav::TickInfo& t) {
      if (!recorder.record(t.tick, t.t_s, true)) return false;
      return !(o.duration_s > 0.0 && t.t_s - start_s >= o.duration_s);
    };
    report = visnav::run_tree(session, *tree, ro);
  } else {
    report = record_without_mission(session, writer, recorder, o.duration_s);
  }
  std::string write_error = recorder.error().empty() ? writer.error() : recorder.error();
  if (!write_error.empty()) {
    std::cerr << "visnav record: " << write_error << "\n";
    report.exit_code = 1;
  }
  std::ostringstream summary;
  summary << header << "complete: true\noutcome: " << yaml_quote(visnav::to_string(report.outcome)) << "\n"
          << "reason: " << yaml_quote(report.reason) << "\nticks: " << report.ticks << "\nframes: " << writer.frames()
          << "\nodometry_samples: " << writer.odometry_rows() << "\nrun_time_s: " << report.run_time_s << "\n";
  if (auto st = writer.run_info(summary.str(), true); !st) std::cerr << "visnav record: " << st.error().message << "\n";
  std::cout << "visnav record: " << visnav::to_string(report.outcome) << ", " << writer.frames() << " frames, "
            << writer.odometry_rows() << " odometry samples, " << report.ticks << " ticks, " << report.run_time_s
            << " s run time -> " << o.out_dir << "\n";
  if (!report.reason.empty()) std::cerr << "visnav record: " << report.reason << "\n";
  return report.exit_code;
}

}  // namespace

VISNAV_COMMAND(record, "record", "record a run (frames, odometry, commands) from any camera and robot", kUsage, &record)
