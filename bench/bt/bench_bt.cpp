// bench_bt: behaviour-tree engine cost.
//  * BM_TickPerNode: ns per node tick on a 100-node tree of Sequences, Fallbacks and synchronous
//    leaves where every node is ticked every tick (target <= 10 ns/node with the scripting
//    engine linked in but unused), and heap allocations per tick (target 0).
//    ns_per_node / ms_per_parse are thread CPU time; wall_* also shown.
//  * BM_TickPerNodeWithPorts: same shape, leaves read a literal double and a blackboard int port
//    (target <= 50 ns/node).
//  * BM_TickScriptHeavy: same shape, every leaf a Script (`n += 1`) or ScriptCondition
//    (`n < 0`); the figure for trees that use scripting everywhere (no target).
//  * BM_TickPreconditionAttributes: same shape, every leaf an AlwaysSuccess/AlwaysFailure
//    carrying `_skipIf="n < 0"`: the cost of pre/post-condition attributes.
//  * BM_TickDeepChain: a chain of ~10,000 nested Inverters (SubTrees of 95, limits raised):
//    ns per node where ticking crosses the stack checkpoints and, past 256 KB of stack,
//    switches to stack segments (runtime/src/bt/bounded_stack.hpp); no target.
//  * BM_ParseValidate1000: parse + validate a generated 1000-node XML file (target <= 5 ms).
//  * BM_Load1000: parse + validate + instantiate the same file.
#include <benchmark/benchmark.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <new>
#include <string>

#include <time.h>

#include "visnav/bt/bt.hpp"

// ---- allocation counter (replaces global operator new for this program) -----------------------
// The replacements pair malloc/free by design; GCC cannot see that through the replacement.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
namespace {
std::atomic<std::uint64_t> g_allocations{0};
}  // namespace

void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace {

using visnav::bt::NodeStatus;

constexpr double kTargetNsPerNode = 10.0;          // plain tree, scripting linked in but unused
constexpr double kTargetNsPerNodeWithPorts = 50.0;  // leaves reading two ports
constexpr double kTargetParseMs = 5.0;

/// CPU time of this thread: the figure that matters on a loaded (shared) machine, where wall
/// time also counts time spent waiting for a core. Both are reported.
double thread_cpu_ns() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e9 + static_cast<double>(ts.tv_nsec);
}

/// Leaf that reads a literal double port and a blackboard int port every tick.
class PortLeaf final : public visnav::bt::SyncActionNode {
 public:
  using SyncActionNode::SyncActionNode;
  static visnav::bt::PortsList provided_ports() {
    return {visnav::bt::input_port<double>("speed_mps", "0.3", "forward speed"),
            visnav::bt::input_port<int>("count", "{count}", "a blackboard value")};
  }

 protected:
  NodeStatus tick() override {
    auto speed = get_input<double>("speed_mps");
    auto count = get_input<int>("count");
    benchmark::DoNotOptimize(speed);
    benchmark::DoNotOptimize(count);
    return speed && count ? NodeStatus::success : NodeStatus::failure;
  }
};

/// 1 root Sequence + 9 groups (alternating Sequence / Fallback) x (1 + 10 leaves) = 100 nodes.
/// Sequences hold succeeding leaves, Fallbacks nine failing leaves then a succeeding one, so
/// every node is ticked on every tick.
std::string tick_tree_xml(const char* success_leaf, const char* failure_leaf) {
  std::string body = "<Sequence>\n";
  for (int g = 0; g < 9; ++g) {
    const bool fallback = g % 2 == 1;
    body += fallback ? "  <Fallback>\n" : "  <Sequence>\n";
    for (int l = 0; l < 10; ++l) {
      const bool fail = fallback && l < 9;
      body += std::string("    <") + (fail ? failure_leaf : success_leaf) + "/>\n";
    }
    body += fallback ? "  </Fallback>\n" : "  </Sequence>\n";
  }
  body += "</Sequence>\n";
  return "<root BTCPP_format=\"4\">\n<BehaviorTree ID=\"MainTree\">\n" + body + "</BehaviorTree>\n</root>\n";
}

