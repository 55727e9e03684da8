// Operator nodes: the pure cores (joystick event decoding, key sequences, deadman, mapping
// file errors) and the nodes loaded from the real libvisnav_teleop.so, driven by a fake joystick
// (a FIFO carrying Linux js_event records), a keyboard FIFO and, with DDS, sensor_msgs/Joy and
// geometry_msgs/Twist samples on a loopback domain.
#include <fcntl.h>
#include <linux/input.h>
#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <thread>

#include "error_expect.hpp"
#include "visnav/bt/registry.hpp"
#include "visnav/bt/tree.hpp"
#include "visnav/dds_joy.hpp"
#include "visnav/loader.hpp"
#include "visnav/runtime_host.hpp"
#include "visnav_teleop/teleop_core.hpp"

#include "dds_test_util.hpp"
#include "fake_devices.hpp"

namespace fs = std::filesystem;
using namespace visnav;
using namespace visnav::teleop;
using bt::NodeStatus;

namespace {

/// One Linux js_event record (linux/joystick.h layout, host byte order).
std::vector<std::uint8_t> js_event(std::uint8_t type, std::uint8_t number, std::int16_t value, std::uint32_t time_ms = 0) {
  std::vector<std::uint8_t> e(8);
  std::memcpy(e.data(), &time_ms, 4);
  std::memcpy(e.data() + 4, &value, 2);
  e[6] = type;
  e[7] = number;
  return e;
}
constexpr std::uint8_t kButton = 0x01, kAxis = 0x02, kInit = 0x80;

/// One Linux evdev record (struct input_event, as read from /dev/input/event*).
std::vector<std::uint8_t> ev_event(std::uint16_t type, std::uint16_t code, std::int32_t value) {
  input_event e{};
  e.type = type;
  e.code = code;
  e.value = value;
  std::vector<std::uint8_t> b(sizeof e);
  std::memcpy(b.data(), &e, sizeof e);
  return b;
}
std::vector<std::uint8_t> cat(std::initializer_list<std::vector<std::uint8_t>> parts) {
  std::vector<std::uint8_t> out;
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}
TeleopParams sticky_keys() {
  TeleopParams p;
  p.key_deadman_s = 0.0;
  return p;
}

// ---- cores -------------------------------------------------------------------------------

using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST(JsEventDecoder, DecodesAxesUpLeftPositiveAndButtonEdgesAcrossPartialReads) {
  JsEventDecoder d;
  auto bytes = js_event(kAxis | kInit, 1, 0);
  auto more = js_event(kButton | kInit, 4, 1);  // held at open: not a press
  bytes.insert(bytes.end(), more.begin(), more.end());
  auto up = js_event(kAxis, 1, -32767);  // stick up: the driver reports negative
  bytes.insert(bytes.end(), up.begin(), up.end());
  auto press = js_event(kButton, 2, 1);
  bytes.insert(bytes.end(), press.begin(), press.end());
  // Split mid-event: nothing is applied until the record is complete.
  EXPECT_EQ(d.feed(bytes.data(), 20), 2U);
  EXPECT_EQ(d.feed(bytes.data() + 20, bytes.size() - 20), 2U);
  EXPECT_DOUBLE_EQ(d.state().axis(1), 1.0);
  EXPECT_TRUE(d.state().button(4));
  EXPECT_EQ(d.take_presses(), std::vector<int>{2});
  EXPECT_TRUE(d.take_presses().empty());
  auto release = js_event(kButton, 4, 0);
  d.feed(release.data(), release.size());
  EXPECT_EQ(d.take_releases(), std::vector<int>{4});
}

TEST(KeyDecoder, SplitsArrowsPrintablesAndIncompleteEscapes) {
  KeyDecoder d;
  std::vector<std::string> keys;
  d.feed("w\x1b[", keys);
  ASSERT_EQ(keys.size(), 1U);
  d.feed("Ds\r\x1b[1;5C", keys);  // left arrow completed; ctrl-right is dropped
  ASSERT_EQ(keys.size(), 4U);
  EXPECT_EQ(keys[1], "\x1b[D");
  EXPECT_EQ(keys[2], "s");
  EXPECT_EQ(keys[3], "\n");
}

TEST(JoyTeleop, DrivesOnlyWithTheDeadmanAndStopsForOneTickOnARelease) {
  TeleopParams p;
  auto t = JoyTeleop::create(p);
  ASSERT_TRUE(t.ok()) << t.error().message;
  JoyState s;
  s.axes = {0.5, 1.0};  // angular axis 0 half left, linear axis 1 full up
  s.buttons.assign(8, false);
  TeleopAction a = t->update(s, {}, true, false);
  EXPECT_FALSE(a.engaged);
  EXPECT_EQ(a.command.linear_mps, 0.0);
  s.buttons[4] = true;
  a = t->update(s, {}, true, false);
  ASSERT_TRUE(a.engaged);
  EXPECT_NEAR(a.command.linear_mps, 0.5, 1e-9);
  EXPECT_NEAR(a.command.angular_radps, 0.8 * (0.5 - 0.08) / (1 - 0.08), 1e-9);  // past the deadzone
  // Released and pressed again between two ticks: still one stopped tick.
  a = t->update(s, {}, true, true);
  EXPECT_FALSE(a.engaged);
  EXPECT_EQ(a.command.linear_mps, 0.0);
  // Stale input (topic silent) never drives.
  a = t->update(s, {}, false, false);
  EXPECT_FALSE(a.engaged);
  // Primitive buttons and done (sticky).
  a = t->update(s, {2}, true, false);
  ASSERT_TRUE(a.primitive.has_value());
  EXPECT_EQ(*a.primitive, "path_following");
  a = t->update(s, {1, 7}, true, false);
  EXPECT_EQ(*a.primitive, "");
  EXPECT_TRUE(a.done);
  EXPECT_TRUE(t->update(s, {}, true, false).done);
}

TEST(EvdevDecoder, NumbersAxesAndButtonsLikeJoydevAndNormalisesWithTheDeviceRange) {
  EvdevDecoder d(EvdevDecoder::Layout::xbox_gamepad());
  auto bytes = cat({ev_event(EV_ABS, ABS_Y, -32768), ev_event(EV_ABS, ABS_X, 32767), ev_event(EV_SYN, SYN_REPORT, 0),
                    ev_event(EV_ABS, ABS_Z, 0), ev_event(EV_KEY, BTN_TL, 1), ev_event(EV_KEY, BTN_START, 1),
                    ev_event(EV_KEY, BTN_START, 0), ev_event(EV_KEY, KEY_A, 1)});
  // Split mid-record: nothing applied until a record is complete.
  const std::size_t cut = EvdevDecoder::kEventBytes + 5;
  EXPECT_EQ(d.feed(bytes.data(), cut), 1U);
  EXPECT_DOUBLE_EQ(d.state().axis(1), 1.0);  // stick up (min) reads +1
  EXPECT_EQ(d.feed(bytes.data() + cut, bytes.size() - cut), 7U);
  EXPECT_DOUBLE_EQ(d.state().axis(0), -1.0);  // stick right (max) reads -1
  EXPECT_DOUBLE_EQ(d.state().axis(2), 1.0);   // trigger released, as joy_linux reports it
  EXPECT_TRUE(d.state().button(4));           // LB is joystick button 4, as on /dev/input/js0
  EXPECT_FALSE(d.state().button(7));
  EXPECT_EQ(d.take_presses(), (std::vector<int>{4, 7}));
  EXPECT_EQ(d.take_releases(), (std::vector<int>{7}));
  // Autorepeat (value 2) of a held button is not a new press; unmapped KEY_A was ignored.
  d.feed(ev_event(EV_KEY, BTN_TL, 2).data(), EvdevDecoder::kEventBytes);
  EXPECT_TRUE(d.take_presses().empty());
  EXPECT_EQ(d.state().buttons.size(), 11U);
  // Events lost (SYN_DROPPED): the held deadman counts as released.
  d.feed(ev_event(EV_SYN, SYN_DROPPED, 0).data(), EvdevDecoder::kEventBytes);
  EXPECT_FALSE(d.state().button(4));
  EXPECT_EQ(d.take_releases(), (std::vector<int>{4}));
}

TEST(EvdevDecoder, DevicePathsChooseEvdevOrTheJoystickApi) {
  EXPECT_TRUE(is_evdev_path("/dev/input/event3"));
  EXPECT_TRUE(is_evdev_path("/dev/input/by-id/usb-Microsoft_X-Box_pad-event-joystick"));
  EXPECT_FALSE(is_evdev_path("/dev/input/js0"));
  EXPECT_FALSE(is_evdev_path("/dev/input/by-id/usb-Microsoft_X-Box_pad-joystick"));
}

TEST(KeyTeleop, HoldToDriveStopsWhenTheKeyRepeatsStop) {
  TeleopParams p;  // default: hold-to-drive, 0.7 s before autorepeat, 0.1 s between repeats
  auto k = KeyTeleop::create(p, true);
  ASSERT_TRUE(k.ok());
  EXPECT_TRUE(k->update(0.0).engaged);
  EXPECT_EQ(k->update(0.0).command.linear_mps, 0.0);
  k->apply_key("w", 1.0);
  EXPECT_DOUBLE_EQ(k->update(1.0).command.linear_mps, p.key_hold_linear_mps);
  // The terminal's autorepeat delay: no event for 0.5 s, still driving.
  EXPECT_DOUBLE_EQ(k->update(1.5).command.linear_mps, p.key_hold_linear_mps);
  for (double t = 1.5; t < 2.0; t += 0.04) k->apply_key("\x1b[A", t);  // repeats at 25 Hz (arrow = w)
  EXPECT_DOUBLE_EQ(k->update(2.0).command.linear_mps, p.key_hold_linear_mps);
  // Released after the last repeat (t ~ 1.98): zero 0.1 s later, not 0.7 s later.
  EXPECT_GT(k->update(2.05).command.linear_mps, 0.0);
  TeleopAction a = k->update(2.1);
  EXPECT_EQ(a.command.linear_mps, 0.0);
  EXPECT_TRUE(a.engaged);  // still manual: the command is a stop
  // A first press that never repeats stops after key_deadman_s; the next key starts from rest.
  k->apply_key("a", 3.0);
  EXPECT_DOUBLE_EQ(k->update(3.6).command.angular_radps, p.key_hold_angular_radps);
  EXPECT_EQ(k->update(3.75).command.angular_radps, 0.0);
  // '+' raises both speeds by a step; a held s backs up.
  k->apply_key("+", 4.0);
  k->apply_key("s", 4.0);
  EXPECT_NEAR(k->update(4.0).command.linear_mps, -(p.key_hold_linear_mps + p.key_linear_step_mps), 1e-12);
  EXPECT_EQ(k->update(4.0).command.angular_radps, 0.0);
}

TEST(KeyTeleop, StepsClampsStopsAndSwitchesPrimitive) {
  TeleopParams p = sticky_keys();
  auto k = KeyTeleop::create(p, true);
  ASSERT_TRUE(k.ok());
  for (int i = 0; i < 20; ++i) k->apply_key("\x1b[A");
  EXPECT_DOUBLE_EQ(k->target().linear_mps, p.max_linear_mps);
  k->apply_key("a");
  EXPECT_NEAR(k->target().angular_radps, p.key_angular_step_radps, 1e-12);
  EXPECT_TRUE(k->apply_key("p"));
  TeleopAction a = k->update();
  EXPECT_TRUE(a.engaged);
  EXPECT_EQ(a.primitive.value_or("?"), "path_following");
  EXPECT_FALSE(k->update().primitive.has_value());
  k->apply_key(" ");
  EXPECT_EQ(k->update().command.linear_mps, 0.0);
  EXPECT_FALSE(k->apply_key("z"));
  k->apply_key("e");
  a = k->update();
  EXPECT_TRUE(a.done);
  EXPECT_FALSE(a.engaged);
}

TEST(EvdevKeyDecoder, SpellsKeysAsATerminalDoesAndReportsReleases) {
  EvdevKeyDecoder d;
  std::vector<EvdevKeyDecoder::Event> events;
  const auto bytes = cat({ev_event(EV_KEY, KEY_UP, 1), ev_event(EV_SYN, SYN_REPORT, 0), ev_event(EV_KEY, KEY_Q, 1),
                          ev_event(EV_KEY, KEY_UP, 2), ev_event(EV_KEY, KEY_UP, 0), ev_event(EV_KEY, KEY_F1, 1),
                          ev_event(EV_MSC, MSC_SCAN, 17)});
  // Fed in two pieces that split a record: the partial one waits for its rest.
  d.feed(bytes.data(), 30, events);
  d.feed(bytes.data() + 30, bytes.size() - 30, events);
  ASSERT_EQ(events.size(), 4U);  // F1 and the scan code mean nothing to teleop
  EXPECT_EQ(events[0].key, "\x1b[A");
  EXPECT_FALSE(events[0].released);
  EXPECT_EQ(events[1].key, "q");
  EXPECT_FALSE(events[2].released);  // autorepeat
  EXPECT_TRUE(events[3].released);
  events.clear();
  d.feed(ev_event(EV_SYN, SYN_DROPPED, 0).data(), EvdevDecoder::kEventBytes, events);
  ASSERT_EQ(events.size(), 1U);  // q is still held: lost events release it
  EXPECT_EQ(events[0].key, "q");
  EXPECT_TRUE(events[0].released);
}

TEST(KeyTeleop, ReleasingTheDrivingKeyStopsAtOnceAndOtherReleasesDoNot) {
  auto k = KeyTeleop::create(TeleopParams{}, true);
  ASSERT_TRUE(k.ok());
  k->apply_key("w", 0.0);
  EXPECT_GT(k->update(0.01).command.linear_mps, 0.0);
  k->release_key("a");  // not the key that drives
  EXPECT_GT(k->update(0.02).command.linear_mps, 0.0);
  k->release_key("w");
  EXPECT_EQ(k->update(0.03).command.linear_mps, 0.0);  // 30 ms: long before any timeout
}

TEST(TeleopParams, CloseKeyAndButtonMustNotClashWithOtherControls) {
  TeleopParams p;
  p.close_key = p.done_key;
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::inconsistent, key_only("close_key")));
  p = TeleopParams{};
  p.close_button = p.deadman_button;
  EXPECT_TRUE(fails_with(p.validate(), ErrorCode::inconsistent, key_only("close_button")));
  p = TeleopParams{};
  p.primitive_keys = {"c=feature_segment"};
  EXPECT_FALSE(p.validate().ok());
}

