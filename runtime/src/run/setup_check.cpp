// check_setup: every check `visnav run` makes before its first tick, shared by `visnav
// validate` (which only reports) and run_mission / prepare_mission (which stop at a problem).
#include <algorithm>
#include <cstdlib>
#include <filesystem>

#include "visnav/bt/registry.hpp"
#include "visnav/bt/tree.hpp"
#include "visnav/runner.hpp"

namespace visnav {

namespace {

namespace fs = std::filesystem;

/// Names the section in a params problem, as `visnav validate` always has:
/// "f:3: key 'k' in detector.params: ..." and "f:3: unknown key 'k' in detector.params (known
/// keys: ...)"; the location's key becomes the full path "detector.params.k".
Error in_section(Error e, const std::string& section) {
  const std::string params = section + ".params";
  if (e.where.key.empty()) {
    e.where.key = params;
    return e;
  }
  const std::string key = "key '" + e.where.key + "'";
  if (const auto pos = e.message.find(key); pos != std::string::npos) e.message.insert(pos + key.size(), " in " + params);
  e.where.key = params + "." + e.where.key;
  return e;
}

Error from_diagnostic(const bt::Diagnostic& d) {
  return Error{d.str(), d.code == ErrorCode::unspecified ? ErrorCode::invalid_value : d.code, {d.file, d.line, d.node_path}};
}

/// Loading a library runs its constructors: say which libraries from the config's plugin_path
/// (not the trusted build/install dirs) are about to be loaded, and which plugin_path folders
/// do not exist (issue 17).
void report_plugin_path(const std::vector<std::string>& dirs, Logger& log) {
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

/// One pass over a setup, collecting problems in order: config, plugins, tree, map.
class SetupChecker {
 public:
  SetupChecker(const SetupCheck& setup, Logger& log) : setup_(setup), log_(log) {}

  std::vector<Error> run() {
    check_config();
    std::vector<std::string> dirs;
    if (setup_.use_default_plugin_path) dirs = PluginLoader::default_search_path();
    dirs.insert(dirs.end(), plugin_dirs_.begin(), plugin_dirs_.end());
    dirs.insert(dirs.end(), setup_.extra_plugin_dirs.begin(), setup_.extra_plugin_dirs.end());
    report_plugin_path(plugin_dirs_, log_);
    PluginLoader loader(std::move(dirs));
    if (auto scanned = loader.scan(); !scanned) add(scanned.error(), ErrorCode::io);
    if (config_) {
      check_plugin(loader, "robot", PluginKind::robot, config_->robot);
      check_plugin(loader, "camera", PluginKind::camera, config_->camera);
      if (config_->detector) check_plugin(loader, "detector", PluginKind::detector, *config_->detector);
    }
    check_tree(loader);
    check_map(loader);
    return std::move(problems_);
  }

 private:
  void add(Error e, ErrorCode fallback) { problems_.push_back(e.with_default_code(fallback)); }

  // The YAML file, the --set overrides and the run config structure. When the structure has
  // problems, plugin_path and nodes are still honoured (when they are fine) so the tree is
  // checked against the right node types.
  void check_config() {
    auto root = parse_yaml_file(setup_.config_file);
    if (!root) return add(root.error(), ErrorCode::parse_error);
    bool overrides_ok = true;
    for (const auto& o : setup_.overrides) {
      if (auto st = apply_override(*root, o); !st) {
        Error e = st.error();
        if (e.where.empty()) e.where = ErrorLocation{"--set", 0, o.substr(0, o.find('='))};
        add(std::move(e), ErrorCode::invalid_value);
        overrides_ok = false;
      }
    }
    if (!overrides_ok) return;
    RunConfig parsed;
    auto problems = run_config_problems(*root, setup_.config_file, &parsed);
    if (problems.empty()) {
      plugin_dirs_ = parsed.plugin_path;
      nodes_ = parsed.nodes;
      config_ = std::move(parsed);
      return;
    }
    for (auto& p : problems) add(std::move(p), ErrorCode::invalid_value);
    if (!root->is_map()) return;
    ConfigNode reduced = ConfigNode::make_map(root->where());
    ConfigNode placeholder = ConfigNode::make_map(root->where());
    placeholder.set("type", ConfigNode::make_scalar("-"));
    reduced.set("robot", placeholder);
    reduced.set("camera", placeholder);
    for (const char* key : {"plugin_path", "nodes"})
      if (const ConfigNode* n = root->find(key)) reduced.set(key, *n);
    if (auto partial = parse_run_config(reduced, setup_.config_file)) {
      plugin_dirs_ = partial->plugin_path;
      nodes_ = partial->nodes;
    }
  }

  // The type exists, and its params pass the type's own check (schema, validate(), files).
  void check_plugin(PluginLoader& loader, const char* section, PluginKind kind, const PluginSpec& spec) {
    const ErrorLocation at{spec.where.file, spec.where.line, std::string(section) + ".type"};
    auto located = [&](const Error& e, ErrorCode code) {
      return Error{spec.where.str() + ": " + section + ": " + e.message, e.with_default_code(code).code, at};
    };
    if (!spec.plugin.empty()) {
      if (auto l = loader.load_library(spec.plugin); !l) return add(located(l.error(), ErrorCode::plugin), ErrorCode::plugin);
    }
    auto entry = loader.type_entry(kind, spec.type, spec.plugin);
    if (!entry) return add(located(entry.error(), ErrorCode::not_found), ErrorCode::not_found);
    if (const ParamCheckFn check = (*entry)->check_params; check != nullptr) {
      for (auto& e : check(spec.params)) add(in_section(std::move(e), section), ErrorCode::invalid_value);
      return;
    }
    // A hand-written TypeEntry without check_params: its declared docs are all there is.
    auto docs = loader.param_docs(kind, spec.type, spec.plugin);
    if (!docs) return add(located(docs.error(), ErrorCode::plugin), ErrorCode::plugin);
    const SourceLocation& p = spec.params.where();
    for (auto& text : check_params_against_docs(spec.params, *docs, section))
      add(Error{std::move(text), ErrorCode::invalid_value, {p.file, p.line, std::string(section) + ".params"}},
          ErrorCode::invalid_value);
  }

  // The nodes plugins register (into a registry bound to a host without devices), then the tree
  // validates against them with the run: block's limits: structure, ports, literal values.
  void check_tree(PluginLoader& loader) {
    StderrLogger quiet(LogLevel::error);
    WallClock clock;
    RuntimeHost host(loader, quiet, clock);
    bt::NodeRegistry registry;
    if (auto st = register_all_nodes(registry, loader, host, nodes_); !st) add(st.error(), ErrorCode::plugin);
    if (setup_.tree_file.empty()) return;
    bt::LoadOptions limits;
    limits.blackboard = bt::Blackboard::create();
    for (const auto& a : setup_.blackboard_values) {
      const auto eq = a.find('=');
      if (eq == std::string::npos || eq == 0) {
        add(Error{"--bb " + a + ": not of the form key=value", ErrorCode::invalid_value, {"--bb", 0, a}},
            ErrorCode::invalid_value);
        continue;
      }
      limits.blackboard->set(std::string_view(a).substr(0, eq), a.substr(eq + 1));
    }
    for (const auto& text : setup_.port_overrides) {
      auto port = bt::parse_port_override(text);
      if (!port) {
        add(Error{"--port " + port.error().message, ErrorCode::parse_error, {"--port", 0, text}}, ErrorCode::parse_error);
        continue;
      }
      limits.port_overrides.push_back(std::move(*port));
    }
    if (config_) {
      limits.max_subtree_depth = config_->run.bt_max_subtree_depth;
      limits.max_nodes = static_cast<std::size_t>(config_->run.bt_max_nodes);
      limits.max_tree_depth = config_->run.bt_max_tree_depth;
    }
    for (const auto& d : bt::validate_tree_file(setup_.tree_file, registry, limits)) add(from_diagnostic(d), ErrorCode::invalid_value);
  }

  // The map opens and every payload passes its checks, bodies included for the kinds whose
  // readers the loaded plugins provide.
  void check_map(const PluginLoader& loader) {
    if (setup_.map_path.empty()) return;
    const std::string path = resolve_map_path(setup_.map_path);
    std::error_code ec;
    if (!fs::exists(path, ec)) {
      if (setup_.create_map) return;  // `run --create` makes it
      return add(Error{"--map " + path + ": no such map folder (give --create to start a new map there)",
                       ErrorCode::not_found, {path, 0, {}}},
                 ErrorCode::not_found);
    }
    auto map = MapStore::open(path);
    if (!map) return add(map.error().with_context("--map " + path), ErrorCode::parse_error);
    loader.install_payload_checks(*map);
    for (auto& text : map->validate()) add(Error{std::move(text), ErrorCode::parse_error, {path, 0, {}}}, ErrorCode::parse_error);
  }

  const SetupCheck& setup_;
  Logger& log_;
  std::vector<Error> problems_;
  std::optional<RunConfig> config_;
  std::vector<std::string> plugin_dirs_;
  std::optional<std::vector<std::string>> nodes_;
};

}  // namespace

std::vector<Error> check_setup(const SetupCheck& setup, Logger* log) {
  StderrLogger fallback(LogLevel::warn);
  return SetupChecker(setup, log != nullptr ? *log : fallback).run();
}

std::vector<std::string> validate_setup(const std::string& config_file, const std::vector<std::string>& overrides,
                                        const std::string& tree_file, const std::vector<std::string>& extra_plugin_dirs,
                                        bool use_default_plugin_path) {
  SetupCheck setup;
  setup.config_file = config_file;
  setup.overrides = overrides;
  setup.tree_file = tree_file;
  setup.extra_plugin_dirs = extra_plugin_dirs;
  setup.use_default_plugin_path = use_default_plugin_path;
  std::vector<std::string> out;
  for (auto& e : check_setup(setup)) out.push_back(std::move(e.message));
  return out;
}

std::string maps_dir() {
  const char* env = std::getenv("VISNAV_MAPS_DIR");
  return env != nullptr && *env != '\0' ? std::string(env) : std::string("maps");
}

std::string resolve_map_path(const std::string& name_or_path) {
  const bool bare = !name_or_path.empty() && name_or_path.find('/') == std::string::npos && name_or_path != "." &&
                    name_or_path != "..";
  return bare ? (fs::path(maps_dir()) / name_or_path).string() : name_or_path;
}

}  // namespace visnav