/// 1 root Sequence + 111 Fallback/Sequence groups x (1 + 8 leaves with ports) = 1000 nodes.
std::string big_tree_xml() {
  std::string body = "<Sequence name=\"root\">\n";
  for (int g = 0; g < 111; ++g) {
    body += g % 2 == 0 ? "  <Fallback name=\"group_" + std::to_string(g) + "\">\n" : "  <Sequence>\n";
    body += "    <AlwaysFailure/>\n";
    body += "    <Sleep msec=\"" + std::to_string(10 + g) + "\"/>\n";
    body += "    <SetBlackboard value=\"" + std::to_string(g) + "\" output_key=\"key_" + std::to_string(g) + "\"/>\n";
    body += "    <SetBlackboard value=\"{key_" + std::to_string(g) + "}\" output_key=\"copy\"/>\n";
    body += "    <AlwaysSuccess name=\"ok_" + std::to_string(g) + "\"/>\n";
    body += "    <Sleep msec=\"{delay}\"/>\n";
    body += "    <AlwaysSuccess/>\n";
    body += "    <AlwaysFailure/>\n";
    body += g % 2 == 0 ? "  </Fallback>\n" : "  </Sequence>\n";
  }
  body += "</Sequence>\n";
  return "<root BTCPP_format=\"4\" main_tree_to_execute=\"MainTree\">\n<BehaviorTree ID=\"MainTree\">\n" + body +
         "</BehaviorTree>\n</root>\n";
}

visnav::bt::NodeRegistry make_registry() {
  visnav::bt::NodeRegistry r;
  if (!visnav::bt::register_builtin_nodes(r)) std::abort();
  if (!r.register_node<PortLeaf>("PortLeaf", "reads two ports")) std::abort();
  return r;
}

void run_tick_bench(benchmark::State& state, const std::string& xml, bool with_ports, double target_ns,
                    const visnav::bt::LoadOptions& options = {}) {
  const auto registry = make_registry();
  auto loaded = visnav::bt::load_tree_string(xml, registry, options);
  if (!loaded) {
    state.SkipWithError(loaded.error().message.c_str());
    return;
  }
  visnav::bt::Tree tree = std::move(loaded).value();
  if (with_ports) tree.blackboard().set("count", 3);
  tree.blackboard().set("n", 0);
  const double nodes = static_cast<double>(tree.node_count());
  if (const NodeStatus first = tree.tick_once(); first != NodeStatus::success && first != NodeStatus::failure) {
    state.SkipWithError("tree did not complete");
    return;
  }
  const std::uint64_t allocs_before = g_allocations.load();
  const auto t0 = std::chrono::steady_clock::now();
  const double cpu0 = thread_cpu_ns();
  for (auto _ : state) {
    benchmark::DoNotOptimize(tree.tick_once());
  }
  const double cpu1 = thread_cpu_ns();
  const auto t1 = std::chrono::steady_clock::now();
  const std::uint64_t allocs = g_allocations.load() - allocs_before;
  const double iterations = static_cast<double>(state.iterations());
  const double ns_per_node = (cpu1 - cpu0) / (iterations * nodes);
  state.counters["nodes"] = nodes;
  state.counters["ns_per_node"] = ns_per_node;
  state.counters["wall_ns_per_node"] = std::chrono::duration<double, std::nano>(t1 - t0).count() / (iterations * nodes);
  if (target_ns > 0.0) {
    state.counters["target_ns"] = target_ns;
    state.counters["ratio_to_target"] = ns_per_node / target_ns;
  }
  state.counters["allocs_per_tick"] = static_cast<double>(allocs) / iterations;
}

void BM_TickPerNode(benchmark::State& state) {
  run_tick_bench(state, tick_tree_xml("AlwaysSuccess", "AlwaysFailure"), false, kTargetNsPerNode);
}
BENCHMARK(BM_TickPerNode);

void BM_TickPerNodeWithPorts(benchmark::State& state) {
  run_tick_bench(state, tick_tree_xml("PortLeaf", "AlwaysFailure"), true, kTargetNsPerNodeWithPorts);
}
BENCHMARK(BM_TickPerNodeWithPorts);