TEST(KeyTeleop, OverrideStartsAutomaticUntilTheManualKey) {
  auto k = KeyTeleop::create(sticky_keys(), false);
  ASSERT_TRUE(k.ok());
  k->apply_key("w");
  EXPECT_FALSE(k->update().engaged);  // ignored: automatic
  k->apply_key("m");
  k->apply_key("w");
  TeleopAction a = k->update();
  EXPECT_TRUE(a.engaged);
  EXPECT_NEAR(a.command.linear_mps, 0.1, 1e-12);
  k->apply_key("m");
  EXPECT_FALSE(k->update().engaged);
}

TEST(TwistAction, EngagedOnlyWhileFreshAndNonZeroAndClamped) {
  TeleopParams p;
  EXPECT_FALSE(twist_action({0.3, 0.0}, false, p).engaged);
  EXPECT_FALSE(twist_action({0.0, 0.0}, true, p).engaged);
  TeleopAction a = twist_action({5.0, -0.2}, true, p);
  EXPECT_TRUE(a.engaged);
  EXPECT_DOUBLE_EQ(a.command.linear_mps, p.max_linear_mps);
  EXPECT_DOUBLE_EQ(a.command.angular_radps, -0.2);
}

TEST(TeleopParams, MappingFileErrorsNameTheFileLineAndKey) {
  const fs::path dir = test::fresh_test_dir("teleop");
  fs::create_directories(dir);
  const fs::path file = dir / "pad.yaml";
  std::ofstream(file) << "axis_linear: 1\ndeadman_buton: 5\n";
  auto r = load_teleop_params(file.string());
  EXPECT_TRUE(fails_with(r, ErrorCode::unknown_key, At{"pad.yaml", 2, "deadman_buton"}));
  std::ofstream(file) << "deadman_button: 2\n";  // also bound to path_following by default
  r = load_teleop_params(file.string());
  EXPECT_TRUE(fails_with(r, ErrorCode::inconsistent, At{"pad.yaml", 0, "primitive_buttons"}));
  std::ofstream(file) << "deadman_button: 5\nprimitive_buttons: [\"0=feature_segment\", \"3=\"]\n";
  r = load_teleop_params(file.string());
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->deadman_button, 5);
  // The shipped mappings load.
  for (const char* shipped : {"config/teleop/gamepad.yaml", "config/teleop/keyboard.yaml"}) {
    auto s = load_teleop_params(std::string(VISNAV_TEST_SOURCE_DIR) + "/" + shipped);
    EXPECT_TRUE(s.ok()) << shipped << ": " << (s.ok() ? "" : s.error().message);
  }
  fs::remove_all(dir);
}

