#include "session_args.hpp"

#include "visnav/config.hpp"
#include "visnav/runtime_host.hpp"

namespace visnav::cli {

Result<std::unique_ptr<Session>> open_session(const Args& a, const std::string& config_file,
                                              const std::vector<std::string>& overrides) {
  VISNAV_ASSIGN(RunConfig config, load_run_config(config_file, overrides));
  if (a.has("--log-level")) {
    if (auto level = parse_log_level(a.get("--log-level")); !level)
      return Error{level.error().message, ErrorCode::invalid_value};
    config.run.log_level = a.get("--log-level");
  }
  SessionOptions so;
  so.extra_plugin_dirs = a.all("--plugin-path");
  so.map_path = resolve_map_path(a.get("--map"));
  so.create_map = a.has("--create");
  so.overrides = overrides;
  return Session::create(std::move(config), so);
}

}  // namespace visnav::cli
