// The `robot_recorded` plugin: robot type `recorded` (docs/recorded_runs.md).
//
// Plays back odometry and drives time; the robot never moves.
//  * Time: the robot offers SimulationControl, so the session runs in lock-step with the run clock
//    = this robot's time. step(dt) moves the time to the next time step: the live run's tick
//    times (RUN/commands.csv, when the run was recorded with a mission), else the frame times
//    (RUN/frames.csv, or `frame_times_file`), i.e. one recorded tick/frame per tick; after the
//    last one step() fails with "end of the recorded run", which ends the run. Without any
//    time list the time advances by dt.
//  * Odometry: latest_odometry() = the log's reading at the current time (odometry_sync latest:
//    the sample at or before it — exactly what the live robot reported; interpolate: linear
//    interpolation). At creation every frame time is checked to have odometry within
//    max_frame_gap_s (error naming the frames file and line).
//  * Commands: accepted, counted, logged at debug level and, with `commands_file`, appended as
//    CSV t_s,linear_mps,angular_radps (flushed per line).
//  * ground_truth_pose(): RUN/ground_truth.csv at the current time when recorded (simulated
//    runs), else the odometry pose. set_ground_truth_pose() is refused.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "visnav/plugin.hpp"
#include "visnav/recorded/csv.hpp"
#include "visnav/recorded/image_pipeline.hpp"
#include "visnav/recorded/odometry_log.hpp"
#include "visnav/recorded/run_format.hpp"

namespace {

using namespace visnav;
using namespace visnav::recorded;
namespace fs = std::filesystem;

struct RecordedRobotParams {
  std::string run_dir;
  std::string odometry_file;
  std::string frame_times_file;
  std::string odometry_sync = "latest";
  double max_frame_gap_s = 0.5;
  std::string commands_file;

  [[nodiscard]] Status validate() const {
    if (run_dir.empty() && odometry_file.empty())
      return Error{"give 'run_dir' (a recorded run) or 'odometry_file'", ErrorCode::missing, {{}, 0, "run_dir"}};
    return ok();
  }
  static const ParamSchema<RecordedRobotParams>& schema() {
    static const auto s =
        ParamSchema<RecordedRobotParams>{}
            .field("run_dir", &RecordedRobotParams::run_dir, "recorded-run folder: frames.csv drives time, odometry.csv is replayed")
            .field("odometry_file", &RecordedRobotParams::odometry_file,
                   "odometry log (CSV or YAML: t_s and x_m;y_m[;heading_rad] or distance_m); '' = RUN/odometry.csv")
            .field("frame_times_file", &RecordedRobotParams::frame_times_file,
                   "frame times that drive the clock (a frames.csv or an image folder's timestamps.csv); '' = RUN/frames.csv")
            .field("odometry_sync", &RecordedRobotParams::odometry_sync,
                   "latest: the sample at or before the frame time; interpolate: linear between samples")
            .one_of({"latest", "interpolate"})
            .field("max_frame_gap_s", &RecordedRobotParams::max_frame_gap_s,
                   "a frame farther than this from its odometry is an error at load, s").range(0.0, 3600.0)
            .field("commands_file", &RecordedRobotParams::commands_file,
                   "append received commands here as CSV (t_s,linear_mps,angular_radps); '' = off");
    return s;
  }
};

struct FileCloser {
  void operator()(std::FILE* f) const noexcept {
    if (f != nullptr) std::fclose(f);
  }
};

class RecordedRobot final : public Robot, public SimulationControl {
 public:
  using Params = RecordedRobotParams;

  static Result<std::unique_ptr<RecordedRobot>> create(const ConfigNode& node, HostServices& host) {
    VISNAV_ASSIGN(Params p, Params::schema().parse(node));
    const std::string base = config_folder(node.where().file);
    std::unique_ptr<RecordedRobot> r(new RecordedRobot(host));
    r->sync_ = p.odometry_sync == "interpolate" ? OdometrySync::interpolate : OdometrySync::latest;
    const std::string run_dir = resolve_path(p.run_dir, base);
    if (!run_dir.empty()) VISNAV_TRY(check_run_folder(run_dir));

    std::string odo_path = resolve_path(p.odometry_file, base);
    if (odo_path.empty()) odo_path = (fs::path(run_dir) / kOdometryFile).string();
    VISNAV_ASSIGN(r->log_, OdometryLog::load(odo_path));

    std::string times_path = resolve_path(p.frame_times_file, base);
    if (times_path.empty() && !run_dir.empty()) times_path = (fs::path(run_dir) / kFramesFile).string();
    if (!times_path.empty()) {
      VISNAV_ASSIGN(r->frames_, load_times(times_path));
      r->times_file_ = times_path;
      VISNAV_TRY(r->log_.check_coverage(r->frames_, times_path, p.max_frame_gap_s, r->sync_));
      if (p.frame_times_file.empty()) {
        // A run recorded with a mission: step through the live run's tick times (commands.csv),
        // so ticks without a new frame and camera latency are reproduced as well.
        VISNAV_ASSIGN(auto ticks, load_tick_times(run_dir));
        if (!ticks.empty()) {
          r->frames_ = std::move(ticks);
          r->times_file_ = (fs::path(run_dir) / kCommandsFile).string();
        }
      }
      if (!r->frames_.empty()) r->time_s_ = r->frames_.front().t_s;
    } else {
      r->time_s_ = r->log_.samples().front().timestamp_s;
    }
    if (!run_dir.empty()) {
      VISNAV_ASSIGN(r->truth_, read_ground_truth(run_dir));
    }
    if (!p.commands_file.empty()) {
      const std::string path = resolve_path(p.commands_file, base);
      r->commands_.reset(std::fopen(path.c_str(), "w"));
      if (!r->commands_) return fail(ErrorCode::io, {path, 0, "commands_file"}, "cannot be written");
      std::fputs("t_s,linear_mps,angular_radps\n", r->commands_.get());
      std::fflush(r->commands_.get());
    }
    host.logger().info("robot_recorded", odo_path + ": " + std::to_string(r->log_.samples().size()) + " odometry samples" +
                                             (times_path.empty() ? std::string()
                                                                 : ", " + std::to_string(r->frames_.size()) + " frame times from " + times_path));
    return r;
  }

