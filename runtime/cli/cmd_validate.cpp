// `visnav validate`: check a config and a tree without running anything.
#include <iostream>

#include "args.hpp"
#include "command.hpp"
#include "visnav/runner.hpp"

namespace {

constexpr const char* kUsage =
    "usage: visnav validate --config C [--tree T] [--set key.path=value]... [--plugin-path DIR]...\n"
    "\n"
    "Checks, without creating any robot, camera or detector:\n"
    "  * the YAML syntax and structure of C (unknown keys, the run: block),\n"
    "  * that a plugin provides each robot/camera/detector type, and each params block against\n"
    "    the type's declared parameters (unknown keys, types, ranges),\n"
    "  * that the nodes plugins register, and the tree T against the registered node types.\n"
    "Prints every problem as file:line: message and exits 1 if there is any, 0 otherwise.\n"
    "Plugins are loaded to read their parameter declarations, which runs their constructors: each\n"
    "library loaded from the config's plugin_path is named in a warning, as is a plugin_path folder\n"
    "that does not exist (the build and install plugin folders are trusted).\n";

int run(const std::vector<std::string>& args) {
  using visnav::cli::Opt;
  visnav::cli::Args a;
  if (auto st = a.parse(args, {{"--config", Opt::value}, {"--tree", Opt::value}, {"--set", Opt::repeated},
                               {"--plugin-path", Opt::repeated}});
      !st)
    return visnav::cli::usage_error("validate", st.error().message);
  if (auto st = a.require({"--config"}); !st) return visnav::cli::usage_error("validate", st.error().message);

  const auto problems =
      visnav::validate_setup(a.get("--config"), a.all("--set"), a.get("--tree"), a.all("--plugin-path"));
  for (const auto& p : problems) std::cerr << p << "\n";
  if (!problems.empty()) {
    std::cerr << "visnav validate: " << problems.size() << (problems.size() == 1 ? " problem" : " problems") << "\n";
    return 1;
  }
  std::cout << "visnav validate: " << a.get("--config") << (a.has("--tree") ? " and " + a.get("--tree") : std::string())
            << " are valid\n";
  return 0;
}

}  // namespace

VISNAV_COMMAND(validate, "validate", "check a config and a tree, listing every error with file:line", kUsage, &run)
