// Option parser for the subcommands (see args.hpp).
#include "args.hpp"

#include <iostream>

namespace visnav::cli {

Status Args::parse(const std::vector<std::string>& args, const std::map<std::string, Opt>& spec) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    std::string name = args[i];
    std::string value;
    bool inline_value = false;
    if (name.rfind("--", 0) == 0) {
      if (const auto eq = name.find('='); eq != std::string::npos) {
        value = name.substr(eq + 1);
        name = name.substr(0, eq);
        inline_value = true;
      }
    }
    auto it = spec.find(name);
    if (it == spec.end()) {
      if (name.rfind("-", 0) == 0) return fail("unknown option '" + name + "'");
      return fail("unexpected argument '" + name + "'");
    }
    if (it->second == Opt::flag) {
      if (inline_value) return fail("option '" + name + "' takes no value");
      values_[name].push_back("true");
      continue;
    }
    if (!inline_value) {
      if (i + 1 >= args.size()) return fail("option '" + name + "' needs a value");
      value = args[++i];
    }
    if (it->second == Opt::value) values_[name].clear();
    values_[name].push_back(value);
  }
  return ok();
}

std::string Args::get(const std::string& name, const std::string& fallback) const {
  auto it = values_.find(name);
  return it == values_.end() || it->second.empty() ? fallback : it->second.back();
}

std::vector<std::string> Args::all(const std::string& name) const {
  auto it = values_.find(name);
  return it == values_.end() ? std::vector<std::string>{} : it->second;
}

Status Args::require(const std::vector<std::string>& names) const {
  std::string missing;
  for (const auto& n : names)
    if (!has(n)) missing += (missing.empty() ? "" : ", ") + n;
  if (!missing.empty()) return fail("missing required option(s): " + missing);
  return ok();
}

int usage_error(const char* command, const std::string& message) {
  std::cerr << "visnav " << command << ": " << message << "\n(see 'visnav " << command << " --help')\n";
  return 2;
}

}  // namespace visnav::cli
