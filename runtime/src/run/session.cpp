// Session: builds loader, host, devices and node registry from a RunConfig; live reload.
#include <filesystem>
#include <system_error>

#include "visnav/bt/registry.hpp"
#include "visnav/runner.hpp"

namespace visnav {

namespace fs = std::filesystem;

namespace {

bool is_zero(const Twist& t) { return t.linear_mps == 0.0 && t.angular_radps == 0.0; }

std::string spec_label(const char* section, const PluginSpec& spec) {
  return std::string(section) + " '" + spec.type + "'" + (spec.plugin.empty() ? "" : " (plugin " + spec.plugin + ")") +
         " at " + spec.where.str();
}

bool same_identity(const PluginSpec& a, const PluginSpec& b) { return a.type == b.type && a.plugin == b.plugin; }

bool same_dds(const DdsSettings& a, const DdsSettings& b) {
  return a.enabled == b.enabled && a.telemetry == b.telemetry && a.control == b.control &&
         a.endpoints.domain_id == b.endpoints.domain_id && a.endpoints.partition == b.endpoints.partition &&
         a.endpoints.telemetry_topic == b.endpoints.telemetry_topic && a.endpoints.control_topic == b.endpoints.control_topic;
}

}  // namespace

// --- GuardedRobot -----------------------------------------------------------------------------

Status GuardedRobot::send_command(const Twist& command) {
  if (latched_reason_ && !is_zero(command)) {
    (void)stop();
    return fail("robot stopped by the runtime (" + *latched_reason_ + "); command refused");
  }
  auto st = inner_->send_command(command);
  if (st) {
    last_command_ = command;
    ++commands_;
  }
  return st;
}

Status GuardedRobot::stop() {
  auto st = inner_->stop();
  if (st) {
    last_command_ = Twist{};
    ++commands_;
  }
  return st;
}

// --- nodes registration -----------------------------------------------------------------------

Status register_all_nodes(bt::NodeRegistry& registry, PluginLoader& loader, HostServices& host,
                          const std::optional<std::vector<std::string>>& only) {
  VISNAV_TRY(bt::register_builtin_nodes(registry));
  std::vector<PluginLoader::NodesPlugin> selected;
  const auto all = loader.nodes_plugins();
  if (only) {
    for (const auto& name : *only) {
      const PluginLoader::NodesPlugin* found = nullptr;
      for (const auto& p : all)
        if (p.library->library_name == name || p.library->name == name || p.library->file_name == name ||
            p.library->path == name)
          found = &p;
      if (found == nullptr) {
        auto loaded = loader.load_library(name);
        if (!loaded) return loaded.error().with_context("nodes plugin '" + name + "'");
        if ((*loaded)->kind != PluginKind::nodes)
          return fail("nodes plugin '" + name + "': " + (*loaded)->path + " is a " + to_string((*loaded)->kind) +
                      " plugin");
        for (const auto& p : loader.nodes_plugins())
          if (p.library == *loaded) selected.push_back(p);
      } else {
        selected.push_back(*found);
      }
    }
  } else {
    selected = all;
  }
  for (const auto& p : selected) {
    Status st = ok();
    try {
      st = p.register_nodes(registry, host);
    } catch (const std::exception& e) {
      st = fail(std::string("registrar threw an exception: ") + e.what());
    } catch (...) {
      st = fail("registrar threw a non-standard exception");
    }
    if (!st) return st.error().with_context("nodes plugin " + p.library->path);
  }
  return ok();
}

// --- Session ----------------------------------------------------------------------------------

Result<std::unique_ptr<Session>> Session::create(RunConfig config, const SessionOptions& options) {
  std::unique_ptr<Session> s(new Session());
  s->config_ = std::move(config);
  s->overrides_ = options.overrides;
  VISNAV_TRY(s->build(options));
  return s;
}

Session::~Session() {
  // Members go in reverse order: registry, detector, camera, guard, robot, ..., loader.
  if (guard_) (void)guard_->stop();
}

Status Session::build(const SessionOptions& options) {
  if (options.logger != nullptr) {
    logger_ = options.logger;
  } else {
    VISNAV_ASSIGN(LogLevel level, parse_log_level(config_.run.log_level));
    own_logger_ = std::make_unique<StderrLogger>(level);
    logger_ = own_logger_.get();
  }

  std::vector<std::string> dirs;
  if (options.use_default_plugin_path) dirs = PluginLoader::default_search_path();
  dirs.insert(dirs.end(), config_.plugin_path.begin(), config_.plugin_path.end());
  dirs.insert(dirs.end(), options.extra_plugin_dirs.begin(), options.extra_plugin_dirs.end());
  loader_ = PluginLoader(std::move(dirs));
  VISNAV_TRY(loader_.scan());
  for (const auto& p : loader_.problems()) logger_->warn("loader", p.path + ": " + p.message);
  for (const auto& dir : config_.plugin_path) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) logger_->warn("loader", "plugin_path folder '" + dir + "' does not exist");
  }

  host_ = std::make_unique<RuntimeHost>(loader_, *logger_, wall_clock_);
  host_->set_frame_bus(&frame_bus_);

  // DDS Security (issue 17) applies to every participant this process creates, the robot's and
  // camera's included, so it is set before any plugin is made.
  const bool secure = config_.dds.enabled && config_.dds.security.has_value();
  if (auto st = dds::set_default_security(secure ? config_.dds.security : std::nullopt); !st)
    return st.error().with_context("dds block at " + config_.dds.where.str());
  {
    auto made = loader_.create<Robot>(config_.robot.type, config_.robot.params, *host_, config_.robot.plugin);
    if (!made) return made.error().with_context(spec_label("robot", config_.robot));
    robot_ = std::move(made).value();
  }
  guard_ = std::make_unique<GuardedRobot>(*robot_);
  host_->set_robot(guard_.get());

  SimulationControl* sim = robot_->simulation();
  if (config_.run.lockstep == "on" && sim == nullptr)
    return fail(config_.robot.where.str() + ": run.lockstep is 'on' but robot '" + config_.robot.type +
                "' is not simulated");
  lockstep_ = sim != nullptr && config_.run.lockstep != "off";
  const bool uses_dds = config_.dds.enabled || config_.robot.type == "dds" || config_.camera.type == "dds";
  if (secure) {
    logger_->info("run", "DDS Security on: identity " + config_.dds.security->identity_cert +
                             " (authenticated, access-controlled; governance " + config_.dds.security->governance + ")");
  } else if (uses_dds && sim == nullptr) {
    logger_->warn("run", "DDS SECURITY IS OFF on a real robot: any participant on the domain can read telemetry, "
                         "pause/abort the mission and publish cmd_vel/odometry. Add dds: {security: {...}} "
                         "(visnav security init; docs/security.md)");
  } else {
    logger_->info("run", std::string("DDS Security off") + (uses_dds ? " (simulated robot)" : " (no DDS in use)"));
  }
  if (lockstep_) {
    sim_clock_ = std::make_unique<SimulationClock>(*sim);
    host_->set_clock(*sim_clock_);
  }

  {
    auto made = loader_.create<Camera>(config_.camera.type, config_.camera.params, *host_, config_.camera.plugin);
    if (!made) return made.error().with_context(spec_label("camera", config_.camera));
    camera_ = std::move(made).value();
  }
  if (config_.detector) {
    auto made = loader_.create<Detector>(config_.detector->type, config_.detector->params, *host_, config_.detector->plugin);
    if (!made) return made.error().with_context(spec_label("detector", *config_.detector));
    detector_ = std::move(made).value();
    host_->set_active_detector(detector_.get());
  }

  if (!options.map_path.empty()) {
    std::error_code ec;
    if (!fs::exists(options.map_path, ec)) {
      // A mistyped path must not silently become an empty map (issue 17): creating is explicit.
      if (!options.create_map)
        return fail("--map " + options.map_path + ": no such map folder (give --create to start a new map there)");
      auto created = MapStore::create(options.map_path, fs::path(options.map_path).filename().string());
      if (!created) return created.error().with_context("--map " + options.map_path);
      logger_->info("run", "created empty map " + options.map_path);
      map_.emplace(std::move(created).value());
    } else {
      auto opened = MapStore::open(options.map_path);
      if (!opened) return opened.error().with_context("--map " + options.map_path);
      map_.emplace(std::move(opened).value());
    }
    loader_.install_payload_checks(*map_);  // the loader outlives the map (member order)
    host_->set_map(&*map_);
  }

  if (!config_.run.telemetry_file.empty()) {
    VISNAV_ASSIGN(telemetry_file_, JsonLinesTelemetry::open(config_.run.telemetry_file, host_->clock()));
    telemetry_.add(telemetry_file_.get());
  }
  if (config_.dds.enabled) {
    const std::string where = "dds block at " + config_.dds.where.str();
    const dds::TelemetryParams& endpoints = config_.dds.endpoints;
    if (config_.dds.telemetry) {
      auto made = dds::DdsTelemetry::create(endpoints, *logger_);
      if (!made) return made.error().with_context(where + ": telemetry on '" + endpoints.telemetry_topic + "'");
      dds_telemetry_ = std::move(made).value();
      telemetry_.add(dds_telemetry_.get());
    }
    if (config_.dds.control) {
      auto made = dds::ControlSubscriber::create(endpoints, *logger_);
      if (!made) return made.error().with_context(where + ": control on '" + endpoints.control_topic + "'");
      control_ = std::move(made).value();
    }
    logger_->info("run", "DDS domain " + std::to_string(endpoints.domain_id) +
                             (endpoints.partition.empty() ? "" : ", partition '" + endpoints.partition + "'") +
                             (dds_telemetry_ ? ": telemetry on '" + endpoints.telemetry_topic + "'" : ":") +
                             (control_ ? std::string(dds_telemetry_ ? "," : "") + " control on '" +
                                             endpoints.control_topic + "'"
                                       : ""));
  }
  if (telemetry_.sinks() > 0) host_->set_telemetry(&telemetry_);

  registry_ = std::make_unique<bt::NodeRegistry>();
  VISNAV_TRY(register_all_nodes(*registry_, loader_, *host_, config_.nodes));

  remember_file_stamp();
  next_poll_wall_s_ = wall_clock_.now_s() + config_.run.reload_poll_s;
  logger_->info("run", "robot '" + config_.robot.type + "', camera '" + config_.camera.type + "'" +
                           (config_.detector ? ", detector '" + config_.detector->type + "'" : std::string()) +
                           (lockstep_ ? ", lock-step simulation" : ", real time") + ", " +
                           std::to_string(registry_->size()) + " node types");
  return ok();
}

