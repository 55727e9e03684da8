// Config: YAML with file:line, --set overrides, run config validation, doc-based param checks.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <fstream>

#include "error_expect.hpp"
#include "visnav/config.hpp"

namespace fs = std::filesystem;
using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;

namespace {

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

visnav::Result<visnav::RunConfig> parse(const std::string& yaml) {
  auto root = visnav::parse_yaml_string(yaml, "setup.yaml");
  if (!root) return root.error();
  return visnav::parse_run_config(*root, "setup.yaml");
}

const char* kMinimal =
    "robot: {type: sim}\n"
    "camera:\n"
    "  type: sim\n"
    "  params:\n"
    "    width_px: 320\n";

}  // namespace

TEST(Yaml, EveryValueKnowsItsLine) {
  auto root = visnav::parse_yaml_string("a: 1\nb:\n  c: [x, y]\n  d:\n    e: true\n", "f.yaml");
  ASSERT_TRUE(root) << root.error().message;
  EXPECT_EQ(root->find("a")->where().str(), "f.yaml:1");
  const auto* b = root->find("b");
  ASSERT_TRUE(b && b->is_map());
  EXPECT_EQ(b->find("c")->where().line, 3);
  EXPECT_EQ(b->find("c")->items()[1].scalar(), "y");
  EXPECT_EQ(b->find("d")->find("e")->where().str(), "f.yaml:5");
  EXPECT_EQ(b->find("d")->find("e")->scalar(), "true");
}

TEST(Yaml, NullValueGetsTheKeyLine) {
  auto root = visnav::parse_yaml_string("x: 1\nempty:\n", "f.yaml");
  ASSERT_TRUE(root);
  const auto* e = root->find("empty");
  ASSERT_TRUE(e && e->is_null());
  EXPECT_EQ(e->where().line, 2);
}

TEST(Yaml, SyntaxErrorNamesFileAndLine) {
  auto root = visnav::parse_yaml_string("robot: {type: sim}\ncamera: [unclosed\nrun: {}\n", "bad.yaml");
  ASSERT_FALSE(root);
  EXPECT_TRUE(fails_with(root, ErrorCode::parse_error, At{"bad.yaml"}));
}

TEST(Yaml, SyntaxErrorLineIsExact) {
  auto root = visnav::parse_yaml_string("a: 1\nb: 2\n  c: 3\n", "bad.yaml");
  ASSERT_FALSE(root);
  EXPECT_TRUE(fails_with(root, ErrorCode::parse_error, At{"bad.yaml", 3}));
}

TEST(Yaml, DuplicateKeyIsAnError) {
  auto root = visnav::parse_yaml_string("a: 1\nb: 2\na: 3\n", "dup.yaml");
  ASSERT_FALSE(root);
  EXPECT_TRUE(fails_with(root, ErrorCode::parse_error, At{"dup.yaml", 3, "a"}));
}

TEST(Yaml, MissingFileIsAnErrorNamingIt) {
  auto root = visnav::parse_yaml_file("/nonexistent/setup.yaml");
  ASSERT_FALSE(root);
  EXPECT_TRUE(fails_with(root, ErrorCode::not_found, At{"/nonexistent/setup.yaml"}));
}

TEST(RunConfig, MinimalConfigGetsDefaults) {
  auto c = parse(kMinimal);
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_EQ(c->robot.type, "sim");
  EXPECT_TRUE(c->robot.params.is_null());
  EXPECT_EQ(c->camera.params.find("width_px")->scalar(), "320");
  EXPECT_FALSE(c->detector);
  EXPECT_FALSE(c->nodes);
  EXPECT_EQ(c->run.tick, "frame");
  EXPECT_DOUBLE_EQ(c->run.rate_hz, 10.0);
  EXPECT_DOUBLE_EQ(c->run.max_odometry_age_s, 0.5);
  EXPECT_EQ(c->run.lockstep, "auto");
}

