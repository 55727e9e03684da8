#include "inputs.hpp"

#include <fcntl.h>
#include <linux/input.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <deque>
#include <mutex>
#include <vector>

#include "visnav/dds_joy.hpp"

namespace visnav::teleop {
namespace {

std::string errno_text() { return std::strerror(errno); }

double steady_now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// Reads every byte available on a non-blocking fd into `out`. Returns false at end of file
/// (a FIFO whose writer closed); errors other than "nothing now" are returned.
Result<bool> read_available(int fd, std::vector<std::uint8_t>& out) {
  std::uint8_t buffer[512];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n > 0) { out.insert(out.end(), buffer, buffer + n); continue; }
    if (n == 0) return false;
    if (errno == EINTR) continue;
    if (errno == EAGAIN || errno == EWOULDBLOCK) return true;
    return fail(errno_text());
  }
}

// ---- keyboard ----------------------------------------------------------------------------

class KeyboardInput final : public OperatorInput {
 public:
  KeyboardInput(int fd, bool owns_fd, KeyTeleop core) : fd_(fd), owns_fd_(owns_fd), core_(std::move(core)) {
    // Raw mode on a terminal (keys arrive at once, no echo); restored in the destructor.
    if (::isatty(fd_) != 0 && ::tcgetattr(fd_, &saved_) == 0) {
      termios raw = saved_;
      raw.c_lflag &= static_cast<tcflag_t>(~(ICANON | ECHO));
      raw.c_cc[VMIN] = 0;
      raw.c_cc[VTIME] = 0;
      restore_ = ::tcsetattr(fd_, TCSANOW, &raw) == 0;
    }
    saved_flags_ = ::fcntl(fd_, F_GETFL);
    if (saved_flags_ >= 0) (void)::fcntl(fd_, F_SETFL, saved_flags_ | O_NONBLOCK);
  }
  ~KeyboardInput() override {
    if (restore_) (void)::tcsetattr(fd_, TCSANOW, &saved_);
    if (saved_flags_ >= 0) (void)::fcntl(fd_, F_SETFL, saved_flags_);
    if (owns_fd_) ::close(fd_);
  }
  KeyboardInput(const KeyboardInput&) = delete;
  KeyboardInput& operator=(const KeyboardInput&) = delete;

  Result<TeleopAction> poll(double now_s) override {
    bytes_.clear();
    auto open = read_available(fd_, bytes_);
    if (!open) return fail("keyboard: read failed: " + open.error().message);
    keys_.clear();
    decoder_.feed(std::string_view(reinterpret_cast<const char*>(bytes_.data()), bytes_.size()), keys_);
    for (const auto& k : keys_) (void)core_.apply_key(k, now_s);
    return core_.update(now_s);
  }
  [[nodiscard]] bool keyboard() const override { return true; }

 private:
  int fd_;
  bool owns_fd_;
  KeyTeleop core_;
  KeyDecoder decoder_;
  termios saved_{};
  bool restore_ = false;
  int saved_flags_ = -1;
  std::vector<std::uint8_t> bytes_;
  std::vector<std::string> keys_;
};

/// A keyboard on evdev: key presses, autorepeats and releases (KeyTeleop::release_key), so letting
/// go of a driving key stops at the next tick. Reading /dev/input/event* needs group `input`.
class EvdevKeyboardInput final : public OperatorInput {
 public:
  EvdevKeyboardInput(std::string device, int fd, KeyTeleop core) : device_(std::move(device)), fd_(fd), core_(std::move(core)) {}
  ~EvdevKeyboardInput() override { ::close(fd_); }
  EvdevKeyboardInput(const EvdevKeyboardInput&) = delete;
  EvdevKeyboardInput& operator=(const EvdevKeyboardInput&) = delete;