// ---- nodes -------------------------------------------------------------------------------

/// Counts ticks and drives at 1 m/s: the mission under TeleopOverride.
class Mission final : public bt::StatefulActionNode {
 public:
  Mission(const std::string& name, const bt::NodeConfig& config, HostServices& host, int& ticks)
      : StatefulActionNode(name, config), host_(host), ticks_(ticks) {}
  static bt::PortsList provided_ports() { return {}; }
  NodeStatus on_start() override { return on_running(); }
  NodeStatus on_running() override {
    ++ticks_;
    (void)host_.robot()->send_command({1.0, 0.0});
    return ticks_ >= 1000 ? NodeStatus::success : NodeStatus::running;
  }
  void on_halted() override {}

 private:
  HostServices& host_;
  int& ticks_;
};

class TeleopNodes : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::fresh_test_dir("teleop_nodes");
    fs::create_directories(dir_);
    fifo_ = (dir_ / "dev").string();
    ASSERT_EQ(::mkfifo(fifo_.c_str(), 0600), 0);
    // O_RDWR never blocks on a FIFO and keeps a writer, so the node's reads see data, not EOF.
    writer_ = ::open(fifo_.c_str(), O_RDWR | O_NONBLOCK);
    ASSERT_GE(writer_, 0);
    sticky_ = (dir_ / "sticky.yaml").string();
    std::ofstream(sticky_) << "key_deadman_s: 0\n";
    host_.set_frame_bus(&bus_);
    host_.set_robot(&robot_);
    ASSERT_TRUE(test::register_plugin_nodes(loader_, "teleop", registry_, host_));
    ASSERT_TRUE(registry_
                    .register_node<Mission>("Mission", "test mission",
                                            [this](const std::string& n, const bt::NodeConfig& c) {
                                              return std::make_unique<Mission>(n, c, host_, mission_ticks_);
                                            })
                    .ok());
  }
  void TearDown() override {
    if (writer_ >= 0) ::close(writer_);
    fs::remove_all(dir_);
  }
  void write_bytes(const std::vector<std::uint8_t>& b) { ASSERT_EQ(::write(writer_, b.data(), b.size()), static_cast<ssize_t>(b.size())); }
  void write_text(const std::string& s) { ASSERT_EQ(::write(writer_, s.data(), s.size()), static_cast<ssize_t>(s.size())); }

  fs::path dir_;
  std::string fifo_;
  std::string sticky_;  // mapping file: sticky-throttle keyboard (no key deadman)
  int writer_ = -1;
  PluginLoader loader_{std::vector<std::string>{VISNAV_TEST_PLUGIN_DIR}};
  StderrLogger logger_{LogLevel::error};
  ManualClock clock_;
  RuntimeHost host_{loader_, logger_, clock_};
  FrameBus bus_;
  test::KinematicRobot robot_{bus_};
  bt::NodeRegistry registry_;
  int mission_ticks_ = 0;
};

