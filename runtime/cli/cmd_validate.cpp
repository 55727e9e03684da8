// `visnav validate`: every check `visnav run` makes before its first tick, without running anything.
#include <iostream>

#include "args.hpp"
#include "command.hpp"
#include "visnav/runner.hpp"

namespace {

constexpr const char* kUsage =
    "usage: visnav validate --config C [--tree T] [--map M] [--set key.path=value]... [--bb key=value]...\n"
    "                       [--port Node.port=value]... [--plugin-path DIR]...\n"
    "\n"
    "Makes exactly the checks `visnav run` makes before its first tick (the same code), without\n"
    "creating any robot, camera or detector:\n"
    "  * the YAML syntax and structure of C (unknown keys, the run: and dds: blocks),\n"
    "  * that a plugin provides each robot/camera/detector type, and each params block through the\n"
    "    type's own schema and validate() (types, ranges, cross-field rules such as\n"
    "    min_threshold <= max_threshold), including files the params name (a simulated world:\n"
    "    is opened and parsed),\n"
    "  * that the nodes plugins register, and the tree T against the registered node types:\n"
    "    structure, ports, and every literal port value against its type and range (built-in\n"
    "    nodes too: <Sleep msec=\"-5\"/>); each --bb value is checked by the ports that read its\n"
    "    key, as `visnav run --bb` would give it (a route_file is opened and parsed); each --port\n"
    "    override is applied first, as `visnav run --port` would,\n"
    "  * with --map: that the map opens and every edge payload reads and passes its check\n"
    "    (a bare name M is maps/M, as for `visnav run`).\n"
    "Prints every problem as `file:line: message [code]` (codes: docs/errors.md) and exits 1 if\n"
    "there is any, 0 otherwise.\n"
    "Plugins are loaded to call their parameter checks, which runs their constructors: each\n"
    "library loaded from the config's plugin_path is named in a warning, as is a plugin_path folder\n"
    "that does not exist (the build and install plugin folders are trusted).\n";

int run(const std::vector<std::string>& args) {
  using visnav::cli::Opt;
  visnav::cli::Args a;
  if (auto st = a.parse(args, {{"--config", Opt::value}, {"--tree", Opt::value}, {"--map", Opt::value},
                               {"--set", Opt::repeated}, {"--bb", Opt::repeated}, {"--port", Opt::repeated}, {"--plugin-path", Opt::repeated}});
      !st)
    return visnav::cli::usage_error("validate", st.error().message);
  if (auto st = a.require({"--config"}); !st) return visnav::cli::usage_error("validate", st.error().message);

  visnav::SetupCheck setup;
  setup.config_file = a.get("--config");
  setup.overrides = a.all("--set");
  setup.tree_file = a.get("--tree");
  setup.map_path = a.get("--map");
  setup.blackboard_values = a.all("--bb");
  setup.port_overrides = a.all("--port");
  setup.extra_plugin_dirs = a.all("--plugin-path");
  const auto problems = visnav::check_setup(setup);
  for (const auto& p : problems) std::cerr << p.message << " [" << visnav::to_string(p.code) << "]\n";
  if (!problems.empty()) {
    std::cerr << "visnav validate: " << problems.size() << (problems.size() == 1 ? " problem" : " problems") << "\n";
    return 1;
  }
  std::cout << "visnav validate: " << a.get("--config") << (a.has("--tree") ? " and " + a.get("--tree") : std::string())
            << (a.has("--map") ? " and map " + visnav::resolve_map_path(a.get("--map")) : std::string())
            << " are valid\n";
  return 0;
}

}  // namespace

VISNAV_COMMAND(validate, "validate", "check a config, a tree and a map as `visnav run` does, listing every error with file:line", kUsage, &run)
