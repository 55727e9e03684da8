// Conformance table: small trees with the tick-by-tick status sequence, the leaves ticked on
// each tick and the final blackboard values that BehaviorTree.CPP v4 specifies for each node
// (from its documentation and the behaviour its unit tests check; the trees are written here).
// Leaves: Act (sync, logs "A"), Async (stateful, logs "L:start", "L:run", "L:halt"); their
// results are scripted per tick. `before` runs a script on the root blackboard before a tick.
#include "bt_test_support.hpp"
#include "visnav/bt/script.hpp"

namespace bt_test {
namespace {

struct Tick {
  const char* before;  // script run on the root blackboard before the tick ("" = none)
  NodeStatus status;   // expected root status
  const char* log;     // expected leaves log of the tick
};

struct Case {
  const char* name;
  const char* body;  // the MainTree
  std::vector<std::pair<std::string, std::vector<NodeStatus>>> results;
  std::vector<Tick> ticks;
  std::vector<std::pair<std::string, std::string>> blackboard;  // key -> expected text at the end
};

constexpr NodeStatus R = NodeStatus::running;
constexpr NodeStatus S = NodeStatus::success;
constexpr NodeStatus F = NodeStatus::failure;
constexpr NodeStatus K = NodeStatus::skipped;

const std::vector<Case>& cases() {
  static const std::vector<Case> table = {
      // ---- controls
      {"Sequence_restarts_after_failure", R"(<Sequence><Act name="A"/><Act name="B"/></Sequence>)",
       {{"B", {F, S}}},
       {{"", F, "A B"}, {"", S, "A B"}}, {}},
      {"Sequence_resumes_running_child", R"(<Sequence><Act name="A"/><Async name="L"/></Sequence>)",
       {{"L", {R, S}}},
       {{"", R, "A L:start"}, {"", S, "L:run"}}, {}},
      {"ReactiveSequence_halts_running_child_when_condition_fails",
       R"(<ReactiveSequence><Act name="C"/><Async name="L"/></ReactiveSequence>)",
       {{"C", {S, S, F}}},
       {{"", R, "C L:start"}, {"", R, "C L:run"}, {"", F, "C L:halt"}}, {}},
      {"SequenceWithMemory_resumes_at_failed_child",
       R"(<SequenceWithMemory><Act name="A"/><Act name="B"/></SequenceWithMemory>)",
       {{"B", {F, S}}},
       {{"", F, "A B"}, {"", S, "B"}}, {}},
      {"AsyncSequence_yields_after_each_child", R"(<AsyncSequence><Act name="A"/><Act name="B"/><Act name="C"/></AsyncSequence>)",
       {},
       {{"", R, "A"}, {"", R, "B"}, {"", S, "C"}}, {}},
      {"Fallback_stops_at_first_success", R"(<Fallback><Act name="A"/><Act name="B"/><Act name="C"/></Fallback>)",
       {{"A", {F}}},
       {{"", S, "A B"}}, {}},
      {"ReactiveFallback_halts_running_child_when_condition_succeeds",
       R"(<ReactiveFallback><Act name="C"/><Async name="L"/></ReactiveFallback>)",
       {{"C", {F, S}}},
       {{"", R, "C L:start"}, {"", S, "C L:halt"}}, {}},
      {"AsyncFallback_yields_after_each_failed_child",
       R"(<AsyncFallback><Act name="A"/><Act name="B"/><Act name="C"/></AsyncFallback>)",
       {{"A", {F}}, {"B", {F}}},
       {{"", R, "A"}, {"", R, "B"}, {"", S, "C"}}, {}},
      {"Parallel_success_threshold", R"(<Parallel success_count="2"><Async name="L"/><Act name="A"/><Async name="M"/></Parallel>)",
       {{"L", {R, S}}, {"M", {R, R}}},
       {{"", R, "L:start A M:start"}, {"", S, "L:run M:halt"}}, {}},
      {"ParallelAll_waits_for_all_and_counts_failures",
       R"(<ParallelAll max_failures="1"><Act name="A"/><Async name="L"/></ParallelAll>)",
       {{"A", {F}}, {"L", {R, S}}},
       {{"", R, "A L:start"}, {"", F, "L:run"}}, {}},
      {"ParallelAll_succeeds_below_max_failures",
       R"(<ParallelAll max_failures="2"><Act name="A"/><Act name="B"/></ParallelAll>)",
       {{"A", {F}}},
       {{"", S, "A B"}}, {}},
      {"TryCatch_runs_catch_then_fails", R"(<TryCatch><Act name="A"/><Act name="B"/><Act name="C"/></TryCatch>)",
       {{"B", {F}}},
       {{"", F, "A B C"}, {"", S, "A B"}}, {}},
      {"TryCatch_running_catch_block", R"(<TryCatch><Act name="A"/><Async name="L"/></TryCatch>)",
       {{"A", {F}}, {"L", {R, F}}},
       {{"", R, "A L:start"}, {"", F, "L:run"}}, {}},
      {"IfThenElse_takes_else_branch", R"(<IfThenElse><Act name="C"/><Act name="T"/><Act name="E"/></IfThenElse>)",
       {{"C", {F, S}}},
       {{"", S, "C E"}, {"", S, "C T"}}, {}},
      {"WhileDoElse_halts_do_branch_when_condition_flips",
       R"(<WhileDoElse><Act name="C"/><Async name="L"/><Act name="E"/></WhileDoElse>)",
       {{"C", {S, F}}},
       {{"", R, "C L:start"}, {"", S, "C L:halt E"}}, {}},
      {"Switch2_compares_script_values",
       R"(<Switch2 variable="{v}" case_1="a" case_2="b"><Act name="A"/><Act name="B"/><Act name="D"/></Switch2>)",
       {},
       {{"v := 'b'", S, "B"}, {"v = 'z'", S, "D"}, {"v = 'a'", S, "A"}}, {{"v", "a"}}},
      // ---- decorators
      {"Inverter_and_ForceSuccess", R"(<Sequence><Inverter><Act name="A"/></Inverter><ForceSuccess><Act name="B"/></ForceSuccess></Sequence>)",
       {{"A", {F}}, {"B", {F}}},
       {{"", S, "A B"}}, {}},
      {"Repeat_num_cycles", R"(<Repeat num_cycles="3"><Act name="A"/></Repeat>)", {},
       {{"", S, "A A A"}}, {}},
      {"RetryUntilSuccessful_num_attempts", R"(<RetryUntilSuccessful num_attempts="3"><Act name="A"/></RetryUntilSuccessful>)",
       {{"A", {F, F, S}}},
       {{"", S, "A A A"}}, {}},
      {"RetryUntilSuccessful_gives_up", R"(<RetryUntilSuccessful num_attempts="2"><Act name="A"/></RetryUntilSuccessful>)",
       {{"A", {F, F}}},
       {{"", F, "A A"}}, {}},
      {"KeepRunningUntilFailure", R"(<KeepRunningUntilFailure><Act name="A"/></KeepRunningUntilFailure>)",
       {{"A", {S, F}}},
       {{"", R, "A"}, {"", F, "A"}}, {}},
      {"RunOnce_then_skip", R"(<Sequence><RunOnce><Act name="A"/></RunOnce><Act name="B"/></Sequence>)", {},
       {{"", S, "A B"}, {"", S, "B"}}, {}},
      {"Precondition_else_status", R"(<Sequence><Precondition if="go" else="SKIPPED"><Act name="A"/></Precondition><Act name="B"/></Sequence>)",
       {},
       {{"go := false", S, "B"}, {"go = true", S, "A B"}}, {}},
      {"LoopInt_one_element_per_tick", R"(<Sequence><Script code="sum := 0"/>
         <LoopInt queue="1;2;3" value="{v}"><Script code="sum += v"/></LoopInt></Sequence>)",
       {},
       {{"", R, ""}, {"", R, ""}, {"", R, ""}, {"", S, ""}}, {{"sum", "6"}, {"v", "3"}}},
      {"LoopString_if_empty", R"(<LoopString queue="" if_empty="FAILURE" value="{v}"><Act name="A"/></LoopString>)", {},
       {{"", F, ""}}, {}},
      {"LoopDouble_child_failure_stops", R"(<LoopDouble queue="0.5;1.5" value="{v}"><Act name="A"/></LoopDouble>)",
       {{"A", {F}}},
       {{"", F, "A"}}, {{"v", "0.5"}}},
      {"SkipUnlessUpdated", R"(<Sequence><SkipUnlessUpdated entry="{x}"><Act name="A"/></SkipUnlessUpdated><Act name="B"/></Sequence>)",
       {},
       {{"x := 1", S, "A B"}, {"", S, "B"}, {"x = 2", S, "A B"}}, {}},
      {"WaitValueUpdate", R"(<WaitValueUpdate entry="{x}"><Act name="A"/></WaitValueUpdate>)", {},
       {{"", R, ""}, {"x := 5", S, "A"}, {"", R, ""}}, {}},
      {"WasEntryUpdated", R"(<WasEntryUpdated entry="{x}"/>)", {},
       {{"x := 1", S, ""}, {"", F, ""}, {"x = 1", S, ""}}, {}},
      // ---- leaves and the blackboard
      {"SetBlackboard_converts_to_declared_unsigned", R"(<Sequence><SetBlackboard value="0" output_key="ms"/><Sleep msec="{ms}"/></Sequence>)",
       {}, {{"", S, ""}}, {{"ms", "0"}}},
      {"SetBlackboard_output_key_reference", R"(<Sequence><SetBlackboard value="dest" output_key="k"/><SetBlackboard value="42" output_key="{k}"/></Sequence>)",
       {}, {{"", S, ""}}, {{"dest", "42"}, {"k", "dest"}}},
      {"UnsetBlackboard_removes_the_value", R"(<Sequence><Script code="x := 1"/><UnsetBlackboard key="x"/>
         <Fallback><ScriptCondition code="x == 1"/><Script code="gone := true"/></Fallback></Sequence>)",
       {}, {{"", S, ""}}, {{"gone", "true"}}},
      {"Script_assignment_operators_and_ternary",
       R"(<Script code="a := 10; a -= 4; a *= 2; b := a &gt; 10 ? 'big' : 'small'; c := 'n' .. a; d := 7 / 2"/>)",
       {}, {{"", S, ""}}, {{"a", "12"}, {"b", "big"}, {"c", "n12"}, {"d", "3.5"}}},
      {"Script_enum_value", R"(<ScriptCondition code="c := blue; c == 7"/>)", {}, {{"", S, ""}}, {{"c", "7"}}},
      // ---- pre/post conditions
      {"skipIf_all_children_skipped_skips_the_sequence",
       R"(<Sequence><Act name="A" _skipIf="true"/><Act name="B" _skipIf="1 == 1"/></Sequence>)", {},
       {{"", K, ""}}, {}},
      {"successIf_and_failureIf_replace_the_tick",
       R"(<Fallback><Act name="A" _failureIf="x &gt; 0"/><Act name="B" _successIf="x &gt; 0"/></Fallback>)", {},
       {{"x := 1", S, ""}, {"x = 0", S, "A"}}, {}},
      {"while_halts_running_node", R"(<Async name="L" _while="go"/>)", {},
       {{"go := true", R, "L:start"}, {"", R, "L:run"}, {"go = false", K, "L:halt"}}, {}},
      {"onSuccess_onFailure_post", R"(<Sequence><Script code="s := 0; f := 0; p := 0"/>
         <ForceSuccess><Act name="A" _onSuccess="s += 1" _onFailure="f += 1" _post="p += 1"/></ForceSuccess></Sequence>)",
       {{"A", {S, F}}},
       {{"", S, "A"}, {"", S, "A"}}, {{"s", "0"}, {"f", "1"}, {"p", "1"}}},
      {"onHalted", R"(<ReactiveSequence><Act name="C"/><Async name="L" _onHalted="h := 'yes'"/></ReactiveSequence>)",
       {{"C", {S, F}}},
       {{"", R, "C L:start"}, {"", F, "C L:halt"}}, {{"h", "yes"}}},
      // ---- SubTree ports
      {"SubTree_remapping_and_autoremap", R"(<Sequence><Script code="in := 2"/><SubTree ID="Twice" x="{in}" y="{out}"/>
         <SubTree ID="Inc" _autoremap="true"/></Sequence>)",
       {}, {{"", S, ""}}, {{"out", "4"}, {"in", "3"}}},
  };
  return table;
}

