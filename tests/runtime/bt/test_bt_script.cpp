// The scripting language (parser and evaluator), the Script/ScriptCondition/Precondition nodes,
// pre/post-condition attributes and the typed blackboard.
#include "bt_test_support.hpp"
#include "visnav/bt/script.hpp"

namespace bt_test {
namespace {

using visnav::bt::Blackboard;
using visnav::bt::Diagnostic;
using visnav::bt::NodeStatus;
using visnav::bt::Script;
using visnav::bt::ScriptValue;

std::string all(const std::vector<Diagnostic>& d) { return visnav::bt::to_string(d); }

class ScriptEval : public ::testing::Test {
 protected:
  ScriptEval() {
    EXPECT_TRUE(tables.add(std::type_index(typeid(Color)), "Color", {{"red", 0}, {"green", 1}, {"blue", 2}}).ok());
  }
  ScriptValue run(std::string_view src) {
    auto s = Script::parse(src);
    EXPECT_TRUE(s.ok()) << src << ": " << (s ? "" : s.error().message);
    if (!s) return {};
    auto v = s->evaluate(*bb, &tables);
    EXPECT_TRUE(v.ok()) << src << ": " << (v ? "" : v.error().message);
    return v ? *v : ScriptValue{};
  }
  std::string eval_error(std::string_view src) {
    auto s = Script::parse(src);
    if (!s) return "parse: " + s.error().message;
    auto v = s->evaluate(*bb, &tables);
    return v ? std::string("no error") : v.error().message;
  }
  std::string parse_error(std::string_view src) {
    auto s = Script::parse(src);
    return s ? std::string("no error") : s.error().message;
  }
  Blackboard::Ptr bb = Blackboard::create();
  visnav::bt::EnumTables tables;
};

TEST_F(ScriptEval, ArithmeticPrecedenceAndTypes) {
  EXPECT_EQ(run("1 + 2 * 3").i, 7);
  EXPECT_EQ(run("(1 + 2) * 3").i, 9);
  EXPECT_EQ(run("10 - 4 - 3").i, 3);  // left associative
  const ScriptValue div = run("5 / 2");
  EXPECT_EQ(div.kind, ScriptValue::Kind::real);
  EXPECT_DOUBLE_EQ(div.d, 2.5);
  EXPECT_DOUBLE_EQ(run("1.5 * 2").d, 3.0);
  EXPECT_EQ(run("-3 + 1").i, -2);
  EXPECT_DOUBLE_EQ(run("1e3 + 0.5").d, 1000.5);
  EXPECT_EQ(run("6 & 3").i, 2);
  EXPECT_EQ(run("6 | 3").i, 7);
  EXPECT_EQ(run("6 ^ 3").i, 5);
  EXPECT_EQ(run("~0").i, -1);
  const ScriptValue big = run("9223372036854775807 + 1");  // overflow -> double
  EXPECT_EQ(big.kind, ScriptValue::Kind::real);
}

TEST_F(ScriptEval, StringsComparisonLogicAndTernary) {
  EXPECT_EQ(run("'ab' + 'cd'").s, "abcd");
  EXPECT_EQ(run("'n=' .. 3 .. ' d=' .. 2.5").s, "n=3 d=2.5");
  EXPECT_TRUE(run("'abc' < 'abd'").b);
  EXPECT_TRUE(run("'12' == 12").b);  // a numeric string compares as a number
  EXPECT_TRUE(run("1 < 2 && 2 <= 2 && 3 > 2 && 3 >= 3 && 1 != 2").b);
  EXPECT_TRUE(run("false || !false").b);
  EXPECT_EQ(run("3 > 2 ? 'yes' : 'no'").s, "yes");
  EXPECT_EQ(run("false ? 1 : true ? 2 : 3").i, 2);
  EXPECT_TRUE(run("1 + 1 == 2 && 'a' .. 'b' == 'ab'").b);
}

TEST_F(ScriptEval, AssignmentCreatesAndConvertsEntries) {
  run("x := 3; y := 2.5; s := 'hi'; b := true");
  EXPECT_EQ(bb->get_any("x")->type(), typeid(int));
  EXPECT_EQ(bb->get_any("y")->type(), typeid(double));
  EXPECT_EQ(bb->get_any("s")->type(), typeid(std::string));
  EXPECT_EQ(bb->get_any("b")->type(), typeid(bool));
  run("x += 4; x *= 2; y -= 0.5; s = s .. '!'");
  EXPECT_EQ(*bb->get<int>("x"), 14);
  EXPECT_DOUBLE_EQ(*bb->get<double>("y"), 2.0);
  EXPECT_EQ(*bb->get<std::string>("s"), "hi!");
  run("x = 10 / 2");  // 5.0 stored into an int entry: exact, so it converts
  EXPECT_EQ(bb->get_any("x")->type(), typeid(int));
  EXPECT_EQ(*bb->get<int>("x"), 5);
  EXPECT_NE(eval_error("x = 2.5").find("cannot store 2.5 into an entry of type int"), std::string::npos) << eval_error("x = 2.5");
  EXPECT_EQ(run("x := 1; x + 1").i, 2);  // the value of a script is its last statement
}

TEST_F(ScriptEval, EnumsAndRootReferences) {
  EXPECT_EQ(run("blue").i, 2);
  EXPECT_TRUE(run("c := green; c == green").b);
  auto child = Blackboard::create(bb);
  auto s = Script::parse("@top := 7");
  ASSERT_TRUE(s.ok());
  ASSERT_TRUE(s->evaluate(*child, &tables).ok());
  EXPECT_EQ(*bb->get<int>("top"), 7);
  EXPECT_FALSE(child->keys().size() > 0);
}

TEST_F(ScriptEval, EvaluationErrorsNameVariableAndOperator) {
  EXPECT_EQ(eval_error("missing + 1"), "column 1: variable 'missing' is not set");
  EXPECT_EQ(eval_error("nope = 1"), "column 6: variable 'nope' does not exist (use ':=' to create it)");
  EXPECT_NE(eval_error("'a' - 1").find("'-' needs two numbers"), std::string::npos);
  EXPECT_NE(eval_error("1.5 & 1").find("'&' needs two integers"), std::string::npos);
  EXPECT_NE(eval_error("'x' ? 1 : 2").find("is not a boolean"), std::string::npos);
  // && and || short-circuit: the unset variable on the right is never read.
  EXPECT_FALSE(run("false && missing").b);
  EXPECT_TRUE(run("true || missing").b);
}

TEST_F(ScriptEval, ParseErrorsNameTheColumn) {
  EXPECT_EQ(parse_error("x := (1 + 2"), "column 12: expected ')', found the end of the script");
  EXPECT_EQ(parse_error("a = = 2"), "column 5: expected a value, a variable or '(', found '='");
  EXPECT_EQ(parse_error("x := 'open"), "column 6: unterminated string");
  EXPECT_EQ(parse_error("1 $ 2"), "column 3: expected ';' or the end of the script, found '$'");
  EXPECT_EQ(parse_error(""), "column 1: empty script");
  EXPECT_EQ(parse_error("x ? 1"), "column 6: expected ':' of the conditional '? :', found the end of the script");
  EXPECT_EQ(parse_error("true := 1"), "column 1: cannot assign to 'true'");
  EXPECT_EQ(parse_error("12abc"), "column 1: unexpected character '12abc'");
}

TEST_F(ScriptEval, NestingAndLengthLimitsKeepEvaluationBounded) {
  EXPECT_NE(parse_error(std::string(100, '(') + "1" + std::string(100, ')')).find("nested more than 64 deep"),
            std::string::npos);
  std::string chain = "1";
  for (int i = 0; i < 300; ++i) chain += "+1";
  EXPECT_NE(parse_error(chain).find("expression too deep"), std::string::npos);
  std::string ok = "1";
  for (int i = 0; i < 200; ++i) ok += "+1";
  EXPECT_EQ(run(ok).i, 201);
  std::string many;
  for (int i = 0; i < 5000; ++i) many += "x := 1;";
  EXPECT_NE(parse_error(many).find("script too long"), std::string::npos);
}

// ---- nodes and attributes -----------------------------------------------------------------

using Scripting = BtTest;

TEST_F(Scripting, ScriptAndScriptConditionNodes) {
  auto tree = load_main(R"(<Sequence>
    <Script code="n := 3; msg := 'count=' .. n"/>
    <ScriptCondition code="n == 3 &amp;&amp; msg == 'count=3'"/>
    <Script code="n += 1"/>
    <ScriptCondition name="Big" code="n &gt; 10"/>
  </Sequence>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::failure);  // the last condition is false
  EXPECT_EQ(*tree.blackboard().get<int>("n"), 4);
  EXPECT_EQ(*tree.blackboard().get<std::string>("msg"), "count=3");
}

TEST_F(Scripting, ScriptErrorsAreValidationErrorsWithFileLineAndColumn) {
  const auto d = validate(main_tree(R"(<Sequence>
    <Script code="x := (1"/>
    <Act _skipIf="a &lt;"/>
  </Sequence>)"));
  ASSERT_EQ(d.size(), 2u) << all(d);
  EXPECT_EQ(d[0].str(), "<string>:4: MainTree/Sequence[0]/Script[0]: port 'code': bad value for type std::string: column 8: expected ')', found the end of the script");
  EXPECT_EQ(d[1].str(), "<string>:5: MainTree/Sequence[0]/Act[1]: _skipIf: script error at column 4: expected a value, a variable or '(', found the end of the script in 'a <'");
}

TEST_F(Scripting, RuntimeScriptErrorFailsTheNodeAndIsReported) {
  auto tree = load_main(R"(<Script code="y := undefined_key + 1"/>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::failure);
  EXPECT_NE(tree.last_script_error().find("variable 'undefined_key' is not set"), std::string::npos) << tree.last_script_error();
}

TEST_F(Scripting, PreconditionTicksChildOnlyWhenTrueAndReturnsElse) {
  auto tree = load_main(R"(<Sequence>
    <Script code="go := false"/>
    <Precondition if="go" else="SUCCESS"><Act name="A"/></Precondition>
    <Precondition if="go"><Act name="B"/></Precondition>
  </Sequence>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::failure);  // A skipped (else=SUCCESS), B: else=FAILURE
  EXPECT_EQ(world.take(), "");
  auto tree2 = load_main(R"(<Precondition if="x &gt; 1"><Async name="L"/></Precondition>)");
  tree2.blackboard().set("x", 2);
  world.push("L", {NodeStatus::running, NodeStatus::running, NodeStatus::success});
  EXPECT_EQ(tree2.tick_once(), NodeStatus::running);
  tree2.blackboard().set("x", 0);  // not re-evaluated while the child runs
  EXPECT_EQ(tree2.tick_once(), NodeStatus::running);
  EXPECT_EQ(tree2.tick_once(), NodeStatus::success);
  EXPECT_EQ(tree2.tick_once(), NodeStatus::failure);  // now x is 0
}

TEST_F(Scripting, PreConditionAttributes) {
  auto tree = load_main(R"(<Sequence>
    <Act name="F" _failureIf="mode == 1"/>
    <Act name="S" _successIf="mode == 2"/>
    <Act name="K" _skipIf="mode == 3"/>
    <Act name="W" _while="mode != 4"/>
  </Sequence>)");
  tree.blackboard().set("mode", 0);
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(world.take(), "F S K W");
  tree.blackboard().set("mode", 1);
  EXPECT_EQ(tree.tick_once(), NodeStatus::failure);
  EXPECT_EQ(world.take(), "");  // F failed without ticking
  tree.blackboard().set("mode", 2);
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(world.take(), "F K W");  // S succeeded without ticking
  tree.blackboard().set("mode", 3);
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(world.take(), "F S W");  // K skipped
  tree.blackboard().set("mode", 4);
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(world.take(), "F S K");  // _while false: skipped
}

TEST_F(Scripting, WhileHaltsARunningNodeWhenItBecomesFalse) {
  auto tree = load_main(R"(<Async name="L" _while="go" _onHalted="halted := true"/>)");
  tree.blackboard().set("go", true);
  world.set("L", NodeStatus::running);
  EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  tree.blackboard().set("go", false);
  EXPECT_EQ(tree.tick_once(), NodeStatus::skipped);
  EXPECT_NE(world.joined().find("L:halt"), std::string::npos) << world.joined();
  EXPECT_TRUE(*tree.blackboard().get<bool>("halted"));
}

TEST_F(Scripting, PostConditionAttributes) {
  auto tree = load_main(R"(<Sequence>
    <Script code="ok := 0; bad := 0; post := 0"/>
    <Fallback>
      <Act name="A" _onSuccess="ok += 1" _onFailure="bad += 1" _post="post += 1"/>
      <Act name="B" _onSuccess="ok += 10" _post="post += 10"/>
    </Fallback>
  </Sequence>)");
  world.push("A", {NodeStatus::failure});
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(*tree.blackboard().get<int>("ok"), 10);
  EXPECT_EQ(*tree.blackboard().get<int>("bad"), 1);
  EXPECT_EQ(*tree.blackboard().get<int>("post"), 11);
}

TEST_F(Scripting, OnHaltedRunsOnlyWhenARunningNodeIsHalted) {
  auto tree = load_main(R"(<Async name="L" _onHalted="h := 1" _onSuccess="s := 1"/>)");
  world.set("L", NodeStatus::running);
  EXPECT_EQ(tree.tick_once(), NodeStatus::running);
  EXPECT_FALSE(tree.blackboard().has("h"));
  tree.halt();
  EXPECT_EQ(*tree.blackboard().get<int>("h"), 1);
  EXPECT_FALSE(tree.blackboard().has("s"));
}

TEST_F(Scripting, ConditionsWorkOnSubTreeElements) {
  auto tree = load(R"(<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main"><SubTree ID="Sub" _skipIf="skip" _onSuccess="done := true"/></BehaviorTree>
  <BehaviorTree ID="Sub"><Act name="A"/></BehaviorTree>
</root>)");
  tree.blackboard().set("skip", true);
  EXPECT_EQ(tree.tick_once(), NodeStatus::skipped);
  EXPECT_EQ(world.take(), "");
  tree.blackboard().set("skip", false);
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(world.take(), "A");
  EXPECT_TRUE(*tree.blackboard().get<bool>("done"));
}

// ---- typed blackboard ---------------------------------------------------------------------

using TypedBlackboard = BtTest;

TEST_F(TypedBlackboard, AKeyUsedWithTwoPortTypesIsAValidationError) {
  const auto d = validate(main_tree(R"(<Sequence>
    <Probe name="P" out_i="{k}" out_s="{s}"/>
    <Probe name="Q" s="{k}" out_i="{o}" out_s="{t}"/>
  </Sequence>)"));
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_EQ(d[0].str(), "<string>:5: MainTree/Sequence[0]/Q: port 's' uses blackboard key 'k' as std::string, but it was "
                        "declared int by port 'out_i' of MainTree/Sequence[0]/P (<string>:4)");
}

TEST_F(TypedBlackboard, TypesFollowSubTreeRemapping) {
  const auto d = validate(R"(<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main"><Sequence><Probe name="P" out_i="{n}" out_s="{s}"/><SubTree ID="Sub" v="{n}"/></Sequence></BehaviorTree>
  <BehaviorTree ID="Sub"><Probe name="Q" d="{v}" out_i="{o}" out_s="{t}"/></BehaviorTree>
</root>)");
  ASSERT_EQ(d.size(), 1u) << all(d);
  EXPECT_NE(d[0].message.find("port 'd' uses blackboard key 'v' as double, but it was declared int"), std::string::npos)
      << d[0].str();
  // Without remapping the subtree's 'n' is another entry: no conflict.
  EXPECT_TRUE(validate(R"(<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main"><Sequence><Probe name="P" out_i="{n}" out_s="{s}"/><SubTree ID="Sub"/></Sequence></BehaviorTree>
  <BehaviorTree ID="Sub"><Probe name="Q" d="{n}" out_i="{o}" out_s="{t}"/></BehaviorTree>
</root>)").empty());
}

TEST_F(TypedBlackboard, AnyTypedPortsAndScriptsDoNotFixTheType) {
  EXPECT_TRUE(validate(main_tree(R"(<Sequence>
    <SetBlackboard value="5" output_key="k"/>
    <Probe name="P" i="{k}" out_i="{o}" out_s="{s}"/>
    <WasEntryUpdated entry="{k}"/>
  </Sequence>)")).empty());
}

TEST_F(TypedBlackboard, ScriptAssignmentConvertsToTheDeclaredType) {
  auto tree = load_main(R"(<Sequence>
    <Script code="n := '41'"/>
    <Probe name="P" i="{n}" out_i="{o}" out_s="{s}"/>
  </Sequence>)");
  EXPECT_EQ(tree.tick_once(), NodeStatus::success);
  EXPECT_EQ(tree.blackboard().get_any("n")->type(), typeid(int));  // '41' parsed as the port's int
  EXPECT_EQ(*tree.blackboard().get<int>("o"), 82);
}

}  // namespace
}  // namespace bt_test
