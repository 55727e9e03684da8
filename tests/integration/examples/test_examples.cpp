// Every `visnav ...` example in the README, docs/*.md (shell code blocks), trees/**/*.xml comments
// and config/**/*.yaml comments runs as written, from the source folder:
//  * `visnav run` examples: the config and tree validate together (`visnav validate` with the
//    example's --set overrides and --bb values), every --bb key is a {key} of the tree or its includes, and
//    every file named in a --bb value exists. A full run would take minutes; validation covers
//    what goes wrong when a file, node, port or parameter is renamed.
//  * other commands: `visnav <command> --help` succeeds and knows every --option the example uses.
// Usage lines (with [optional] parts, A|B, or PLACEHOLDER arguments) are checked as commands
// only. Every config/*.yaml run config validates on its own, and gives a simulated robot a body.
// A `visnav run` example whose tree teaches passes --map and --create.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "visnav/config.hpp"

namespace fs = std::filesystem;

namespace {

const fs::path kSource = VISNAV_TEST_SOURCE_DIR;

struct Example {
  std::string where;  // file:line
  std::vector<std::string> args;  // after "visnav"
  bool usage = false;             // a synopsis, not a runnable example
};

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t\r") - b + 1);
}

std::vector<std::string> split_words(const std::string& text) {
  std::vector<std::string> out;
  std::string cur;
  char quote = 0;
  bool have = false;
  for (char c : text) {
    if (quote != 0) {
      if (c == quote) quote = 0; else cur.push_back(c);
      continue;
    }
    if (c == '"' || c == '\'') { quote = c; have = true; continue; }
    if (c == ' ' || c == '\t') {
      if (have) out.push_back(cur);
      cur.clear();
      have = false;
      continue;
    }
    cur.push_back(c);
    have = true;
  }
  if (have) out.push_back(cur);
  return out;
}

bool is_usage(const std::vector<std::string>& words) {
  static const std::regex placeholder("^[A-Z][A-Z0-9_]*(\\.[a-z]+)?(,[A-Z0-9_]+)*$");
  for (const auto& w : words) {
    if (w.find_first_of("[]|<>") != std::string::npos || w.find("...") != std::string::npos) return true;
    const auto eq = w.find('=');
    const std::string value = eq == std::string::npos ? w : w.substr(eq + 1);
    if (std::regex_match(value, placeholder)) return true;
  }
  return false;
}

/// Lines of `file` that start a command, with continuation lines (trailing '\') joined.
/// `comment` is the prefix stripped from each line first ("#" in YAML; "" otherwise).
void collect(const fs::path& file, const std::string& comment, bool markdown, std::vector<Example>& out) {
  std::ifstream in(file);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  bool in_shell_block = false;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    std::string line = trim(lines[i]);
    if (markdown) {
      if (line.rfind("```", 0) == 0) {
        const std::string lang = line.substr(3);
        in_shell_block = !in_shell_block && (lang.empty() || lang == "sh" || lang == "bash" || lang == "console");
        continue;
      }
      if (!in_shell_block) continue;
    }
    auto strip = [&](std::string l) {
      l = trim(l);
      if (!comment.empty() && l.rfind(comment, 0) == 0) l = trim(l.substr(comment.size()));
      if (l.rfind("$ ", 0) == 0) l = l.substr(2);
      return l;
    };
    line = strip(lines[i]);
    if (line.rfind("visnav ", 0) != 0) continue;
    Example e;
    e.where = fs::relative(file, kSource).string() + ":" + std::to_string(i + 1);
    std::string text = line;
    while (!text.empty() && text.back() == '\\' && i + 1 < lines.size()) {
      text.pop_back();
      text += ' ';
      text += strip(lines[++i]);
    }
    // A trailing shell comment is not part of the command.
    if (auto hash = text.find(" #"); hash != std::string::npos) text = text.substr(0, hash);
    auto words = split_words(text);
    words.erase(words.begin());  // "visnav"
    if (words.empty()) continue;
    e.usage = is_usage(words);
    e.args = std::move(words);
    out.push_back(std::move(e));
  }
}

std::vector<Example> all_examples() {
  std::vector<Example> out;
  collect(kSource / "README.md", "", true, out);
  collect(kSource / "HACKING.md", "", true, out);
  for (const auto& f : fs::directory_iterator(kSource / "docs"))
    if (f.path().extension() == ".md") collect(f.path(), "", true, out);
  for (const auto& f : fs::recursive_directory_iterator(kSource / "trees"))
    if (f.path().extension() == ".xml") collect(f.path(), "", false, out);
  for (const auto& f : fs::recursive_directory_iterator(kSource / "config"))
    if (f.path().extension() == ".yaml") collect(f.path(), "#", false, out);
  return out;
}

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) {
    if (c == '\'') q += "'\\''"; else q.push_back(c);
  }
  return q + "'";
}