TEST(RunConfig, FullConfigParses) {
  auto c = parse(std::string(kMinimal) +
                 "detector: {type: orb, plugin: detectors_opencv, params: {target_keypoints: 500}}\n"
                 "nodes: [feature_replay, path_following]\n"
                 "run: {tick: rate, rate_hz: 20, max_frame_age_s: 0.3, trace_file: t.jsonl, lockstep: off}\n");
  ASSERT_TRUE(c) << c.error().message;
  ASSERT_TRUE(c->detector);
  EXPECT_EQ(c->detector->plugin, "detectors_opencv");
  ASSERT_TRUE(c->nodes);
  EXPECT_EQ(c->nodes->size(), 2u);
  EXPECT_EQ(c->run.tick, "rate");
  EXPECT_DOUBLE_EQ(c->run.rate_hz, 20.0);
  EXPECT_EQ(c->run.trace_file, "t.jsonl");
  EXPECT_EQ(c->run.lockstep, "off");
}

TEST(RunConfig, UnknownTopLevelKeyNamesLineAndKnownKeys) {
  auto c = parse(std::string(kMinimal) + "detectr: {type: orb}\n");
  ASSERT_FALSE(c);
  EXPECT_TRUE(fails_with(c, ErrorCode::unknown_key, At{"setup.yaml", 6, "detectr"}));
  // The message lists what is allowed, which the code cannot say.
  EXPECT_TRUE(contains(c.error().message, "known keys: robot, camera, detector")) << c.error().message;
}

TEST(RunConfig, UnknownKeyInRunBlock) {
  auto c = parse(std::string(kMinimal) + "run:\n  rate_hz: 5\n  tick_rate: 5\n");
  ASSERT_FALSE(c);
  EXPECT_TRUE(fails_with(c, ErrorCode::unknown_key, At{"setup.yaml", 8, "run.tick_rate"}));
}

TEST(RunConfig, OutOfRangeValueNamesLineKeyAndRange) {
  auto c = parse(std::string(kMinimal) + "run:\n  rate_hz: 5000\n");
  ASSERT_FALSE(c);
  EXPECT_TRUE(fails_with(c, ErrorCode::out_of_range, At{"setup.yaml", 7, "run.rate_hz"}));
  EXPECT_TRUE(contains(c.error().message, "[0.1, 1000]")) << c.error().message;  // the range is told
}

TEST(RunConfig, BadTypeIsAnError) {
  auto c = parse(std::string(kMinimal) + "run: {max_frame_age_s: soon}\n");
  ASSERT_FALSE(c);
  EXPECT_TRUE(fails_with(c, ErrorCode::invalid_value, At{"setup.yaml", 6, "run.max_frame_age_s"}));
}

TEST(RunConfig, EnumValueMustBeKnown) {
  auto c = parse(std::string(kMinimal) + "run: {tick: sometimes}\n");
  ASSERT_FALSE(c);
  EXPECT_TRUE(fails_with(c, ErrorCode::out_of_range, At{"setup.yaml", 6, "run.tick"}));
  EXPECT_TRUE(contains(c.error().message, "frame rate")) << c.error().message;  // the choices are told
}

TEST(RunConfig, SectionNeedsType) {
  auto c = parse("robot: {params: {a: 1}}\ncamera: {type: sim}\n");
  ASSERT_FALSE(c);
  EXPECT_TRUE(fails_with(c, ErrorCode::missing, At{"setup.yaml", 1, "robot.type"}));
}

TEST(RunConfig, UnknownKeyInSection) {
  auto c = parse("robot: {type: sim, parms: {a: 1}}\ncamera: {type: sim}\n");
  ASSERT_FALSE(c);
  EXPECT_TRUE(fails_with(c, ErrorCode::unknown_key, At{"setup.yaml", 1, "robot.parms"}));
}

TEST(RunConfig, TypeMustBeAName) {
  auto c = parse("robot: {type: [a, b]}\ncamera: {type: sim}\n");
  ASSERT_FALSE(c);
  EXPECT_TRUE(fails_with(c, ErrorCode::invalid_value, At{"setup.yaml", 1, "robot.type"}));
}

TEST(RunConfig, MissingSectionsAreReported) {
  auto c = parse("detector: {type: orb}\n");
  ASSERT_FALSE(c);
  EXPECT_TRUE(fails_with(c, ErrorCode::missing, At{"setup.yaml", 0, "robot"}));
  EXPECT_TRUE(contains(c.error().message, "missing section 'camera'")) << c.error().message;  // both are listed
}