TEST_F(TeleopNodes, JoystickTeachesWithTheDeadmanAndEndsWithTheDoneButton) {
  bt::Tree tree = test::load_main_tree(
      "<Teleop input=\"joystick\" device=\"" + fifo_ + "\" primitive=\"{primitive}\" done=\"{teach_done}\"/>", registry_,
      &clock_);
  write_bytes(js_event(kAxis | kInit, 1, 0));
  EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
  // Stick up without the deadman: nothing.
  write_bytes(js_event(kAxis, 1, -32767));
  tree.tick_once();
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
  // Deadman held: drives; the feature button switches primitive.
  write_bytes(js_event(kButton, 4, 1));
  write_bytes(js_event(kButton, 0, 1));
  tree.tick_once();
  EXPECT_NEAR(robot_.command_.linear_mps, 0.5, 1e-9);
  EXPECT_EQ(*tree.blackboard().get<std::string>("primitive"), "feature_segment");
  EXPECT_FALSE(*tree.blackboard().get<bool>("teach_done"));
  write_bytes(js_event(kButton, 7, 1));
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_TRUE(*tree.blackboard().get<bool>("teach_done"));
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
}

TEST_F(TeleopNodes, DeadmanReleaseStopsTheRobotWithin100msAtA20HzTick) {
  bt::Tree tree = test::load_main_tree("<Teleop input=\"joystick\" device=\"" + fifo_ + "\"/>", registry_, &clock_);
  write_bytes(js_event(kButton, 4, 1));
  write_bytes(js_event(kAxis, 1, -32767));
  tree.tick_once();
  ASSERT_GT(robot_.command_.linear_mps, 0.4);
  // The release arrives at an arbitrary moment between ticks; the tick loop runs at 20 Hz.
  using Clock = std::chrono::steady_clock;
  Clock::time_point released_at{};
  std::thread pad([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(137));
    released_at = Clock::now();
    auto e = js_event(kButton, 4, 0);
    (void)::write(writer_, e.data(), e.size());
  });
  Clock::time_point stopped_at{};
  const auto start = Clock::now();
  while (Clock::now() - start < std::chrono::milliseconds(600)) {
    tree.tick_once();
    if (robot_.command_.linear_mps == 0.0 && stopped_at == Clock::time_point{}) stopped_at = Clock::now();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  pad.join();
  ASSERT_NE(stopped_at, Clock::time_point{});
  const double latency_ms = std::chrono::duration<double, std::milli>(stopped_at - released_at).count();
  std::printf("deadman release -> zero command: %.1f ms\n", latency_ms);
  EXPECT_GE(latency_ms, 0.0);
  EXPECT_LE(latency_ms, 100.0);
}

