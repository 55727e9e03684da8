// `visnav` entry point: dispatches to the built-in subcommands registered with
// VISNAV_COMMAND (one cli/cmd_*.cpp each).
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "command.hpp"
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
void print_help() {
  std::cout << "visnav " << visnav::runtime_version()
            << " — monocular visual teach-and-repeat navigation\n\n"
               "usage: visnav <command> [options]\n       visnav <command> --help\n       visnav --version\n\n"
               "commands:\n";
  for (const auto& c : visnav::cli::commands()) {
    std::printf("  %-12s %s\n", c.name, c.summary);
  }
}
}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "-h" || args[0] == "--help" || args[0] == "help") {
    print_help();
    return args.empty() ? 2 : 0;
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
  std::cerr << "visnav: unknown command '" << name << "' (see 'visnav --help')\n";
  return 2;
}