TEST(RunConfig, ReportsEveryErrorNotJustTheFirst) {
  auto c = parse("robot: {type: sim}\ncamera: {type: sim}\nrun:\n  rate_hz: -1\n  lockstep: maybe\nextra: 1\n");
  ASSERT_FALSE(c);
  const auto& m = c.error().message;
  EXPECT_TRUE(contains(m, "setup.yaml:4:")) << m;
  EXPECT_TRUE(contains(m, "setup.yaml:5:")) << m;
  EXPECT_TRUE(contains(m, "setup.yaml:6:")) << m;
}

TEST(Override, SetsNestedValueAndCreatesMaps) {
  auto root = visnav::parse_yaml_string("detector: {type: orb, params: {target_keypoints: 500}}\n", "s.yaml");
  ASSERT_TRUE(root);
  ASSERT_TRUE(visnav::apply_override(*root, "detector.params.target_keypoints=300"));
  ASSERT_TRUE(visnav::apply_override(*root, "run.trace.deep=x"));
  const auto* v = root->find("detector")->find("params")->find("target_keypoints");
  EXPECT_EQ(v->scalar(), "300");
  EXPECT_EQ(v->where().str(), "--set detector.params.target_keypoints=300");
  EXPECT_EQ(root->find("detector")->find("type")->scalar(), "orb");  // siblings untouched
  EXPECT_EQ(root->find("run")->find("trace")->find("deep")->scalar(), "x");
}

TEST(Override, ValueCanBeAListAndEmpty) {
  visnav::ConfigNode root;
  ASSERT_TRUE(visnav::apply_override(root, "nodes=[a, b]"));
  ASSERT_TRUE(visnav::apply_override(root, "run.trace_file="));
  ASSERT_TRUE(root.find("nodes")->is_sequence());
  EXPECT_EQ(root.find("nodes")->items().size(), 2u);
  EXPECT_EQ(root.find("run")->find("trace_file")->scalar(), "");
}

TEST(Override, MalformedOverridesAreErrors) {
  auto root = visnav::parse_yaml_string("robot: {type: sim}\n", "s.yaml");
  ASSERT_TRUE(root);
  auto no_eq = visnav::apply_override(*root, "robot.type");
  ASSERT_FALSE(no_eq);
  EXPECT_TRUE(fails_with(no_eq, ErrorCode::invalid_value, At{"--set robot.type"}));
  EXPECT_FALSE(visnav::apply_override(*root, "=3"));
  EXPECT_FALSE(visnav::apply_override(*root, "robot..type=3"));
  auto through_scalar = visnav::apply_override(*root, "robot.type.name=x");
  ASSERT_FALSE(through_scalar);
  EXPECT_TRUE(fails_with(through_scalar, ErrorCode::invalid_value, At{"s.yaml", 1, "robot.type"}));
}

TEST(Override, BadOverrideValueIsReportedWithItsOrigin) {
  auto root = visnav::parse_yaml_string(kMinimal, "s.yaml");
  ASSERT_TRUE(root);
  ASSERT_TRUE(visnav::apply_override(*root, "run.rate_hz=0"));
  auto c = visnav::parse_run_config(*root, "s.yaml");
  ASSERT_FALSE(c);
  EXPECT_TRUE(fails_with(c, ErrorCode::out_of_range, At{"--set run.rate_hz=0", 0, "run.rate_hz"}));
}

TEST(RunConfigFile, LoadsWithOverridesAndResolvesPluginPathAgainstTheFile) {
  std::string pattern = (fs::temp_directory_path() / "visnav_cfg_XXXXXX").string();
  ASSERT_NE(mkdtemp(pattern.data()), nullptr);
  const fs::path dir(pattern);
  { std::ofstream(dir / "c.yaml") << kMinimal << "plugin_path: [extra, /abs/dir]\n"; }
  auto c = visnav::load_run_config((dir / "c.yaml").string(), {"camera.params.width_px=640"});
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_EQ(c->camera.params.find("width_px")->scalar(), "640");
  ASSERT_EQ(c->plugin_path.size(), 2u);
  EXPECT_EQ(c->plugin_path[0], (dir / "extra").string());
  EXPECT_EQ(c->plugin_path[1], "/abs/dir");
  fs::remove_all(dir);
}

