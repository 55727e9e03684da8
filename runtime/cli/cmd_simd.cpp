// `visnav simd`: the simulated robot and camera as their own process, exposed over DDS with
// ROS 2 topics and types, in real time, so `visnav run` with the `dds` robot and camera drives
// it from another process or machine.
//
// The robot and camera are the `sim` plugins, created through the plugin loader like any other
// robot/camera (the runtime never includes the simulator's headers). The main thread steps the
// simulation in real time at --rate, applies the newest cmd_vel and publishes odometry; a
// second thread renders and publishes camera images at --camera-rate.
//
// Command watchdog: when no cmd_vel arrived for --command-timeout seconds (default 0.25), simd
// commands zero velocity and brakes at --brake-decel (the sim robot's acceleration limits are
// raised to the brake values until the next command arrives), so a killed or hung navigation
// process leaves the robot standing.
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <mutex>
#include <thread>

#include <opencv2/imgcodecs.hpp>

#include "args.hpp"
#include "command.hpp"
#include "visnav/config.hpp"
#include "visnav/dds.hpp"
#include "visnav/loader.hpp"
#include "visnav/runtime_host.hpp"

namespace {

namespace dds = visnav::dds;

constexpr const char* kUsage =
    "usage: visnav simd --world W [--domain N] [--partition P] [--rate HZ] [--camera-rate HZ]\n"
    "                   [--command-timeout S] [--brake-decel MPS2] [--transport raw|compressed]\n"
    "                   [--jpeg-quality Q] [--cmd-vel-topic T] [--odom-topic T] [--image-topic T]\n"
    "                   [--ground-truth-topic T] [--robot-param k=v]... [--camera-param k=v]...\n"
    "                   [--cmd-vel-writer GUID|first] [--control-topic T] [--no-control]\n"
    "                   [--keystore DIR --identity NAME]\n"
    "                   [--duration S] [--plugin-path DIR]... [--log-level L]\n"
    "\n"
    "Runs the simulated robot (type sim) in world W and its camera (type sim) in real time and\n"
    "exposes them over Cyclone DDS with ROS 2 names and types:\n"
    "  subscribes  rt/cmd_vel                    geometry_msgs/Twist (reliable or best effort)\n"
    "  publishes   rt/odom                       nav_msgs/Odometry at --rate (reliable, keep-last 10)\n"
    "              rt/camera/image_raw           sensor_msgs/Image bgr8/mono8 at --camera-rate (best effort)\n"
    "           or rt/camera/image_raw/compressed sensor_msgs/CompressedImage jpeg (--transport compressed)\n"
    "              rt/visnav/sim/ground_truth    nav_msgs/Odometry, world frame (evaluation only)\n"
    "Drive it with `visnav run` and the `dds` robot and camera (docs/dds.md).\n"
    "\n"
    "  --world W             world file or name (config/worlds/<name>.yaml)\n"
    "  --domain N            DDS domain id (default 0, or $ROS_DOMAIN_ID)\n"
    "  --partition P         DDS partition (default: none, like ROS 2)\n"
    "  --rate HZ             simulation step and odometry rate (default 100)\n"
    "  --camera-rate HZ      image rate (default 15)\n"
    "  --command-timeout S   watchdog: stop when no cmd_vel for S seconds (default 0.25; 0 = off)\n"
    "  --brake-decel MPS2    deceleration of a watchdog stop, m/s^2 (default 50; yaw: 2x in rad/s^2)\n"
    "  --transport T         raw (sensor_msgs/Image) or compressed (JPEG CompressedImage)\n"
    "  --robot-param k=v     sim robot parameter (see `visnav plugins --params`), repeatable\n"
    "  --camera-param k=v    sim camera parameter, repeatable\n"
    "  --cmd-vel-writer W    command arbitration: accept cmd_vel only from the participant with GUID W\n"
    "                        (32 hex digits; `visnav run` logs its robot's GUID), or `first`: from the\n"
    "                        participant that sends the first command; others are dropped and counted\n"
    "  --control-topic T     mission control topic obeyed at the robot side (default rt/visnav/control):\n"
    "                        pause (or abort) holds the robot at zero whoever sends cmd_vel, until resume\n"
    "  --no-control          do not subscribe the control topic\n"
    "  --keystore DIR        DDS Security: authenticate as --identity from a keystore made by\n"
    "  --identity NAME       `visnav security init` (e.g. ROBOT-driver; docs/security.md). Without: security off\n"
    "  --duration S          exit after S seconds (default: until SIGINT/SIGTERM)\n"
    "\n"
    "Prints \"simd: ready\" on stdout once publishing. Exit status: 0 ok, 1 setup error, 2 usage error.\n";

std::atomic<bool> g_stop{false};

/// Short decimal rendering for log lines ("0.25", "100").
std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}
extern "C" void on_stop_signal(int) { g_stop = true; }

