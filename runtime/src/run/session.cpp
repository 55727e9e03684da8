// Session: builds logger, loader, host, devices, map, links and node registry from a RunConfig
// (one step each); swaps the detector. Live reload is in session_reload.cpp.
#include <ifaddrs.h>
#include <net/if.h>
#include <netdb.h>
#include <netinet/in.h>

#include <cstdlib>
#include <filesystem>
#include <system_error>

#include "run/session_parts.hpp"
#include "visnav/bt/registry.hpp"
#include "visnav/runner.hpp"

namespace visnav {

namespace fs = std::filesystem;

namespace {

/// The first non-loopback IPv4/IPv6 interface that is up, as "name (address)", unless
/// CYCLONEDDS_URI pins Cyclone DDS to the loopback interface (127.0.0.1 / ::1 / "lo"): where an
/// unsecured participant can be reached from other machines. nullopt: loopback only.
std::optional<std::string> dds_network_exposure() {
  if (const char* uri = std::getenv("CYCLONEDDS_URI")) {
    const std::string text(uri);
    const bool pinned_to_loopback = text.find("127.0.0.1") != std::string::npos ||
                                    text.find("\"::1\"") != std::string::npos ||
                                    text.find("name=\"lo\"") != std::string::npos;
    if (pinned_to_loopback && text.find("NetworkInterface") != std::string::npos) return std::nullopt;
  }
  struct ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) return std::nullopt;
  std::optional<std::string> found;
  for (const struct ifaddrs* a = list; a != nullptr && !found; a = a->ifa_next) {
    if (a->ifa_addr == nullptr || (a->ifa_flags & IFF_UP) == 0 || (a->ifa_flags & IFF_LOOPBACK) != 0) continue;
    const int family = a->ifa_addr->sa_family;
    if (family != AF_INET && family != AF_INET6) continue;
    char host[NI_MAXHOST] = {};
    const socklen_t len = family == AF_INET ? sizeof(struct sockaddr_in) : sizeof(struct sockaddr_in6);
    if (::getnameinfo(a->ifa_addr, len, host, sizeof host, nullptr, 0, NI_NUMERICHOST) != 0) continue;
    found = std::string(a->ifa_name) + " (" + host + ")";
  }
  ::freeifaddrs(list);
  return found;
}

bool is_zero(const Twist& t) { return t.linear_mps == 0.0 && t.angular_radps == 0.0; }

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
        if (!loaded) {
          Error e = loaded.error().with_context("nodes plugin '" + name + "'");
          if (e.where.key.empty()) e.where.key = "nodes";
          return e;
        }
        if (!(*loaded)->provides(PluginKind::nodes))
          return Error{"nodes plugin '" + name + "': " + (*loaded)->path + " provides no behaviour-tree nodes (it provides: " +
                           (*loaded)->kinds_text() + ")",
                       ErrorCode::plugin, {{}, 0, "nodes"}};
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

Session::Session() : links_(std::make_unique<Links>()) {}

Result<std::unique_ptr<Session>> Session::create(RunConfig config, const SessionOptions& options) {
  std::unique_ptr<Session> s(new Session());
  s->config_ = std::move(config);
  VISNAV_TRY(s->build(options));
  return s;
}

Session::~Session() {
  // Members go in reverse order: live reload, registry, detector, camera, guard, robot, map,
  // links, host, ..., loader.
  if (guard_) (void)guard_->stop();
}

std::uint64_t Session::telemetry_published() const { return links_->fan_out.published(); }

void Session::add_telemetry_sink(Telemetry* sink) {
  links_->fan_out.add(sink);
  if (links_->fan_out.sinks() > 0) host_->set_telemetry(&links_->fan_out);
}

void Session::remove_telemetry_sink(Telemetry* sink) {
  links_->fan_out.remove(sink);
  if (links_->fan_out.sinks() == 0) host_->set_telemetry(nullptr);
}
dds::DdsTelemetry* Session::dds_telemetry() { return links_->dds.get(); }
dds::ControlSubscriber* Session::control() { return links_->control.get(); }
int Session::reloads_applied() const { return reload_ ? reload_->applied() : 0; }
int Session::reloads_rejected() const { return reload_ ? reload_->rejected() : 0; }
bool Session::poll_config_reload(bool force) { return reload_->poll(force); }
Result<bool> Session::reload_config() { return reload_->reload(); }

Status Session::build(const SessionOptions& options) {
  VISNAV_TRY(build_logger(options));
  VISNAV_TRY(build_loader(options));
  host_ = std::make_unique<RuntimeHost>(loader_, *logger_, wall_clock_);
  host_->set_frame_bus(&frame_bus_);
  VISNAV_TRY(build_devices());
  VISNAV_TRY(open_map(options));
  VISNAV_TRY(build_links());
  registry_ = std::make_unique<bt::NodeRegistry>();
  VISNAV_TRY(register_all_nodes(*registry_, loader_, *host_, config_.nodes));

  reload_ = std::make_unique<LiveReload>(
      LiveReload::Parts{config_, *logger_, own_logger_.get(), loader_, *host_, *robot_, *camera_, detector_, wall_clock_},
      options.overrides);
  logger_->info("run", "robot '" + config_.robot.type + "', camera '" + config_.camera.type + "'" +
                           (config_.detector ? ", detector '" + config_.detector->type + "'" : std::string()) +
                           (lockstep_ ? ", lock-step simulation" : ", real time") + ", " +
                           std::to_string(registry_->size()) + " node types");
  return ok();
}

Status Session::build_logger(const SessionOptions& options) {
  if (options.logger != nullptr) {
    logger_ = options.logger;
    return ok();
  }
  VISNAV_ASSIGN(LogLevel level, parse_log_level(config_.run.log_level));
  own_logger_ = std::make_unique<StderrLogger>(level);
  logger_ = own_logger_.get();
  return ok();
}

Status Session::build_loader(const SessionOptions& options) {
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
  return ok();
}

// DDS security, robot (host.robot() is set before the camera is made, so a simulated camera can
// follow the simulated robot), the run clock, camera, detector.
Status Session::build_devices() {
  // DDS Security (issue 17) applies to every participant this process creates, the robot's and
  // camera's included, so it is set before any plugin is made.
  const bool secure = config_.dds.enabled && config_.dds.security.has_value();
  if (auto st = dds::set_default_security(secure ? config_.dds.security : std::nullopt); !st)
    return st.error().with_context("dds block at " + config_.dds.where.str());
  {
    auto made = loader_.create<Robot>(config_.robot.type, config_.robot.params, *host_, config_.robot.plugin);
    if (!made) return spec_error(made.error(), "robot", config_.robot);
    robot_ = std::move(made).value();
  }
  guard_ = std::make_unique<GuardedRobot>(*robot_);
  host_->set_robot(guard_.get());

  SimulationControl* sim = robot_->simulation();
  if (config_.run.lockstep == "on" && sim == nullptr)
    return Error{config_.robot.where.str() + ": run.lockstep is 'on' but robot '" + config_.robot.type + "' is not simulated",
                 ErrorCode::inconsistent, {config_.file, 0, "run.lockstep"}};
  lockstep_ = sim != nullptr && config_.run.lockstep != "off";
  const bool uses_dds = config_.dds.enabled || config_.robot.type == "dds" || config_.camera.type == "dds";
  const std::optional<std::string> exposed = uses_dds && !secure ? dds_network_exposure() : std::nullopt;
  if (secure) {
    logger_->info("run", "DDS Security on: identity " + config_.dds.security->identity_cert +
                             " (authenticated, access-controlled; governance " + config_.dds.security->governance + ")");
  } else if (uses_dds && (sim == nullptr || exposed)) {
    logger_->warn("run", std::string("DDS SECURITY IS OFF ") + (sim == nullptr ? "on a real robot" : "with a simulated robot") +
                             (exposed ? ", DDS reachable on " + *exposed : std::string()) +
                             ": any participant on the domain can read telemetry, pause/abort the mission and "
                             "publish cmd_vel/odometry. Secure it: visnav security init keys --robot R --operator O, "
                             "then dds: {security: keys/R-mission} (docs/security.md)");
  } else {
    logger_->info("run", std::string("DDS Security off") + (uses_dds ? " (simulated robot)" : " (no DDS in use)"));
  }
  if (lockstep_) {
    sim_clock_ = std::make_unique<SimulationClock>(*sim);
    host_->set_clock(*sim_clock_);
  }
  {
    auto made = loader_.create<Camera>(config_.camera.type, config_.camera.params, *host_, config_.camera.plugin);
    if (!made) return spec_error(made.error(), "camera", config_.camera);
    camera_ = std::move(made).value();
    // HostServices::camera_mount() answers from the camera's own config (issue 37).
    host_->set_camera(camera_.get(), "camera '" + config_.camera.type + "' (" + config_.camera.where.str() + ")");
  }
  if (config_.detector) {
    auto made = loader_.create<Detector>(config_.detector->type, config_.detector->params, *host_, config_.detector->plugin);
    if (!made) return spec_error(made.error(), "detector", *config_.detector);
    install_detector(*host_, detector_, std::move(made).value());
  }
  return ok();
}

Status Session::open_map(const SessionOptions& options) {
  if (options.map_path.empty()) return ok();
  std::error_code ec;
  if (!fs::exists(options.map_path, ec)) {
    // A mistyped path must not silently become an empty map (issue 17): creating is explicit.
    if (!options.create_map)
      return Error{"--map " + options.map_path + ": no such map folder (give --create to start a new map there)",
                   ErrorCode::not_found, {options.map_path, 0, {}}};
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
  return ok();
}

// Telemetry sinks (the run.telemetry_file JSON lines and DDS telemetry, behind one fan-out that
// becomes the host's telemetry) and the DDS control subscriber.
Status Session::build_links() {
  Links& l = *links_;
  if (!config_.run.telemetry_file.empty()) {
    VISNAV_ASSIGN(l.file, JsonLinesTelemetry::open(config_.run.telemetry_file, host_->clock()));
    l.fan_out.add(l.file.get());
  }
  if (config_.dds.enabled) {
    const std::string where = "dds block at " + config_.dds.where.str();
    const dds::TelemetryParams& endpoints = config_.dds.endpoints;
    if (config_.dds.telemetry) {
      auto made = dds::DdsTelemetry::create(endpoints, *logger_);
      if (!made) return made.error().with_context(where + ": telemetry on '" + endpoints.telemetry_topic + "'");
      l.dds = std::move(made).value();
      l.fan_out.add(l.dds.get());
    }
    if (config_.dds.control) {
      auto made = dds::ControlSubscriber::create(endpoints, *logger_);
      if (!made) return made.error().with_context(where + ": control on '" + endpoints.control_topic + "'");
      l.control = std::move(made).value();
    }
    logger_->info("run", "DDS domain " + std::to_string(endpoints.domain_id) +
                             (endpoints.partition.empty() ? "" : ", partition '" + endpoints.partition + "'") +
                             (l.dds ? ": telemetry on '" + endpoints.telemetry_topic + "'" : ":") +
                             (l.control ? std::string(l.dds ? "," : "") + " control on '" + endpoints.control_topic + "'"
                                        : ""));
  }
  if (l.fan_out.sinks() > 0) host_->set_telemetry(&l.fan_out);
  return ok();
}

Result<bt::Tree> Session::load_tree(const std::string& tree_file, const std::vector<bt::PortOverride>& port_overrides) {
  bt::LoadOptions options;
  options.port_overrides = port_overrides;
  options.clock = &host_->clock();
  options.max_subtree_depth = config_.run.bt_max_subtree_depth;
  options.max_nodes = static_cast<std::size_t>(config_.run.bt_max_nodes);
  options.max_tree_depth = config_.run.bt_max_tree_depth;
  return bt::load_tree_file(tree_file, *registry_, options);
}

// --- detector swap ----------------------------------------------------------------------------

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
  install_detector(*host_, detector_, std::move(made).value());
  config_.detector = std::move(spec);
  logger_->info("run", "active detector is now '" + type + "' (was '" + old_type + "'), swapped by the control topic");
  return ok();
}

}  // namespace visnav
