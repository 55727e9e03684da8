// visnav SDK — the plugin ABI.
//
// Every plugin is a shared object exporting exactly one C symbol,
//   extern "C" const visnav::PluginDescriptor* visnav_plugin_entry();
// that returns a pointer to a static descriptor. The host reads `abi_version` (the
// first field) before anything else and refuses a mismatch, naming the library.
//
// Plugins and host exchange C++ objects, so a plugin must be built with the same
// compiler family and SDK version; kPluginAbiVersion is bumped on any change to the
// SDK headers' class layouts. Exceptions never cross the boundary: factories are
// wrapped by `visnav::plugin_factory<Impl>()`, which turns any escaping exception into
// an Error.
//
// Minimal plugin:
//   class MyCamera : public visnav::Camera {
//    public:
//     using Params = MyCameraParams;   // struct with defaults, validate() and schema()
//     static visnav::Result<std::unique_ptr<MyCamera>> create(const visnav::ConfigNode& params,
//                                                             visnav::HostServices& host);
//     visnav::Result<std::optional<visnav::Frame>> grab(double timeout_s) override;
//   };
//   static const visnav::TypeEntry kTypes[] = {visnav::make_type<MyCamera>("mycam", "What it is")};
//   VISNAV_PLUGIN({.name = "mycam", .version = "1.0", .description = "My camera", .types = kTypes})
//
// One plugin may carry several kinds: robot, camera and detector types in `types` (each entry
// names its kind, derived by make_type from the interface the class implements), behaviour-tree
// nodes through `register_nodes`, `visnav` subcommands in `commands` and edge payload readers in
// `payload_checks`. Objects of one plugin that must cooperate (a simulated robot and the camera
// that renders its world) find each other through HostServices, never through process-wide
// state (see HostServices::robot()).
#pragma once

#include <cstddef>
#include <cstdint>
#include <exception>
#include <memory>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "visnav/config_node.hpp"
#include "visnav/devices.hpp"
#include "visnav/host.hpp"
#include "visnav/map.hpp"
#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav {

namespace bt { class NodeRegistry; }  // visnav/bt/registry.hpp

/// Bumped whenever the descriptor or any SDK class layout changes.
/// 2: PluginDescriptor gained payload_checks (issue 17).
/// 3: TypeEntry gained check_params; Error gained a code and a location; bt::PortInfo gained
///    check/constraint; navigation primitives are SDK types (primitive.hpp; the lost-policy ports
///    of bt/nav_health_ports.hpp are the primitive adapter's now) (issue 14).
/// 4: a descriptor carries several kinds (TypeEntry::kind; PluginDescriptor lost its single
///    `kind`); VISNAV_PLUGIN takes a PluginInfo with named fields (issue 14).
/// 5: NavStatus and ReplayStep gained the live-view overlay (NavOverlay, issue 18).
/// 6: EdgeReplayer gained succeeded() (multi-experience learning, issue 13).
/// 7: NodeManifest gained check_literals, PrimitiveType check_params (validate = run, issue 37).
/// 8: Camera gained mount(), HostServices camera_mount() (the camera mount comes from the camera
///    config), ReplayStep gained failure_code (issue 37).
inline constexpr std::uint32_t kPluginAbiVersion = 8;

/// What a plugin contributes. A library may contribute several kinds at once.
enum class PluginKind : std::uint32_t { robot = 1, camera = 2, detector = 3, nodes = 4 };

[[nodiscard]] inline const char* to_string(PluginKind kind) {
  switch (kind) {
    case PluginKind::robot: return "robot";
    case PluginKind::camera: return "camera";
    case PluginKind::detector: return "detector";
    case PluginKind::nodes: return "nodes";
  }
  return "unknown";
}

using ObjectFactory = Result<std::unique_ptr<PluginObject>> (*)(const ConfigNode& params, HostServices& host);
using ParamDocsFn = std::vector<ParamDoc> (*)();
/// Every problem of a `params:` block, found exactly as the factory would find it before it
/// builds anything: the schema (unknown keys, types, ranges), the struct's validate(), and the
/// files the params name (e.g. a simulated world, opened and parsed). Creates no device, opens
/// no connection. Each Error has a code and a location. Never throws (make_type wraps it).
using ParamCheckFn = std::vector<Error> (*)(const ConfigNode& params);

