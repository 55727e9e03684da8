// visnav teleop plugin — the pure cores behind the operator nodes (Teleop, TeleopOverride):
// decoding a Linux joystick byte stream (joystick API or evdev) and terminal key sequences, and turning joystick,
// keyboard or teleop-Twist input into a velocity command, the primitive being taught and
// "teaching done", with a deadman and an input timeout. No I/O, no clock: every function takes
// the time it should assume (run clock, s). The node adapters (src/) own the devices.
//
// Conventions: axes are normalised like ROS 2 `sensor_msgs/Joy` from joy_linux — stick up and
// stick left are +1 — so one mapping file serves /dev/input/js* and the `rt/joy` topic alike.
// Commands: linear_mps forward, angular_radps counter-clockwise (stick left turns left).
// Thread-safety: none; one instance per node, used from the tick thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "visnav/params.hpp"
#include "visnav/result.hpp"
#include "visnav/types.hpp"

namespace visnav::teleop {

/// The operator mapping (a YAML file such as config/teleop/gamepad.yaml, keys below; every key
/// has a default, unknown keys are errors). Button and axis numbers are those of the device
/// (`jstest /dev/input/js0` or `ros2 topic echo /joy` shows them).
struct TeleopParams {
  // --- joystick / sensor_msgs/Joy ---
  int axis_linear = 1;                  ///< forward axis (left stick vertical on most pads)
  int axis_angular = 0;                 ///< turn axis (left stick horizontal)
  double scale_linear_mps = 0.5;        ///< speed at full deflection
  double scale_angular_radps = 0.8;     ///< yaw rate at full deflection
  double deadzone = 0.08;               ///< |axis| below this reads as 0
  int deadman_button = 4;               ///< must be held for the robot to move (LB on Xbox-style pads)
  int done_button = 7;                  ///< ends teaching (Start)
  /// Closes the loop: the robot is back at the start; the last edge ends at the start node and
  /// the turn the operator makes before pressing done is recorded as the closing turn (Back).
  int close_button = 6;
  /// "button=kind": pressing the button switches the primitive being taught; kind "" (e.g. "1=")
  /// means "turning / not recording".
  std::vector<std::string> primitive_buttons{"0=feature_segment", "2=path_following", "1="};
  // --- keyboard ---
  /// Keyboard deadman. > 0: hold-to-drive (like teleop_twist_keyboard's key_timeout): a driving
  /// key moves the robot only while the terminal keeps repeating it; no key event for this long
  /// stops the robot. It must exceed the terminal's autorepeat delay (250-660 ms) so a held key
  /// does not stutter before the repeats start. 0: sticky throttle (keys step a speed that
  /// stays until space) — no deadman.
  double key_deadman_s = 0.7;
  /// Hold-to-drive: once the held key is repeating, a gap this long means it was released (at
  /// 25-30 Hz autorepeat a repeat arrives every 33-40 ms). Release -> zero within this plus one tick.
  double key_repeat_timeout_s = 0.1;
  double key_hold_linear_mps = 0.3;     ///< hold-to-drive: speed of a held up/w, down/s (+/- change it)
  double key_hold_angular_radps = 0.5;  ///< hold-to-drive: turn rate of a held left/a, right/d (+/- change it)
  double key_linear_step_mps = 0.1;     ///< sticky: up/w, down/s change the speed by this much; hold: the +/- step
  double key_angular_step_radps = 0.15; ///< sticky: left/a, right/d change the turn rate by this much; hold: the +/- step
  double max_linear_mps = 0.8;          ///< keyboard and Twist commands are clamped to these
  double max_angular_radps = 1.2;
  /// "key=kind" for the keyboard (single characters); kind "" = turning / not recording.
  std::vector<std::string> primitive_keys{"f=feature_segment", "p=path_following", "t="};
  std::string done_key = "e";           ///< ends teaching
  std::string close_key = "c";          ///< closes the loop (as close_button)
  std::string manual_key = "m";         ///< TeleopOverride: toggles manual driving
  // --- topics (sensor_msgs/Joy, geometry_msgs/Twist) ---
  double input_timeout_s = 0.5;         ///< no message for this long: the operator is gone, stop

