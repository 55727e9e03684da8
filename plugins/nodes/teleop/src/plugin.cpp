// `teleop` nodes plugin: the operator on a real robot, without writing code.
//  * Teleop — teaching: the operator drives (keyboard, joystick, ROS 2 Joy or Twist) and switches
//    the primitive being taught; publishes {primitive} and {teach_done} for TeachRoute, like the
//    simulator's ScriptedOperator.
//  * TeleopOverride — replay with a hand on the controls: while the operator drives (deadman
//    held, manual mode, or a fresh teleop Twist) the child is not ticked and the operator's
//    command goes to the robot; when they let go the robot stops and the child resumes.
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>

#include "inputs.hpp"
#include "visnav/bt/node.hpp"
#include "visnav/bt/registry.hpp"
#include "visnav/plugin.hpp"
#include "visnav/file_io.hpp"
#include "visnav_teleop/teleop_core.hpp"

namespace visnav::teleop {
namespace {

using bt::NodeStatus;

bt::PortsList input_ports() {
  return {bt::input_port<std::string>("input", "keyboard", "keyboard | joystick | joy (sensor_msgs/Joy) | twist (geometry_msgs/Twist)"),
          bt::input_port<std::string>("device", "", "keyboard: '' = stdin, a file/FIFO, or /dev/input/eventN (evdev: reports key releases); joystick: '' = /dev/input/js0, or /dev/input/eventN (evdev)"),
          bt::input_port<std::string>("topic", "", "joy: '' = rt/joy; twist: '' = rt/cmd_vel_teleop (ROS /x = rt/x)"),
          bt::input_port<int>("domain_id", "0", "DDS domain of the joy/twist topic (ROS_DOMAIN_ID)"),
          bt::input_port<std::string>("mapping_file", "", "axes/buttons/keys mapping YAML (config/teleop/*.yaml); '' = defaults")};
}

/// Reads the input ports, loads the mapping and opens the device.
Result<std::unique_ptr<OperatorInput>> open_from_ports(const bt::TreeNode& node, bool start_manual,
                                                       TeleopParams& params_out) {
  InputSpec spec;
  VISNAV_ASSIGN(spec.input, node.get_input<std::string>("input"));
  VISNAV_ASSIGN(spec.device, node.get_input<std::string>("device"));
  VISNAV_ASSIGN(spec.topic, node.get_input<std::string>("topic"));
  VISNAV_ASSIGN(spec.domain_id, node.get_input<int>("domain_id"));
  VISNAV_ASSIGN(const std::string mapping, node.get_input<std::string>("mapping_file"));
  spec.start_manual = start_manual;
  VISNAV_ASSIGN(params_out, load_teleop_params(mapping));
  return open_input(spec, params_out);
}

/// The status line on a terminal (stderr), at most 5 times a second; nothing otherwise.
class StatusLine {
 public:
  StatusLine() : tty_(::isatty(STDERR_FILENO) != 0) {}
  void show(double now_s, const std::string& text) {
    if (!tty_ || now_s - last_s_ < 0.2) return;
    last_s_ = now_s;
    std::fprintf(stderr, "\r%s\x1b[K", text.c_str());
    std::fflush(stderr);
    shown_ = true;
  }
  void end() {
    if (shown_) std::fputs("\n", stderr);
    shown_ = false;
  }

 private:
  bool tty_;
  bool shown_ = false;
  double last_s_ = -1e9;
};

class Teleop final : public bt::StatefulActionNode {
 public:
  Teleop(const std::string& name, const bt::NodeConfig& config, HostServices& host)
      : StatefulActionNode(name, config), host_(host) {}

  static bt::PortsList provided_ports() {
    bt::PortsList ports = input_ports();
    ports.push_back(bt::input_port<std::string>("initial_primitive", "", "edge kind taught from the start ('' = none until the operator picks one)"));
    ports.push_back(bt::output_port<std::string>("primitive", "{primitive}", "edge kind being taught; empty while turning"));
    ports.push_back(bt::output_port<bool>("done", "{teach_done}", "true once the operator ends teaching"));
    ports.push_back(bt::output_port<bool>(
        "closing", "{teach_closing}",
        "true once the operator closed the loop at the start (TeachRoute ends the last edge there and records the "
        "turn made before done as the closing turn)"));
    return ports;
  }