TEST_F(TeleopNodes, UnpluggedJoystickStopsAndFails) {
  bt::Tree tree = test::load_main_tree("<Teleop input=\"joystick\" device=\"" + fifo_ + "\"/>", registry_, &clock_);
  write_bytes(js_event(kButton, 4, 1));
  write_bytes(js_event(kAxis, 1, -32767));
  tree.tick_once();
  ASSERT_GT(robot_.command_.linear_mps, 0.4);
  ::close(writer_);  // the only writer: the node reads end of file
  writer_ = -1;
  EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
}

TEST_F(TeleopNodes, MissingJoystickDeviceFailsNamingIt) {
  bt::Tree tree = test::load_main_tree("<Teleop input=\"joystick\" device=\"/dev/input/js_missing\"/>", registry_, &clock_);
  EXPECT_EQ(tree.tick_once(), NodeStatus::failure);
}

TEST_F(TeleopNodes, KeyboardDrivesSwitchesPrimitiveAndEndsTeaching) {
  bt::Tree tree = test::load_main_tree("<Teleop input=\"keyboard\" device=\"" + fifo_ + "\" mapping_file=\"" + sticky_ +
                                           "\" initial_primitive=\"feature_segment\"/>",
                                       registry_, &clock_);
  EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  EXPECT_EQ(*tree.blackboard().get<std::string>("primitive"), "feature_segment");
  write_text("ww\x1b[Dp");
  tree.tick_once();
  EXPECT_NEAR(robot_.command_.linear_mps, 0.2, 1e-9);
  EXPECT_NEAR(robot_.command_.angular_radps, 0.15, 1e-9);
  EXPECT_EQ(*tree.blackboard().get<std::string>("primitive"), "path_following");
  write_text("e");
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
}

