// run_mission (what `visnav run` does) and validate_setup (what `visnav validate` does).
#include <sstream>

#include "visnav/bt/registry.hpp"
#include "visnav/bt/tree.hpp"
#include <algorithm>
#include <filesystem>

#include "visnav/runner.hpp"

namespace visnav {

namespace {

std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line))
    if (!line.empty()) out.push_back(line);
  return out;
}

RunReport error_report(std::string reason) {
  RunReport r;
  r.outcome = RunOutcome::error;
  r.exit_code = 1;
  r.reason = std::move(reason);
  return r;
}

}  // namespace

Status set_blackboard_values(bt::Tree& tree, const std::vector<std::string>& assignments) {
  for (const auto& a : assignments) {
    const auto eq = a.find('=');
    if (eq == std::string::npos || eq == 0)
      return fail("blackboard value '" + a + "' is not of the form key=value");
    tree.blackboard().set(std::string_view(a).substr(0, eq), a.substr(eq + 1));
  }
  return ok();
}

RunReport run_mission(const MissionOptions& options) {
  auto config = load_run_config(options.config_file, options.overrides);
  if (!config) return error_report(config.error().message);
  if (options.log_level) config->run.log_level = to_string(*options.log_level);

  SessionOptions so;
  so.extra_plugin_dirs = options.extra_plugin_dirs;
  so.use_default_plugin_path = options.use_default_plugin_path;
  so.map_path = options.map_path;
  so.create_map = options.create_map;
  so.overrides = options.overrides;
  auto session = Session::create(std::move(config).value(), so);
  if (!session) return error_report(session.error().message);

  auto tree = (*session)->load_tree(options.tree_file);
  if (!tree) return error_report(options.tree_file + ": tree is not valid, nothing was run:\n" + tree.error().message);
  if (auto st = set_blackboard_values(*tree, options.blackboard_values); !st)
    return error_report(st.error().message);

  RunOptions ro;
  ro.trace_file = options.trace_file;
  ro.stop_requested = options.stop_requested;
  RunReport report = run_tree(**session, *tree, ro);
  return report;  // the tree goes before the session (declared after it)
}

/// Loading a library runs its constructors: say which libraries from the config's plugin_path
/// (not the trusted build/install dirs) `visnav validate` is about to load, and which plugin_path
/// folders do not exist (issue 17).
static void report_plugin_path(const std::vector<std::string>& dirs, Logger& log) {
  namespace fs = std::filesystem;
  for (const auto& dir : dirs) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) {
      log.warn("validate", "plugin_path folder '" + dir + "' does not exist");
      continue;
    }
    std::vector<std::string> libs;
    for (const auto& entry : fs::directory_iterator(dir, ec)) {
      const std::string name = entry.path().filename().string();
      if (name.rfind("libvisnav_", 0) == 0 && name.size() > 3 && name.compare(name.size() - 3, 3, ".so") == 0)
        libs.push_back(name);
    }
    std::sort(libs.begin(), libs.end());
    for (const auto& l : libs) log.warn("validate", "loading " + dir + "/" + l + " from plugin_path (its constructors run)");
  }
}

std::vector<std::string> validate_setup(const std::string& config_file, const std::vector<std::string>& overrides,
                                        const std::string& tree_file, const std::vector<std::string>& extra_plugin_dirs,
                                        bool use_default_plugin_path) {
  std::vector<std::string> problems;
  std::optional<RunConfig> config;
  std::vector<std::string> plugin_dirs;
  std::optional<std::vector<std::string>> nodes;

  auto root = parse_yaml_file(config_file);
  if (!root) {
    problems.push_back(root.error().message);
  } else {
    bool overrides_ok = true;
    for (const auto& o : overrides) {
      if (auto st = apply_override(*root, o); !st) {
        problems.push_back(st.error().message);
        overrides_ok = false;
      }
    }
    if (overrides_ok) {
      auto parsed = parse_run_config(*root, config_file);
      if (!parsed) {
        for (auto& l : split_lines(parsed.error().message)) problems.push_back(std::move(l));
        // Still honour plugin_path and nodes (when they are fine) so the tree is checked
        // against the right node types.
        if (root->is_map()) {
          ConfigNode reduced = ConfigNode::make_map(root->where());
          ConfigNode placeholder = ConfigNode::make_map(root->where());
          placeholder.set("type", ConfigNode::make_scalar("-"));
          reduced.set("robot", placeholder);
          reduced.set("camera", placeholder);
          for (const char* key : {"plugin_path", "nodes"})
            if (const ConfigNode* n = root->find(key)) reduced.set(key, *n);
          if (auto partial = parse_run_config(reduced, config_file)) {
            plugin_dirs = partial->plugin_path;
            nodes = partial->nodes;
          }
        }
      } else {
        plugin_dirs = parsed->plugin_path;
        nodes = parsed->nodes;
        config = std::move(parsed).value();
      }
    }
  }

  std::vector<std::string> dirs;
  if (use_default_plugin_path) dirs = PluginLoader::default_search_path();
  dirs.insert(dirs.end(), plugin_dirs.begin(), plugin_dirs.end());
  dirs.insert(dirs.end(), extra_plugin_dirs.begin(), extra_plugin_dirs.end());
  StderrLogger logger(LogLevel::warn);
  report_plugin_path(plugin_dirs, logger);
  PluginLoader loader(std::move(dirs));
  if (auto scanned = loader.scan(); !scanned) problems.push_back(scanned.error().message);

  WallClock clock;
  RuntimeHost host(loader, logger, clock);

  if (config) {
    auto check = [&](const char* section, PluginKind kind, const PluginSpec& spec) {
      if (!spec.plugin.empty()) {
        if (auto l = loader.load_library(spec.plugin); !l) {
          problems.push_back(spec.where.str() + ": " + section + ": " + l.error().message);
          return;
        }
      }
      auto docs = loader.param_docs(kind, spec.type, spec.plugin);
      if (!docs) {
        problems.push_back(spec.where.str() + ": " + section + ": " + docs.error().message);
        return;
      }
      for (auto& p : check_params_against_docs(spec.params, *docs, section)) problems.push_back(std::move(p));
    };
    check("robot", PluginKind::robot, config->robot);
    check("camera", PluginKind::camera, config->camera);
    if (config->detector) check("detector", PluginKind::detector, *config->detector);
  }

  bt::NodeRegistry registry;
  if (auto st = register_all_nodes(registry, loader, host, nodes); !st)
    problems.push_back(st.error().message);

  if (!tree_file.empty()) {
    bt::LoadOptions limits;  // the run: block's behaviour-tree limits, when the config parsed
    if (config) {
      limits.max_subtree_depth = config->run.bt_max_subtree_depth;
      limits.max_nodes = static_cast<std::size_t>(config->run.bt_max_nodes);
      limits.max_tree_depth = config->run.bt_max_tree_depth;
    }
    for (const auto& d : bt::validate_tree_file(tree_file, registry, limits)) problems.push_back(d.str());
  }
  return problems;
}

}  // namespace visnav
