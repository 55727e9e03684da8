#include "visnav_teleop/teleop_core.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iomanip>

#include <linux/input.h>
#include <sstream>

#include "visnav/config_node.hpp"

namespace visnav::teleop {

// ---- params ------------------------------------------------------------------------------

namespace {
/// A params problem of `key` (validate()'s contract: the key, no file; ParamSchema adds the line).
Error param_problem(ErrorCode code, const char* key, std::string message) {
  return Error{std::move(message), code, {{}, 0, key}};
}
}  // namespace

Status TeleopParams::validate() const {
  if (axis_linear == axis_angular)
    return param_problem(ErrorCode::inconsistent, "axis_angular",
                         "key 'axis_angular': must differ from axis_linear");
  if (deadman_button == done_button)
    return param_problem(ErrorCode::inconsistent, "done_button",
                         "key 'done_button': must differ from deadman_button");
  if (close_button == deadman_button || close_button == done_button)
    return param_problem(ErrorCode::inconsistent, "close_button",
                         "key 'close_button': must differ from deadman_button and done_button");
  VISNAV_ASSIGN(auto buttons, parse_bindings(primitive_buttons, "primitive_buttons"));
  for (const auto& b : buttons) {
    auto n = detail::parse_int(b.trigger);
    if (!n || *n < 0 || *n > 255)
      return param_problem(ErrorCode::invalid_value, "primitive_buttons",
                           "key 'primitive_buttons': '" + b.trigger + "' is not a button number 0..255");
    if (*n == deadman_button || *n == done_button || *n == close_button)
      return param_problem(ErrorCode::inconsistent, "primitive_buttons",
                           "key 'primitive_buttons': button " + b.trigger + " is also the deadman, done or close button");
  }
  VISNAV_ASSIGN(auto keys, parse_bindings(primitive_keys, "primitive_keys"));
  const std::string reserved = "wasd q";
  for (const auto& k : keys) {
    if (k.trigger.size() != 1)
      return param_problem(ErrorCode::invalid_value, "primitive_keys",
                           "key 'primitive_keys': '" + k.trigger + "' is not a single character");
    if (reserved.find(k.trigger) != std::string::npos || k.trigger == done_key || k.trigger == manual_key ||
        k.trigger == close_key)
      return param_problem(ErrorCode::inconsistent, "primitive_keys",
                           "key 'primitive_keys': '" + k.trigger + "' is a driving, done, close or manual key");
  }
  if (done_key.size() != 1)
    return param_problem(ErrorCode::invalid_value, "done_key",
                         "key 'done_key': '" + done_key + "' is not a single character");
  if (manual_key.size() != 1 || manual_key == done_key)
    return param_problem(ErrorCode::inconsistent, "manual_key",
                         "key 'manual_key': '" + manual_key + "' must be one character other than done_key");
  if (close_key.size() != 1 || close_key == done_key || close_key == manual_key)
    return param_problem(ErrorCode::inconsistent, "close_key",
                         "key 'close_key': '" + close_key + "' must be one character other than done_key and manual_key");
  if (done_key == "+" || done_key == "-" || manual_key == "+" || manual_key == "-" || close_key == "+" || close_key == "-")
    return param_problem(ErrorCode::inconsistent, "done_key",
                         "key 'done_key'/'manual_key'/'close_key': + and - change the hold-to-drive speed");
  for (const auto& k : keys)
    if (k.trigger == "+" || k.trigger == "-")
      return param_problem(ErrorCode::inconsistent, "primitive_keys",
                           "key 'primitive_keys': + and - change the hold-to-drive speed");
  if (key_deadman_s > 0.0 && key_repeat_timeout_s > key_deadman_s)
    return param_problem(ErrorCode::inconsistent, "key_repeat_timeout_s",
                         "key 'key_repeat_timeout_s': must not exceed key_deadman_s (" + std::to_string(key_deadman_s) + ")");
  if (reserved.find(done_key) != std::string::npos || reserved.find(manual_key) != std::string::npos ||
      reserved.find(close_key) != std::string::npos)
    return param_problem(ErrorCode::inconsistent, "done_key",
                         "key 'done_key'/'manual_key'/'close_key': w, a, s, d, space and q are driving keys");
  return ok();
}

const ParamSchema<TeleopParams>& TeleopParams::schema() {
  static const auto s =
      ParamSchema<TeleopParams>{}
          .field("axis_linear", &TeleopParams::axis_linear, "joystick axis for forward speed (up = +)").range(0, 63)
          .field("axis_angular", &TeleopParams::axis_angular, "joystick axis for the turn rate (left = +)").range(0, 63)
          .field("scale_linear_mps", &TeleopParams::scale_linear_mps, "speed at full deflection, m/s (negative inverts)").range(-3, 3)
          .field("scale_angular_radps", &TeleopParams::scale_angular_radps, "yaw rate at full deflection, rad/s (negative inverts)").range(-6, 6)
          .field("deadzone", &TeleopParams::deadzone, "|axis| below this reads as 0").range(0, 0.9)
          .field("deadman_button", &TeleopParams::deadman_button, "button that must be held for the robot to move").range(0, 255)
          .field("done_button", &TeleopParams::done_button, "button that ends teaching").range(0, 255)
          .field("close_button", &TeleopParams::close_button, "button that closes the loop back at the start (then turn to face the first edge and press done)").range(0, 255)
          .field("primitive_buttons", &TeleopParams::primitive_buttons, "button=kind: switches the primitive being taught (kind '' = turning)")
          .field("key_deadman_s", &TeleopParams::key_deadman_s, "keyboard deadman: > 0 hold-to-drive, no key event for this long (before autorepeat starts) stops; 0 = sticky throttle, no deadman").range(0, 5)
          .field("key_repeat_timeout_s", &TeleopParams::key_repeat_timeout_s, "hold-to-drive: gap between autorepeats that means the key was released").range(0.02, 5)
          .field("key_hold_linear_mps", &TeleopParams::key_hold_linear_mps, "hold-to-drive: speed of a held up/w, down/s, m/s").range(0.01, 3)
          .field("key_hold_angular_radps", &TeleopParams::key_hold_angular_radps, "hold-to-drive: turn rate of a held left/a, right/d, rad/s").range(0.01, 6)
          .field("key_linear_step_mps", &TeleopParams::key_linear_step_mps, "keyboard: speed step per up/down key, m/s").range(0.01, 1)
          .field("key_angular_step_radps", &TeleopParams::key_angular_step_radps, "keyboard: turn-rate step per left/right key, rad/s").range(0.01, 2)
          .field("max_linear_mps", &TeleopParams::max_linear_mps, "keyboard/Twist speed limit, m/s").range(0.01, 3)
          .field("max_angular_radps", &TeleopParams::max_angular_radps, "keyboard/Twist turn-rate limit, rad/s").range(0.01, 6)
          .field("primitive_keys", &TeleopParams::primitive_keys, "key=kind: switches the primitive being taught (kind '' = turning)")
          .field("done_key", &TeleopParams::done_key, "keyboard key that ends teaching")
          .field("close_key", &TeleopParams::close_key, "keyboard key that closes the loop (as close_button)")
          .field("manual_key", &TeleopParams::manual_key, "keyboard key that toggles manual driving (TeleopOverride)")
          .field("input_timeout_s", &TeleopParams::input_timeout_s, "Joy/Twist topic silent this long: stop").range(0.02, 10);
  return s;
}

Result<TeleopParams> load_teleop_params(const std::string& path) {
  TeleopParams params;
  if (path.empty()) return params;
  VISNAV_ASSIGN(ConfigNode root, parse_yaml_file(path));
  return TeleopParams::schema().parse(root);
}

Result<std::vector<PrimitiveBinding>> parse_bindings(const std::vector<std::string>& entries, std::string_view what) {
  std::vector<PrimitiveBinding> out;
  for (const auto& e : entries) {
    const auto eq = e.find('=');
    if (eq == std::string::npos || eq == 0)
      return Error{"key '" + std::string(what) + "': entry '" + e + "' is not trigger=kind", ErrorCode::invalid_value,
                   {{}, 0, std::string(what)}};
    PrimitiveBinding b{e.substr(0, eq), e.substr(eq + 1)};
    for (const auto& other : out)
      if (other.trigger == b.trigger)
        return Error{"key '" + std::string(what) + "': '" + b.trigger + "' is bound twice", ErrorCode::inconsistent,
                     {{}, 0, std::string(what)}};
    out.push_back(std::move(b));
  }
  return out;
}

// ---- decoders ----------------------------------------------------------------------------

std::size_t JsEventDecoder::feed(const std::uint8_t* data, std::size_t size) {
  std::size_t events = 0;
  for (std::size_t i = 0; i < size; ++i) {
    partial_[partial_size_++] = data[i];
    if (partial_size_ < kEventBytes) continue;
    partial_size_ = 0;
    // struct js_event { __u32 time; __s16 value; __u8 type; __u8 number; } in host byte order.
    std::int16_t value = 0;
    std::memcpy(&value, partial_ + 4, sizeof value);
    apply(partial_[6], partial_[7], value);
    ++events;
  }
  return events;
}

void JsEventDecoder::apply(std::uint8_t type, std::uint8_t number, std::int16_t value) {
  constexpr std::uint8_t kButton = 0x01, kAxis = 0x02, kInit = 0x80;
  const bool init = (type & kInit) != 0;  // the driver's synthetic "current state" events at open
  const std::uint8_t kind = type & static_cast<std::uint8_t>(~kInit);
  const std::size_t n = number;
  if (kind == kAxis) {
    if (state_.axes.size() <= n) state_.axes.resize(n + 1, 0.0);
    state_.axes[n] = std::clamp(-static_cast<double>(value) / 32767.0, -1.0, 1.0);
  } else if (kind == kButton) {
    if (state_.buttons.size() <= n) state_.buttons.resize(n + 1, false);
    const bool pressed = value != 0;
    if (!init && pressed && !state_.buttons[n]) presses_.push_back(number);
    if (!init && !pressed && state_.buttons[n]) releases_.push_back(number);
    state_.buttons[n] = pressed;
  }
}

EvdevDecoder::Layout EvdevDecoder::Layout::xbox_gamepad() {
  Layout l;
  for (std::uint16_t code : {ABS_X, ABS_Y, ABS_Z, ABS_RX, ABS_RY, ABS_RZ}) l.axes.push_back({code, -32768, 32767});
  l.axes[2] = {ABS_Z, 0, 1023};  // triggers: released = min (reads +1, as on js*), pulled = max
  l.axes[5] = {ABS_RZ, 0, 1023};
  l.axes.push_back({ABS_HAT0X, -1, 1});
  l.axes.push_back({ABS_HAT0Y, -1, 1});
  l.buttons = {BTN_SOUTH, BTN_EAST, BTN_NORTH, BTN_WEST, BTN_TL, BTN_TR,
               BTN_SELECT, BTN_START, BTN_MODE, BTN_THUMBL, BTN_THUMBR};
  return l;
}

const std::size_t EvdevDecoder::kEventBytes = sizeof(input_event);

EvdevDecoder::EvdevDecoder(Layout layout) : layout_(std::move(layout)) {
  state_.axes.assign(layout_.axes.size(), 0.0);
  state_.buttons.assign(layout_.buttons.size(), false);
  partial_.reserve(kEventBytes);
}

std::size_t EvdevDecoder::feed(const std::uint8_t* data, std::size_t size) {
  std::size_t events = 0;
  for (std::size_t i = 0; i < size; ++i) {
    partial_.push_back(data[i]);
    if (partial_.size() < kEventBytes) continue;
    input_event e{};
    std::memcpy(&e, partial_.data(), kEventBytes);
    partial_.clear();
    apply(e.type, e.code, e.value);
    ++events;
  }
  return events;
}

void EvdevDecoder::apply(std::uint16_t type, std::uint16_t code, std::int32_t value) {
  if (type == EV_ABS) {
    for (std::size_t i = 0; i < layout_.axes.size(); ++i) {
      const Axis& a = layout_.axes[i];
      if (a.code != code) continue;
      const double span = static_cast<double>(a.max) - static_cast<double>(a.min);
      const double unit = span > 0.0 ? 2.0 * (static_cast<double>(value) - a.min) / span - 1.0 : 0.0;
      state_.axes[i] = std::clamp(-unit, -1.0, 1.0);  // up/left = +1 (evdev: up/left = min)
      return;
    }
  } else if (type == EV_KEY) {
    for (std::size_t i = 0; i < layout_.buttons.size(); ++i) {
      if (layout_.buttons[i] != code) continue;
      const bool pressed = value != 0;  // 1 press, 2 autorepeat (still held), 0 release
      const int number = static_cast<int>(i);
      if (pressed && !state_.buttons[i]) presses_.push_back(number);
      if (!pressed && state_.buttons[i]) releases_.push_back(number);
      state_.buttons[i] = pressed;
      return;
    }
  }
  if (type == EV_SYN && code == SYN_DROPPED) {
    // The kernel's buffer overflowed: events were lost, a deadman release among them perhaps.
    // Every button counts as released until the device reports it again (the robot stops).
    for (std::size_t i = 0; i < state_.buttons.size(); ++i) {
      if (state_.buttons[i]) releases_.push_back(static_cast<int>(i));
      state_.buttons[i] = false;
    }
  }
  // Other EV_SYN, EV_MSC and unmapped codes carry nothing for teleop.
}

std::string EvdevKeyDecoder::key_name(std::uint16_t code) {
  switch (code) {
    case KEY_UP: return "\x1b[A";
    case KEY_DOWN: return "\x1b[B";
    case KEY_RIGHT: return "\x1b[C";
    case KEY_LEFT: return "\x1b[D";
    case KEY_SPACE: return " ";
    case KEY_ENTER: return "\n";
    case KEY_MINUS: case KEY_KPMINUS: return "-";
    case KEY_EQUAL: return "=";
    case KEY_KPPLUS: return "+";
    default: break;
  }
  // Letters and digits, as the lower-case character a terminal would send for them.
  static constexpr std::pair<std::uint16_t, char> kChars[] = {
      {KEY_A, 'a'}, {KEY_B, 'b'}, {KEY_C, 'c'}, {KEY_D, 'd'}, {KEY_E, 'e'}, {KEY_F, 'f'}, {KEY_G, 'g'},
      {KEY_H, 'h'}, {KEY_I, 'i'}, {KEY_J, 'j'}, {KEY_K, 'k'}, {KEY_L, 'l'}, {KEY_M, 'm'}, {KEY_N, 'n'},
      {KEY_O, 'o'}, {KEY_P, 'p'}, {KEY_Q, 'q'}, {KEY_R, 'r'}, {KEY_S, 's'}, {KEY_T, 't'}, {KEY_U, 'u'},
      {KEY_V, 'v'}, {KEY_W, 'w'}, {KEY_X, 'x'}, {KEY_Y, 'y'}, {KEY_Z, 'z'}, {KEY_0, '0'}, {KEY_1, '1'},
      {KEY_2, '2'}, {KEY_3, '3'}, {KEY_4, '4'}, {KEY_5, '5'}, {KEY_6, '6'}, {KEY_7, '7'}, {KEY_8, '8'},
      {KEY_9, '9'}};
  for (const auto& [c, ch] : kChars)
    if (c == code) return std::string(1, ch);
  return {};
}

void EvdevKeyDecoder::feed(const std::uint8_t* data, std::size_t size, std::vector<Event>& out) {
  for (std::size_t i = 0; i < size; ++i) {
    partial_.push_back(data[i]);
    if (partial_.size() < EvdevDecoder::kEventBytes) continue;
    input_event e{};
    std::memcpy(&e, partial_.data(), EvdevDecoder::kEventBytes);
    partial_.clear();
    if (e.type == EV_SYN && e.code == SYN_DROPPED) {
      // Events were lost (a release among them, perhaps): every held key counts as let go.
      for (auto& k : held_) out.push_back({std::move(k), true});
      held_.clear();
      continue;
    }
    if (e.type != EV_KEY) continue;
    std::string key = key_name(e.code);
    if (key.empty()) continue;
    const auto it = std::find(held_.begin(), held_.end(), key);
    if (e.value == 0) {
      if (it != held_.end()) held_.erase(it);
      out.push_back({std::move(key), true});
    } else {  // 1 press, 2 autorepeat
      if (it == held_.end()) held_.push_back(key);
      out.push_back({std::move(key), false});
    }
  }
}

bool is_evdev_path(const std::string& device) {
  const auto slash = device.find_last_of('/');
  const std::string base = slash == std::string::npos ? device : device.substr(slash + 1);
  return base.starts_with("event") || base.find("-event-") != std::string::npos;
}

void KeyDecoder::feed(std::string_view bytes, std::vector<std::string>& out) {
  pending_.append(bytes);
  std::size_t i = 0;
  while (i < pending_.size()) {
    const char c = pending_[i];
    if (c == '\x1b') {
      if (i + 1 >= pending_.size()) break;  // wait for the rest
      if (pending_[i + 1] != '[' && pending_[i + 1] != 'O') { out.emplace_back("\x1b"); ++i; continue; }
      if (i + 2 >= pending_.size()) break;
      // CSI: parameters (digits, ';') then one final byte in '@'..'~'.
      std::size_t j = i + 2;
      while (j < pending_.size() && ((pending_[j] >= '0' && pending_[j] <= '9') || pending_[j] == ';')) ++j;
      if (j >= pending_.size()) break;
      const char final_byte = pending_[j];
      if (j == i + 2 && final_byte >= 'A' && final_byte <= 'D') out.push_back(std::string("\x1b[") + final_byte);
      i = j + 1;
      continue;
    }
    out.emplace_back(1, c == '\r' ? '\n' : c);
    ++i;
  }
  pending_.erase(0, i);
}

// ---- teleops -----------------------------------------------------------------------------

namespace {

double shaped_axis(double value, double deadzone) {
  if (std::abs(value) < deadzone) return 0.0;
  // Rescale so the output starts at 0 at the deadzone edge (no jump).
  const double sign = value < 0.0 ? -1.0 : 1.0;
  return sign * (std::abs(value) - deadzone) / (1.0 - deadzone);
}

Twist clamp_twist(const Twist& t, const TeleopParams& p) {
  return {std::clamp(t.linear_mps, -p.max_linear_mps, p.max_linear_mps),
          std::clamp(t.angular_radps, -p.max_angular_radps, p.max_angular_radps)};
}

double snap(double v) { return std::abs(v) < 1e-9 ? 0.0 : v; }

}  // namespace

Result<JoyTeleop> JoyTeleop::create(const TeleopParams& params) {
  VISNAV_TRY(params.validate());
  VISNAV_ASSIGN(auto bindings, parse_bindings(params.primitive_buttons, "primitive_buttons"));
  std::vector<std::pair<int, std::string>> buttons;
  for (auto& b : bindings) buttons.emplace_back(*detail::parse_int(b.trigger), std::move(b.kind));
  return JoyTeleop(params, std::move(buttons));
}

TeleopAction JoyTeleop::update(const JoyState& state, const std::vector<int>& presses, bool fresh,
                               bool released_deadman) {
  TeleopAction a;
  for (int b : presses) {
    if (b == params_.done_button) done_ = true;
    if (b == params_.close_button) closing_ = true;
    for (const auto& [button, kind] : buttons_)
      if (button == b) a.primitive = kind;
  }
  a.done = done_;
  a.closing = closing_;
  if (!fresh) {
    a.reason = "no joystick input";
  } else if (released_deadman || !state.button(params_.deadman_button)) {
    a.reason = "deadman (button " + std::to_string(params_.deadman_button) + ") released";
  } else {
    a.engaged = true;
    a.command.linear_mps = snap(shaped_axis(state.axis(params_.axis_linear), params_.deadzone) * params_.scale_linear_mps);
    a.command.angular_radps =
        snap(shaped_axis(state.axis(params_.axis_angular), params_.deadzone) * params_.scale_angular_radps);
  }
  return a;
}

Result<KeyTeleop> KeyTeleop::create(const TeleopParams& params, bool start_manual) {
  VISNAV_TRY(params.validate());
  VISNAV_ASSIGN(auto bindings, parse_bindings(params.primitive_keys, "primitive_keys"));
  std::vector<std::pair<std::string, std::string>> keys;
  for (auto& b : bindings) keys.emplace_back(std::move(b.trigger), std::move(b.kind));
  return KeyTeleop(params, std::move(keys), start_manual);
}

bool KeyTeleop::apply_hold_key(const std::string& key, double now_s) {
  std::string drive;  // the motion, so "w" and the up arrow repeat as one key
  Twist t;
  if (key == "\x1b[A" || key == "w" || key == "W") { drive = "fwd"; t.linear_mps = hold_speed_.linear_mps; }
  else if (key == "\x1b[B" || key == "s" || key == "S") { drive = "back"; t.linear_mps = -hold_speed_.linear_mps; }
  else if (key == "\x1b[D" || key == "a" || key == "A") { drive = "left"; t.angular_radps = hold_speed_.angular_radps; }
  else if (key == "\x1b[C" || key == "d" || key == "D") { drive = "right"; t.angular_radps = -hold_speed_.angular_radps; }
  else if (key == "+" || key == "=" || key == "-") {
    const double sign = key == "-" ? -1.0 : 1.0;
    hold_speed_.linear_mps = std::clamp(hold_speed_.linear_mps + sign * params_.key_linear_step_mps,
                                        params_.key_linear_step_mps, params_.max_linear_mps);
    hold_speed_.angular_radps = std::clamp(hold_speed_.angular_radps + sign * params_.key_angular_step_radps,
                                           params_.key_angular_step_radps, params_.max_angular_radps);
    return true;
  } else {
    return false;
  }
  // A second event of the same key within the deadman is the terminal's autorepeat: from then
  // on a short gap already means the key is up.
  repeating_ = drive == held_key_ && now_s - last_key_s_ <= params_.key_deadman_s;
  held_key_ = drive;
  last_key_s_ = now_s;
  target_ = clamp_twist(t, params_);
  return true;
}

void KeyTeleop::release_key(const std::string& key) {
  if (!manual_ || !hold_mode() || held_key_.empty()) return;
  const std::string drive = key == "\x1b[A" || key == "w"   ? "fwd"
                            : key == "\x1b[B" || key == "s" ? "back"
                            : key == "\x1b[D" || key == "a" ? "left"
                            : key == "\x1b[C" || key == "d" ? "right"
                                                             : "";
  if (drive != held_key_) return;  // another key let go while the driving one is still down
  held_key_.clear();
  repeating_ = false;
  target_ = Twist{};
}

void KeyTeleop::release_all() {
  if (!hold_mode() || held_key_.empty()) return;
  held_key_.clear();
  repeating_ = false;
  target_ = Twist{};
}

bool KeyTeleop::apply_key(const std::string& key, double now_s) {
  const auto& p = params_;
  if (manual_ && hold_mode() && apply_hold_key(key, now_s)) return true;
  if (key == "\x1b[A" || key == "w" || key == "W") target_.linear_mps += p.key_linear_step_mps;
  else if (key == "\x1b[B" || key == "s" || key == "S") target_.linear_mps -= p.key_linear_step_mps;
  else if (key == "\x1b[D" || key == "a" || key == "A") target_.angular_radps += p.key_angular_step_radps;
  else if (key == "\x1b[C" || key == "d" || key == "D") target_.angular_radps -= p.key_angular_step_radps;
  else if (key == " ") { target_ = Twist{}; held_key_.clear(); }
  else if (key == p.done_key) { done_ = true; target_ = Twist{}; }
  else if (key == p.close_key) { closing_ = true; target_ = Twist{}; }  // stop at the start, then turn
  else if (key == p.manual_key) { manual_ = !manual_; target_ = Twist{}; held_key_.clear(); }
  else {
    for (const auto& [k, kind] : keys_)
      if (k == key) { switched_ = kind; return true; }
    return false;
  }
  target_ = clamp_twist(target_, p);
  target_.linear_mps = snap(target_.linear_mps);
  target_.angular_radps = snap(target_.angular_radps);
  return true;
}

TeleopAction KeyTeleop::update(double now_s) {
  TeleopAction a;
  a.primitive = std::exchange(switched_, std::nullopt);
  a.done = done_;
  a.closing = closing_;
  if (!manual_) {
    a.reason = "automatic (press " + params_.manual_key + " to drive)";
  } else if (done_) {
    a.reason = "teaching ended";
  } else {
    if (hold_mode() && !held_key_.empty() &&
        now_s - last_key_s_ > (repeating_ ? params_.key_repeat_timeout_s : params_.key_deadman_s)) {
      // The keyboard deadman: the key is up. Zero, and forget the key so the next one starts
      // from rest. Still engaged (manual): TeleopOverride keeps the mission waiting until the
      // operator hands back with manual_key.
      held_key_.clear();
      repeating_ = false;
      target_ = Twist{};
    }
    a.engaged = true;
    a.command = target_;
  }
  return a;
}

TeleopAction twist_action(const Twist& newest, bool fresh, const TeleopParams& params) {
  TeleopAction a;
  if (!fresh) {
    a.reason = "no teleop Twist within " + std::to_string(params.input_timeout_s) + " s";
  } else if (newest.linear_mps == 0.0 && newest.angular_radps == 0.0) {
    a.reason = "teleop Twist is zero";
  } else {
    a.engaged = true;
    a.command = clamp_twist(newest, params);
  }
  return a;
}

Result<std::vector<Mark>> parse_marks(const std::string& text, const std::string& file) {
  std::vector<Mark> marks;
  std::size_t start = 0;
  int line_no = 0;
  bool header = false;
  while (start <= text.size()) {
    std::size_t nl = text.find('\n', start);
    if (nl == std::string::npos) nl = text.size();
    std::string line = text.substr(start, nl - start);
    start = nl + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') {
      if (nl == text.size()) break;
      continue;
    }
    if (!header) {
      if (line != "t_s,primitive") return fail(ErrorCode::parse_error, {file, line_no}, "expected the header 't_s,primitive'");
      header = true;
      continue;
    }
    const auto comma = line.find(',');
    if (comma == std::string::npos) return fail(ErrorCode::parse_error, {file, line_no}, "expected t_s,primitive");
    auto t = detail::parse_double(line.substr(0, comma));
    if (!t) return fail(ErrorCode::invalid_value, {file, line_no, "t_s"}, t.error().message);
    if (!marks.empty() && *t < marks.back().t_s)
      return fail(ErrorCode::inconsistent, {file, line_no, "t_s"},
                  "time " + line.substr(0, comma) + " is earlier than the previous mark");
    marks.push_back({*t, line.substr(comma + 1)});
    if (nl == text.size()) break;
  }
  if (!header) return fail(ErrorCode::parse_error, {file}, "empty marks file (expected the header 't_s,primitive')");
  return marks;
}

std::string primitive_at(const std::vector<Mark>& marks, double t_s) {
  std::string p;
  for (const auto& m : marks) {
    if (m.t_s > t_s) break;
    p = m.primitive;
  }
  return p;
}

std::string status_line(const TeleopAction& action, const std::string& primitive, const TeleopParams& params,
                        bool keyboard) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(2) << "v " << std::setw(5) << action.command.linear_mps << " m/s  w "
    << std::setw(5) << action.command.angular_radps << " rad/s  teaching: "
    << (primitive.empty() ? std::string("(turning, not recorded)") : primitive);
  if (!action.engaged) s << "  [stopped: " << action.reason << "]";
  if (keyboard) {
    s << (params.key_deadman_s > 0.0 ? "  | hold arrows/WASD to drive, +/- speed, space stop" : "  | arrows/WASD drive, space stop");
    for (const auto& e : params.primitive_keys) s << ", " << e;
    s << ", " << params.close_key << " close loop, " << params.done_key << " end";
  }
  return s.str();
}

}  // namespace visnav::teleop