void BM_TickScriptHeavy(benchmark::State& state) {
  run_tick_bench(state, tick_tree_xml("Script code=\"n += 1\"", "ScriptCondition code=\"n &lt; 0\""), false, 0.0);
}
BENCHMARK(BM_TickScriptHeavy);

void BM_TickPreconditionAttributes(benchmark::State& state) {
  run_tick_bench(state, tick_tree_xml("AlwaysSuccess _skipIf=\"n &lt; 0\"", "AlwaysFailure _skipIf=\"n &lt; 0\""), false,
                 0.0);
}
BENCHMARK(BM_TickPreconditionAttributes);

/// D0 -> ... -> D(trees-1) -> AlwaysSuccess, each tree 95 nested Inverters around the next SubTree.
std::string deep_chain_xml(int trees) {
  std::string xml = "<root BTCPP_format=\"4\" main_tree_to_execute=\"D0\">\n";
  for (int t = 0; t < trees; ++t) {
    xml += "<BehaviorTree ID=\"D" + std::to_string(t) + "\">";
    for (int i = 0; i < 95; ++i) xml += "<Inverter>";
    xml += t + 1 < trees ? "<SubTree ID=\"D" + std::to_string(t + 1) + "\"/>" : "<AlwaysSuccess/>";
    for (int i = 0; i < 95; ++i) xml += "</Inverter>";
    xml += "</BehaviorTree>\n";
  }
  return xml + "</root>\n";
}

void BM_TickDeepChain(benchmark::State& state) {
  visnav::bt::LoadOptions options;
  options.max_subtree_depth = 200;
  options.max_tree_depth = 20'000;
  run_tick_bench(state, deep_chain_xml(105), false, 0.0, options);
}
BENCHMARK(BM_TickDeepChain);

std::filesystem::path write_big_tree() {
  const auto path = std::filesystem::temp_directory_path() / "visnav_bench_bt_1000.xml";
  std::ofstream(path) << big_tree_xml();
  return path;
}

void report_parse(benchmark::State& state, std::chrono::steady_clock::duration wall, double cpu_ns) {
  const double iterations = static_cast<double>(state.iterations());
  const double ms = cpu_ns * 1e-6 / iterations;
  state.counters["ms_per_parse"] = ms;
  state.counters["wall_ms_per_parse"] = std::chrono::duration<double, std::milli>(wall).count() / iterations;
  state.counters["target_ms"] = kTargetParseMs;
  state.counters["ratio_to_target"] = ms / kTargetParseMs;
}

void BM_ParseValidate1000(benchmark::State& state) {
  const auto registry = make_registry();
  const auto path = write_big_tree();
  const auto check = visnav::bt::load_tree_file(path, registry);
  if (!check) {
    state.SkipWithError(check.error().message.c_str());
    return;
  }
  state.counters["nodes"] = static_cast<double>(check->node_count());
  const auto t0 = std::chrono::steady_clock::now();
  const double cpu0 = thread_cpu_ns();
  for (auto _ : state) {
    auto d = visnav::bt::validate_tree_file(path, registry);
    benchmark::DoNotOptimize(d);
  }
  report_parse(state, std::chrono::steady_clock::now() - t0, thread_cpu_ns() - cpu0);
  std::filesystem::remove(path);
}
BENCHMARK(BM_ParseValidate1000)->Unit(benchmark::kMillisecond);

void BM_Load1000(benchmark::State& state) {
  const auto registry = make_registry();
  const auto path = write_big_tree();
  const auto t0 = std::chrono::steady_clock::now();
  const double cpu0 = thread_cpu_ns();
  for (auto _ : state) {
    auto tree = visnav::bt::load_tree_file(path, registry);
    if (!tree) {
      state.SkipWithError(tree.error().message.c_str());
      break;
    }
    benchmark::DoNotOptimize(tree);
  }
  report_parse(state, std::chrono::steady_clock::now() - t0, thread_cpu_ns() - cpu0);
  std::filesystem::remove(path);
}
BENCHMARK(BM_Load1000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