/// One object type (a robot, camera or detector) a plugin provides.
struct TypeEntry {
  PluginKind kind;          ///< robot, camera or detector (make_type derives it)
  const char* type_name;    ///< name used in config, e.g. "orb"
  const char* description;  ///< one line
  ObjectFactory create;
  ParamDocsFn param_docs;   ///< may be nullptr
  /// `visnav validate` and the check before `visnav run` call this; nullptr: params unchecked
  /// there (the factory still checks them). make_type fills it (see plugin_check_params).
  ParamCheckFn check_params = nullptr;
};

/// Registers behaviour-tree node types (the plugin's `nodes` kind).
using NodesRegistrar = Status (*)(bt::NodeRegistry& registry, HostServices& host);

/// A `visnav <name> ...` subcommand contributed by a plugin (e.g. `visnav sim`).
/// `argv[0]` is the subcommand name. Returns the process exit status.
struct CommandEntry {
  const char* name;
  const char* summary;
  int (*run)(int argc, char** argv, HostServices& host);
};

/// The body reader of one edge kind, for checking maps before anything moves (`visnav map
/// validate`, a mission's planned route): `check` decodes a payload body exactly as the
/// primitive's replay would and compares what the body states with the graph's record (e.g. the
/// taught length). Interim hook until primitives become SDK types (DESIGN.md).
struct PayloadCheckEntry {
  const char* kind;          ///< edge kind, e.g. "feature_segment"
  PayloadBodyCheck check;    ///< noexcept, pure, thread-safe
};

/// The descriptor a plugin's entry symbol returns. Plugins do not fill it by hand: they write a
/// PluginInfo in VISNAV_PLUGIN, which builds it. Only `abi_version` is read before it matches.
struct PluginDescriptor {
  std::uint32_t abi_version;      ///< must be first; == kPluginAbiVersion
  std::uint32_t descriptor_size;  ///< sizeof(PluginDescriptor) as compiled into the plugin
  const char* name;               ///< plugin name, e.g. "detectors_opencv"
  const char* version;
  const char* description;
  const TypeEntry* types;         ///< robot/camera/detector types (any mix of kinds)
  std::size_t type_count;
  NodesRegistrar register_nodes;  ///< nullptr: the plugin provides no behaviour-tree nodes
  const CommandEntry* commands;   ///< optional CLI subcommands
  std::size_t command_count;
  const PayloadCheckEntry* payload_checks;  ///< optional (plugins providing primitives)
  std::size_t payload_check_count;
};

/// What a plugin declares, by name (designated initialisers; every field but `name` optional):
///   VISNAV_PLUGIN({.name = "sim", .version = "0.1.0", .description = "...", .types = kTypes,
///                  .commands = kCommands})
/// Arrays are static tables of the plugin; a std::span views them without copying.
struct PluginInfo {
  const char* name = nullptr;
  const char* version = "0.0.0";
  const char* description = "";
  std::span<const TypeEntry> types = {};
  NodesRegistrar register_nodes = nullptr;
  std::span<const CommandEntry> commands = {};
  std::span<const PayloadCheckEntry> payload_checks = {};
};

[[nodiscard]] constexpr PluginDescriptor make_descriptor(const PluginInfo& info) {
  return PluginDescriptor{kPluginAbiVersion,      sizeof(PluginDescriptor),  info.name,
                          info.version,           info.description,          info.types.data(),
                          info.types.size(),      info.register_nodes,       info.commands.data(),
                          info.commands.size(),   info.payload_checks.data(), info.payload_checks.size()};
}

/// The kinds a descriptor provides (types' kinds in order of first appearance, then nodes).
[[nodiscard]] inline std::vector<PluginKind> descriptor_kinds(const PluginDescriptor& d) {
  std::vector<PluginKind> kinds;
  for (std::size_t i = 0; i < d.type_count; ++i) {
    bool seen = false;
    for (PluginKind k : kinds) seen = seen || k == d.types[i].kind;
    if (!seen) kinds.push_back(d.types[i].kind);
  }
  if (d.register_nodes != nullptr) kinds.push_back(PluginKind::nodes);
  return kinds;
}