  NodeStatus on_start() override {
    if (host_.robot() == nullptr) return failed("Teleop needs a robot");
    auto input = open_from_ports(*this, true, params_);
    if (!input) return failed(input.error().message);
    input_ = std::move(*input);
    auto initial = get_input<std::string>("initial_primitive");
    if (!initial) return failed(initial.error().message);
    primitive_ = *initial;
    (void)set_output("done", false);
    (void)set_output("closing", false);
    closing_ = false;
    (void)set_output("primitive", primitive_);
    host_.logger().info(path(), "operator teaching: " + status_line(TeleopAction{}, primitive_, params_, input_->keyboard()));
    return on_running();
  }

  NodeStatus on_running() override {
    auto action = input_->poll(host_.clock().now_s());
    if (!action) {
      (void)host_.robot()->stop();
      return failed(action.error().message);
    }
    if (action->primitive && *action->primitive != primitive_) {
      primitive_ = *action->primitive;
      (void)set_output("primitive", primitive_);
      host_.logger().info(path(), "teaching " + (primitive_.empty() ? std::string("nothing (turning)") : primitive_));
    }
    if (action->closing && !closing_) {
      closing_ = true;
      (void)set_output("closing", true);
      host_.logger().info(path(), "the operator closed the loop at the start; turn to face the first edge, then end");
    }
    if (action->done) {
      (void)host_.robot()->stop();
      (void)set_output("done", true);
      release();
      host_.logger().info(path(), "the operator ended teaching");
      return NodeStatus::success;
    }
    // Not engaged (deadman up, input gone): a zero command every tick, so the robot's own
    // command watchdog never has to act.
    if (auto st = host_.robot()->send_command(action->engaged ? action->command : Twist{}); !st) {
      (void)host_.robot()->stop();
      return failed("the robot refused the velocity command: " + st.error().message);
    }
    status_.show(host_.clock().now_s(), status_line(*action, primitive_, params_, input_->keyboard()));
    return NodeStatus::running;
  }

  void on_halted() override {
    if (Robot* robot = host_.robot()) (void)robot->stop();
    release();
  }

 private:
  void release() {
    status_.end();
    input_.reset();  // restores the terminal
  }
  NodeStatus failed(const std::string& message) {
    release();
    host_.logger().error(path(), message);
    return NodeStatus::failure;
  }

  HostServices& host_;
  TeleopParams params_;
  std::unique_ptr<OperatorInput> input_;
  std::string primitive_;
  bool closing_ = false;  // the closing output was set this run
  StatusLine status_;
};

class TeleopOverride final : public bt::DecoratorNode {
 public:
  TeleopOverride(const std::string& name, const bt::NodeConfig& config, HostServices& host)
      : DecoratorNode(name, config), host_(host) {}

  static bt::PortsList provided_ports() { return input_ports(); }

 protected:
  NodeStatus tick() override {
    if (host_.robot() == nullptr) return failed("TeleopOverride needs a robot");
    if (!input_) {
      // The keyboard starts automatic: the operator presses manual_key to take over.
      auto input = open_from_ports(*this, false, params_);
      if (!input) return failed(input.error().message);
      input_ = std::move(*input);
    }
    set_status(NodeStatus::running);
    auto action = input_->poll(host_.clock().now_s());
    if (!action) {
      halt_child();
      (void)host_.robot()->stop();
      return failed(action.error().message);
    }
    if (action->engaged) {
      if (!manual_) host_.logger().warn(path(), "manual override: the operator drives, the mission waits");
      manual_ = true;
      if (auto st = host_.robot()->send_command(action->command); !st) {
        halt_child();
        (void)host_.robot()->stop();
        return failed("the robot refused the velocity command: " + st.error().message);
      }
      status_.show(host_.clock().now_s(), status_line(*action, "(override)", params_, input_->keyboard()));
      return NodeStatus::running;
    }
    if (manual_) {
      manual_ = false;
      (void)host_.robot()->stop();
      host_.logger().warn(path(), "manual override ended (" + action->reason + "): the mission resumes");
    }
    const NodeStatus s = child()->execute_tick();
    if (s == NodeStatus::success || s == NodeStatus::failure) {
      reset_child();
      release();
    }
    return s;
  }

  void halt() override {
    halt_child();
    if (Robot* robot = host_.robot()) (void)robot->stop();
    release();
  }