visnav::Result<double> number(const visnav::cli::Args& a, const std::string& name, double fallback, double min_value,
                              double max_value) {
  if (!a.has(name)) return fallback;
  auto v = visnav::detail::parse_double(a.get(name));
  if (!v) return visnav::fail(name + ": " + v.error().message);
  if (*v < min_value || *v > max_value)
    return visnav::fail(name + ": " + a.get(name) + " is out of range [" + std::to_string(min_value) + ", " +
                        std::to_string(max_value) + "]");
  return *v;
}

/// Newest command with its arrival time (steady clock).
struct CommandSlot {
  std::mutex mutex;
  visnav::Twist command;
  std::chrono::steady_clock::time_point received{};
  std::uint64_t count = 0;
  std::uint64_t rejected = 0;
  dds::WriterArbiter arbiter;  ///< --cmd-vel-writer: who may drive (counts what it drops)
  bool paused = false;         ///< control topic: pause/abort hold zero until resume
};

dds::msg::Odometry to_ros_odometry(const visnav::Pose2D& pose, const visnav::Twist& twist, const char* frame_id) {
  dds::msg::Odometry o;
  o.header.stamp = dds::msg::Time::from_seconds(dds::epoch_now_s());
  o.header.frame_id = frame_id;
  o.child_frame_id = "base_link";
  o.pose.pose.position = {pose.x_m, pose.y_m, 0.0};
  o.pose.pose.orientation = dds::quaternion_from_yaw(pose.heading_rad);
  o.twist.twist.linear.x = twist.linear_mps;
  o.twist.twist.angular.z = twist.angular_radps;
  return o;
}

/// What the command line asked for, checked (usage errors are the Result's errors).
struct SimdOptions {
  std::string world;
  int domain_id = 0;
  double rate_hz = 100.0;
  double camera_rate_hz = 15.0;
  double command_timeout_s = 0.25;
  double brake_decel_mps2 = 50.0;
  double jpeg_quality = 90.0;
  double duration_s = 0.0;
  std::string transport = "raw";
  std::string partition;
  std::string cmd_topic;
  std::string odom_topic;
  std::string image_topic;
  std::string ground_truth_topic;
  std::string control_topic;
  std::string writer_rule;  ///< --cmd-vel-writer: empty (anyone), "first" or a GUID (checked)
  bool control = true;      ///< subscribe the control topic
  std::string keystore;
  std::string identity;
  std::vector<std::string> plugin_path;
  visnav::LogLevel log_level = visnav::LogLevel::info;
  visnav::ConfigNode robot_params;   ///< the sim robot's params (world, rates, --robot-param)
  visnav::ConfigNode brake_params;   ///< robot_params with the acceleration limits of a watchdog stop
  visnav::ConfigNode camera_params;  ///< --camera-param
};