  Result<TeleopAction> poll(double now_s) override {
    bytes_.clear();
    auto open = read_available(fd_, bytes_);
    if (!open) return fail(ErrorCode::io, {device_}, "keyboard: read failed: " + open.error().message);
    events_.clear();
    decoder_.feed(bytes_.data(), bytes_.size(), events_);
    for (const auto& e : events_) {
      if (e.released) core_.release_key(e.key);
      else (void)core_.apply_key(e.key, now_s);
    }
    if (!*open) {
      // The device went away (unplugged, FIFO writer closed): nothing is held any more.
      core_.release_all();
    }
    return core_.update(now_s);
  }
  [[nodiscard]] bool keyboard() const override { return true; }

 private:
  std::string device_;
  int fd_;
  KeyTeleop core_;
  EvdevKeyDecoder decoder_;
  std::vector<std::uint8_t> bytes_;
  std::vector<EvdevKeyDecoder::Event> events_;
};

// ---- Linux joystick: joystick API (js*) or evdev (event*) ---------------------------------

/// Asks an evdev device which axes and buttons it has, numbered as joydev numbers them (so the
/// mapping of /dev/input/jsN fits /dev/input/eventN). A file that does not answer (a FIFO
/// replaying events, a device without EV_ABS) gets the Xbox-style gamepad layout.
EvdevDecoder::Layout evdev_layout(int fd) {
  constexpr std::size_t kLongBits = sizeof(unsigned long) * 8;
  auto has = [](const std::vector<unsigned long>& bits, std::size_t i) {
    return (bits[i / kLongBits] >> (i % kLongBits)) & 1UL;
  };
  std::vector<unsigned long> abs_bits(ABS_CNT / kLongBits + 1, 0UL);
  std::vector<unsigned long> key_bits(KEY_CNT / kLongBits + 1, 0UL);
  if (::ioctl(fd, EVIOCGBIT(EV_ABS, abs_bits.size() * sizeof(unsigned long)), abs_bits.data()) < 0 ||
      ::ioctl(fd, EVIOCGBIT(EV_KEY, key_bits.size() * sizeof(unsigned long)), key_bits.data()) < 0)
    return EvdevDecoder::Layout::xbox_gamepad();
  EvdevDecoder::Layout layout;
  for (std::uint16_t code = 0; code < ABS_CNT; ++code) {
    if (!has(abs_bits, code)) continue;
    input_absinfo info{};
    if (::ioctl(fd, EVIOCGABS(code), &info) < 0) continue;
    layout.axes.push_back({code, info.minimum, info.maximum});
  }
  // joydev: BTN_MISC..KEY_MAX first, then 0..BTN_MISC-1.
  for (std::uint16_t code = BTN_MISC; code < KEY_CNT; ++code)
    if (has(key_bits, code)) layout.buttons.push_back(code);
  for (std::uint16_t code = 0; code < BTN_MISC; ++code)
    if (has(key_bits, code)) layout.buttons.push_back(code);
  return layout;
}

template <typename Decoder>
class JoystickInput final : public OperatorInput {
 public:
  JoystickInput(std::string device, int fd, JoyTeleop core, int deadman, Decoder decoder)
      : device_(std::move(device)), fd_(fd), core_(std::move(core)), deadman_(deadman), decoder_(std::move(decoder)) {}
  ~JoystickInput() override { ::close(fd_); }
  JoystickInput(const JoystickInput&) = delete;
  JoystickInput& operator=(const JoystickInput&) = delete;

  Result<TeleopAction> poll(double /*now_s*/) override {
    bytes_.clear();
    auto open = read_available(fd_, bytes_);
    // ENODEV: unplugged. The node stops the robot and fails with this message.
    if (!open) return fail(device_ + ": joystick read failed (" + open.error().message + "); unplugged?");
    if (!*open) closed_ = true;
    decoder_.feed(bytes_.data(), bytes_.size());
    bool released = false;
    for (int b : decoder_.take_releases()) released = released || b == deadman_;
    TeleopAction a = core_.update(decoder_.state(), decoder_.take_presses(), !closed_, released);
    if (closed_) a.reason = device_ + " closed";
    return a;
  }