class Conformance : public BtTest, public ::testing::WithParamInterface<std::size_t> {};

TEST_P(Conformance, StatusSequenceLogAndBlackboard) {
  const Case& c = cases()[GetParam()];
  SCOPED_TRACE(c.name);
  const std::string xml = std::string("<root BTCPP_format=\"4\" main_tree_to_execute=\"MainTree\">\n") +
                          "<BehaviorTree ID=\"MainTree\">" + c.body + "</BehaviorTree>\n" +
                          "<BehaviorTree ID=\"Twice\"><Script code=\"y := x * 2\"/></BehaviorTree>\n" +
                          "<BehaviorTree ID=\"Inc\"><Script code=\"in += 1\"/></BehaviorTree>\n</root>\n";
  for (const auto& [node, results] : c.results)
    for (NodeStatus s : results) world.script[node].push_back(s);
  auto loaded = visnav::bt::load_tree_string(xml, registry, options);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  visnav::bt::Tree tree = std::move(loaded).value();
  for (std::size_t i = 0; i < c.ticks.size(); ++i) {
    const Tick& t = c.ticks[i];
    if (*t.before != '\0') {
      auto s = visnav::bt::Script::parse(t.before);
      ASSERT_TRUE(s.ok()) << s.error().message;
      ASSERT_TRUE(s->evaluate(tree.blackboard(), registry.enums().get()).ok());
    }
    EXPECT_EQ(visnav::bt::to_string(tree.tick_once()), std::string(visnav::bt::to_string(t.status))) << "tick " << i + 1;
    EXPECT_EQ(world.take(), t.log) << "tick " << i + 1;
  }
  for (const auto& [key, text] : c.blackboard) {
    auto v = tree.blackboard().get<std::string>(key);
    ASSERT_TRUE(v.ok()) << key << ": " << v.error().message;
    EXPECT_EQ(*v, text) << key;
  }
}

INSTANTIATE_TEST_SUITE_P(BehaviorTreeCpp, Conformance, ::testing::Range<std::size_t>(0, cases().size()),
                         [](const ::testing::TestParamInfo<std::size_t>& p) { return std::string(cases()[p.param].name); });

}  // namespace
}  // namespace bt_test
