// The run configuration: top-level sections, plugin specs, the `run:` block, and the
// doc-based parameter check used by `visnav validate`.
#include <algorithm>
#include <filesystem>
#include <sstream>

#include "visnav/config.hpp"

namespace visnav {

namespace {

std::string join_lines(const std::vector<Error>& errors) {
  std::string out;
  for (const auto& e : errors) out += (out.empty() ? "" : "\n") + e.message;
  return out;
}

/// One run-config problem: the message starts with the location, as every config error does.
Error problem(ErrorCode code, const SourceLocation& at, std::string key, const std::string& text) {
  return Error{at.str() + ": " + text, code, {at.file, at.line, std::move(key)}};
}

/// A nested parser's error (possibly several lines) as one problem of `section`.
Error nested(const Error& e, const SourceLocation& at, const std::string& section) {
  return Error{e.message, e.with_default_code(ErrorCode::invalid_value).code,
               e.where.empty() ? ErrorLocation{at.file, at.line, section} : e.where};
}

std::string key_list(std::initializer_list<const char*> keys) {
  std::string out;
  for (const char* k : keys) out += (out.empty() ? "" : ", ") + std::string(k);
  return out;
}

/// Parses `robot: {type: ..., plugin: ..., params: {...}}`, appending problems to `errors`.
std::optional<PluginSpec> parse_spec(const ConfigNode& node, const std::string& section, std::vector<Error>& errors) {
  if (!node.is_map()) {
    errors.push_back(problem(ErrorCode::invalid_value, node.where(), section,
                             "'" + section + "' must be a map with 'type' (and optional 'plugin', 'params')"));
    return std::nullopt;
  }
  PluginSpec spec;
  spec.where = node.where();
  bool good = true;
  for (const auto& [key, value] : node.entries()) {
    if (key == "type") {
      if (!value.is_scalar() || value.scalar().empty()) {
        errors.push_back(problem(ErrorCode::invalid_value, value.where(), section + ".type",
                                 section + ".type must be a type name, e.g. 'sim'"));
        good = false;
      } else {
        spec.type = value.scalar();
      }
    } else if (key == "plugin") {
      if (!value.is_scalar() || value.scalar().empty()) {
        errors.push_back(problem(ErrorCode::invalid_value, value.where(), section + ".plugin",
                                 section + ".plugin must be a library name or path"));
        good = false;
      } else {
        spec.plugin = value.scalar();
      }
    } else if (key == "params") {
      if (!value.is_map() && !value.is_null()) {
        errors.push_back(problem(ErrorCode::invalid_value, value.where(), section + ".params", section + ".params must be a map"));
        good = false;
      } else {
        spec.params = value;
      }
    } else {
      errors.push_back(problem(ErrorCode::unknown_key, value.where(), section + "." + key,
                               "unknown key '" + key + "' in '" + section + "' (known keys: " +
                                   key_list({"type", "plugin", "params"}) + ")"));
      good = false;
    }
  }
  if (spec.type.empty() && node.find("type") == nullptr) {
    errors.push_back(problem(ErrorCode::missing, node.where(), section + ".type", "'" + section + "' has no 'type'"));
    good = false;
  }
  if (spec.params.is_null()) spec.params.set_where(node.where());
  if (!good) return std::nullopt;
  return spec;
}

std::vector<std::string> string_list(const ConfigNode& node, const std::string& key, std::vector<Error>& errors) {
  std::vector<std::string> out;
  if (node.is_null()) return out;
  if (node.is_scalar()) {
    out.push_back(node.scalar());
    return out;
  }
  if (!node.is_sequence()) {
    errors.push_back(problem(ErrorCode::invalid_value, node.where(), key, "'" + key + "' must be a list of names"));
    return out;
  }
  for (const auto& item : node.items()) {
    if (!item.is_scalar() || item.scalar().empty()) {
      errors.push_back(problem(ErrorCode::invalid_value, item.where(), key, "'" + key + "' entries must be non-empty names"));
      continue;
    }
    out.push_back(item.scalar());
  }
  return out;
}

}  // namespace

Status RunSettings::validate() const {
  // Every rule is a per-field range or choice (see schema()); no rule couples two fields.
  return ok();
}

const ParamSchema<RunSettings>& RunSettings::schema() {
  static const auto s =
      ParamSchema<RunSettings>{}
          .field("tick", &RunSettings::tick, "frame: one tick per new camera frame; rate: ticks at rate_hz")
          .one_of({"frame", "rate"})
          .field("rate_hz", &RunSettings::rate_hz, "tick rate (tick: rate), tick budget for overrun detection, lock-step period")
          .range(0.1, 1000.0)
          .field("max_frame_age_s", &RunSettings::max_frame_age_s, "newest camera frame older than this stops the robot")
          .range(0.001, 60.0)
          .field("max_odometry_age_s", &RunSettings::max_odometry_age_s, "newest odometry older than this stops the robot")
          .range(0.001, 60.0)
          .field("startup_timeout_s", &RunSettings::startup_timeout_s, "wait this long for the first frame and odometry")
          .range(0.0, 600.0)
          .field("max_duration_s", &RunSettings::max_duration_s, "end the run with failure after this long (run clock); 0 = no limit")
          .range(0.0, 1e7)
          .field("lockstep", &RunSettings::lockstep, "auto: lock-step when the robot is simulated; on; off")
          .one_of({"auto", "on", "off"})
          .field("trace_file", &RunSettings::trace_file, "behaviour-tree status transitions as JSON lines; empty = off")
          .field("telemetry_file", &RunSettings::telemetry_file, "NavStatus per tick as JSON lines; empty = off")
          .field("log_level", &RunSettings::log_level, "lowest level logged to stderr")
          .one_of({"debug", "info", "warn", "error"})
          .field("reload_poll_s", &RunSettings::reload_poll_s, "config file change poll interval (wall time); 0 = no live reload")
          .range(0.0, 3600.0)
          .field("odometry_max_speed_mps", &RunSettings::odometry_max_speed_mps,
                 "odometry moving faster than this between two readings (plus the slack) is implausible: safety stop")
          .range(0.01, 100.0)
          .field("odometry_jump_slack_m", &RunSettings::odometry_jump_slack_m,
                 "allowed on top of odometry_max_speed_mps x dt between two readings (noise, latency)")
          .range(0.0, 100.0)
          .field("bt_max_subtree_depth", &RunSettings::bt_max_subtree_depth, "deepest SubTree nesting a behaviour tree may use")
          .range(1, 100000)
          .field("bt_max_nodes", &RunSettings::bt_max_nodes, "nodes a behaviour tree may instantiate, SubTrees expanded")
          .range(1, 10000000)
          .field("bt_max_tree_depth", &RunSettings::bt_max_tree_depth, "deepest behaviour-tree node, counted through SubTrees")
          .range(2, 10000000)
          .field("view_port", &RunSettings::view_port,
                 "visnav run: serve the live view (Foxglove WebSocket) on this port, as --view; 0 = off")
          .range(0, 65535)
          .field("bag_image_topic", &RunSettings::bag_image_topic,
                 "MCAP bag of a ROS 2 robot: topic of the images (sensor_msgs Image or CompressedImage), as --image-topic")
          .field("bag_odom_topic", &RunSettings::bag_odom_topic,
                 "MCAP bag of a ROS 2 robot: topic of nav_msgs/Odometry, as --odom-topic")
          .field("bag_joy_topic", &RunSettings::bag_joy_topic,
                 "teach --run from an MCAP bag: primitive switches from this sensor_msgs/Joy topic, as --joy-topic; empty = off");
  return s;
}

std::vector<ParamDoc> DdsSettings::docs() {
  std::vector<ParamDoc> out = {
      {"enabled", "bool", "true", "false: ignore the block (no DDS endpoints are created)", ""},
      {"telemetry", "bool", "true", "publish every NavStatus on telemetry_topic", ""},
      {"control", "bool", "true", "obey pause/resume/abort/swap_detector requests on control_topic", ""},
  };
  for (auto& d : dds::TelemetryParams::schema().docs()) out.push_back(std::move(d));
  return out;
}

namespace {

/// The `dds.security` block: five file paths, relative ones resolved against the folder of the
/// file that names them. Files are checked when the run starts (SecurityFiles::validate).
/// Problems are appended to `errors`, each with its code and the key's location.
dds::SecurityFiles parse_security_block(const ConfigNode& node, std::vector<Error>& errors) {
  dds::SecurityFiles files;
  if (node.is_scalar() && !node.scalar().empty()) {
    // One key: an identity folder of a keystore made by `visnav security init DIR` (DIR/<identity>);
    // the CA and the governance are the keystore's, one folder up.
    std::filesystem::path identity(node.scalar());
    const std::string& file = node.where().file;
    if (identity.is_relative() && !file.empty() && file.rfind("--set", 0) != 0)
      identity = std::filesystem::path(file).parent_path() / identity;
    identity = identity.lexically_normal();
    if (!identity.has_filename()) identity = identity.parent_path();  // "keys/r1-mission/"
    const std::filesystem::path keystore = identity.parent_path();
    files.ca = (keystore / "ca.pem").string();
    files.governance = (keystore / "governance.p7s").string();
    files.identity_cert = (identity / "cert.pem").string();
    files.private_key = (identity / "key.pem").string();
    files.permissions = (identity / "permissions.p7s").string();
    return files;
  }
  if (!node.is_map()) {
    errors.push_back(problem(ErrorCode::invalid_value, node.where(), "dds.security",
                             "'dds.security' must be an identity folder of a keystore (visnav security init DIR: "
                             "DIR/<identity>) or a map with keys ca, identity_cert, private_key, governance, permissions"));
    return files;
  }
  std::pair<const char*, std::string*> keys[] = {{"ca", &files.ca},
                                                 {"identity_cert", &files.identity_cert},
                                                 {"private_key", &files.private_key},
                                                 {"governance", &files.governance},
                                                 {"permissions", &files.permissions}};
  for (const auto& [key, value] : node.entries()) {
    std::string* target = nullptr;
    for (auto& [name, field] : keys)
      if (key == name) target = field;
    if (target == nullptr) {
      errors.push_back(problem(ErrorCode::unknown_key, value.where(), "dds.security." + key,
                               "unknown key '" + key +
                                   "' in 'dds.security' (known keys: ca, identity_cert, private_key, governance, permissions)"));
      continue;
    }
    if (!value.is_scalar() || value.scalar().empty()) {
      errors.push_back(problem(ErrorCode::invalid_value, value.where(), "dds.security." + key,
                               "key '" + key + "' in 'dds.security': expected a file path"));
      continue;
    }
    std::filesystem::path p(value.scalar());
    const std::string& file = value.where().file;
    if (p.is_relative() && !file.empty() && file.rfind("--set", 0) != 0)
      p = std::filesystem::path(file).parent_path() / p;
    *target = p.lexically_normal().string();
  }
  for (const auto& [name, field] : keys)
    if (field->empty())
      errors.push_back(problem(ErrorCode::missing, node.where(), std::string("dds.security.") + name,
                               "'dds.security': missing key '" + std::string(name) + "'"));
  return files;
}

/// A `dds:` endpoint parameter's error (the schema names the file, line and key) keyed under `dds.`.
Error dds_endpoint_problem(Error e) {
  e.where.key = e.where.key.empty() ? "dds" : "dds." + e.where.key;
  e.message += " (in 'dds')";
  return e;
}

}  // namespace

Result<DdsSettings> parse_dds_settings(const ConfigNode& node) {
  DdsSettings settings;
  settings.enabled = true;
  settings.where = node.where();
  if (node.is_null()) return settings;
  if (!node.is_map())
    return problem(ErrorCode::invalid_value, node.where(), "dds",
                   "'dds' must be a map (keys: enabled, telemetry, control, security, domain_id, partition, "
                   "telemetry_topic, control_topic)");
  ConfigNode endpoints = ConfigNode::make_map(node.where());
  std::vector<Error> errors;
  for (const auto& [key, value] : node.entries()) {
    if (key == "security") {
      settings.security = parse_security_block(value, errors);
      continue;
    }
    bool* flag = key == "enabled" ? &settings.enabled
                 : key == "telemetry" ? &settings.telemetry
                 : key == "control" ? &settings.control
                                    : nullptr;
    if (flag == nullptr) {
      endpoints.set(key, value);
      continue;
    }
    auto parsed = value.is_scalar() ? detail::parse_bool(value.scalar()) : Result<bool>(fail("expected true or false"));
    if (!parsed) {
      errors.push_back(problem(ErrorCode::invalid_value, value.where(), "dds." + key,
                               "key '" + key + "': " + parsed.error().message + " (in 'dds')"));
      continue;
    }
    *flag = *parsed;
  }
  for (const auto& [key, value] : endpoints.entries()) {
    const auto docs = dds::TelemetryParams::schema().docs();
    const std::string& name = key;  // (clang 14 cannot capture a structured binding)
    const bool known = std::any_of(docs.begin(), docs.end(), [&name](const ParamDoc& d) { return d.name == name; });
    if (!known)
      errors.push_back(problem(ErrorCode::unknown_key, value.where(), "dds." + key,
                               "unknown key '" + key + "' in 'dds' (known keys: " +
                                   key_list({"enabled", "telemetry", "control", "security", "domain_id", "partition",
                                             "telemetry_topic", "control_topic"}) +
                                   ")"));
  }
  if (!errors.empty()) return Error{join_lines(errors), errors.front().code, errors.front().where};
  auto endpoints_parsed = dds::TelemetryParams::schema().parse(endpoints);
  if (!endpoints_parsed) return dds_endpoint_problem(endpoints_parsed.error());
  settings.endpoints = std::move(endpoints_parsed).value();
  return settings;
}

namespace {

/// parse_run_config, collecting every problem in `errors`.
RunConfig parse_run_config_into(const ConfigNode& root, const std::string& file, std::vector<Error>& errors) {
  RunConfig config;
  config.file = file;
  config.root = root;
  const std::string where_file = file.empty() ? root.where().str() : file;

  if (!root.is_map()) {
    errors.push_back(Error{where_file + ": a run config must be a map with the sections robot, camera, detector, nodes, run, "
                           "plugin_path, dds",
                           ErrorCode::invalid_value, {file, root.where().line, {}}});
    return config;
  }

  bool have_robot = false;
  bool have_camera = false;
  for (const auto& [key, value] : root.entries()) {
    if (key == "robot") {
      have_robot = true;
      if (auto spec = parse_spec(value, key, errors)) config.robot = std::move(*spec);
    } else if (key == "camera") {
      have_camera = true;
      if (auto spec = parse_spec(value, key, errors)) config.camera = std::move(*spec);
    } else if (key == "detector") {
      if (auto spec = parse_spec(value, key, errors)) config.detector = std::move(*spec);
    } else if (key == "nodes") {
      config.nodes = string_list(value, key, errors);
    } else if (key == "plugin_path") {
      const std::filesystem::path base = file.empty() ? std::filesystem::path{} : std::filesystem::path(file).parent_path();
      for (const auto& dir : string_list(value, key, errors)) {
        std::filesystem::path p(dir);
        config.plugin_path.push_back(p.is_absolute() || base.empty() ? p.string() : (base / p).string());
      }
    } else if (key == "run") {
      if (!value.is_map() && !value.is_null()) {
        errors.push_back(problem(ErrorCode::invalid_value, value.where(), "run", "'run' must be a map"));
        continue;
      }
      // Parse entry by entry so every bad key is reported, not just the first.
      for (const auto& [run_key, run_value] : value.entries()) {
        ConfigNode single = ConfigNode::make_map(value.where());
        single.set(run_key, run_value);
        auto parsed = RunSettings::schema().parse(single, config.run);
        if (!parsed) {
          Error e = parsed.error();
          e.message += " (in 'run')";
          if (!e.where.key.empty()) e.where.key = "run." + e.where.key;
          errors.push_back(std::move(e));
          continue;
        }
        config.run = std::move(parsed).value();
      }
      auto valid = config.run.validate();
      if (!valid)
        errors.push_back(problem(valid.error().with_default_code(ErrorCode::inconsistent).code, value.where(), "run",
                                 valid.error().message));
    } else if (key == "dds") {
      auto parsed = parse_dds_settings(value);
      if (!parsed) {
        errors.push_back(nested(parsed.error(), value.where(), "dds"));
        continue;
      }
      config.dds = std::move(parsed).value();
    } else {
      errors.push_back(problem(ErrorCode::unknown_key, value.where(), key,
                               "unknown top-level key '" + key + "' (known keys: " +
                                   key_list({"robot", "camera", "detector", "nodes", "run", "plugin_path", "dds"}) + ")"));
    }
  }
  if (!have_robot)
    errors.push_back(Error{where_file + ": missing section 'robot' (e.g. robot: {type: sim})", ErrorCode::missing,
                           {file, 0, "robot"}});
  if (!have_camera)
    errors.push_back(Error{where_file + ": missing section 'camera' (e.g. camera: {type: sim})", ErrorCode::missing,
                           {file, 0, "camera"}});
  return config;
}

}  // namespace

Result<RunConfig> parse_run_config(const ConfigNode& root, const std::string& file) {
  std::vector<Error> errors;
  RunConfig config = parse_run_config_into(root, file, errors);
  if (!errors.empty()) return Error{join_lines(errors), errors.front().code, errors.front().where};
  return config;
}

std::vector<Error> run_config_problems(const ConfigNode& root, const std::string& file, RunConfig* config) {
  std::vector<Error> errors;
  RunConfig parsed = parse_run_config_into(root, file, errors);
  if (config != nullptr) *config = std::move(parsed);
  return errors;
}


Result<RunConfig> load_run_config(const std::string& path, const std::vector<std::string>& overrides) {
  VISNAV_ASSIGN(ConfigNode root, parse_yaml_file(path));
  for (const auto& o : overrides) VISNAV_TRY(apply_override(root, o));
  return parse_run_config(root, path);
}

namespace {

std::optional<std::pair<double, double>> parse_range(const std::string& constraint) {
  if (constraint.size() < 5 || constraint.front() != '[' || constraint.back() != ']') return std::nullopt;
  const auto comma = constraint.find(',');
  if (comma == std::string::npos) return std::nullopt;
  auto lo = detail::parse_double(constraint.substr(1, comma - 1));
  std::string hi_text = constraint.substr(comma + 1, constraint.size() - comma - 2);
  while (!hi_text.empty() && hi_text.front() == ' ') hi_text.erase(hi_text.begin());
  auto hi = detail::parse_double(hi_text);
  if (!lo || !hi) return std::nullopt;
  return std::make_pair(*lo, *hi);
}

std::vector<std::string> parse_one_of(const std::string& constraint) {
  const std::string prefix = "one of:";
  std::vector<std::string> out;
  if (constraint.rfind(prefix, 0) != 0) return out;
  std::istringstream in(constraint.substr(prefix.size()));
  std::string word;
  while (in >> word) out.push_back(word);
  return out;
}

/// Checks one value against its doc; returns the problem or an empty string.
std::string check_value(const ConfigNode& value, const ParamDoc& doc) {
  std::vector<std::string> texts;
  const bool is_list = doc.type.rfind("list<", 0) == 0;
  if (is_list) {
    if (value.is_sequence()) {
      for (const auto& item : value.items()) {
        if (!item.is_scalar()) return "expected a list of scalars";
        texts.push_back(item.scalar());
      }
    } else if (value.is_scalar()) {
      texts = detail::split_list(value.scalar());
    } else {
      return "expected a list";
    }
  } else {
    if (!value.is_scalar()) return "expected a scalar of type " + doc.type;
    texts.push_back(value.scalar());
  }
  for (const auto& t : texts) {
    if (doc.type == "int") {
      if (auto v = detail::parse_int(t); !v) return v.error().message;
    } else if (doc.type == "double" || doc.type == "list<double>") {
      if (auto v = detail::parse_double(t); !v) return v.error().message;
    } else if (doc.type == "bool") {
      if (auto v = detail::parse_bool(t); !v) return v.error().message;
    }
    if (auto range = parse_range(doc.constraint)) {
      auto v = detail::parse_double(t);
      if (v && (*v < range->first || *v > range->second)) return "value " + t + " is out of range " + doc.constraint;
    }
    const auto allowed = parse_one_of(doc.constraint);
    if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), t) == allowed.end())
      return "value '" + t + "' is not " + doc.constraint;
  }
  return {};
}

}  // namespace

std::vector<std::string> check_params_against_docs(const ConfigNode& params, const std::vector<ParamDoc>& docs,
                                                   const std::string& section) {
  std::vector<std::string> problems;
  if (params.is_null()) return problems;
  if (!params.is_map()) {
    problems.push_back(params.where().str() + ": " + section + ".params must be a map");
    return problems;
  }
  for (const auto& [key, value] : params.entries()) {
    const ParamDoc* doc = nullptr;
    for (const auto& d : docs)
      if (d.name == key) doc = &d;
    if (doc == nullptr) {
      std::string known;
      for (const auto& d : docs) known += (known.empty() ? "" : ", ") + d.name;
      problems.push_back(value.where().str() + ": unknown key '" + key + "' in " + section + ".params (known keys: " +
                         (known.empty() ? std::string("none") : known) + ")");
      continue;
    }
    const std::string problem = check_value(value, *doc);
    if (!problem.empty()) problems.push_back(value.where().str() + ": key '" + key + "' in " + section + ".params: " + problem);
  }
  return problems;
}

}  // namespace visnav