  Status send_command(const Twist& command) override {
    ++commands_sent_;
    host_->logger().log(LogLevel::debug, "robot_recorded",
                        "command " + std::to_string(command.linear_mps) + " m/s, " +
                            std::to_string(command.angular_radps) + " rad/s at t = " + std::to_string(time_s_) + " s");
    if (commands_) {
      std::fprintf(commands_.get(), "%.17g,%.17g,%.17g\n", time_s_, command.linear_mps, command.angular_radps);
      std::fflush(commands_.get());
    }
    return ok();
  }
  std::optional<Odometry> latest_odometry() override { return log_.sample_at(time_s_, sync_); }
  SimulationControl* simulation() override { return this; }

  Status step(double dt_s) override {
    if (frames_.empty()) {
      time_s_ += dt_s;
      return ok();
    }
    if (next_frame_ >= frames_.size())
      return fail(ErrorCode::missing, {times_file_}, "end of the recorded run after " + std::to_string(frames_.size()) + " time steps (t = " +
                  std::to_string(time_s_) + " s)");
    time_s_ = frames_[next_frame_++].t_s;
    return ok();
  }
  [[nodiscard]] double time_s() const override { return time_s_; }
  [[nodiscard]] Pose2D ground_truth_pose() const override {
    if (!truth_.empty()) {
      auto it = std::upper_bound(truth_.begin(), truth_.end(), time_s_ + 1e-9,
                                 [](double t, const std::pair<double, Pose2D>& s) { return t < s.first; });
      if (it != truth_.begin()) return (it - 1)->second;
    }
    auto odo = log_.sample_at(time_s_, sync_);
    return odo ? odo->pose : Pose2D{};
  }
  Status set_ground_truth_pose(const Pose2D&) override {
    return fail("robot 'recorded' plays back a recording and cannot be teleported");
  }

 private:
  explicit RecordedRobot(HostServices& host) : host_(&host) {}

  static Result<std::vector<TimedLine>> load_times(const std::string& path) {
    if (fs::path(path).filename() == kFramesFile) {
      VISNAV_ASSIGN(FrameList list, read_run_frames(fs::path(path).parent_path().string()));
      return list.times();
    }
    // An image folder's timestamps file: times only (the images are the camera's business).
    VISNAV_ASSIGN(FrameList list, list_image_folder(fs::path(path).parent_path().string(), path, 1.0));
    return list.times();
  }

  /// Tick times of RUN/commands.csv (empty when the file is missing or has no rows).
  static Result<std::vector<TimedLine>> load_tick_times(const std::string& run_dir) {
    std::vector<TimedLine> out;
    const std::string path = (fs::path(run_dir) / kCommandsFile).string();
    std::error_code ec;
    if (!fs::exists(path, ec)) return out;
    VISNAV_ASSIGN(CsvTable table, read_csv(path));
    const auto ct = table.column({"t_s"});
    if (!ct) return fail(ErrorCode::missing, {path, table.header_line}, "needs a column t_s");
    for (const CsvRow& row : table.rows) {
      VISNAV_ASSIGN(double t, csv_number(row.fields[*ct], table.where(row), "t_s"));
      if (!out.empty() && t < out.back().t_s)
        return fail(ErrorCode::inconsistent, table.where(row, "t_s"), "tick time " + std::to_string(t) + " s is earlier than the previous one");
      out.push_back(TimedLine{t, row.line});
    }
    return out;
  }

  HostServices* host_;
  OdometryLog log_;
  OdometrySync sync_ = OdometrySync::latest;
  std::vector<TimedLine> frames_;
  std::string times_file_;
  std::size_t next_frame_ = 0;
  double time_s_ = 0.0;
  std::vector<std::pair<double, Pose2D>> truth_;
  std::unique_ptr<std::FILE, FileCloser> commands_;
  std::uint64_t commands_sent_ = 0;
};

const TypeEntry kTypes[] = {
    make_type<RecordedRobot>("recorded", "plays back recorded odometry; lock-step time from the recorded frames")};

}  // namespace

VISNAV_PLUGIN({.name = "robot_recorded",
               .version = "0.1.0",
               .description = "recorded run as a robot",
               .types = kTypes})