 private:
  void release() {
    status_.end();
    input_.reset();
    manual_ = false;
  }
  NodeStatus failed(const std::string& message) {
    release();
    host_.logger().error(path(), message);
    return NodeStatus::failure;
  }

  HostServices& host_;
  TeleopParams params_;
  std::unique_ptr<OperatorInput> input_;
  bool manual_ = false;
  StatusLine status_;
};

/// Teaching from a recording (`visnav teach --run`): the primitive switches come from a marks
/// file instead of a person; the robot is the recording and is never commanded.
class RecordedOperator final : public bt::StatefulActionNode {
 public:
  RecordedOperator(const std::string& name, const bt::NodeConfig& config, HostServices& host)
      : StatefulActionNode(name, config), host_(host) {}

  static bt::PortsList provided_ports() {
    return {bt::input_port<std::string>("marks_file", "{marks_file}", "CSV t_s,primitive: primitive switches on the recording's clock"),
            bt::input_port<double>("end_time_s", "{end_time_s}", "teaching ends at this run-clock time (the end of the recording)"),
            bt::output_port<std::string>("primitive", "{primitive}", "edge kind being taught; empty while turning"),
            bt::output_port<bool>("done", "{teach_done}", "true once end_time_s is reached")};
  }

  NodeStatus on_start() override {
    auto file = get_input<std::string>("marks_file");
    auto end = get_input<double>("end_time_s");
    if (!file || !end) return failed(!file ? file.error().message : end.error().message);
    auto text = read_text_file(*file, kMaxConfigFileBytes, "marks");
    if (!text) return failed("marks_file: " + text.error().message);
    auto marks = parse_marks(*text, *file);
    if (!marks) return failed(marks.error().message);
    marks_ = std::move(*marks);
    end_s_ = *end;
    primitive_ = "?";
    (void)set_output("done", false);
    return on_running();
  }

  NodeStatus on_running() override {
    const double now_s = host_.clock().now_s();
    const std::string p = primitive_at(marks_, now_s);
    if (p != primitive_) {
      primitive_ = p;
      (void)set_output("primitive", p);
      host_.logger().info(path(), "t " + std::to_string(now_s) + " s: teaching " + (p.empty() ? std::string("nothing") : p));
    }
    if (now_s >= end_s_) {
      (void)set_output("done", true);
      return NodeStatus::success;
    }
    return NodeStatus::running;
  }

  void on_halted() override {}

 private:
  NodeStatus failed(const std::string& message) {
    host_.logger().error(path(), message);
    return NodeStatus::failure;
  }
  HostServices& host_;
  std::vector<Mark> marks_;
  double end_s_ = 0.0;
  std::string primitive_;
};

Status register_teleop_nodes(bt::NodeRegistry& registry, HostServices& host) {
  VISNAV_TRY(registry.register_node<RecordedOperator>(
      "RecordedOperator",
      "Teaching from a recording: publishes the primitive of a marks file (t_s,primitive) at the run clock's time and "
      "teach_done at end_time_s",
      [&host](const std::string& name, const bt::NodeConfig& config) {
        return std::make_unique<RecordedOperator>(name, config, host);
      }));
  VISNAV_TRY(registry.register_node<Teleop>(
      "Teleop",
      "Operator teaching on a real robot: drives from the keyboard, a joystick (/dev/input/js* or event*) or ROS 2 "
      "Joy/Twist over DDS with a deadman, and publishes the primitive being taught and teach_done",
      [&host](const std::string& name, const bt::NodeConfig& config) {
        return std::make_unique<Teleop>(name, config, host);
      }));
  return registry.register_node<TeleopOverride>(
      "TeleopOverride",
      "Manual override: while the operator drives (deadman held, manual key, fresh teleop Twist) the child "
      "waits and the operator's command goes to the robot; on release the robot stops and the child resumes",
      [&host](const std::string& name, const bt::NodeConfig& config) {
        return std::make_unique<TeleopOverride>(name, config, host);
      });
}

}  // namespace
}  // namespace visnav::teleop

VISNAV_PLUGIN({.name = "teleop",
               .version = "0.1.0",
               .description = "Operator nodes: Teleop (teaching from keyboard, joystick or ROS 2 Joy/Twist) and TeleopOverride",
               .register_nodes = &visnav::teleop::register_teleop_nodes})
