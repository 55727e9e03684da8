// Test support for the behaviour-tree engine: a fake clock, a scripted "world" and recording
// nodes that log every tick / start / running / halt.
#pragma once

#include <gtest/gtest.h>

#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "visnav/bt/bt.hpp"

namespace bt_test {

using visnav::bt::NodeConfig;
using visnav::bt::NodeStatus;
using visnav::bt::PortsList;

class FakeClock final : public visnav::Clock {
 public:
  [[nodiscard]] double now_s() const override { return t_s; }
  void advance_ms(double ms) { t_s += ms * 1e-3; }
  double t_s = 100.0;
};

/// Scripted results and an event log shared by the recording nodes.
struct World {
  std::vector<std::string> log;
  std::map<std::string, std::deque<NodeStatus>> script;  // next results, per node name
  std::map<std::string, NodeStatus> fixed;                // result once the script is empty

  NodeStatus next(const std::string& name, NodeStatus fallback) {
    auto& q = script[name];
    if (!q.empty()) {
      const NodeStatus s = q.front();
      q.pop_front();
      return s;
    }
    auto it = fixed.find(name);
    return it != fixed.end() ? it->second : fallback;
  }
  void set(const std::string& name, NodeStatus s) { fixed[name] = s; }
  void push(const std::string& name, std::initializer_list<NodeStatus> s) {
    for (NodeStatus x : s) script[name].push_back(x);
  }
  std::string joined() const {
    std::string out;
    for (const auto& e : log) out += (out.empty() ? "" : " ") + e;
    return out;
  }
  std::string take() {
    std::string out = joined();
    log.clear();
    return out;
  }
};

/// Condition: logs "<name>" on tick; result scripted (default success).
class TestCondition final : public visnav::bt::ConditionNode {
 public:
  TestCondition(const std::string& name, const NodeConfig& config, World& world)
      : ConditionNode(name, config), world_(world) {}
  static PortsList provided_ports() { return {}; }

 protected:
  NodeStatus tick() override {
    world_.log.push_back(name());
    return world_.next(name(), NodeStatus::success);
  }

 private:
  World& world_;
};

/// Synchronous action: logs "<name>" on tick; result scripted (default success).
class TestAction final : public visnav::bt::SyncActionNode {
 public:
  TestAction(const std::string& name, const NodeConfig& config, World& world)
      : SyncActionNode(name, config), world_(world) {}
  static PortsList provided_ports() { return {}; }

 protected:
  NodeStatus tick() override {
    world_.log.push_back(name());
    return world_.next(name(), NodeStatus::success);
  }

 private:
  World& world_;
};

/// Stateful action: logs "<name>:start", "<name>:run", "<name>:halt"; results scripted
/// (default running).
class TestAsync final : public visnav::bt::StatefulActionNode {
 public:
  TestAsync(const std::string& name, const NodeConfig& config, World& world)
      : StatefulActionNode(name, config), world_(world) {}
  static PortsList provided_ports() { return {}; }
  NodeStatus on_start() override {
    world_.log.push_back(name() + ":start");
    return world_.next(name(), NodeStatus::running);
  }
  NodeStatus on_running() override {
    world_.log.push_back(name() + ":run");
    return world_.next(name(), NodeStatus::running);
  }
  void on_halted() override { world_.log.push_back(name() + ":halt"); }

 private:
  World& world_;
};

enum class Color { red = 1, green = 2, blue = 7 };

/// Reads every typed port and stores what it got in the world log; writes outputs.
class Probe final : public visnav::bt::SyncActionNode {
 public:
  Probe(const std::string& name, const NodeConfig& config, World& world) : SyncActionNode(name, config), world_(world) {}
  static PortsList provided_ports() {
    using namespace visnav::bt;
    return {input_port<int>("i", "7", "an int"),
            input_port<double>("d", "0.5", "a double"),
            input_port<bool>("b", "false", "a bool"),
            input_port<std::string>("s", "hello", "a string"),
            input_port<Color>("color", "green", "an enum"),
            input_port<std::vector<int>>("vi", "1;2;3", "int list"),
            input_port<std::vector<double>>("vd", "", "double list"),
            input_port<std::vector<std::string>>("vs", "a;b", "string list"),
            output_port<int>("out_i", "an int output"),
            output_port<std::string>("out_s", "a string output")};
  }