  [[nodiscard]] Status validate() const;
  static const ParamSchema<TeleopParams>& schema();
};

/// Parses a mapping file (empty path: the defaults). Errors name file:line and key.
[[nodiscard]] Result<TeleopParams> load_teleop_params(const std::string& path);

/// One "button=kind" / "key=kind" table, parsed.
struct PrimitiveBinding {
  std::string trigger;  ///< button number as text, or the key character
  std::string kind;
};
[[nodiscard]] Result<std::vector<PrimitiveBinding>> parse_bindings(const std::vector<std::string>& entries,
                                                                   std::string_view what);

/// The state of a joystick: axes normalised to [-1, 1] (up/left positive), buttons pressed.
struct JoyState {
  std::vector<double> axes;
  std::vector<bool> buttons;
  [[nodiscard]] double axis(int i) const {
    return i >= 0 && static_cast<std::size_t>(i) < axes.size() ? axes[static_cast<std::size_t>(i)] : 0.0;
  }
  [[nodiscard]] bool button(int i) const {
    return i >= 0 && static_cast<std::size_t>(i) < buttons.size() && buttons[static_cast<std::size_t>(i)];
  }
};

/// Linux joystick API (linux/joystick.h) event stream -> JoyState. Events are 8 bytes
/// (u32 time_ms, s16 value, u8 type, u8 number); partial events are kept until completed.
/// Axis values are negated and scaled by 1/32767 (up/left = +1, as joy_linux does).
class JsEventDecoder {
 public:
  /// Feeds raw bytes; returns the number of complete events applied.
  std::size_t feed(const std::uint8_t* data, std::size_t size);
  [[nodiscard]] const JoyState& state() const { return state_; }
  /// Button presses / releases (numbers) seen by feed() since the last take, in order. They
  /// keep a short press, or a deadman release, that starts and ends between two ticks.
  std::vector<int> take_presses() { return std::exchange(presses_, {}); }
  std::vector<int> take_releases() { return std::exchange(releases_, {}); }

  static constexpr std::size_t kEventBytes = 8;

 private:
  void apply(std::uint8_t type, std::uint8_t number, std::int16_t value);
  JoyState state_;
  std::uint8_t partial_[kEventBytes]{};
  std::size_t partial_size_ = 0;
  std::vector<int> presses_;
  std::vector<int> releases_;
};

/// Linux evdev (/dev/input/event*, linux/input.h `struct input_event`) event stream -> JoyState,
/// numbered like the joystick API (joydev) numbers the same pad — axes in the order of their
/// ABS_* codes, buttons in the order of their BTN_*/KEY_* codes from BTN_MISC up — so one
/// mapping file serves js*, event* and sensor_msgs/Joy. Axes are normalised with the device's
/// min/max to [-1, 1] and negated (up/left = +1), as joy_linux does. EV_KEY value 2 (autorepeat)
/// is a held button, not a press. SYN_DROPPED (events lost) releases every button, so a lost
/// deadman release cannot keep the robot moving. Codes not in the layout are ignored.
class EvdevDecoder {
 public:
  struct Axis {
    std::uint16_t code = 0;  ///< ABS_* code
    std::int32_t min = -32768;
    std::int32_t max = 32767;
  };
  struct Layout {
    std::vector<Axis> axes;               ///< in joystick-number order
    std::vector<std::uint16_t> buttons;   ///< BTN_*/KEY_* codes in joystick-number order
    /// The Linux gamepad layout of an Xbox-style pad (xpad): 8 axes (X, Y, Z=LT, RX, RY, RZ=RT,
    /// HAT0X, HAT0Y) and 11 buttons (A, B, X, Y, LB, RB, Back, Start, Guide, LS, RS) — used
    /// when the device does not answer the EVIOCGBIT/EVIOCGABS queries (e.g. a recorded FIFO).
    static Layout xbox_gamepad();
  };
  explicit EvdevDecoder(Layout layout);
  /// Feeds raw bytes (records of kEventBytes); returns the number of complete events applied.
  std::size_t feed(const std::uint8_t* data, std::size_t size);
  [[nodiscard]] const JoyState& state() const { return state_; }
  std::vector<int> take_presses() { return std::exchange(presses_, {}); }
  std::vector<int> take_releases() { return std::exchange(releases_, {}); }
  [[nodiscard]] const Layout& layout() const { return layout_; }