 private:
  std::string device_;
  int fd_;
  JoyTeleop core_;
  int deadman_;
  Decoder decoder_;
  bool closed_ = false;
  std::vector<std::uint8_t> bytes_;
};

// ---- DDS: sensor_msgs/Joy and geometry_msgs/Twist ----------------------------------------

/// Samples queued by the subscription thread (bounded: a stalled tick drops the oldest).
template <typename M>
struct SampleQueue {
  static constexpr std::size_t kMax = 256;
  std::mutex mutex;
  std::deque<M> samples;
  double last_receive_s = -1.0;  // steady clock
  void push(M&& m) {
    std::lock_guard lock(mutex);
    if (samples.size() == kMax) samples.pop_front();
    samples.push_back(std::move(m));
    last_receive_s = steady_now_s();
  }
  std::deque<M> take(double& last_receive) {
    std::lock_guard lock(mutex);
    last_receive = last_receive_s;
    return std::exchange(samples, {});
  }
};

class JoyTopicInput final : public OperatorInput {
 public:
  JoyTopicInput(JoyTeleop core, const TeleopParams& params, std::shared_ptr<SampleQueue<dds::msg::Joy>> queue,
                std::unique_ptr<dds::Subscription<dds::msg::Joy>> subscription)
      : core_(std::move(core)), params_(params), queue_(std::move(queue)), subscription_(std::move(subscription)) {}

  Result<TeleopAction> poll(double /*now_s*/) override {
    double last_receive_s = -1.0;
    auto samples = queue_->take(last_receive_s);
    std::vector<int> presses;
    bool released = false;
    // Button edges between consecutive messages (joy_node publishes on every change).
    for (const auto& m : samples) {
      JoyState next;
      next.axes.assign(m.axes.begin(), m.axes.end());
      next.buttons.resize(m.buttons.size());
      for (std::size_t i = 0; i < m.buttons.size(); ++i) next.buttons[i] = m.buttons[i] != 0;
      for (std::size_t i = 0; i < next.buttons.size(); ++i) {
        const bool was = state_.button(static_cast<int>(i));
        if (next.buttons[i] && !was) presses.push_back(static_cast<int>(i));
        if (!next.buttons[i] && was && static_cast<int>(i) == params_.deadman_button) released = true;
      }
      state_ = std::move(next);
      have_state_ = true;
    }
    const bool fresh = have_state_ && last_receive_s >= 0.0 && steady_now_s() - last_receive_s <= params_.input_timeout_s;
    TeleopAction a = core_.update(state_, presses, fresh, released);
    if (!fresh) a.reason = "no sensor_msgs/Joy on " + subscription_->topic() + " within " +
                           std::to_string(params_.input_timeout_s) + " s";
    return a;
  }

 private:
  JoyTeleop core_;
  TeleopParams params_;
  std::shared_ptr<SampleQueue<dds::msg::Joy>> queue_;
  std::unique_ptr<dds::Subscription<dds::msg::Joy>> subscription_;  // after queue_: stops first
  JoyState state_;
  bool have_state_ = false;
};

class TwistTopicInput final : public OperatorInput {
 public:
  TwistTopicInput(const TeleopParams& params, std::shared_ptr<SampleQueue<dds::msg::Twist>> queue,
                  std::unique_ptr<dds::Subscription<dds::msg::Twist>> subscription)
      : params_(params), queue_(std::move(queue)), subscription_(std::move(subscription)) {}

  Result<TeleopAction> poll(double /*now_s*/) override {
    double last_receive_s = -1.0;
    auto samples = queue_->take(last_receive_s);
    if (!samples.empty()) newest_ = Twist{samples.back().linear.x, samples.back().angular.z};
    const bool fresh = last_receive_s >= 0.0 && steady_now_s() - last_receive_s <= params_.input_timeout_s;
    return twist_action(newest_, fresh, params_);
  }