  int i = 0;
  double d = 0;
  bool b = false;
  std::string s;
  Color color = Color::red;
  std::vector<int> vi;
  std::vector<double> vd;
  std::vector<std::string> vs;
  std::vector<std::string> errors;

 protected:
  NodeStatus tick() override {
    world_.log.push_back(name());
    errors.clear();
    read("i", i);
    read("d", d);
    read("b", b);
    read("s", s);
    read("color", color);
    read("vi", vi);
    read("vd", vd);
    read("vs", vs);
    if (auto st = set_output("out_i", i * 2); !st) errors.push_back(st.error().message);
    if (auto st = set_output("out_s", s + "!"); !st) errors.push_back(st.error().message);
    return errors.empty() ? NodeStatus::success : NodeStatus::failure;
  }

 private:
  template <typename T>
  void read(const char* port, T& out) {
    auto v = get_input<T>(port);
    if (v) {
      out = *v;
    } else {
      errors.push_back(v.error().message);
    }
  }
  World& world_;
};

/// Registry with the built-ins, the enum Color and the test nodes Cond, Act, Async, Probe.
inline visnav::bt::NodeRegistry make_registry(World& world) {
  visnav::bt::NodeRegistry r;
  EXPECT_TRUE(visnav::bt::register_builtin_nodes(r).ok());
  EXPECT_TRUE(r.register_enum<Color>("Color", {{"red", Color::red}, {"green", Color::green}, {"blue", Color::blue}}).ok());
  auto factory = [&world]<typename T>() {
    return [&world](const std::string& name, const NodeConfig& config) { return std::make_unique<T>(name, config, world); };
  };
  EXPECT_TRUE(r.register_node<TestCondition>("Cond", "test condition", factory.operator()<TestCondition>()).ok());
  EXPECT_TRUE(r.register_node<TestAction>("Act", "test action", factory.operator()<TestAction>()).ok());
  EXPECT_TRUE(r.register_node<TestAsync>("Async", "test stateful action", factory.operator()<TestAsync>()).ok());
  EXPECT_TRUE(r.register_node<Probe>("Probe", "port probe", factory.operator()<Probe>()).ok());
  return r;
}

/// `<root BTCPP_format="4"><BehaviorTree ID="MainTree">body</BehaviorTree></root>`
inline std::string main_tree(const std::string& body) {
  return "<root BTCPP_format=\"4\">\n<BehaviorTree ID=\"MainTree\">\n" + body + "\n</BehaviorTree>\n</root>\n";
}

/// Test fixture: a world, a registry, a fake clock and a loader helper.
class BtTest : public ::testing::Test {
 protected:
  BtTest() : registry(make_registry(world)) { options.clock = &clock; }

  visnav::bt::Tree load(const std::string& xml) {
    auto tree = visnav::bt::load_tree_string(xml, registry, options);
    if (!tree) {
      ADD_FAILURE() << tree.error().message;
      std::abort();
    }
    return std::move(tree).value();
  }
  visnav::bt::Tree load_main(const std::string& body) { return load(main_tree(body)); }
  std::vector<visnav::bt::Diagnostic> validate(const std::string& xml) {
    return visnav::bt::validate_tree_string(xml, registry, options);
  }

  World world;
  visnav::bt::NodeRegistry registry;
  FakeClock clock;
  visnav::bt::LoadOptions options;
};

/// A fresh temporary directory, removed at destruction.
class TempDir {
 public:
  TempDir() {
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() / ("visnav_bt_test_" + std::to_string(rd()) + std::to_string(rd()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  std::filesystem::path write(const std::string& name, const std::string& text) const {
    const auto p = path_ / name;
    std::filesystem::create_directories(p.parent_path());
    std::ofstream(p) << text;
    return p;
  }

 private:
  std::filesystem::path path_;
};

}  // namespace bt_test