/// Wraps `Impl::create(params, host)` (returning Result<std::unique_ptr<Impl>>) so that
/// no exception escapes into the host.
template <typename Impl>
Result<std::unique_ptr<PluginObject>> plugin_factory(const ConfigNode& params, HostServices& host) noexcept {
  try {
    auto made = Impl::create(params, host);
    if (!made) return std::move(made).error();
    return std::unique_ptr<PluginObject>(std::move(made).value());
  } catch (const std::exception& e) {
    return fail(std::string("factory threw an exception: ") + e.what());
  } catch (...) {
    return fail("factory threw a non-standard exception");
  }
}

/// Wraps a plugin command's `Run(argc, argv, host)` so that no exception escapes into the host:
/// one that escapes is logged under the command's name (argv[0]) and gives exit status 1.
///   const CommandEntry kCommands[] = {{"align", "one line", &visnav::guarded_command<&run_align>}};
template <int (*Run)(int, char**, HostServices&)>
int guarded_command(int argc, char** argv, HostServices& host) noexcept {
  const char* name = argc > 0 && argv != nullptr && argv[0] != nullptr ? argv[0] : "command";
  try {
    return Run(argc, argv, host);
  } catch (const std::exception& e) {
    host.logger().error(name, std::string("unexpected exception: ") + e.what());
  } catch (...) {
    host.logger().error(name, "unexpected non-standard exception");
  }
  return 1;
}

/// Param docs of `Impl::Params` (Impl must expose `using Params = ...` with a schema()).
template <typename Impl>
std::vector<ParamDoc> plugin_param_docs() {
  return Impl::Params::schema().docs();
}

/// Checks a params block for `Impl`: `Impl::check_params(params)` when Impl declares one (a
/// type whose params name files adds those checks there, and its factory calls it too), else
/// `Impl::Params::schema().problems(params)`. No exception escapes.
template <typename Impl>
std::vector<Error> plugin_check_params(const ConfigNode& params) noexcept {
  try {
    if constexpr (requires { Impl::check_params(params); })
      return Impl::check_params(params);
    else
      return Impl::Params::schema().problems(params);
  } catch (const std::exception& e) {
    return {Error{params.where().str() + ": checking params threw an exception: " + e.what(), ErrorCode::plugin,
                  {params.where().file, params.where().line, {}}}};
  } catch (...) {
    return {Error{params.where().str() + ": checking params threw a non-standard exception", ErrorCode::plugin,
                  {params.where().file, params.where().line, {}}}};
  }
}

/// The kind of an object class, from the SDK interface it implements.
template <typename Impl>
constexpr PluginKind kind_of() {
  if constexpr (std::is_base_of_v<Robot, Impl>) return PluginKind::robot;
  else if constexpr (std::is_base_of_v<Camera, Impl>) return PluginKind::camera;
  else {
    static_assert(std::is_base_of_v<Detector, Impl>, "make_type: Impl must derive from Robot, Camera or Detector");
    return PluginKind::detector;
  }
}

template <typename Impl>
constexpr TypeEntry make_type(const char* type_name, const char* description) {
  return TypeEntry{kind_of<Impl>(), type_name, description, &plugin_factory<Impl>, &plugin_param_docs<Impl>,
                   &plugin_check_params<Impl>};
}

}  // namespace visnav

#define VISNAV_PLUGIN_ENTRY_SYMBOL "visnav_plugin_entry"

/// Defines the entry symbol from a PluginInfo written with designated initialisers, e.g.
///   VISNAV_PLUGIN({.name = "camera_dds", .version = "1.0", .description = "...", .types = kTypes})
#define VISNAV_PLUGIN(...)                                                                                  \
  extern "C" __attribute__((visibility("default"))) const ::visnav::PluginDescriptor* visnav_plugin_entry() { \
    static const ::visnav::PluginDescriptor descriptor = ::visnav::make_descriptor(::visnav::PluginInfo __VA_ARGS__); \
    return &descriptor;                                                                                     \
  }