  static const std::size_t kEventBytes;  ///< sizeof(struct input_event): 24 on 64-bit Linux

 private:
  void apply(std::uint16_t type, std::uint16_t code, std::int32_t value);
  Layout layout_;
  JoyState state_;
  std::vector<std::uint8_t> partial_;
  std::vector<int> presses_;
  std::vector<int> releases_;
};

/// True if `device` names an evdev node (/dev/input/eventN, or a by-id/by-path link ending in
/// "-event-joystick"), false for the joystick API (/dev/input/jsN, "...-joystick").
[[nodiscard]] bool is_evdev_path(const std::string& device);

/// Splits terminal input into keys: a printable character, "\x1b[A".."\x1b[D" for the arrows,
/// " " for space, "\n" for Enter (CR too). Unknown escape sequences are dropped whole.
class KeyDecoder {
 public:
  /// Appends the keys found in `bytes` to `out`. An incomplete escape sequence is kept.
  void feed(std::string_view bytes, std::vector<std::string>& out);

 private:
  std::string pending_;
};

/// A keyboard on evdev (/dev/input/eventN): unlike a terminal it reports key releases, so a
/// held driving key stops the robot at the tick after it is let go, not after a timeout.
/// Keys come out spelled as KeyDecoder spells them ("w", "\x1b[A" for up, " " for space).
class EvdevKeyDecoder {
 public:
  struct Event {
    std::string key;
    bool released = false;  ///< false: pressed or autorepeat
  };
  /// Feeds raw bytes (input_event records); appends the key events found to `out`. A lost-events
  /// marker (SYN_DROPPED) releases every key held.
  void feed(const std::uint8_t* data, std::size_t size, std::vector<Event>& out);
  /// The name of an evdev key code ("" for a key teleop has no use for).
  static std::string key_name(std::uint16_t code);

 private:
  std::vector<std::uint8_t> partial_;
  std::vector<std::string> held_;
};

/// What the operator asks for this tick.
struct TeleopAction {
  Twist command;                         ///< zero unless `engaged`
  bool engaged = false;                  ///< the operator is driving (deadman held / manual mode / fresh Twist)
  std::optional<std::string> primitive;  ///< set when the operator switched primitive this tick
  bool done = false;                     ///< the operator ended teaching (sticky)
  bool closing = false;                  ///< the operator closed the loop at the start (sticky)
  std::string reason;                    ///< why not engaged (for the status line / log), empty if engaged
};

/// Joystick or sensor_msgs/Joy teleop: deadman, deadzone, scaling, primitive and done buttons.
class JoyTeleop {
 public:
  /// `params` must have passed validate().
  static Result<JoyTeleop> create(const TeleopParams& params);
  /// The action for the newest state, `presses` since the last call (button numbers, in
  /// order), and whether the input is fresh (false: timed out or no data yet -> not engaged).
  /// `released_deadman` is true if the deadman went up since the last call, even if it is
  /// held again now (a release always stops for one tick).
  TeleopAction update(const JoyState& state, const std::vector<int>& presses, bool fresh, bool released_deadman);

