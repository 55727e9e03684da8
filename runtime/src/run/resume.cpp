// `visnav run --resume`: the progress checkpoint of a map folder as blackboard assignments.
// The runtime does not interpret the entries (it stays primitive-agnostic): whatever node wrote
// the checkpoint (FollowRoute checkpoint="true") and whatever tree reads it agree on the keys.
#include <filesystem>

#include "visnav/config_node.hpp"
#include "visnav/runner.hpp"

namespace visnav {

Result<std::vector<std::string>> progress_checkpoint_values(const std::string& map_dir) {
  const std::string path = (std::filesystem::path(map_dir) / "progress.yaml").string();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    return fail(ErrorCode::not_found, path + ": no progress checkpoint to resume from (the last run finished its "
                                             "route, or its tree keeps none: FollowRoute checkpoint=\"true\")");
  VISNAV_ASSIGN(ConfigNode root, parse_yaml_file(path));
  if (!root.is_map()) return fail(ErrorCode::parse_error, {path, 0, ""}, "a progress checkpoint is a map of key: value");
  std::vector<std::string> values;
  for (const auto& [key, value] : root.entries()) {
    if (!value.is_scalar())
      return fail(ErrorCode::invalid_value, {path, value.where().line, key}, "a checkpoint value must be a scalar");
    values.push_back(key + "=" + value.scalar());
  }
  values.emplace_back("resume=true");
  return values;
}

}  // namespace visnav