visnav::Result<SimdOptions> parse_options(const std::vector<std::string>& args) {
  using visnav::cli::Opt;
  visnav::cli::Args a;
  VISNAV_TRY(a.parse(args, {{"--world", Opt::value}, {"--domain", Opt::value}, {"--partition", Opt::value},
                            {"--rate", Opt::value}, {"--camera-rate", Opt::value}, {"--command-timeout", Opt::value},
                            {"--brake-decel", Opt::value}, {"--transport", Opt::value}, {"--jpeg-quality", Opt::value},
                            {"--cmd-vel-topic", Opt::value}, {"--odom-topic", Opt::value}, {"--image-topic", Opt::value},
                            {"--ground-truth-topic", Opt::value}, {"--robot-param", Opt::repeated},
                            {"--camera-param", Opt::repeated}, {"--duration", Opt::value},
                            {"--cmd-vel-writer", Opt::value}, {"--control-topic", Opt::value},
                            {"--no-control", Opt::flag}, {"--keystore", Opt::value}, {"--identity", Opt::value},
                            {"--plugin-path", Opt::repeated}, {"--log-level", Opt::value}}));
  VISNAV_TRY(a.require({"--world"}));
  SimdOptions o;
  o.world = a.get("--world");
  std::string domain_text = a.get("--domain");
  if (domain_text.empty() && std::getenv("ROS_DOMAIN_ID") != nullptr) domain_text = std::getenv("ROS_DOMAIN_ID");
  if (!domain_text.empty()) {
    auto d = visnav::detail::parse_int(domain_text);
    if (!d || *d < 0 || *d > 232) return visnav::fail("--domain: expected 0..232, got '" + domain_text + "'");
    o.domain_id = *d;
  }
  VISNAV_ASSIGN(o.rate_hz, number(a, "--rate", o.rate_hz, 1.0, 1000.0));
  VISNAV_ASSIGN(o.camera_rate_hz, number(a, "--camera-rate", o.camera_rate_hz, 0.0, 200.0));
  VISNAV_ASSIGN(o.command_timeout_s, number(a, "--command-timeout", o.command_timeout_s, 0.0, 3600.0));
  VISNAV_ASSIGN(o.brake_decel_mps2, number(a, "--brake-decel", o.brake_decel_mps2, 0.01, 100.0));
  VISNAV_ASSIGN(o.jpeg_quality, number(a, "--jpeg-quality", o.jpeg_quality, 1.0, 100.0));
  VISNAV_ASSIGN(o.duration_s, number(a, "--duration", o.duration_s, 0.0, 1e9));
  o.transport = a.get("--transport", "raw");
  if (o.transport != "raw" && o.transport != "compressed")
    return visnav::fail("--transport: expected raw or compressed, got '" + o.transport + "'");
  o.partition = a.get("--partition");
  o.cmd_topic = a.get("--cmd-vel-topic", "rt/cmd_vel");
  o.odom_topic = a.get("--odom-topic", "rt/odom");
  o.image_topic = a.get("--image-topic", o.transport == "raw" ? "rt/camera/image_raw" : "rt/camera/image_raw/compressed");
  o.ground_truth_topic = a.get("--ground-truth-topic", "rt/visnav/sim/ground_truth");
  o.control_topic = a.get("--control-topic", "rt/visnav/control");
  o.control = !a.has("--no-control");
  o.writer_rule = a.get("--cmd-vel-writer");
  if (auto rule = dds::WriterArbiter::parse(o.writer_rule); !rule)
    return std::move(rule).error().with_context("--cmd-vel-writer");
  if (a.has("--keystore") != a.has("--identity")) return visnav::fail("--keystore and --identity go together");
  o.keystore = a.get("--keystore");
  o.identity = a.get("--identity");
  o.plugin_path = a.all("--plugin-path");
  if (a.has("--log-level")) {
    VISNAV_ASSIGN(o.log_level, visnav::parse_log_level(a.get("--log-level")));
  }

  o.robot_params = visnav::ConfigNode::make_map({"--world", 0});
  o.robot_params.set("world", visnav::ConfigNode::make_scalar(o.world, {"--world", 0}));
  o.robot_params.set("command_timeout_s", visnav::ConfigNode::make_scalar("0"));  // simd's wall-time watchdog rules
  o.robot_params.set("odom_rate_hz", visnav::ConfigNode::make_scalar(std::to_string(o.rate_hz)));
  for (const auto& kv : a.all("--robot-param")) VISNAV_TRY(visnav::apply_override(o.robot_params, kv));
  o.camera_params = visnav::ConfigNode::make_map();
  for (const auto& kv : a.all("--camera-param")) VISNAV_TRY(visnav::apply_override(o.camera_params, kv));
  // Brake: the same params with the acceleration limits raised (reconfigured while stopping).
  o.brake_params = o.robot_params;
  o.brake_params.set("linear_accel_mps2", visnav::ConfigNode::make_scalar(std::to_string(o.brake_decel_mps2)));
  o.brake_params.set("angular_accel_radps2",
                     visnav::ConfigNode::make_scalar(std::to_string(std::min(200.0, 2.0 * o.brake_decel_mps2))));
  return o;
}

