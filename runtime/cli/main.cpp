// `visnav` entry point: dispatches to the built-in subcommands registered with
// VISNAV_COMMAND (one cli/cmd_*.cpp each); a name that is not built in is looked up among
// the commands contributed by plugins (CommandEntry) on the default search path
// (build dir, install dir, VISNAV_PLUGIN_PATH).
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "command.hpp"
#include "visnav/loader.hpp"
#include "visnav/runtime_host.hpp"
#include "visnav/version.hpp"

namespace visnav::cli {

namespace {
std::vector<Command>& mutable_commands() {
  static std::vector<Command> all;
  return all;
}
}  // namespace

CommandRegistrar::CommandRegistrar(const Command& command) {
  auto& all = mutable_commands();
  all.push_back(command);
  std::sort(all.begin(), all.end(), [](const Command& a, const Command& b) { return std::string(a.name) < b.name; });
}

const std::vector<Command>& commands() { return mutable_commands(); }

bool wants_help(const std::vector<std::string>& args) {
  return std::any_of(args.begin(), args.end(), [](const std::string& a) { return a == "-h" || a == "--help"; });
}

}  // namespace visnav::cli

namespace {

void print_help(const visnav::PluginLoader& loader) {
  std::cout << "visnav " << visnav::runtime_version()
            << " — monocular visual teach-and-repeat navigation\n\n"
               "usage: visnav <command> [options]\n       visnav <command> --help\n       visnav --version\n\n"
               "commands:\n";
  for (const auto& c : visnav::cli::commands()) {
    std::printf("  %-12s %s\n", c.name, c.summary);
  }
  const auto plugin_commands = loader.commands();
  if (!plugin_commands.empty()) {
    std::cout << "\ncommands from plugins:\n";
    for (const auto& c : plugin_commands) std::printf("  %-12s %s\n", c.name.c_str(), c.summary.c_str());
  }
}

}  // namespace

int visnav::cli::run_plugin_command(const visnav::PluginCommandInfo& command, std::vector<std::string> args,
                                   visnav::PluginLoader& loader) {
  visnav::StderrLogger logger(visnav::LogLevel::info);
  visnav::WallClock clock;
  visnav::RuntimeHost host(loader, logger, clock);
  args.insert(args.begin(), command.name);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::fflush(stdout);
  try {
    const int rc = command.run(static_cast<int>(args.size()), argv.data(), host);
    std::fflush(stdout);
    return rc;
  } catch (const std::exception& e) {
    std::cerr << "visnav " << command.name << ": the plugin command threw an exception: " << e.what() << " ("
              << command.library_path << ")\n";
  } catch (...) {
    std::cerr << "visnav " << command.name << ": the plugin command threw (" << command.library_path << ")\n";
  }
  return 1;
}

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "-h" || args[0] == "--help" || args[0] == "help") {
    if (args.size() >= 2 && args[0] == "help") {  // `visnav help run` == `visnav run --help`
      args = {args[1], "--help"};
    } else {
      auto loader = visnav::PluginLoader::with_default_path();
      (void)loader.scan();
      print_help(loader);
      return args.empty() ? 2 : 0;
    }
  }
  if (args[0] == "--version" || args[0] == "-V") {
    std::cout << "visnav " << visnav::runtime_version() << "\n";
    return 0;
  }
  const std::string name = args[0];
  args.erase(args.begin());
  for (const auto& c : visnav::cli::commands()) {
    if (name == c.name) {
      if (visnav::cli::wants_help(args)) {
        std::cout << c.usage;
        return 0;
      }
      return c.run(args);
    }
  }
  // Not built in: look for a plugin command (libraries are only loaded here, when needed).
  auto loader = visnav::PluginLoader::with_default_path();
  if (auto scanned = loader.scan(); !scanned) {
    std::cerr << "visnav: " << scanned.error().message << "\n";
    return 2;
  }
  for (const auto& c : loader.commands()) {
    if (c.name == name) return visnav::cli::run_plugin_command(c, std::move(args), loader);
  }
  std::cerr << "visnav: unknown command '" << name << "' (see 'visnav --help'; plugin commands are searched in: ";
  for (std::size_t i = 0; i < loader.search_dirs().size(); ++i) std::cerr << (i ? ", " : "") << loader.search_dirs()[i];
  std::cerr << ")\n";
  return 2;
}