// Closing a taught loop by hand: the close key stops the robot at the start and sets
// {teach_closing} (TeachRoute ends the last edge there); the operator then turns in place to face
// the first edge (that turn is the closing turn TeachRoute records) and ends teaching.
TEST_F(TeleopNodes, CloseKeySignalsTheClosingTurnThenTheOperatorTurnsAndEnds) {
  bt::Tree tree = test::load_main_tree("<Teleop input=\"keyboard\" device=\"" + fifo_ + "\" mapping_file=\"" + sticky_ +
                                           "\" initial_primitive=\"feature_segment\"/>",
                                       registry_, &clock_);
  EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  EXPECT_FALSE(*tree.blackboard().get<bool>("teach_closing"));
  write_text("ww");
  tree.tick_once();
  EXPECT_NEAR(robot_.command_.linear_mps, 0.2, 1e-9);
  write_text("c");
  EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  EXPECT_TRUE(*tree.blackboard().get<bool>("teach_closing"));
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);  // stopped at the start
  EXPECT_FALSE(*tree.blackboard().get<bool>("teach_done"));
  write_text("aa");  // turn on the spot to face the first edge
  tree.tick_once();
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
  EXPECT_NEAR(robot_.command_.angular_radps, 0.30, 1e-9);
  write_text("e");
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_TRUE(*tree.blackboard().get<bool>("teach_done"));
  EXPECT_TRUE(*tree.blackboard().get<bool>("teach_closing"));
}

TEST_F(TeleopNodes, KeyboardDeadmanStopsWithin100msOfTheLastAutorepeat) {
  bt::Tree tree = test::load_main_tree("<Teleop input=\"keyboard\" device=\"" + fifo_ + "\"/>", registry_, &clock_);
  EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  // A held key at 20 Hz ticks: the first event, the terminal's 0.5 s autorepeat delay, then a
  // repeat every 40 ms (the run clock is the test's; two repeats per tick at most).
  double last_key_s = 0.0;
  for (int tick = 1; tick <= 30; ++tick) {
    clock_.set(tick * 0.05);
    if (tick == 1 || tick >= 11) { write_text(tick >= 11 ? "ww" : "w"); last_key_s = clock_.now_s(); }
    tree.tick_once();
    EXPECT_DOUBLE_EQ(robot_.command_.linear_mps, 0.3) << "tick " << tick;
  }
  // Released: the first tick more than 0.1 s after the last repeat sends zero.
  double stopped_s = -1.0;
  for (int tick = 31; tick <= 40 && stopped_s < 0.0; ++tick) {
    clock_.set(tick * 0.05);
    tree.tick_once();
    if (robot_.command_.linear_mps == 0.0) stopped_s = clock_.now_s();
  }
  ASSERT_GT(stopped_s, 0.0);
  std::printf("keyboard: last autorepeat -> zero command: %.0f ms of run clock at a 20 Hz tick\n",
              (stopped_s - last_key_s) * 1e3);
  EXPECT_LE(stopped_s - last_key_s, 0.1 + 0.05 + 1e-9);  // the timeout plus at most one tick
}

