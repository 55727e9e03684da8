// Operator input devices for the teleop nodes: the terminal keyboard, a Linux joystick
// (/dev/input/js* through the joystick API, /dev/input/event* through evdev), and the ROS 2 teleop topics over DDS (sensor_msgs/Joy, geometry_msgs/Twist).
//
// Each input is polled once per tick from the tick thread and reads everything that arrived
// since, without blocking (files are opened O_NONBLOCK; DDS samples are queued by the
// subscription thread and drained here). So a deadman release acts at the next tick: within
// one tick period (50 ms at the shipped real-robot configs' 20 Hz).
// Ownership: an input owns its file descriptor / DDS subscription and restores the terminal
// mode it changed in its destructor. Thread-safety: poll() from one thread only.
#pragma once

#include <memory>
#include <string>

#include "visnav/result.hpp"
#include "visnav_teleop/teleop_core.hpp"

namespace visnav::teleop {

class OperatorInput {
 public:
  virtual ~OperatorInput() = default;
  /// Everything that arrived since the last poll, turned into this tick's action; `now_s` is
  /// the run clock (the keyboard deadman times key repeats with it). An error means the device
  /// is gone (unplugged, read error); the node then stops the robot.
  virtual Result<TeleopAction> poll(double now_s) = 0;
  /// True for the keyboard (the status line then lists the keys).
  [[nodiscard]] virtual bool keyboard() const { return false; }
};

/// Where the operator's input comes from (the nodes' ports).
struct InputSpec {
  std::string input = "keyboard";  ///< keyboard | joystick | joy | twist
  std::string device;              ///< keyboard: "" = stdin, or a file/FIFO; joystick: /dev/input/jsN or eventN
  std::string topic;               ///< joy: "" = rt/joy; twist: "" = rt/cmd_vel_teleop
  int domain_id = 0;               ///< DDS domain of joy/twist
  bool start_manual = true;        ///< keyboard: drive from the start (Teleop) or after manual_key (TeleopOverride)
};

/// Opens the input. Errors name the device or topic and say what to check.
[[nodiscard]] Result<std::unique_ptr<OperatorInput>> open_input(const InputSpec& spec, const TeleopParams& params);

}  // namespace visnav::teleop
