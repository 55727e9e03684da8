// An out-of-tree plugin carrying two kinds in one descriptor: a robot driver and a detector.
//
//  * robot `line_robot`: a base that speaks a text protocol over two byte streams (a serial
//    port, a pair of FIFOs, a pty): visnav writes one command per line, "CMD <v_mps> <w_radps>",
//    to `command_path`, and reads odometry lines, "ODOM <t_s> <x_m> <y_m> <heading_rad>
//    <distance_m>", from `odometry_path`. Many hobby and research bases speak something like it.
//  * detector `fast_orb`: FAST corners described by ORB, strongest `max_keypoints` kept.
//
// docs/plugins.md walks through this file; tests/runtime/cli/test_out_of_tree.cpp builds it
// against the installed SDK and drives both types through the real loader.
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/features2d.hpp>

#include <visnav/plugin.hpp>

namespace {

struct LineRobotParams {
  std::string command_path;   // written: one "CMD v w" line per command
  std::string odometry_path;  // read: "ODOM t x y heading distance" lines
  double max_linear_mps = 0.5;

  visnav::Status validate() const {
    if (command_path.empty() || odometry_path.empty())
      return visnav::fail(visnav::ErrorCode::missing, {{}, 0, command_path.empty() ? "command_path" : "odometry_path"},
                          "keys 'command_path' and 'odometry_path' are required");
    return visnav::ok();
  }
  static const visnav::ParamSchema<LineRobotParams>& schema() {
    static const auto s = visnav::ParamSchema<LineRobotParams>{}
                              .field("command_path", &LineRobotParams::command_path, "stream the commands go to")
                              .field("odometry_path", &LineRobotParams::odometry_path, "stream odometry comes from")
                              .field("max_linear_mps", &LineRobotParams::max_linear_mps, "speed limit, m/s")
                              .range(0.01, 5.0);
    return s;
  }
};

class LineRobot final : public visnav::Robot {
 public:
  using Params = LineRobotParams;

  static visnav::Result<std::unique_ptr<LineRobot>> create(const visnav::ConfigNode& node, visnav::HostServices&) {
    VISNAV_ASSIGN(Params p, Params::schema().parse(node));
    VISNAV_TRY(p.validate());
    // Non-blocking both ways: a base that stops reading or writing must not stall the tick.
    const int out = ::open(p.command_path.c_str(), O_WRONLY | O_NONBLOCK | O_CLOEXEC);
    if (out < 0) return visnav::fail(visnav::ErrorCode::io, {p.command_path}, std::strerror(errno));
    const int in = ::open(p.odometry_path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (in < 0) {
      ::close(out);
      return visnav::fail(visnav::ErrorCode::io, {p.odometry_path}, std::strerror(errno));
    }
    return std::unique_ptr<LineRobot>(new LineRobot(p, out, in));
  }
  ~LineRobot() override {
    ::close(out_);
    ::close(in_);
  }
  LineRobot(const LineRobot&) = delete;
  LineRobot& operator=(const LineRobot&) = delete;

  visnav::Status send_command(const visnav::Twist& c) override {
    const double v = std::clamp(c.linear_mps, -params_.max_linear_mps, params_.max_linear_mps);
    char line[64];
    const int n = std::snprintf(line, sizeof line, "CMD %.4f %.4f\n", v, c.angular_radps);
    if (::write(out_, line, static_cast<std::size_t>(n)) != n)
      return visnav::fail(params_.command_path + ": command not written: " + std::strerror(errno));
    return visnav::ok();
  }

  std::optional<visnav::Odometry> latest_odometry() override {
    char chunk[512];
    for (ssize_t n; (n = ::read(in_, chunk, sizeof chunk)) > 0;) pending_.append(chunk, static_cast<std::size_t>(n));
    for (std::size_t eol; (eol = pending_.find('\n')) != std::string::npos; pending_.erase(0, eol + 1)) {
      visnav::Odometry o;
      if (std::sscanf(pending_.c_str(), "ODOM %lf %lf %lf %lf %lf", &o.timestamp_s, &o.pose.x_m, &o.pose.y_m,
                      &o.pose.heading_rad, &o.distance_m) == 5)
        latest_ = o;  // a malformed line is skipped; the runtime's odometry checks see gaps
    }
    return latest_;
  }

 private:
  LineRobot(Params p, int out, int in) : params_(std::move(p)), out_(out), in_(in) {}
  Params params_;
  int out_, in_;
  std::string pending_;
  std::optional<visnav::Odometry> latest_;
};

struct FastOrbParams {
  int threshold = 20;
  int max_keypoints = 500;
  visnav::Status validate() const { return visnav::ok(); }
  static const visnav::ParamSchema<FastOrbParams>& schema() {
    static const auto s = visnav::ParamSchema<FastOrbParams>{}
                              .field("threshold", &FastOrbParams::threshold, "FAST threshold, grey levels")
                              .range(1, 255)
                              .field("max_keypoints", &FastOrbParams::max_keypoints, "strongest corners kept")
                              .range(1, 100000);
    return s;
  }
};

class FastOrb final : public visnav::Detector {
 public:
  using Params = FastOrbParams;
  static visnav::Result<std::unique_ptr<FastOrb>> create(const visnav::ConfigNode& node, visnav::HostServices&) {
    VISNAV_ASSIGN(Params p, Params::schema().parse(node));
    return std::make_unique<FastOrb>(p);
  }
  explicit FastOrb(const Params& p)
      : params_(p), fast_(cv::FastFeatureDetector::create(p.threshold)), orb_(cv::ORB::create()) {}

  visnav::Status detect(const cv::Mat& image, visnav::Features& out) override {
    if (image.empty() || (image.type() != CV_8UC1 && image.type() != CV_8UC3))
      return visnav::fail("fast_orb: needs a non-empty 8-bit grey or BGR image");
    out.clear();
    fast_->detect(image, out.keypoints);
    cv::KeyPointsFilter::retainBest(out.keypoints, params_.max_keypoints);  // may keep ties beyond the count
    if (out.keypoints.size() > static_cast<std::size_t>(params_.max_keypoints)) out.keypoints.resize(params_.max_keypoints);
    orb_->compute(image, out.keypoints, out.descriptors);  // drops keypoints too near the border
    out.norm = norm();
    return visnav::ok();
  }
  [[nodiscard]] visnav::DescriptorNorm norm() const override { return visnav::DescriptorNorm::hamming; }

 private:
  Params params_;
  cv::Ptr<cv::FastFeatureDetector> fast_;
  cv::Ptr<cv::ORB> orb_;
};

const visnav::TypeEntry kTypes[] = {
    visnav::make_type<LineRobot>("line_robot", "base speaking CMD/ODOM text lines over two streams"),
    visnav::make_type<FastOrb>("fast_orb", "FAST corners with ORB descriptors"),
};

}  // namespace

VISNAV_PLUGIN({.name = "line_devices", .version = "1.0", .description = "example robot driver and detector",
               .types = kTypes})
