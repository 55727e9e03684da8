// Small option parser shared by the built-in subcommands.
//   Args a;
//   if (!a.parse(args, {{"--config", Opt::value}, {"--set", Opt::repeated}, {"--xml", Opt::flag}})) ...
// Accepts "--name value" and "--name=value". Positional arguments are errors unless allowed.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "visnav/result.hpp"

namespace visnav::cli {

enum class Opt { flag, value, repeated };

class Args {
 public:
  /// Parses `args` against `spec`; the error names the offending argument.
  Status parse(const std::vector<std::string>& args, const std::map<std::string, Opt>& spec);

  [[nodiscard]] bool has(const std::string& name) const { return values_.count(name) != 0; }
  /// Last value of an option, or `fallback`.
  [[nodiscard]] std::string get(const std::string& name, const std::string& fallback = {}) const;
  /// All values of a repeated option, in order.
  [[nodiscard]] std::vector<std::string> all(const std::string& name) const;
  /// Error unless every name in `names` was given.
  Status require(const std::vector<std::string>& names) const;

 private:
  std::map<std::string, std::vector<std::string>> values_;
};

/// Prints "visnav <command>: <message>" and the usage hint to stderr; returns 2.
int usage_error(const char* command, const std::string& message);

}  // namespace visnav::cli
