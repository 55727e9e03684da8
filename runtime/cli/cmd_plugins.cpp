// `visnav plugins`: list the plugin libraries on the search path.
#include <iostream>

#include "args.hpp"
#include "command.hpp"
#include "visnav/bt/registry.hpp"
#include "visnav/loader.hpp"
#include "visnav/runner.hpp"

namespace {

constexpr const char* kUsage =
    "usage: visnav plugins [--params] [--config C] [--plugin-path DIR]...\n"
    "\n"
    "Lists every plugin library found on the search path (build dir, install dir,\n"
    "VISNAV_PLUGIN_PATH, the config's plugin_path, --plugin-path): kind, name, version, ABI,\n"
    "path, the types it provides (node IDs for nodes plugins) and its commands; then the\n"
    "libraries that could not be used"
    " and why (wrong ABI, missing entry symbol, shadowed, duplicate types).\n"
    "  --params      also print each type's parameters (name, type, default, constraint)\n"
    "  --config C    add C's plugin_path\n";

int run(const std::vector<std::string>& args) {
  using visnav::cli::Opt;
  visnav::cli::Args a;
  if (auto st = a.parse(args, {{"--params", Opt::flag}, {"--config", Opt::value}, {"--plugin-path", Opt::repeated}}); !st)
    return visnav::cli::usage_error("plugins", st.error().message);
  std::vector<std::string> dirs = a.all("--plugin-path");
  if (a.has("--config")) {
    auto config = visnav::load_run_config(a.get("--config"));
    if (!config) {
      std::cerr << "visnav plugins: " << config.error().message << "\n";
      return 1;
    }
    dirs.insert(dirs.begin(), config->plugin_path.begin(), config->plugin_path.end());
  }
  auto loader = visnav::PluginLoader::with_default_path(dirs);
  if (auto st = loader.scan(); !st) {
    std::cerr << "visnav plugins: " << st.error().message << "\n";
    return 1;
  }
  visnav::StderrLogger logger(visnav::LogLevel::warn);
  visnav::WallClock clock;
  visnav::RuntimeHost host(loader, logger, clock);
  std::cout << "search path:\n";
  for (const auto& d : loader.search_dirs()) std::cout << "  " << d << "\n";
  const auto libraries = loader.libraries();
  std::cout << "\n" << libraries.size() << (libraries.size() == 1 ? " plugin" : " plugins") << ":\n";
  for (const auto* lib : libraries) {
    std::cout << "  " << lib->kinds_text() << "  " << lib->name << " " << lib->version << "  (ABI "
              << lib->abi_version << ")  " << lib->path << "\n";
    if (!lib->description.empty()) std::cout << "      " << lib->description << "\n";
    for (const auto& t : lib->types) {
      std::string description;
      for (const auto& info : loader.types())
        if (info.library_path == lib->path && info.kind == t.kind && info.type_name == t.name)
          description = info.description;
      std::cout << "      " << visnav::to_string(t.kind) << " type " << t.name
                << (description.empty() ? "" : "  — " + description) << "\n";
      if (a.has("--params")) {
        auto docs = loader.param_docs(t.kind, t.name, lib->path);
        if (!docs) {
          std::cout << "        (params unavailable: " << docs.error().message << ")\n";
          continue;
        }
        if (docs->empty()) std::cout << "        (no parameters)\n";
        for (const auto& d : *docs) {
          std::cout << "        " << d.name << " : " << d.type << " = " << (d.default_value.empty() ? "\"\"" : d.default_value);
          if (!d.constraint.empty()) std::cout << "  " << d.constraint;
          if (!d.description.empty()) std::cout << "  — " << d.description;
          std::cout << "\n";
        }
      }
    }
    if (lib->provides(visnav::PluginKind::nodes)) {
      // Register into a scratch registry to list the node IDs this library provides.
      for (const auto& np : loader.nodes_plugins()) {
        if (np.library != lib) continue;
        visnav::bt::NodeRegistry scratch;
        visnav::Status st = visnav::ok();
        try {
          st = np.register_nodes(scratch, host);
        } catch (...) {
          st = visnav::fail("registrar threw an exception");
        }
        if (!st) {
          std::cout << "      (nodes unavailable: " << st.error().message << ")\n";
          continue;
        }
        for (const auto* m : scratch.manifests()) std::cout << "      node " << m->id << "\n";
      }
    }
    for (const auto& c : lib->command_names) std::cout << "      command visnav " << c << "\n";
  }
  if (!loader.problems().empty()) {
    std::cout << "\nnot used:\n";
    for (const auto& p : loader.problems()) std::cout << "  " << p.path << ": " << p.message << "\n";
  }
  return 0;
}

}  // namespace

VISNAV_COMMAND(plugins, "plugins", "list plugin libraries: kind, types, ABI, path (--params: parameters)", kUsage, &run)
