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
//   VISNAV_PLUGIN(visnav::PluginKind::camera, "mycam", "1.0", "My camera", kTypes, 1,
//                 /*register_nodes=*/nullptr, /*commands=*/nullptr, 0)
#pragma once

#include <cstddef>
#include <cstdint>
#include <exception>
#include <memory>
#include <span>
#include <string>
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
inline constexpr std::uint32_t kPluginAbiVersion = 3;

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

/// One object type a robot/camera/detector plugin provides.
struct TypeEntry {
  const char* type_name;    ///< name used in config, e.g. "orb"
  const char* description;  ///< one line
  ObjectFactory create;
  ParamDocsFn param_docs;   ///< may be nullptr
  /// `visnav validate` and the check before `visnav run` call this; nullptr: params unchecked
  /// there (the factory still checks them). make_type fills it (see plugin_check_params).
  ParamCheckFn check_params = nullptr;
};

/// Registers behaviour-tree node types (kind == nodes).
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

struct PluginDescriptor {
  std::uint32_t abi_version;      ///< must be first; == kPluginAbiVersion
  std::uint32_t descriptor_size;  ///< sizeof(PluginDescriptor) as compiled into the plugin
  PluginKind kind;
  const char* name;               ///< plugin name, e.g. "detectors_opencv"
  const char* version;
  const char* description;
  const TypeEntry* types;         ///< robot/camera/detector types
  std::size_t type_count;
  NodesRegistrar register_nodes;  ///< nodes kind; nullptr otherwise
  const CommandEntry* commands;   ///< optional CLI subcommands
  std::size_t command_count;
  const PayloadCheckEntry* payload_checks;  ///< optional (nodes plugins providing primitives)
  std::size_t payload_check_count;
};

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

template <typename Impl>
constexpr TypeEntry make_type(const char* type_name, const char* description) {
  return TypeEntry{type_name, description, &plugin_factory<Impl>, &plugin_param_docs<Impl>,
                   &plugin_check_params<Impl>};
}

}  // namespace visnav

#define VISNAV_PLUGIN_ENTRY_SYMBOL "visnav_plugin_entry"

/// Defines the entry symbol. TYPES and COMMANDS are arrays (or use VISNAV_NO_ITEMS).
#define VISNAV_PLUGIN(KIND, NAME, VERSION, DESCRIPTION, TYPES, TYPE_COUNT, REGISTRAR, COMMANDS, COMMAND_COUNT) \
  VISNAV_PLUGIN_WITH_PAYLOAD_CHECKS(KIND, NAME, VERSION, DESCRIPTION, TYPES, TYPE_COUNT, REGISTRAR, COMMANDS,  \
                                    COMMAND_COUNT, nullptr, 0)

/// As VISNAV_PLUGIN, plus a table of PayloadCheckEntry (the plugin's edge payload readers).
#define VISNAV_PLUGIN_WITH_PAYLOAD_CHECKS(KIND, NAME, VERSION, DESCRIPTION, TYPES, TYPE_COUNT, REGISTRAR, COMMANDS, \
                                          COMMAND_COUNT, CHECKS, CHECK_COUNT)                                     \
  extern "C" __attribute__((visibility("default"))) const ::visnav::PluginDescriptor* visnav_plugin_entry() {    \
    static const ::visnav::PluginDescriptor descriptor{                                                       \
        ::visnav::kPluginAbiVersion, sizeof(::visnav::PluginDescriptor), KIND, NAME, VERSION, DESCRIPTION,    \
        TYPES, TYPE_COUNT, REGISTRAR, COMMANDS, COMMAND_COUNT, CHECKS, CHECK_COUNT};                          \
    return &descriptor;                                                                                       \
  }