 private:
  TeleopParams params_;
  std::shared_ptr<SampleQueue<dds::msg::Twist>> queue_;
  std::unique_ptr<dds::Subscription<dds::msg::Twist>> subscription_;
  Twist newest_;
};

template <typename M>
Result<std::unique_ptr<dds::Subscription<M>>> subscribe(const InputSpec& spec, const std::string& default_topic,
                                                        const std::shared_ptr<SampleQueue<M>>& queue) {
  VISNAV_ASSIGN(auto participant, dds::Participant::create(spec.domain_id));
  dds::EndpointOptions options;
  options.topic = dds::ros_topic(spec.topic.empty() ? default_topic : spec.topic);
  options.qos = dds::Qos::sensor_data();  // best effort: matches joy_node's and teleop's writers
  return dds::Subscription<M>::create(participant, options, [queue](M&& m, const dds::SampleInfo&) {
    queue->push(std::move(m));
  });
}

}  // namespace

Result<std::unique_ptr<OperatorInput>> open_input(const InputSpec& spec, const TeleopParams& params) {
  VISNAV_TRY(params.validate());
  if (spec.input == "keyboard") {
    VISNAV_ASSIGN(auto core, KeyTeleop::create(params, spec.start_manual));
    if (spec.device.empty()) {
      if (::isatty(STDIN_FILENO) == 0)
        return fail("input 'keyboard': stdin is not a terminal (run visnav in a terminal, or set device= to a FIFO)");
      return std::unique_ptr<OperatorInput>(new KeyboardInput(STDIN_FILENO, false, std::move(core)));
    }
    const int fd = ::open(spec.device.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
      return fail(ErrorCode::io, {spec.device}, "input 'keyboard': cannot open the device: " + errno_text() +
                                                    (is_evdev_path(spec.device) ? " (is the user in group 'input'?)" : ""));
    if (is_evdev_path(spec.device))
      return std::unique_ptr<OperatorInput>(new EvdevKeyboardInput(spec.device, fd, std::move(core)));
    return std::unique_ptr<OperatorInput>(new KeyboardInput(fd, true, std::move(core)));
  }
  if (spec.input == "joystick") {
    const std::string device = spec.device.empty() ? "/dev/input/js0" : spec.device;
    VISNAV_ASSIGN(auto core, JoyTeleop::create(params));
    const int fd = ::open(device.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
      return fail("input 'joystick': cannot open '" + device + "': " + errno_text() +
                  " (is the pad plugged in? is the user in group 'input'?)");
    if (is_evdev_path(device))
      return std::unique_ptr<OperatorInput>(new JoystickInput<EvdevDecoder>(
          device, fd, std::move(core), params.deadman_button, EvdevDecoder(evdev_layout(fd))));
    return std::unique_ptr<OperatorInput>(
        new JoystickInput<JsEventDecoder>(device, fd, std::move(core), params.deadman_button, JsEventDecoder{}));
  }
  if (spec.input == "joy") {
    VISNAV_ASSIGN(auto core, JoyTeleop::create(params));
    auto queue = std::make_shared<SampleQueue<dds::msg::Joy>>();
    auto sub = subscribe<dds::msg::Joy>(spec, "rt/joy", queue);
    if (!sub) return fail("input 'joy': " + sub.error().message);
    return std::unique_ptr<OperatorInput>(new JoyTopicInput(std::move(core), params, queue, std::move(*sub)));
  }
  if (spec.input == "twist") {
    auto queue = std::make_shared<SampleQueue<dds::msg::Twist>>();
    auto sub = subscribe<dds::msg::Twist>(spec, "rt/cmd_vel_teleop", queue);
    if (!sub) return fail("input 'twist': " + sub.error().message);
    return std::unique_ptr<OperatorInput>(new TwistTopicInput(params, queue, std::move(*sub)));
  }
  return fail("port 'input': '" + spec.input + "' is not one of keyboard, joystick, joy, twist");
}

}  // namespace visnav::teleop
