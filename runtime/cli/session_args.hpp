// The session of a command that builds one from its own options (`visnav play`, `visnav record`):
// the run config with overrides, then --log-level, --plugin-path, --map (a bare name is
// maps/NAME) and --create applied the same way for each.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "args.hpp"
#include "visnav/result.hpp"
#include "visnav/runner.hpp"

namespace visnav::cli {

/// Loads `config_file` with `overrides` and creates the session the options ask for. A bad
/// --log-level is an error with code invalid_value (a usage error); every other error comes from
/// the config or the session (file:line included).
[[nodiscard]] Result<std::unique_ptr<Session>> open_session(const Args& a, const std::string& config_file,
                                                            const std::vector<std::string>& overrides);

}  // namespace visnav::cli