Result<bt::Tree> Session::load_tree(const std::string& tree_file) {
  bt::LoadOptions options;
  options.clock = &host_->clock();
  options.max_subtree_depth = config_.run.bt_max_subtree_depth;
  options.max_nodes = static_cast<std::size_t>(config_.run.bt_max_nodes);
  options.max_tree_depth = config_.run.bt_max_tree_depth;
  return bt::load_tree_file(tree_file, *registry_, options);
}

void Session::remember_file_stamp() {
  if (config_.file.empty()) return;
  std::error_code ec;
  const auto t = fs::last_write_time(config_.file, ec);
  if (ec) return;
  file_mtime_ns_ = static_cast<std::int64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count());
  file_size_ = fs::file_size(config_.file, ec);
}

bool Session::poll_config_reload(bool force) {
  if (config_.file.empty()) return false;
  if (!force) {
    if (config_.run.reload_poll_s <= 0.0) return false;
    const double now = wall_clock_.now_s();
    if (now < next_poll_wall_s_) return false;
    next_poll_wall_s_ = now + config_.run.reload_poll_s;
  }
  std::error_code ec;
  const auto t = fs::last_write_time(config_.file, ec);
  if (ec) return false;  // e.g. mid-rename by an editor; try again next poll
  const auto size = fs::file_size(config_.file, ec);
  if (ec) return false;
  const auto mtime_ns =
      static_cast<std::int64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count());
  if (mtime_ns == file_mtime_ns_ && size == file_size_) return false;
  file_mtime_ns_ = mtime_ns;
  file_size_ = size;
  auto applied = reload_config();
  return applied && *applied;
}

