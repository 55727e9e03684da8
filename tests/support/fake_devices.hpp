// Test support shared by the behaviour-tree node tests of the primitive plugins (feature_replay,
// navigation): a kinematic fake robot on a FrameBus, a per-test scratch folder and map, loading a nodes
// plugin through the real loader into a registry, and trees from an XML body. Header-only
// (tests add tests/support to their include directories). Nothing here is
// thread-safe: one fixture per test.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <optional>
#include <string>

#include "visnav/bt/registry.hpp"
#include "visnav/bt/tree.hpp"
#include "visnav/devices.hpp"
#include "visnav/host.hpp"
#include "visnav/loader.hpp"
#include "visnav/map.hpp"
#include "visnav/runtime_host.hpp"

namespace visnav::test {

/// Unicycle robot integrating the last command over `step(dt)`; publishes its odometry on `bus`
/// at construction, after every step and on publish(). The fields are open for the tests.
class KinematicRobot final : public Robot {
 public:
  explicit KinematicRobot(FrameBus& bus) : bus_(bus) { publish(); }
  Status send_command(const Twist& c) override {
    if (refuse_commands_ && (c.linear_mps != 0.0 || c.angular_radps != 0.0))
      return fail(ErrorCode::io, "the motor driver is not responding");
    command_ = c;
    ++commands_;
    return ok();
  }
  std::optional<Odometry> latest_odometry() override { return odom_; }
  void step(double dt_s) {
    odom_.pose.heading_rad += command_.angular_radps * dt_s;
    odom_.pose.x_m += command_.linear_mps * dt_s * std::cos(odom_.pose.heading_rad);
    odom_.pose.y_m += command_.linear_mps * dt_s * std::sin(odom_.pose.heading_rad);
    odom_.distance_m += command_.linear_mps * dt_s;
    odom_.timestamp_s += dt_s;
    odom_.twist = command_;
    publish();
  }
  void publish() { bus_.publish_odometry(odom_); }
  Odometry odom_;
  Twist command_;
  int commands_ = 0;
  bool refuse_commands_ = false;  ///< true: every moving command fails (a stop is still taken)

 private:
  FrameBus& bus_;
};

/// <tmp>/<prefix>_<pid>_<current test name>, removed first (the caller creates what it needs).
inline std::filesystem::path fresh_test_dir(const std::string& prefix) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() /
      (prefix + "_" + std::to_string(::getpid()) + "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
  std::filesystem::remove_all(dir);
  return dir;
}

/// Creates a fresh map store "test" in `dir` (no fsync per edge) into `map` and gives `host` the
/// bus, the robot and that map. Use as ASSERT_TRUE(attach_scratch_map(...)).
inline ::testing::AssertionResult attach_scratch_map(RuntimeHost& host, FrameBus& bus, Robot& robot,
                                                     std::optional<MapStore>& map, const std::filesystem::path& dir) {
  auto created = MapStore::create(dir.string(), "test");
  if (!created.ok()) return ::testing::AssertionFailure() << created.error().message;
  map.emplace(std::move(*created));
  map->set_sync(false);
  host.set_frame_bus(&bus);
  host.set_robot(&robot);
  host.set_map(&*map);
  return ::testing::AssertionSuccess();
}

/// Loads `library` through `loader` and registers the builtin nodes and that library's nodes
/// plugin (with `host`) in `registry`. Use as ASSERT_TRUE(register_plugin_nodes(...)).
inline ::testing::AssertionResult register_plugin_nodes(PluginLoader& loader, const std::string& library,
                                                        bt::NodeRegistry& registry, HostServices& host) {
  auto lib = loader.load_library(library);
  if (!lib.ok()) return ::testing::AssertionFailure() << lib.error().message;
  if (!bt::register_builtin_nodes(registry).ok()) return ::testing::AssertionFailure() << "builtin nodes";
  bool found = false;
  for (const auto& p : loader.nodes_plugins()) {
    if (p.library == *lib) {
      auto st = p.register_nodes(registry, host);
      if (!st.ok()) return ::testing::AssertionFailure() << st.error().message;
      found = true;
    }
  }
  if (!found) return ::testing::AssertionFailure() << library << " provides no nodes plugin";
  return ::testing::AssertionSuccess();
}

/// A tree "Main" with `body` from `registry`, ticked on `clock`; fails the test when it does not load.
inline bt::Tree load_main_tree(const std::string& body, const bt::NodeRegistry& registry,
                               const Clock* clock) {
  const std::string xml = "<root BTCPP_format=\"4\"><BehaviorTree ID=\"Main\">" + body + "</BehaviorTree></root>";
  bt::LoadOptions options;
  options.clock = clock;
  auto tree = bt::load_tree_string(xml, registry, options);
  EXPECT_TRUE(tree.ok()) << (tree.ok() ? "" : tree.error().message);
  return std::move(*tree);
}

}  // namespace visnav::test