/// Runs `visnav args...` in the source folder; returns the exit status and the output.
int run_cli(const std::vector<std::string>& args, std::string& output) {
  std::string cmd = "cd " + shell_quote(kSource.string()) + " && " + shell_quote(VISNAV_TEST_CLI);
  for (const auto& a : args) {
    cmd += ' ';
    cmd += shell_quote(a);
  }
  cmd += " 2>&1";
  output.clear();
  FILE* p = ::popen(cmd.c_str(), "r");
  if (p == nullptr) return -1;
  std::array<char, 4096> buffer{};
  while (std::size_t n = std::fread(buffer.data(), 1, buffer.size(), p)) output.append(buffer.data(), n);
  const int status = ::pclose(p);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// The tree's text plus that of every <include path="..."/> (relative to the including file).
std::string tree_text(const fs::path& tree) {
  std::string text = read_file(tree);
  static const std::regex include("<include\\s+path=\"([^\"]+)\"");
  std::string all = text;
  for (std::sregex_iterator it(text.begin(), text.end(), include), end; it != end; ++it)
    all += tree_text(tree.parent_path() / (*it)[1].str());
  return all;
}

std::string option_value(const std::vector<std::string>& args, const std::string& name) {
  for (std::size_t i = 0; i + 1 < args.size(); ++i)
    if (args[i] == name) return args[i + 1];
  return "";
}

TEST(Examples, AreFoundInEveryPlaceTheyAreWritten) {
  const auto examples = all_examples();
  std::set<std::string> files;
  int runs = 0;
  for (const auto& e : examples) {
    files.insert(e.where.substr(0, e.where.find(':')));
    runs += !e.usage && e.args[0] == "run" ? 1 : 0;
  }
  // The extraction itself must keep working: these files hold run examples.
  for (const char* f : {"trees/teach_hybrid_route.xml", "trees/replay_route.xml", "trees/patrol_loop.xml",
                        "trees/teach_operator.xml", "config/sim_campus.yaml", "docs/real_robot.md"})
    EXPECT_TRUE(files.count(f) == 1) << f << " has no visnav example any more";
  EXPECT_GE(runs, 12);
}

// Issue 38: every edge kind a hybrid map holds has a patrol tree that drives it; maps with
// visual_memory edges patrol with trees/patrol_loop_visual_memory.xml (its example validates in
// RunExamplesValidateAsWritten).
TEST(Examples, EveryReplayPrimitiveHasAPatrolTree) {
  std::set<std::string> patrolled;
  for (const auto& f : fs::directory_iterator(kSource / "trees")) {
    const std::string name = f.path().filename().string();
    if (name.rfind("patrol_loop", 0) != 0) continue;
    const std::string text = tree_text(f.path());
    if (text.find("<Repeat") == std::string::npos) continue;
    for (const char* node : {"ReplayFeatureEdge", "FollowPathEdge", "ReplayVisualMemoryEdge"})
      if (text.find(std::string("<") + node) != std::string::npos ||
          (text.find("TraverseRoute") != std::string::npos && std::string(node) != "ReplayVisualMemoryEdge"))
        patrolled.insert(node);
  }
  for (const char* node : {"ReplayFeatureEdge", "FollowPathEdge", "ReplayVisualMemoryEdge"})
    EXPECT_EQ(patrolled.count(node), 1u) << "no trees/patrol_loop*.xml drives " << node;
}

TEST(Examples, RunExamplesValidateAsWritten) {
  for (const auto& e : all_examples()) {
    if (e.usage || e.args[0] != "run") continue;
    SCOPED_TRACE(e.where);
    std::vector<std::string> validate{"validate"};
    std::vector<std::string> bb;
    for (std::size_t i = 1; i < e.args.size(); ++i) {
      const std::string& a = e.args[i];
      const bool has_value = i + 1 < e.args.size();
      if ((a == "--config" || a == "--tree" || a == "--set" || a == "--plugin-path") && has_value) {
        validate.push_back(a);
        validate.push_back(e.args[++i]);
      } else if (a == "--bb" && has_value) {
        bb.push_back(e.args[++i]);
        validate.push_back("--bb");  // checked by the ports that read it, as `visnav run` does
        validate.push_back(bb.back());
      } else if ((a == "--map" || a == "--trace" || a == "--log-level" || a == "--view") && has_value) {
        ++i;
      } else if (a == "--resume" || a == "--create") {
        // --create: `visnav run` makes the missing --map folder; validate is not given --map.
        // --resume reads the map's progress checkpoint at run time; validate checks the tree and config.
      } else {
        ADD_FAILURE() << "unknown option of visnav run: " << a;
      }
    }
    const std::string tree = option_value(e.args, "--tree");
    ASSERT_FALSE(tree.empty()) << "visnav run without --tree";
    ASSERT_TRUE(fs::exists(kSource / tree)) << tree << " does not exist";
    std::string out;
    EXPECT_EQ(run_cli(validate, out), 0) << out;
    const std::string text = tree_text(kSource / tree);
    for (const auto& kv : bb) {
      const auto eq = kv.find('=');
      ASSERT_NE(eq, std::string::npos) << "--bb " << kv;
      const std::string key = kv.substr(0, eq), value = kv.substr(eq + 1);
      EXPECT_NE(text.find("{" + key + "}"), std::string::npos) << "--bb " << key << ": the tree has no {" << key << "}";
      const bool names_file = value.find('/') != std::string::npos && value.rfind("/dev/", 0) != 0 &&
                              (fs::path(value).extension() == ".yaml" || fs::path(value).extension() == ".xml");
      if (names_file) {
        EXPECT_TRUE(fs::exists(kSource / value)) << "--bb " << kv << ": no such file";
      }
    }
  }
}

TEST(Examples, OtherCommandsExistAndKnowTheirOptions) {
  std::string out;
  for (const auto& e : all_examples()) {
    if (e.args[0] == "run") continue;
    SCOPED_TRACE(e.where);
    std::vector<std::string> help{e.args[0]};
    // Commands with subcommands (`visnav sim snapshot`, `visnav map info`).
    if (e.args.size() > 1 && (e.args[0] == "sim" || e.args[0] == "map")) help.push_back(e.args[1]);
    help.push_back("--help");
    const int rc = run_cli(help, out);
    EXPECT_EQ(rc, 0) << "visnav " << e.args[0] << " --help: " << out;
    if (rc != 0 || e.usage) continue;
    for (const auto& a : e.args)
      if (a.rfind("--", 0) == 0) {
        const std::string option = a.substr(0, a.find('='));
        EXPECT_NE(out.find(option), std::string::npos) << "visnav " << e.args[0] << " --help does not mention " << option;
      }
  }
}

// Issue 38: a teach example makes a new map, which `visnav run` does only with --create (a
// missing --map folder is an error otherwise), so every `visnav run` example whose tree (or an
// included one) teaches an edge names --map and --create; --create stands only with --map.
TEST(Examples, TeachExamplesCreateTheirMap) {
  static const std::regex teaches("<Teach[A-Z][A-Za-z]*[\\s/>]");
  int teach_examples = 0;
  for (const auto& e : all_examples()) {
    if (e.usage || e.args[0] != "run") continue;
    SCOPED_TRACE(e.where);
    const auto has = [&](const std::string& option) {
      return std::find(e.args.begin(), e.args.end(), option) != e.args.end();
    };
    if (has("--create")) {
      EXPECT_TRUE(has("--map")) << "--create without --map";
    }
    const std::string tree = option_value(e.args, "--tree");
    if (tree.empty() || !fs::exists(kSource / tree)) continue;  // RunExamplesValidateAsWritten reports it
    if (!std::regex_search(tree_text(kSource / tree), teaches)) continue;
    ++teach_examples;
    EXPECT_TRUE(has("--map")) << tree << " teaches into a map: the example needs --map";
    EXPECT_TRUE(has("--create")) << tree << " teaches a new map: the example needs --create (visnav run --help)";
  }
  // The teach trees' own examples, config/sim_campus.yaml's and docs/real_robot.md's at least.
  EXPECT_GE(teach_examples, 8);
}

// Issue 38: the simulated robot collides only with a body (body_radius_m 0 = none), so every
// shipped config that drives it gives it one; without, a replay through a wall "succeeds".
TEST(Examples, EverySimulatedRobotConfigHasABody) {
  int sim_configs = 0;
  for (const auto& f : fs::directory_iterator(kSource / "config")) {
    if (f.path().extension() != ".yaml") continue;
    const std::string text = read_file(f.path());
    if (text.find("\nrobot:") == std::string::npos && text.rfind("robot:", 0) != 0) continue;
    SCOPED_TRACE(f.path().string());
    auto config = visnav::load_run_config(f.path().string());
    if (!config) {
      ADD_FAILURE() << config.error().message;
      continue;
    }
    if (config->robot.type != "sim") continue;
    ++sim_configs;
    const visnav::ConfigNode* radius = config->robot.params.find("body_radius_m");
    if (radius == nullptr || !radius->is_scalar()) {
      ADD_FAILURE() << "robot.params has no body_radius_m: the simulated robot never collides";
      continue;
    }
    double r = 0.0;
    try {
      r = std::stod(radius->scalar());
    } catch (...) {
    }
    EXPECT_GT(r, 0.0) << "robot.params.body_radius_m: " << radius->scalar();
  }
  EXPECT_GE(sim_configs, 5);
}

TEST(Examples, EveryShippedRunConfigValidates) {
  std::string out;
  for (const auto& f : fs::directory_iterator(kSource / "config")) {
    if (f.path().extension() != ".yaml") continue;
    const std::string text = read_file(f.path());
    if (text.find("\nrobot:") == std::string::npos && text.rfind("robot:", 0) != 0) continue;
    SCOPED_TRACE(f.path().string());
    EXPECT_EQ(run_cli({"validate", "--config", "config/" + f.path().filename().string()}, out), 0) << out;
  }
}

}  // namespace