/// The image writer of the chosen transport (exactly one is set).
struct ImageWriters {
  std::optional<dds::Writer<dds::msg::Image>> raw;
  std::optional<dds::Writer<dds::msg::CompressedImage>> jpeg;
};

/// The DDS side of simd: writers and the two subscriptions feeding `commands`.
struct Endpoints {
  std::optional<dds::Participant> participant;
  std::optional<dds::Writer<dds::msg::Odometry>> odom;
  std::optional<dds::Writer<dds::msg::Odometry>> ground_truth;
  ImageWriters images;
  std::unique_ptr<dds::Subscription<dds::msg::Twist>> cmd_vel;
  std::unique_ptr<dds::Subscription<dds::msg::Control>> control;  ///< null with --no-control
};

/// cmd_vel handler: arbitration (issue 17: with --cmd-vel-writer only one participant drives),
/// non-finite commands dropped, the newest command kept with its arrival time.
void accept_command(CommandSlot& commands, dds::WarningLimiter& warnings, visnav::Logger& logger,
                    const dds::msg::Twist& t, const dds::SampleInfo& info) {
  std::lock_guard lock(commands.mutex);
  const auto verdict = commands.arbiter.admit(info.writer_participant);
  if (verdict.locked)
    logger.info("simd", "cmd_vel: locked to the first sender, participant " + commands.arbiter.allowed());
  if (!verdict.accepted) {
    if (warnings.allow(info.receive_time_s))
      logger.warn("simd", "dropped cmd_vel from participant '" + dds::log_safe(info.writer_participant) + "' (" +
                              commands.arbiter.describe() + " may drive; " + std::to_string(commands.arbiter.refused()) +
                              " dropped so far)");
    return;
  }
  if (!std::isfinite(t.linear.x) || !std::isfinite(t.angular.z)) {
    ++commands.rejected;
    if (warnings.allow(info.receive_time_s))
      logger.warn("simd", "dropped a non-finite cmd_vel (" + std::to_string(commands.rejected) + " so far)");
    return;
  }
  commands.command = visnav::Twist{t.linear.x, t.angular.z};
  commands.received = std::chrono::steady_clock::now();
  ++commands.count;
}

/// Control handler: pause at the robot side (issue 17). Whoever sends cmd_vel, a paused robot
/// stays at zero. Any participant may pause (stopping is always safe); with DDS Security only
/// operators can.
void accept_control(CommandSlot& commands, visnav::Logger& logger, const dds::msg::Control& c, const dds::SampleInfo& info) {
  const auto command = static_cast<dds::msg::ControlCommand>(c.command);
  if (command != dds::msg::ControlCommand::pause && command != dds::msg::ControlCommand::resume &&
      command != dds::msg::ControlCommand::abort)
    return;  // swap_detector and unknown codes concern the mission only
  std::lock_guard lock(commands.mutex);
  const bool hold = command != dds::msg::ControlCommand::resume;
  if (hold == commands.paused) return;
  commands.paused = hold;
  logger.warn("simd", std::string(hold ? "paused" : "resumed") + " by " + dds::to_string(command) + " from participant " +
                          dds::log_safe(info.writer_participant) + (hold ? ": holding zero velocity until resume" : ""));
}

