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
  std::uint64_t foreign = 0;   ///< dropped by arbitration (--cmd-vel-writer)
  std::string allowed_writer;  ///< participant GUID allowed to drive; empty = anyone (or not locked yet)
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

int simd(const std::vector<std::string>& args) {
  using visnav::cli::Opt;
  visnav::cli::Args a;
  if (auto st = a.parse(args, {{"--world", Opt::value}, {"--domain", Opt::value}, {"--partition", Opt::value},
                               {"--rate", Opt::value}, {"--camera-rate", Opt::value}, {"--command-timeout", Opt::value},
                               {"--brake-decel", Opt::value}, {"--transport", Opt::value}, {"--jpeg-quality", Opt::value},
                               {"--cmd-vel-topic", Opt::value}, {"--odom-topic", Opt::value}, {"--image-topic", Opt::value},
                               {"--ground-truth-topic", Opt::value}, {"--robot-param", Opt::repeated},
                               {"--camera-param", Opt::repeated}, {"--duration", Opt::value},
                               {"--cmd-vel-writer", Opt::value}, {"--control-topic", Opt::value},
                               {"--no-control", Opt::flag}, {"--keystore", Opt::value}, {"--identity", Opt::value},
                               {"--plugin-path", Opt::repeated}, {"--log-level", Opt::value}});
      !st)
    return visnav::cli::usage_error("simd", st.error().message);
  if (auto st = a.require({"--world"}); !st) return visnav::cli::usage_error("simd", st.error().message);

  std::string domain_text = a.get("--domain");
  if (domain_text.empty() && std::getenv("ROS_DOMAIN_ID") != nullptr) domain_text = std::getenv("ROS_DOMAIN_ID");
  int domain_id = 0;
  if (!domain_text.empty()) {
    auto d = visnav::detail::parse_int(domain_text);
    if (!d || *d < 0 || *d > 232) return visnav::cli::usage_error("simd", "--domain: expected 0..232, got '" + domain_text + "'");
    domain_id = *d;
  }
  auto rate_hz = number(a, "--rate", 100.0, 1.0, 1000.0);
  auto camera_rate_hz = number(a, "--camera-rate", 15.0, 0.0, 200.0);
  auto timeout_s = number(a, "--command-timeout", 0.25, 0.0, 3600.0);
  auto brake = number(a, "--brake-decel", 50.0, 0.01, 100.0);
  auto quality = number(a, "--jpeg-quality", 90.0, 1.0, 100.0);
  auto duration_s = number(a, "--duration", 0.0, 0.0, 1e9);
  for (const auto* r : {&rate_hz, &camera_rate_hz, &timeout_s, &brake, &quality, &duration_s})
    if (!*r) return visnav::cli::usage_error("simd", r->error().message);
  const std::string transport = a.get("--transport", "raw");
  if (transport != "raw" && transport != "compressed")
    return visnav::cli::usage_error("simd", "--transport: expected raw or compressed, got '" + transport + "'");
  const std::string partition = a.get("--partition");
  const std::string cmd_topic = a.get("--cmd-vel-topic", "rt/cmd_vel");
  const std::string odom_topic = a.get("--odom-topic", "rt/odom");
  const std::string image_topic =
      a.get("--image-topic", transport == "raw" ? "rt/camera/image_raw" : "rt/camera/image_raw/compressed");
  const std::string gt_topic = a.get("--ground-truth-topic", "rt/visnav/sim/ground_truth");
  const std::string control_topic = a.get("--control-topic", "rt/visnav/control");
  const std::string writer_rule = a.get("--cmd-vel-writer");
  const bool lock_first = writer_rule == "first";
  if (!writer_rule.empty() && !lock_first &&
      (writer_rule.size() != 32 || writer_rule.find_first_not_of("0123456789abcdef") != std::string::npos))
    return visnav::cli::usage_error("simd", "--cmd-vel-writer: expected 32 lowercase hex digits or 'first', got '" +
                                                dds::log_safe(writer_rule) + "'");

  visnav::LogLevel level = visnav::LogLevel::info;
  if (a.has("--log-level")) {
    auto l = visnav::parse_log_level(a.get("--log-level"));
    if (!l) return visnav::cli::usage_error("simd", l.error().message);
    level = *l;
  }
  visnav::StderrLogger logger(level);
  auto error = [&](const std::string& message) {
    logger.error("simd", message);
    return 1;
  };

  // --- the simulated robot and camera, through the plugin loader -------------------------------
  visnav::ConfigNode robot_params = visnav::ConfigNode::make_map({"--world", 0});
  robot_params.set("world", visnav::ConfigNode::make_scalar(a.get("--world"), {"--world", 0}));
  robot_params.set("command_timeout_s", visnav::ConfigNode::make_scalar("0"));  // simd's wall-time watchdog rules
  robot_params.set("odom_rate_hz", visnav::ConfigNode::make_scalar(std::to_string(*rate_hz)));
  for (const auto& kv : a.all("--robot-param"))
    if (auto st = visnav::apply_override(robot_params, kv); !st) return visnav::cli::usage_error("simd", st.error().message);
  visnav::ConfigNode camera_params = visnav::ConfigNode::make_map();
  for (const auto& kv : a.all("--camera-param"))
    if (auto st = visnav::apply_override(camera_params, kv); !st) return visnav::cli::usage_error("simd", st.error().message);
  // Brake: the same params with the acceleration limits raised (reconfigured while stopping).
  visnav::ConfigNode brake_params = robot_params;
  brake_params.set("linear_accel_mps2", visnav::ConfigNode::make_scalar(std::to_string(*brake)));
  brake_params.set("angular_accel_radps2", visnav::ConfigNode::make_scalar(std::to_string(std::min(200.0, 2.0 * *brake))));

  auto loader = visnav::PluginLoader::with_default_path(a.all("--plugin-path"));
  if (auto scanned = loader.scan(); !scanned) return error(scanned.error().message);
  visnav::WallClock clock;
  visnav::RuntimeHost host(loader, logger, clock);
  auto robot = loader.create<visnav::Robot>("sim", robot_params, host);
  if (!robot) return error("robot: " + robot.error().message);
  visnav::SimulationControl* sim = (*robot)->simulation();
  if (sim == nullptr) return error("robot type 'sim' is not a simulated robot");
  host.set_robot(robot->get());
  auto camera = loader.create<visnav::Camera>("sim", camera_params, host);
  if (!camera) return error("camera: " + camera.error().message);

  // --- DDS endpoints -------------------------------------------------------------------------
  if (a.has("--keystore") != a.has("--identity"))
    return visnav::cli::usage_error("simd", "--keystore and --identity go together");
  if (a.has("--keystore")) {
    if (auto st = dds::set_default_security(dds::keystore_identity(a.get("--keystore"), a.get("--identity"))); !st)
      return error(st.error().message);
    logger.info("simd", "DDS Security on: identity '" + a.get("--identity") + "' from " + a.get("--keystore"));
  } else {
    logger.info("simd", "DDS Security off: any participant on the domain can command this robot unless "
                        "--cmd-vel-writer pins the sender (docs/security.md)");
  }
  auto participant = dds::Participant::create(domain_id);
  if (!participant) return error(participant.error().message);
  const dds::Qos odom_qos = dds::Qos::ros_default();
  auto odom_writer = dds::Writer<dds::msg::Odometry>::create(*participant, {odom_topic, odom_qos, partition});
  if (!odom_writer) return error(odom_writer.error().message);
  auto gt_writer = dds::Writer<dds::msg::Odometry>::create(*participant, {gt_topic, dds::Qos::sensor_data(), partition});
  if (!gt_writer) return error(gt_writer.error().message);
  std::optional<dds::Writer<dds::msg::Image>> raw_writer;
  std::optional<dds::Writer<dds::msg::CompressedImage>> jpeg_writer;
  const dds::Qos image_qos{dds::Reliability::best_effort, dds::Durability::volatile_data, 1, 0.0};
  if (transport == "raw") {
    auto w = dds::Writer<dds::msg::Image>::create(*participant, {image_topic, image_qos, partition});
    if (!w) return error(w.error().message);
    raw_writer.emplace(std::move(*w));
  } else {
    auto w = dds::Writer<dds::msg::CompressedImage>::create(*participant, {image_topic, image_qos, partition});
    if (!w) return error(w.error().message);
    jpeg_writer.emplace(std::move(*w));
  }
  CommandSlot commands;
  commands.allowed_writer = lock_first ? std::string() : writer_rule;
  dds::WarningLimiter command_warnings(1.0);
  auto cmd_sub = dds::Subscription<dds::msg::Twist>::create(
      *participant, {cmd_topic, dds::Qos::sensor_data(), partition},
      [&](dds::msg::Twist&& t, const dds::SampleInfo& info) {
        std::lock_guard lock(commands.mutex);
        // Command arbitration (issue 17): with --cmd-vel-writer only one participant drives.
        if (!writer_rule.empty()) {
          if (lock_first && commands.allowed_writer.empty() && !info.writer_participant.empty()) {
            commands.allowed_writer = info.writer_participant;
            logger.info("simd", "cmd_vel: locked to the first sender, participant " + commands.allowed_writer);
          }
          if (info.writer_participant.empty() || info.writer_participant != commands.allowed_writer) {
            ++commands.foreign;
            if (command_warnings.allow(info.receive_time_s))
              logger.warn("simd", "dropped cmd_vel from participant '" + dds::log_safe(info.writer_participant) +
                                      "' (only " + commands.allowed_writer + " may drive; " +
                                      std::to_string(commands.foreign) + " dropped so far)");
            return;
          }
        }
        if (!std::isfinite(t.linear.x) || !std::isfinite(t.angular.z)) {
          ++commands.rejected;
          if (command_warnings.allow(info.receive_time_s))
            logger.warn("simd", "dropped a non-finite cmd_vel (" + std::to_string(commands.rejected) + " so far)");
          return;
        }
        commands.command = visnav::Twist{t.linear.x, t.angular.z};
        commands.received = std::chrono::steady_clock::now();
        ++commands.count;
      },
      [&](const std::string& message) { logger.warn("simd", message); });
  if (!cmd_sub) return error(cmd_sub.error().message);
  // Pause at the robot side (issue 17): whoever sends cmd_vel, a paused robot stays at zero. Any
  // participant may pause (stopping is always safe); with DDS Security only operators can.
  std::unique_ptr<dds::Subscription<dds::msg::Control>> control_sub;
  if (!a.has("--no-control")) {
    auto made = dds::Subscription<dds::msg::Control>::create(
        *participant, {control_topic, dds::Qos{dds::Reliability::reliable, dds::Durability::volatile_data, 32, 0.0}, partition},
        [&](dds::msg::Control&& c, const dds::SampleInfo& info) {
          const auto command = static_cast<dds::msg::ControlCommand>(c.command);
          if (command != dds::msg::ControlCommand::pause && command != dds::msg::ControlCommand::resume &&
              command != dds::msg::ControlCommand::abort)
            return;  // swap_detector and unknown codes concern the mission only
          std::lock_guard lock(commands.mutex);
          const bool hold = command != dds::msg::ControlCommand::resume;
          if (hold == commands.paused) return;
          commands.paused = hold;
          logger.warn("simd", std::string(hold ? "paused" : "resumed") + " by " + dds::to_string(command) +
                                  " from participant " + dds::log_safe(info.writer_participant) +
                                  (hold ? ": holding zero velocity until resume" : ""));
        },
        [&](const std::string& message) { logger.warn("simd", message); });
    if (!made) return error(made.error().message);
    control_sub = std::move(*made);
  }

  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);

  // --- camera thread ---------------------------------------------------------------------------
  std::atomic<std::uint64_t> frames{0};
  std::thread camera_thread;
  if (*camera_rate_hz > 0.0) {
    camera_thread = std::thread([&] {
      const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
          std::chrono::duration<double>(1.0 / *camera_rate_hz));
      auto next = std::chrono::steady_clock::now();
      dds::msg::Image image_msg;
      dds::msg::CompressedImage jpeg_msg;
      jpeg_msg.format = "jpeg";
      std::vector<uchar> encoded;
      const std::vector<int> jpeg_params{cv::IMWRITE_JPEG_QUALITY, static_cast<int>(*quality)};
      dds::WarningLimiter warnings(5.0);
      while (!g_stop) {
        next += period;
        auto grabbed = (*camera)->grab(0.0);
        if (grabbed && grabbed->has_value()) {
          const visnav::Frame& f = **grabbed;
          visnav::Status st = visnav::ok();
          if (raw_writer) {
            st = dds::fill_image_message(f.image, image_msg);
            image_msg.header.stamp = dds::msg::Time::from_seconds(dds::epoch_now_s());
            image_msg.header.frame_id = "camera";
            if (st) st = raw_writer->write(image_msg);
          } else if (cv::imencode(".jpg", f.image, encoded, jpeg_params)) {
            jpeg_msg.data.assign(encoded.begin(), encoded.end());
            jpeg_msg.header.stamp = dds::msg::Time::from_seconds(dds::epoch_now_s());
            jpeg_msg.header.frame_id = "camera";
            st = jpeg_writer->write(jpeg_msg);
          }
          if (st) ++frames;
          else if (warnings.allow(dds::epoch_now_s())) logger.warn("simd", "image: " + st.error().message);
        } else if (!grabbed && warnings.allow(dds::epoch_now_s())) {
          logger.warn("simd", "camera: " + grabbed.error().message);
        }
        std::this_thread::sleep_until(next);
        if (std::chrono::steady_clock::now() > next + period) next = std::chrono::steady_clock::now();  // fell behind
      }
    });
  }

  logger.info("simd", "world '" + a.get("--world") + "', domain " + std::to_string(domain_id) +
                          (partition.empty() ? "" : ", partition '" + partition + "'") + ": cmd_vel from '" + cmd_topic +
                          "' (watchdog " + fmt(*timeout_s) + " s), odometry on '" + odom_topic + "' at " +
                          fmt(*rate_hz) + " Hz, " + transport + " images on '" + image_topic + "' at " +
                          fmt(*camera_rate_hz) + " Hz; participant " + participant->guid() +
                          (writer_rule.empty() ? ", cmd_vel from any participant (no --cmd-vel-writer)"
                                               : ", cmd_vel only from " + (lock_first ? std::string("the first sender") : writer_rule)) +
                          (control_sub ? ", pause/resume on '" + control_topic + "'" : ""));
  std::cout << "simd: ready" << std::endl;

  // --- real-time simulation loop ----------------------------------------------------------------
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(1.0 / *rate_hz));
  const auto start = std::chrono::steady_clock::now();
  auto last = start;
  auto next = start;
  double last_odom_stamp = -1.0;
  bool braking = false;
  std::uint64_t watchdog_trips = 0;
  int exit_code = 0;
  while (!g_stop) {
    next += period;
    std::this_thread::sleep_until(next);
    const auto now = std::chrono::steady_clock::now();
    if (*duration_s > 0.0 && std::chrono::duration<double>(now - start).count() >= *duration_s) break;
    if (now > next + 5 * period) next = now;  // fell far behind (e.g. suspended): don't burst

    visnav::Twist command;
    bool fresh = false;
    bool any = false;
    {
      std::lock_guard lock(commands.mutex);
      any = commands.count > 0;
      fresh = any &&
              (*timeout_s <= 0.0 || std::chrono::duration<double>(now - commands.received).count() <= *timeout_s);
      if (fresh && !commands.paused) command = commands.command;
    }
    if (fresh && braking) {
      braking = false;
      if (auto st = (*robot)->reconfigure(robot_params); !st) logger.warn("simd", "restore limits: " + st.error().message);
    } else if (!fresh && !braking && any) {
      braking = true;
      ++watchdog_trips;
      logger.warn("simd", "watchdog: no cmd_vel for " + fmt(*timeout_s) + " s, stopping");
      if (auto st = (*robot)->reconfigure(brake_params); !st) logger.warn("simd", "brake: " + st.error().message);
    }
    if (auto st = (*robot)->send_command(command); !st) logger.warn("simd", "command: " + st.error().message);

    const double dt_s = std::min(0.1, std::chrono::duration<double>(now - last).count());
    last = now;
    if (auto st = sim->step(dt_s); !st) {
      exit_code = error("simulation step: " + st.error().message);
      break;
    }
    if (auto odom = (*robot)->latest_odometry(); odom && odom->timestamp_s != last_odom_stamp) {
      last_odom_stamp = odom->timestamp_s;
      (void)odom_writer->write(to_ros_odometry(odom->pose, odom->twist, "odom"));
      (void)gt_writer->write(to_ros_odometry(sim->ground_truth_pose(), odom->twist, "world"));
    }
  }
  g_stop = true;
  if (camera_thread.joinable()) camera_thread.join();
  (void)(*robot)->send_command(visnav::Twist{});
  std::uint64_t received = 0;
  std::uint64_t foreign = 0;
  {
    std::lock_guard lock(commands.mutex);
    received = commands.count;
    foreign = commands.foreign;
  }
  logger.info("simd", "stopped after " + fmt(sim->time_s()) + " s: " + std::to_string(received) +
                          " commands, " + std::to_string(foreign) + " dropped by arbitration, " +
                          std::to_string(watchdog_trips) + " watchdog stops, " +
                          std::to_string(frames.load()) + " images");
  control_sub.reset();
  cmd_sub->reset();
  return exit_code;
}

}  // namespace

VISNAV_COMMAND(simd, "simd", "run the simulated robot and camera as a DDS process (ROS 2 topics)", kUsage, &simd)
