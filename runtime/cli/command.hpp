// The `visnav` command registry. Each subcommand lives in its own cli/cmd_<name>.cpp and
// registers itself with VISNAV_COMMAND; main.cpp dispatches. Plugins may contribute
// further subcommands through their descriptor (CommandEntry); main.cpp looks those up
// when no built-in command matches.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace visnav {
struct PluginCommandInfo;
class PluginLoader;
}  // namespace visnav

namespace visnav::cli {

struct Command {
  const char* name;
  const char* summary;  ///< one line for `visnav --help`
  const char* usage;    ///< full text for `visnav <name> --help`
  int (*run)(const std::vector<std::string>& args);  ///< args exclude the command name
};

/// All built-in commands, sorted by name.
const std::vector<Command>& commands();

struct CommandRegistrar {
  explicit CommandRegistrar(const Command& command);
};

/// True if `args` contains -h or --help.
bool wants_help(const std::vector<std::string>& args);

/// Runs a plugin-contributed command with `args` (argv[0] becomes its name) on a host of its own;
/// stdout is flushed around it so its output and ours keep their order. An exception is the
/// command's failure (exit status 1, reported on stderr with the library that threw).
int run_plugin_command(const PluginCommandInfo& command, std::vector<std::string> args, PluginLoader& loader);

}  // namespace visnav::cli

#define VISNAV_COMMAND(ident, name, summary, usage, fn) \
  static const ::visnav::cli::CommandRegistrar visnav_command_##ident{::visnav::cli::Command{name, summary, usage, fn}};