/// Opens the participant (with DDS Security when a keystore is given), writers and subscriptions.
/// The handlers keep references to `commands`, `warnings` and `logger`, which must outlive the result.
visnav::Status open_endpoints(const SimdOptions& o, CommandSlot& commands, dds::WarningLimiter& warnings,
                              visnav::Logger& logger, Endpoints& out) {
  if (!o.keystore.empty()) {
    VISNAV_TRY(dds::set_default_security(dds::keystore_identity(o.keystore, o.identity)));
    logger.info("simd", "DDS Security on: identity '" + o.identity + "' from " + o.keystore);
  } else {
    logger.info("simd", "DDS Security off: any participant on the domain can command this robot unless "
                        "--cmd-vel-writer pins the sender (docs/security.md)");
  }
  VISNAV_ASSIGN(auto participant, dds::Participant::create(o.domain_id));
  out.participant.emplace(std::move(participant));
  dds::Participant& p = *out.participant;
  VISNAV_ASSIGN(auto odom, dds::Writer<dds::msg::Odometry>::create(p, {o.odom_topic, dds::Qos::ros_default(), o.partition}));
  out.odom.emplace(std::move(odom));
  VISNAV_ASSIGN(auto gt, dds::Writer<dds::msg::Odometry>::create(p, {o.ground_truth_topic, dds::Qos::sensor_data(), o.partition}));
  out.ground_truth.emplace(std::move(gt));
  const dds::Qos image_qos{dds::Reliability::best_effort, dds::Durability::volatile_data, 1, 0.0};
  if (o.transport == "raw") {
    VISNAV_ASSIGN(auto w, dds::Writer<dds::msg::Image>::create(p, {o.image_topic, image_qos, o.partition}));
    out.images.raw.emplace(std::move(w));
  } else {
    VISNAV_ASSIGN(auto w, dds::Writer<dds::msg::CompressedImage>::create(p, {o.image_topic, image_qos, o.partition}));
    out.images.jpeg.emplace(std::move(w));
  }
  VISNAV_ASSIGN(commands.arbiter, dds::WriterArbiter::parse(o.writer_rule));
  auto warn = [&logger](const std::string& message) { logger.warn("simd", message); };
  auto cmd_vel = dds::Subscription<dds::msg::Twist>::create(
      p, {o.cmd_topic, dds::Qos::sensor_data(), o.partition},
      [&commands, &warnings, &logger](dds::msg::Twist&& t, const dds::SampleInfo& info) {
        accept_command(commands, warnings, logger, t, info);
      },
      warn);
  if (!cmd_vel) return std::move(cmd_vel).error();
  out.cmd_vel = std::move(*cmd_vel);
  if (o.control) {
    const dds::Qos control_qos{dds::Reliability::reliable, dds::Durability::volatile_data, 32, 0.0};
    auto control = dds::Subscription<dds::msg::Control>::create(
        p, {o.control_topic, control_qos, o.partition},
        [&commands, &logger](dds::msg::Control&& c, const dds::SampleInfo& info) { accept_control(commands, logger, c, info); },
        warn);
    if (!control) return std::move(control).error();
    out.control = std::move(*control);
  }
  return visnav::ok();
}