Status Session::swap_detector(const std::string& type) {
  if (type.empty()) return fail("swap_detector: no detector type given");
  if (config_.detector && config_.detector->type == type && detector_) {
    logger_->info("run", "swap_detector: '" + type + "' is already the active detector");
    return ok();
  }
  PluginSpec spec;
  spec.type = type;
  spec.where = SourceLocation{"control topic", 0};
  spec.params.set_where(spec.where);
  auto made = loader_.create<Detector>(spec.type, spec.params, *host_);
  if (!made) return made.error().with_context("swap_detector '" + type + "'");
  const std::string old_type = config_.detector ? config_.detector->type : std::string("none");
  host_->set_active_detector(made->get());
  detector_ = std::move(made).value();  // the old detector is destroyed here, between ticks
  config_.detector = std::move(spec);
  logger_->info("run", "active detector is now '" + type + "' (was '" + old_type + "'), swapped by the control topic");
  return ok();
}

Result<bool> Session::reload_config() {
  auto reject = [this](const std::string& why) -> Error {
    ++reloads_rejected_;
    logger_->error("config", "reload of " + config_.file + " rejected, keeping the running config: " + why);
    return fail(why);
  };

  auto loaded = load_run_config(config_.file, overrides_);
  if (!loaded) return reject(loaded.error().message);
  RunConfig next = std::move(loaded).value();

  // Changes that need a restart.
  std::vector<std::string> restart;
  if (!same_identity(next.robot, config_.robot)) restart.push_back("robot.type/plugin");
  if (!same_identity(next.camera, config_.camera)) restart.push_back("camera.type/plugin");
  if (next.nodes != config_.nodes) restart.push_back("nodes");
  if (next.plugin_path != config_.plugin_path) restart.push_back("plugin_path");
  if (next.run.tick != config_.run.tick) restart.push_back("run.tick");
  if (next.run.lockstep != config_.run.lockstep) restart.push_back("run.lockstep");
  if (next.run.trace_file != config_.run.trace_file) restart.push_back("run.trace_file");
  if (next.run.telemetry_file != config_.run.telemetry_file) restart.push_back("run.telemetry_file");
  if (!same_dds(next.dds, config_.dds)) restart.push_back("dds");
  if (!restart.empty()) {
    std::string keys;
    for (const auto& k : restart) keys += (keys.empty() ? "" : ", ") + k;
    return reject("changing " + keys + " needs a restart");
  }

  // Detector: a new type (or plugin) is created before anything is applied, so a failing
  // factory rejects the whole reload.
  PluginPtr<Detector> new_detector;
  bool detector_changed = false;
  if (next.detector.has_value() != config_.detector.has_value() ||
      (next.detector && !same_identity(*next.detector, *config_.detector))) {
    detector_changed = true;
    if (next.detector) {
      auto made = loader_.create<Detector>(next.detector->type, next.detector->params, *host_, next.detector->plugin);
      if (!made) return reject(made.error().with_context(spec_label("detector", *next.detector)).message);
      new_detector = std::move(made).value();
    }
  } else if (next.detector && !same_config(next.detector->params, config_.detector->params)) {
    auto st = detector_->reconfigure(next.detector->params);
    if (!st) {
      // Cannot reconfigure in place: build a fresh one with the new params and swap.
      auto made = loader_.create<Detector>(next.detector->type, next.detector->params, *host_, next.detector->plugin);
      if (!made)
        return reject("detector '" + next.detector->type + "': reconfigure failed (" + st.error().message +
                      ") and a new one could not be created (" + made.error().message + ")");
      new_detector = std::move(made).value();
      detector_changed = true;
    }
    logger_->info("config", "detector '" + next.detector->type + "' params updated");
  }

  bool changed = false;
  auto reconfigure = [&](const char* section, PluginObject& object, PluginSpec& current, const PluginSpec& wanted) {
    if (same_config(current.params, wanted.params)) return;
    auto st = object.reconfigure(wanted.params);
    if (!st) {
      logger_->error("config", std::string(section) + " '" + current.type + "' kept its old params: " + st.error().message);
      return;
    }
    logger_->info("config", std::string(section) + " '" + current.type + "' params updated");
    current = wanted;
    changed = true;
  };
  reconfigure("robot", *robot_, config_.robot, next.robot);
  reconfigure("camera", *camera_, config_.camera, next.camera);
  next.robot = config_.robot;    // keep what was actually applied
  next.camera = config_.camera;

  if (detector_changed) {
    host_->set_active_detector(new_detector.get());
    detector_ = std::move(new_detector);  // the old detector is destroyed here, between ticks
    logger_->info("config", next.detector ? "active detector is now '" + next.detector->type + "'" : "detector removed");
    changed = true;
  } else if (next.detector && !same_config(next.detector->params, config_.detector->params)) {
    changed = true;
  }

  if (next.run.log_level != config_.run.log_level && own_logger_) {
    if (auto level = parse_log_level(next.run.log_level)) own_logger_->set_level(*level);
  }
  const bool run_changed = next.run.rate_hz != config_.run.rate_hz || next.run.max_frame_age_s != config_.run.max_frame_age_s ||
                           next.run.max_odometry_age_s != config_.run.max_odometry_age_s ||
                           next.run.startup_timeout_s != config_.run.startup_timeout_s ||
                           next.run.max_duration_s != config_.run.max_duration_s ||
                           next.run.log_level != config_.run.log_level || next.run.reload_poll_s != config_.run.reload_poll_s;
  if (run_changed) {
    logger_->info("config", "run settings updated");
    changed = true;
  }

  config_ = std::move(next);
  remember_file_stamp();
  ++reloads_applied_;
  if (!changed) logger_->info("config", config_.file + " changed but the effective config is the same");
  return changed;
}

}  // namespace visnav
