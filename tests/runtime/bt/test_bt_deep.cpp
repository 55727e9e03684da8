// Very deep trees: ~100,000 nested decorators (limits raised) tick, halt and report a throwing
// leaf on a thread with an 8 MB stack (the default main-thread stack on Linux) and on one with
// a 1 MB stack: the stack a tree needs does not grow with its depth. Without the stack
// checkpoints (runtime/src/bt/bounded_stack.hpp) this nesting overflows the 1 MB stack (and
// the 8 MB one in the sanitizer build).
#include <pthread.h>

#include <functional>
#include <stdexcept>

#include "bt_test_support.hpp"

namespace bt_test {
namespace {

using visnav::bt::NodeStatus;

constexpr int kTrees = 1043;             // SubTree chain length
constexpr int kInvertersPerTree = 95;    // tinyxml2 caps XML nesting at 100 per file
constexpr int kLevels = kTrees * (kInvertersPerTree + 1);  // Inverters, kTrees-1 SubTree nodes, leaf

/// Leaf that throws from tick() (a bug in a node): the tree must catch it and halt.
class Thrower final : public visnav::bt::SyncActionNode {
 public:
  using SyncActionNode::SyncActionNode;
  static visnav::bt::PortsList provided_ports() { return {}; }

 protected:
  NodeStatus tick() override { throw std::runtime_error("deep leaf threw"); }
};

/// D0 -> D1 -> ... -> D(kTrees-1) -> leaf, each tree 95 nested Inverters around the next SubTree.
std::string deep_xml(const std::string& leaf) {
  std::string xml = "<root BTCPP_format=\"4\" main_tree_to_execute=\"D0\">\n";
  for (int t = 0; t < kTrees; ++t) {
    xml += "<BehaviorTree ID=\"D" + std::to_string(t) + "\">";
    for (int i = 0; i < kInvertersPerTree; ++i) xml += "<Inverter>";
    xml += t + 1 < kTrees ? "<SubTree ID=\"D" + std::to_string(t + 1) + "\"/>" : leaf;
    for (int i = 0; i < kInvertersPerTree; ++i) xml += "</Inverter>";
    xml += "</BehaviorTree>\n";
  }
  return xml + "</root>\n";
}

/// Runs `f` on a new thread with a stack of `megabytes` and waits for it.
void on_stack(std::size_t megabytes, std::function<void()> f) {
  pthread_attr_t attr;
  ASSERT_EQ(pthread_attr_init(&attr), 0);
  ASSERT_EQ(pthread_attr_setstacksize(&attr, megabytes << 20), 0);
  pthread_t thread;
  auto entry = [](void* p) -> void* {
    (*static_cast<std::function<void()>*>(p))();
    return nullptr;
  };
  ASSERT_EQ(pthread_create(&thread, &attr, entry, &f), 0);
  pthread_join(thread, nullptr);
  pthread_attr_destroy(&attr);
}

class DeepTree : public BtTest {
 protected:
  DeepTree() {
    options.max_subtree_depth = kTrees;
    options.max_nodes = 200'000;
    options.max_tree_depth = 200'000;
    EXPECT_TRUE(registry.register_node<Thrower>("Thrower", "throws").ok());
  }
};

TEST_F(DeepTree, HundredThousandNestedDecoratorsTickAndHaltOnAnEightAndAOneMegabyteStack) {
  auto tree = load(deep_xml("<Async name=\"leaf\"/>"));
  ASSERT_EQ(tree.node_count(), static_cast<std::size_t>(kLevels));
  static_assert((kTrees * kInvertersPerTree) % 2 == 1);
  for (const std::size_t megabytes : {8u, 1u}) {
    SCOPED_TRACE(std::to_string(megabytes) + " MB stack");
    world.push("leaf", {NodeStatus::running, NodeStatus::running});
    on_stack(megabytes, [&] {
      EXPECT_EQ(tree.tick_once(), NodeStatus::running);
      EXPECT_EQ(tree.tick_once(), NodeStatus::running);
      tree.halt();  // down the whole RUNNING chain to the leaf
    });
    EXPECT_EQ(world.take(), "leaf:start leaf:run leaf:halt");
    EXPECT_EQ(tree.status(), NodeStatus::idle);
    world.push("leaf", {NodeStatus::running, NodeStatus::success});
    on_stack(megabytes, [&] {
      EXPECT_EQ(tree.tick_once(), NodeStatus::running);  // starts again after the halt
      EXPECT_EQ(tree.tick_once(), NodeStatus::failure);  // leaf success through 99,085 Inverters
    });
    EXPECT_EQ(world.take(), "leaf:start leaf:run");
  }
}

TEST_F(DeepTree, AnExceptionAtTheBottomReachesTheTreeAndEveryNodeIsHalted) {
  auto tree = load(deep_xml("<Thrower/>"));
  on_stack(1, [&] { EXPECT_EQ(tree.tick_once(), NodeStatus::failure); });
  EXPECT_NE(tree.last_error().find("deep leaf threw"), std::string::npos) << tree.last_error();
  std::size_t not_idle = 0;
  tree.visit([&](visnav::bt::TreeNode& n) { not_idle += n.status() != NodeStatus::idle ? 1 : 0; });
  EXPECT_EQ(not_idle, 0u);
}

TEST_F(DeepTree, DestroyingARunningDeepTreeHaltsItWithoutOverflow) {
  on_stack(1, [&] {
    auto tree = load(deep_xml("<Async name=\"leaf\"/>"));
    EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  });  // ~Tree halts the RUNNING chain
  EXPECT_EQ(world.take(), "leaf:start leaf:halt");
}

}  // namespace
}  // namespace bt_test