TEST(ParamDocsCheck, FindsUnknownKeysTypesRangesAndChoices) {
  std::vector<visnav::ParamDoc> docs{
      {"target_keypoints", "int", "500", "", "[10, 20000]"},
      {"mode", "string", "fast", "", "one of: fast accurate"},
      {"gains", "list<double>", "", "", "[0, 1]"},
      {"upright", "bool", "false", "", ""},
  };
  auto root = visnav::parse_yaml_string(
      "target_keypoints: 5\nmode: slow\ngains: [0.5, 2]\nupright: perhaps\ncolour: red\n", "d.yaml");
  ASSERT_TRUE(root);
  const auto problems = visnav::check_params_against_docs(*root, docs, "detector");
  ASSERT_EQ(problems.size(), 5u);
  EXPECT_TRUE(contains(problems[0], "d.yaml:1: key 'target_keypoints' in detector.params: value 5 is out of range"));
  EXPECT_TRUE(contains(problems[1], "d.yaml:2:") && contains(problems[1], "'slow' is not one of: fast accurate"));
  EXPECT_TRUE(contains(problems[2], "d.yaml:3:") && contains(problems[2], "value 2 is out of range [0, 1]"));
  EXPECT_TRUE(contains(problems[3], "d.yaml:4:") && contains(problems[3], "not a boolean"));
  EXPECT_TRUE(contains(problems[4], "d.yaml:5: unknown key 'colour' in detector.params (known keys: target_keypoints"));
  auto good = visnav::parse_yaml_string("target_keypoints: 300\nmode: accurate\ngains: 0.1;0.9\n", "d.yaml");
  EXPECT_TRUE(visnav::check_params_against_docs(*good, docs, "detector").empty());
}

TEST(SameConfig, IgnoresLocationsButSeesChanges) {
  auto a = visnav::parse_yaml_string("x: {a: 1, b: [1, 2]}\n", "a.yaml");
  auto b = visnav::parse_yaml_string("\n\nx:\n  b: [1, 2]\n  a: 1\n", "b.yaml");
  auto c = visnav::parse_yaml_string("x: {a: 1, b: [1, 3]}\n", "a.yaml");
  ASSERT_TRUE(a && b && c);
  EXPECT_TRUE(visnav::same_config(*a, *b));
  EXPECT_FALSE(visnav::same_config(*a, *c));
}

// Issue 39: `dds: {security: DIR/<identity>}` is the one key of a keystore made by
// `visnav security init DIR`: the identity's files in its folder, CA and governance one up;
// relative to the config file like the long form.
TEST(RunConfig, DdsSecurityIdentityFolderIsOneKey) {
  auto root = visnav::parse_yaml_string(
      "robot: {type: sim}\ncamera: {type: sim}\ndds: {security: keys/r1-mission}\n", "/robots/r1/run.yaml");
  ASSERT_TRUE(root.ok()) << root.error().message;
  auto config = visnav::parse_run_config(*root, "/robots/r1/run.yaml");
  ASSERT_TRUE(config.ok()) << config.error().message;
  ASSERT_TRUE(config->dds.security.has_value());
  const auto& files = *config->dds.security;
  EXPECT_EQ(files.ca, "/robots/r1/keys/ca.pem");
  EXPECT_EQ(files.governance, "/robots/r1/keys/governance.p7s");
  EXPECT_EQ(files.identity_cert, "/robots/r1/keys/r1-mission/cert.pem");
  EXPECT_EQ(files.private_key, "/robots/r1/keys/r1-mission/key.pem");
  EXPECT_EQ(files.permissions, "/robots/r1/keys/r1-mission/permissions.p7s");
  // A sequence is neither form: the error names the key and both forms.
  auto bad_root = visnav::parse_yaml_string("robot: {type: sim}\ncamera: {type: sim}\ndds: {security: [a, b]}\n", "x.yaml");
  ASSERT_TRUE(bad_root.ok());
  auto bad = visnav::parse_run_config(*bad_root, "x.yaml");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("identity folder of a keystore"), std::string::npos) << bad.error().message;
}