/// The camera thread's body: grabs and publishes at --camera-rate until g_stop.
void publish_images(const SimdOptions& o, visnav::Camera& camera, ImageWriters& writers, visnav::Logger& logger,
                    std::atomic<std::uint64_t>& frames) {
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(1.0 / o.camera_rate_hz));
  auto next = std::chrono::steady_clock::now();
  dds::msg::Image image_msg;
  dds::msg::CompressedImage jpeg_msg;
  jpeg_msg.format = "jpeg";
  std::vector<uchar> encoded;
  const std::vector<int> jpeg_params{cv::IMWRITE_JPEG_QUALITY, static_cast<int>(o.jpeg_quality)};
  dds::WarningLimiter warnings(5.0);
  while (!g_stop) {
    next += period;
    auto grabbed = camera.grab(0.0);
    if (grabbed && grabbed->has_value()) {
      const visnav::Frame& f = **grabbed;
      visnav::Status st = visnav::ok();
      if (writers.raw) {
        st = dds::fill_image_message(f.image, image_msg);
        image_msg.header.stamp = dds::msg::Time::from_seconds(dds::epoch_now_s());
        image_msg.header.frame_id = "camera";
        if (st) st = writers.raw->write(image_msg);
      } else if (cv::imencode(".jpg", f.image, encoded, jpeg_params)) {
        jpeg_msg.data.assign(encoded.begin(), encoded.end());
        jpeg_msg.header.stamp = dds::msg::Time::from_seconds(dds::epoch_now_s());
        jpeg_msg.header.frame_id = "camera";
        st = writers.jpeg->write(jpeg_msg);
      }
      if (st) ++frames;
      else if (warnings.allow(dds::epoch_now_s())) logger.warn("simd", "image: " + st.error().message);
    } else if (!grabbed && warnings.allow(dds::epoch_now_s())) {
      logger.warn("simd", "camera: " + grabbed.error().message);
    }
    std::this_thread::sleep_until(next);
    if (std::chrono::steady_clock::now() > next + period) next = std::chrono::steady_clock::now();  // fell behind
  }
}

/// The real-time simulation loop (main thread): the newest fresh command (zero while paused), the
/// watchdog brake, one step per period, odometry and ground truth published. Returns the exit
/// status: 0 at g_stop or --duration, 1 when a step fails.
int simulate(const SimdOptions& o, visnav::Robot& robot, visnav::SimulationControl& sim, CommandSlot& commands,
             Endpoints& endpoints, visnav::Logger& logger, std::uint64_t& watchdog_trips) {
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(1.0 / o.rate_hz));
  const auto start = std::chrono::steady_clock::now();
  auto last = start;
  auto next = start;
  double last_odom_stamp = -1.0;
  bool braking = false;
  while (!g_stop) {
    next += period;
    std::this_thread::sleep_until(next);
    const auto now = std::chrono::steady_clock::now();
    if (o.duration_s > 0.0 && std::chrono::duration<double>(now - start).count() >= o.duration_s) break;
    if (now > next + 5 * period) next = now;  // fell far behind (e.g. suspended): don't burst

    visnav::Twist command;
    bool fresh = false;
    bool any = false;
    {
      std::lock_guard lock(commands.mutex);
      any = commands.count > 0;
      fresh = any && (o.command_timeout_s <= 0.0 ||
                      std::chrono::duration<double>(now - commands.received).count() <= o.command_timeout_s);
      if (fresh && !commands.paused) command = commands.command;
    }
    if (fresh && braking) {
      braking = false;
      if (auto st = robot.reconfigure(o.robot_params); !st) logger.warn("simd", "restore limits: " + st.error().message);
    } else if (!fresh && !braking && any) {
      braking = true;
      ++watchdog_trips;
      logger.warn("simd", "watchdog: no cmd_vel for " + fmt(o.command_timeout_s) + " s, stopping");
      if (auto st = robot.reconfigure(o.brake_params); !st) logger.warn("simd", "brake: " + st.error().message);
    }
    if (auto st = robot.send_command(command); !st) logger.warn("simd", "command: " + st.error().message);

    const double dt_s = std::min(0.1, std::chrono::duration<double>(now - last).count());
    last = now;
    if (auto st = sim.step(dt_s); !st) {
      logger.error("simd", "simulation step: " + st.error().message);
      return 1;
    }
    if (auto odom = robot.latest_odometry(); odom && odom->timestamp_s != last_odom_stamp) {
      last_odom_stamp = odom->timestamp_s;
      (void)endpoints.odom->write(to_ros_odometry(odom->pose, odom->twist, "odom"));
      (void)endpoints.ground_truth->write(to_ros_odometry(sim.ground_truth_pose(), odom->twist, "world"));
    }
  }
  return 0;
}