TEST_F(TeleopNodes, EvdevKeyboardStopsAtTheTickAfterTheDrivingKeyIsLetGo) {
  // A keyboard on evdev reports releases: the deadman does not wait for a timeout.
  const std::string event_dev = (dir_ / "event4").string();
  ASSERT_EQ(::mkfifo(event_dev.c_str(), 0600), 0);
  const int w = ::open(event_dev.c_str(), O_RDWR | O_NONBLOCK);
  ASSERT_GE(w, 0);
  auto send = [&](const std::vector<std::uint8_t>& b) {
    ASSERT_EQ(::write(w, b.data(), b.size()), static_cast<ssize_t>(b.size()));
  };
  bt::Tree tree = test::load_main_tree("<Teleop input=\"keyboard\" device=\"" + event_dev + "\"/>", registry_, &clock_);
  clock_.set(0.0);
  send(cat({ev_event(EV_KEY, KEY_W, 1), ev_event(EV_SYN, SYN_REPORT, 0)}));
  EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  EXPECT_GT(robot_.command_.linear_mps, 0.0);
  // Held through the kernel's autorepeat (value 2) for a while.
  for (int tick = 1; tick <= 10; ++tick) {
    clock_.set(tick * 0.05);
    send(cat({ev_event(EV_KEY, KEY_W, 2), ev_event(EV_SYN, SYN_REPORT, 0)}));
    tree.tick_once();
    EXPECT_GT(robot_.command_.linear_mps, 0.0) << "tick " << tick;
  }
  // Let go 10 ms after the last repeat; the next tick (40 ms later) sends zero.
  send(cat({ev_event(EV_KEY, KEY_W, 0), ev_event(EV_SYN, SYN_REPORT, 0)}));
  const double released_s = 0.51;
  clock_.set(0.55);
  tree.tick_once();
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
  std::printf("evdev keyboard: key release -> zero command: %.0f ms of run clock at a 20 Hz tick\n",
              (clock_.now_s() - released_s) * 1e3);
  // A held turn key, then lost events (SYN_DROPPED): counted as let go.
  send(cat({ev_event(EV_KEY, KEY_LEFT, 1), ev_event(EV_SYN, SYN_REPORT, 0)}));
  clock_.set(0.60);
  tree.tick_once();
  EXPECT_GT(robot_.command_.angular_radps, 0.0);
  send(ev_event(EV_SYN, SYN_DROPPED, 0));
  clock_.set(0.65);
  tree.tick_once();
  EXPECT_EQ(robot_.command_.angular_radps, 0.0);
  // A held key, then the device goes away (the only writer closes: end of file): let go.
  send(cat({ev_event(EV_KEY, KEY_S, 1), ev_event(EV_SYN, SYN_REPORT, 0)}));
  clock_.set(0.70);
  tree.tick_once();
  EXPECT_LT(robot_.command_.linear_mps, 0.0);
  ::close(w);
  clock_.set(0.75);
  tree.tick_once();
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
}

TEST_F(TeleopNodes, EvdevGamepadTeachesWithTheDeadmanLikeTheJoystickApi) {
  // An evdev node (the FIFO's name says event*) replaying struct input_event records.
  const std::string event_dev = (dir_ / "event7").string();
  ASSERT_EQ(::mkfifo(event_dev.c_str(), 0600), 0);
  const int w = ::open(event_dev.c_str(), O_RDWR | O_NONBLOCK);
  ASSERT_GE(w, 0);
  auto send = [&](const std::vector<std::uint8_t>& b) {
    ASSERT_EQ(::write(w, b.data(), b.size()), static_cast<ssize_t>(b.size()));
  };
  bt::Tree tree = test::load_main_tree("<Teleop input=\"joystick\" device=\"" + event_dev + "\"/>", registry_, &clock_);
  send(cat({ev_event(EV_ABS, ABS_Y, -32768), ev_event(EV_SYN, SYN_REPORT, 0)}));
  EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);  // no deadman yet
  send(cat({ev_event(EV_KEY, BTN_TL, 1), ev_event(EV_KEY, BTN_SOUTH, 1), ev_event(EV_SYN, SYN_REPORT, 0)}));
  tree.tick_once();
  EXPECT_NEAR(robot_.command_.linear_mps, 0.5, 1e-9);
  EXPECT_EQ(*tree.blackboard().get<std::string>("primitive"), "feature_segment");
  // Deadman released and pressed again between two ticks: one tick of zero.
  send(cat({ev_event(EV_KEY, BTN_TL, 0), ev_event(EV_SYN, SYN_REPORT, 0), ev_event(EV_KEY, BTN_TL, 1)}));
  tree.tick_once();
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
  tree.tick_once();
  EXPECT_NEAR(robot_.command_.linear_mps, 0.5, 1e-9);
  send(ev_event(EV_KEY, BTN_START, 1));
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
  ::close(w);
}