 private:
  explicit JoyTeleop(const TeleopParams& params, std::vector<std::pair<int, std::string>> buttons)
      : params_(params), buttons_(std::move(buttons)) {}
  TeleopParams params_;
  std::vector<std::pair<int, std::string>> buttons_;
  bool done_ = false;
  bool closing_ = false;
};

/// Keyboard teleop, two modes (TeleopParams::key_deadman_s):
///  * hold-to-drive (key_deadman_s > 0, the default): a held up/w, down/s drives forward/back at
///    key_hold_linear_mps, a held left/a, right/d turns on the spot at key_hold_angular_radps;
///    '+'/'-' change both by a step. The command holds while key events keep arriving (the
///    terminal's autorepeat): key_deadman_s after a first press, key_repeat_timeout_s once
///    repeats have been seen. No key: zero — the keyboard's deadman.
///  * sticky throttle (key_deadman_s = 0): arrows/WASD step the commanded speed and turn rate,
///    which stay until space; no deadman.
/// In both, space stops, the primitive keys switch primitive, `done_key` ends teaching,
/// `manual_key` toggles manual mode (used by TeleopOverride; Teleop is always manual).
/// Times are on one clock (s), non-decreasing.
class KeyTeleop {
 public:
  static Result<KeyTeleop> create(const TeleopParams& params, bool start_manual);
  /// Applies one key (as KeyDecoder yields them) received at `now_s`. Returns false for a key
  /// that means nothing.
  bool apply_key(const std::string& key, double now_s = 0.0);
  /// A key reported as let go (evdev keyboards only): in hold-to-drive, releasing the driving
  /// key zeroes the command at once. Other keys' releases mean nothing.
  void release_key(const std::string& key);
  /// Every key let go (the device went away or lost events): a held driving key stops.
  void release_all();
  /// The action at `now_s` after the keys applied since the last call.
  TeleopAction update(double now_s = 0.0);
  [[nodiscard]] const Twist& target() const { return target_; }
  [[nodiscard]] bool manual() const { return manual_; }

 private:
  KeyTeleop(const TeleopParams& params, std::vector<std::pair<std::string, std::string>> keys, bool manual)
      : params_(params), keys_(std::move(keys)), manual_(manual) {
    hold_speed_ = {params.key_hold_linear_mps, params.key_hold_angular_radps};
  }
  [[nodiscard]] bool hold_mode() const { return params_.key_deadman_s > 0.0; }
  bool apply_hold_key(const std::string& key, double now_s);
  TeleopParams params_;
  std::vector<std::pair<std::string, std::string>> keys_;
  Twist target_;
  Twist hold_speed_;             // hold-to-drive: magnitudes of a held key
  std::string held_key_;         // hold-to-drive: the driving key of the last event
  double last_key_s_ = -1e18;    // ... its newest event
  bool repeating_ = false;       // ... autorepeat seen
  bool manual_ = true;
  bool done_ = false;
  bool closing_ = false;
  std::optional<std::string> switched_;
};

/// A geometry_msgs/Twist teleop topic (teleop_twist_joy, teleop_twist_keyboard): engaged while
/// the newest message is fresh and non-zero; clamped to the max speeds.
[[nodiscard]] TeleopAction twist_action(const Twist& newest, bool fresh, const TeleopParams& params);

/// A marks file for teaching from a recording: CSV `t_s,primitive` (header first, '#' comments),
/// times in the recording's run clock, non-decreasing; primitive "" = turning, nothing recorded.
struct Mark {
  double t_s = 0.0;
  std::string primitive;
};
/// Parses the marks file's text; errors name `file`:line.
[[nodiscard]] Result<std::vector<Mark>> parse_marks(const std::string& text, const std::string& file);
/// The primitive in force at `t_s` (the last mark at or before it; "" before the first).
[[nodiscard]] std::string primitive_at(const std::vector<Mark>& marks, double t_s);

/// One-line status for the terminal: command, primitive, engaged or why not, and the keys.
[[nodiscard]] std::string status_line(const TeleopAction& action, const std::string& primitive,
                                      const TeleopParams& params, bool keyboard);

}  // namespace visnav::teleop