std::string describe_setup(const SimdOptions& o, const std::string& participant_guid) {
  return "world '" + o.world + "', domain " + std::to_string(o.domain_id) +
         (o.partition.empty() ? "" : ", partition '" + o.partition + "'") + ": cmd_vel from '" + o.cmd_topic +
         "' (watchdog " + fmt(o.command_timeout_s) + " s), odometry on '" + o.odom_topic + "' at " + fmt(o.rate_hz) +
         " Hz, " + o.transport + " images on '" + o.image_topic + "' at " + fmt(o.camera_rate_hz) +
         " Hz; participant " + participant_guid +
         (o.writer_rule.empty() ? ", cmd_vel from any participant (no --cmd-vel-writer)"
                                : ", cmd_vel only from " + (o.writer_rule == "first" ? std::string("the first sender") : o.writer_rule)) +
         (o.control ? ", pause/resume on '" + o.control_topic + "'" : "");
}

int simd(const std::vector<std::string>& args) {
  auto options = parse_options(args);
  if (!options) return visnav::cli::usage_error("simd", options.error().message);
  const SimdOptions& o = *options;
  visnav::StderrLogger logger(o.log_level);
  auto error = [&](const std::string& message) {
    logger.error("simd", message);
    return 1;
  };

  // The simulated robot and camera, through the plugin loader.
  auto loader = visnav::PluginLoader::with_default_path(o.plugin_path);
  if (auto scanned = loader.scan(); !scanned) return error(scanned.error().message);
  visnav::WallClock clock;
  visnav::RuntimeHost host(loader, logger, clock);
  auto robot = loader.create<visnav::Robot>("sim", o.robot_params, host);
  if (!robot) return error("robot: " + robot.error().message);
  visnav::SimulationControl* sim = (*robot)->simulation();
  if (sim == nullptr) return error("robot type 'sim' is not a simulated robot");
  host.set_robot(robot->get());
  auto camera = loader.create<visnav::Camera>("sim", o.camera_params, host);
  if (!camera) return error("camera: " + camera.error().message);
  host.set_camera(camera->get(), "camera 'sim' (visnav simd --camera-param)");

  CommandSlot commands;
  dds::WarningLimiter command_warnings(1.0);
  Endpoints endpoints;
  if (auto st = open_endpoints(o, commands, command_warnings, logger, endpoints); !st) return error(st.error().message);

  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);
  std::atomic<std::uint64_t> frames{0};
  std::thread camera_thread;
  if (o.camera_rate_hz > 0.0)
    camera_thread = std::thread([&] { publish_images(o, **camera, endpoints.images, logger, frames); });
  logger.info("simd", describe_setup(o, endpoints.participant->guid()));
  std::cout << "simd: ready" << std::endl;

  std::uint64_t watchdog_trips = 0;
  const int exit_code = simulate(o, **robot, *sim, commands, endpoints, logger, watchdog_trips);
  g_stop = true;
  if (camera_thread.joinable()) camera_thread.join();
  (void)(*robot)->send_command(visnav::Twist{});
  std::uint64_t received = 0;
  std::uint64_t foreign = 0;
  {
    std::lock_guard lock(commands.mutex);
    received = commands.count;
    foreign = commands.arbiter.refused();
  }
  logger.info("simd", "stopped after " + fmt(sim->time_s()) + " s: " + std::to_string(received) + " commands, " +
                          std::to_string(foreign) + " dropped by arbitration, " + std::to_string(watchdog_trips) +
                          " watchdog stops, " + std::to_string(frames.load()) + " images");
  // The subscriptions' handlers reference `commands` and `logger`: stop them first.
  endpoints.control.reset();
  endpoints.cmd_vel.reset();
  return exit_code;
}

}  // namespace

VISNAV_COMMAND(simd, "simd", "run the simulated robot and camera as a DDS process (ROS 2 topics)", kUsage, &simd)
