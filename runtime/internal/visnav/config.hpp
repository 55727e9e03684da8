// visnav runtime — YAML configuration: parsing with file:line, `--set` overrides and the
// run configuration (which plugins to build, their params, the tick loop settings).
//
// Keys are documented in docs/config.md. Every error names file:line and the key or value.
// Thread-safety: free functions are pure (apart from reading the named file); RunConfig is
// a value type.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "visnav/config_node.hpp"
#include "visnav/dds.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav {

/// Applies one `key.path=value` override to `root` (a map). Intermediate maps are created
/// when missing; the value is parsed as YAML (so `a=[1, 2]` gives a sequence). The new node's
/// location is `--set key.path=value`. Errors: no '=', empty key, a path through a scalar.
[[nodiscard]] Status apply_override(ConfigNode& root, std::string_view assignment);

/// One plugin object named in config: `{type: orb, plugin: detectors_opencv, params: {...}}`.
struct PluginSpec {
  std::string type;        ///< type name, e.g. "orb"
  std::string plugin;      ///< optional library pin ("detectors_opencv" or a path); empty = any
  ConfigNode params;       ///< the `params:` block (null when absent)
  SourceLocation where;    ///< location of the section
};

/// The `run:` block.
struct RunSettings {
  std::string tick = "frame";          ///< "frame": one tick per new camera frame; "rate": fixed rate
  double rate_hz = 10.0;               ///< tick rate ("rate"), tick budget and lock-step period
  double max_frame_age_s = 0.5;        ///< newest frame older than this → safety stop
  double max_odometry_age_s = 0.5;     ///< newest odometry older than this → safety stop
  double startup_timeout_s = 5.0;      ///< wait this long for the first frame and odometry
  double max_duration_s = 0.0;         ///< stop the run (failure) after this long; 0 = no limit
  std::string lockstep = "auto";       ///< "auto" (when the robot is simulated), "on", "off"
  std::string trace_file;              ///< BT status transitions as JSON lines; empty = off
  std::string telemetry_file;          ///< NavStatus per tick as JSON lines; empty = off
  std::string log_level = "info";      ///< debug, info, warn, error
  double reload_poll_s = 0.5;          ///< config file mtime poll interval (wall time); 0 = no live reload
  /// Odometry plausibility (issue 17): a reading farther from the previous one than
  /// odometry_max_speed_mps x dt + odometry_jump_slack_m, non-finite, or going back in time
  /// stops the robot (safety stop) with the reason.
  double odometry_max_speed_mps = 3.0;
  double odometry_jump_slack_m = 0.5;
  int bt_max_subtree_depth = 64;       ///< deepest SubTree nesting a tree may use (bt::LoadOptions)
  int bt_max_nodes = 100000;           ///< nodes the expanded tree may instantiate (bt::LoadOptions)
  int bt_max_tree_depth = 1000;        ///< deepest node, counted through SubTrees (bt::LoadOptions)
  /// `visnav run` live view (docs/live_view.md): serve the Foxglove WebSocket protocol on this
  /// port (as --view PORT, which wins); 0 = off. Read at start only.
  int view_port = 0;
  /// Topics of an MCAP bag recorded by a ROS 2 robot, for play / evaluate / teach --run /
  /// convert (their --image-topic / --odom-topic / --joy-topic win; docs/recorded_runs.md).
  std::string bag_image_topic = "/camera/image_raw/compressed";
  std::string bag_odom_topic = "/odom";
  std::string bag_joy_topic;           ///< teach --run: primitive buttons from this Joy topic; empty = off

  [[nodiscard]] Status validate() const;
  static const ParamSchema<RunSettings>& schema();
};

/// The optional top-level `dds:` block: telemetry and mission control of `visnav run` over
/// Cyclone DDS (docs/dds.md). Present and not `enabled: false` → `visnav run` publishes every
/// NavStatus on `endpoints.telemetry_topic` (besides `run.telemetry_file`, when set) and obeys
/// pause/resume/abort/swap_detector requests on `endpoints.control_topic`.
struct DdsSettings {
  bool enabled = false;    ///< false when the block is absent or says `enabled: false`
  bool telemetry = true;   ///< publish NavStatus on the telemetry topic
  bool control = true;     ///< subscribe the control topic
  dds::TelemetryParams endpoints;  ///< domain_id, partition, telemetry_topic, control_topic
  /// `security: {ca, identity_cert, private_key, governance, permissions}` (paths relative to
  /// the config file's folder): every DDS participant of the run (robot, camera, telemetry,
  /// control) authenticates with this identity (docs/security.md). Absent = security off.
  std::optional<dds::SecurityFiles> security;
  SourceLocation where;    ///< location of the block (for error messages)

  /// Key docs of the block (enabled, telemetry, control, then TelemetryParams' keys).
  [[nodiscard]] static std::vector<ParamDoc> docs();
};

/// Parses a `dds:` block (a map, or null = all defaults, enabled). Errors name file:line and
/// the key: unknown keys, wrong types, `domain_id` outside [0, 232], equal or empty topics.
[[nodiscard]] Result<DdsSettings> parse_dds_settings(const ConfigNode& node);

/// A parsed, validated run configuration.
struct RunConfig {
  std::string file;                               ///< path of the YAML file (empty if from a string)
  ConfigNode root;                                ///< the whole tree after overrides
  PluginSpec robot;
  PluginSpec camera;
  std::optional<PluginSpec> detector;             ///< optional section
  std::optional<std::vector<std::string>> nodes;  ///< nodes plugins to load; nullopt = all found
  RunSettings run;
  std::vector<std::string> plugin_path;           ///< extra plugin dirs (relative to the file's folder)
  DdsSettings dds;                                ///< the `dds:` block (disabled when absent)
};

/// Validates the structure of a run config (known top-level keys, sections with `type`,
/// the `run:` block through RunSettings::schema(), the `dds:` block through
/// parse_dds_settings()). Plugin params are checked by the plugins.
[[nodiscard]] Result<RunConfig> parse_run_config(const ConfigNode& root, const std::string& file = {});

/// parse_run_config with every problem as its own Error (code, location {file, line, key
/// path}); empty: the config is valid. `config` (optional) receives what parsed, complete only
/// when there is no problem (the sections that did parse are filled even then).
[[nodiscard]] std::vector<Error> run_config_problems(const ConfigNode& root, const std::string& file,
                                                     RunConfig* config = nullptr);

/// Reads `path`, applies `overrides` (`key.path=value` each) and parses the run config.
[[nodiscard]] Result<RunConfig> load_run_config(const std::string& path, const std::vector<std::string>& overrides = {});

/// Checks `params` against a plugin type's ParamDocs without creating the object: unknown
/// keys, values of the wrong type, values outside a "[min, max]" range or a "one of:" list.
/// Returns every problem found (empty = fine), each prefixed with file:line.
[[nodiscard]] std::vector<std::string> check_params_against_docs(const ConfigNode& params,
                                                                 const std::vector<ParamDoc>& docs,
                                                                 const std::string& section);

/// Structural equality of two config trees (ignores locations).
[[nodiscard]] bool same_config(const ConfigNode& a, const ConfigNode& b);

}  // namespace visnav
