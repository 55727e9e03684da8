// run_mission and prepare_mission: what `visnav run` does (check_setup, the checks `visnav
// validate` makes, lives in setup_check.cpp).
#include "visnav/bt/tree.hpp"
#include "visnav/runner.hpp"

namespace visnav {

namespace {

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

namespace {

/// Every problem as one Error: the messages one per line, the first problem's code and location.
Error combined(const std::vector<Error>& problems, const std::string& headline) {
  std::string text = headline;
  for (const auto& p : problems) text += "\n" + p.message;
  return Error{std::move(text), problems.front().code, problems.front().where};
}

}  // namespace

Result<PreparedMission> prepare_mission(const MissionOptions& options) {
  const std::string map_path = options.map_path.empty() ? std::string() : resolve_map_path(options.map_path);
  SetupCheck setup;
  setup.config_file = options.config_file;
  setup.overrides = options.overrides;
  setup.tree_file = options.tree_file;
  setup.blackboard_values = options.blackboard_values;
  setup.port_overrides = options.port_overrides;
  setup.map_path = map_path;
  setup.create_map = options.create_map;
  setup.extra_plugin_dirs = options.extra_plugin_dirs;
  setup.use_default_plugin_path = options.use_default_plugin_path;
  // The plugins on the default and extra paths stay loaded from the check until the session has
  // loaded them too, so their process-wide caches (e.g. a simulated world parsed by the check)
  // are not dropped by a dlclose in between.
  PluginLoader keep_loaded(options.use_default_plugin_path ? PluginLoader::default_search_path()
                                                           : std::vector<std::string>{});
  for (const auto& dir : options.extra_plugin_dirs) keep_loaded.add_search_dir(dir);
  (void)keep_loaded.scan();  // its problems are check_setup's to report
  StderrLogger quiet(LogLevel::error);  // validate's plugin_path notices are not run's concern
  if (auto problems = check_setup(setup, &quiet); !problems.empty())
    return combined(problems, "the setup is not valid, nothing was run (" + std::to_string(problems.size()) +
                                  (problems.size() == 1 ? " problem):" : " problems):"));

  VISNAV_ASSIGN(RunConfig config, load_run_config(options.config_file, options.overrides));
  if (options.log_level) config.run.log_level = to_string(*options.log_level);
  SessionOptions so;
  so.extra_plugin_dirs = options.extra_plugin_dirs;
  so.use_default_plugin_path = options.use_default_plugin_path;
  so.map_path = map_path;
  so.create_map = options.create_map;
  so.overrides = options.overrides;
  PreparedMission m;
  VISNAV_ASSIGN(m.session, Session::create(std::move(config), so));
  std::vector<bt::PortOverride> ports;
  for (const auto& text : options.port_overrides) {
    VISNAV_ASSIGN(bt::PortOverride port, bt::parse_port_override(text));
    ports.push_back(std::move(port));
  }
  auto tree = m.session->load_tree(options.tree_file, ports);
  if (!tree)
    return Error{options.tree_file + ": tree is not valid, nothing was run:\n" + tree.error().message, tree.error().code,
                 tree.error().where};
  m.tree.emplace(std::move(tree).value());
  VISNAV_TRY(set_blackboard_values(*m.tree, options.blackboard_values));
  return m;
}

RunReport run_mission(const MissionOptions& options) {
  auto prepared = prepare_mission(options);
  if (!prepared) return error_report(prepared.error().message);
  RunOptions ro;
  ro.trace_file = options.trace_file;
  ro.stop_requested = options.stop_requested;
  return run_tree(*prepared->session, *prepared->tree, ro);  // the tree goes before the session
}

}  // namespace visnav