TEST_F(TeleopNodes, JoystickCloseButtonSetsTheClosingOutput) {
  bt::Tree tree = test::load_main_tree("<Teleop input=\"joystick\" device=\"" + fifo_ + "\"/>", registry_, &clock_);
  write_bytes(js_event(kAxis | kInit, 1, 0));
  EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  EXPECT_FALSE(*tree.blackboard().get<bool>("teach_closing"));
  write_bytes(js_event(kButton, 6, 1));
  EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  EXPECT_TRUE(*tree.blackboard().get<bool>("teach_closing"));
}

TEST_F(TeleopNodes, OverridePausesTheMissionWhileTheOperatorDrives) {
  bt::Tree tree = test::load_main_tree(
      "<TeleopOverride input=\"keyboard\" device=\"" + fifo_ + "\" mapping_file=\"" + sticky_ + "\"><Mission/></TeleopOverride>",
      registry_, &clock_);
  tree.tick_once();
  EXPECT_EQ(mission_ticks_, 1);
  EXPECT_EQ(robot_.command_.linear_mps, 1.0);
  write_text("mss");  // take over and back up
  for (int i = 0; i < 3; ++i) EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  EXPECT_EQ(mission_ticks_, 1);
  EXPECT_NEAR(robot_.command_.linear_mps, -0.2, 1e-9);
  write_text("m");  // hand back: stop, then the mission continues where it was
  const int stops_before = robot_.commands_;
  tree.tick_once();
  EXPECT_EQ(mission_ticks_, 2);
  EXPECT_GE(robot_.commands_, stops_before + 2);  // a stop, then the mission's command
  EXPECT_EQ(robot_.command_.linear_mps, 1.0);
}

TEST_F(TeleopNodes, JoyTopicDrivesAndStopsWhenTheTopicFallsSilent) {
  if (!dds::available()) GTEST_SKIP() << "built without DDS";
  dds::testing::use_loopback();
  const int domain = dds::testing::random_domain_id();
  auto participant = dds::Participant::create(domain);
  ASSERT_TRUE(participant.ok());
  auto writer = dds::Writer<dds::msg::Joy>::create(*participant, {"rt/joy", dds::Qos::ros_default(), ""});
  ASSERT_TRUE(writer.ok());
  bt::Tree tree = test::load_main_tree(
      "<Teleop input=\"joy\" domain_id=\"" + std::to_string(domain) + "\" primitive=\"{primitive}\"/>", registry_, &clock_);
  tree.tick_once();
  ASSERT_TRUE(writer->wait_for_readers(1, 5.0));
  dds::msg::Joy joy;
  joy.axes = {0.0F, 1.0F};
  joy.buttons = {0, 0, 1, 0, 1, 0, 0, 0};  // path_following button and deadman held
  ASSERT_TRUE(writer->write(joy).ok());
  ASSERT_TRUE(dds::testing::eventually([&] {
    tree.tick_once();
    return robot_.command_.linear_mps > 0.4;
  }));
  EXPECT_EQ(*tree.blackboard().get<std::string>("primitive"), "path_following");
  // No more messages: after input_timeout_s (0.5 s) the robot is stopped.
  ASSERT_TRUE(dds::testing::eventually([&] {
    tree.tick_once();
    return robot_.command_.linear_mps == 0.0;
  }, 2.0));
}

TEST_F(TeleopNodes, TwistTopicOverridesOnlyWhileFresh) {
  if (!dds::available()) GTEST_SKIP() << "built without DDS";
  dds::testing::use_loopback();
  const int domain = dds::testing::random_domain_id();
  auto participant = dds::Participant::create(domain);
  ASSERT_TRUE(participant.ok());
  auto writer = dds::Writer<dds::msg::Twist>::create(*participant, {"rt/cmd_vel_teleop", dds::Qos::ros_default(), ""});
  ASSERT_TRUE(writer.ok());
  bt::Tree tree = test::load_main_tree("<TeleopOverride input=\"twist\" domain_id=\"" + std::to_string(domain) +
                                           "\"><Mission/></TeleopOverride>",
                                       registry_, &clock_);
  tree.tick_once();
  EXPECT_EQ(mission_ticks_, 1);
  ASSERT_TRUE(writer->wait_for_readers(1, 5.0));
  dds::msg::Twist t;
  t.angular.z = 0.4;
  ASSERT_TRUE(writer->write(t).ok());
  ASSERT_TRUE(dds::testing::eventually([&] {
    tree.tick_once();
    return robot_.command_.angular_radps == 0.4;
  }));
  const int ticks = mission_ticks_;
  ASSERT_TRUE(dds::testing::eventually([&] {
    tree.tick_once();
    return mission_ticks_ > ticks;
  }, 2.0));
  EXPECT_EQ(robot_.command_.linear_mps, 1.0);
}

}  // namespace
