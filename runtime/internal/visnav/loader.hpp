// visnav runtime — the plugin loader: finds `libvisnav_*.so` on an ordered search path,
// checks each library's ABI, indexes the types it provides and creates objects.
//
// Search path (in this order; the first file of a given name wins, later files of the same
// name are reported as shadowed):
//   1. the build tree's plugin dir (VISNAV_BUILD_PLUGIN_DIR),
//   2. the install plugin dir (VISNAV_INSTALL_PLUGIN_DIR),
//   3. each entry of the environment variable VISNAV_PLUGIN_PATH (colon-separated),
//   4. extra dirs given by config (`plugin_path:`) or the CLI.
// Directories are scanned non-recursively.
//
// Loading a library: dlopen(RTLD_NOW|RTLD_LOCAL) → dlsym("visnav_plugin_entry") → the
// descriptor's `abi_version` is read first and a mismatch is refused (naming the library
// and both versions) → descriptor_size and kind are checked → types are indexed by
// (kind, type_name). A library that fails to load does not stop the others: its error is
// kept in `problems()` and reported when a type it might have provided is asked for.
// Two libraries providing the same (kind, type_name) both load, the clash is recorded in
// `problems()`, and asking for that type without pinning a library (`plugin:` in config)
// is an error naming both libraries.
//
// Ownership and lifetime: the loader owns the library handles. Objects from `create<T>()`
// carry a shared reference to their library in their deleter, so they may outlive the
// loader; objects handed out as plain std::unique_ptr (HostServices::create_detector) and
// behaviour-tree nodes registered by `nodes` plugins must be destroyed before the loader.
// Thread-safety: not thread-safe; use from one thread (setup happens on the main thread).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "visnav/config_node.hpp"
#include "visnav/devices.hpp"
#include "visnav/host.hpp"
#include "visnav/map.hpp"
#include "visnav/params.hpp"
#include "visnav/plugin.hpp"
#include "visnav/result.hpp"

namespace visnav {

namespace detail { struct LibraryHandle; }

/// One object type a loaded library provides.
struct PluginTypeInfo {
  PluginKind kind = PluginKind::robot;
  std::string type_name;
  std::string description;
  std::string library_path;  ///< absolute path of the providing .so
};

/// A plugin-contributed `visnav <name>` subcommand.
struct PluginCommandInfo {
  std::string name;
  std::string summary;
  std::string library_path;
  int (*run)(int argc, char** argv, HostServices& host) = nullptr;
};

/// One (kind, name) a library provides.
struct PluginTypeKey {
  PluginKind kind = PluginKind::robot;
  std::string name;
  bool operator==(const PluginTypeKey&) const = default;
};

/// A successfully loaded library.
struct PluginLibraryInfo {
  std::string path;          ///< absolute path of the .so
  std::string file_name;     ///< e.g. "libvisnav_sim.so"
  std::string library_name;  ///< file name without "libvisnav_" and ".so", e.g. "sim"
  std::vector<PluginKind> kinds;  ///< what it provides (descriptor_kinds), e.g. robot, camera
  std::string name;          ///< descriptor name
  std::string version;
  std::string description;
  std::uint32_t abi_version = 0;
  std::vector<PluginTypeKey> types;        ///< robot/camera/detector types, descriptor order
  std::vector<std::string> command_names;

  [[nodiscard]] bool provides(PluginKind kind) const {
    for (PluginKind k : kinds)
      if (k == kind) return true;
    return false;
  }
  /// Names of the types of one kind.
  [[nodiscard]] std::vector<std::string> type_names(PluginKind kind) const {
    std::vector<std::string> out;
    for (const auto& t : types)
      if (t.kind == kind) out.push_back(t.name);
    return out;
  }
  /// "robot, camera, nodes" (or "commands only").
  [[nodiscard]] std::string kinds_text() const {
    std::string out;
    for (PluginKind k : kinds) out += (out.empty() ? "" : ", ") + std::string(to_string(k));
    return out.empty() ? std::string("commands only") : out;
  }
};

/// A plugin-provided reader of one edge kind's payload bodies (PayloadCheckEntry).
struct PayloadCheckInfo {
  std::string kind;
  PayloadBodyCheck check = nullptr;
  std::string library_path;
};

/// A library on the search path that could not be used (kept so errors can mention it).
struct PluginProblem {
  std::string path;
  std::string message;
};

/// Deleter that keeps the object's library loaded until the object is gone.
struct PluginObjectDeleter {
  std::shared_ptr<detail::LibraryHandle> library;
  void operator()(PluginObject* object) const noexcept;
};

/// An object made by a plugin factory, typed as the SDK interface T.
template <typename T>
using PluginPtr = std::unique_ptr<T, PluginObjectDeleter>;

class PluginLoader {
 public:
  /// The default search path: build dir, install dir, then VISNAV_PLUGIN_PATH entries
  /// (empty entries skipped). Pure: reads the environment, touches no files.
  [[nodiscard]] static std::vector<std::string> default_search_path();

  /// A loader over `search_dirs` (in priority order). Nothing is loaded until `scan()`.
  explicit PluginLoader(std::vector<std::string> search_dirs);
  /// A loader over default_search_path() followed by `extra_dirs`.
  static PluginLoader with_default_path(const std::vector<std::string>& extra_dirs = {});

  PluginLoader(PluginLoader&&) noexcept;
  PluginLoader& operator=(PluginLoader&&) noexcept;
  PluginLoader(const PluginLoader&) = delete;
  PluginLoader& operator=(const PluginLoader&) = delete;
  ~PluginLoader();

  /// Appends a directory to the search path (takes effect at the next scan()).
  void add_search_dir(std::string dir);
  [[nodiscard]] const std::vector<std::string>& search_dirs() const { return search_dirs_; }

  /// Loads every `libvisnav_*.so` on the search path (already loaded files are skipped).
  /// Libraries that fail are recorded in problems(); the scan itself only fails if the
  /// filesystem cannot be read. Returns the number of libraries loaded by this call.
  Result<std::size_t> scan();

  /// Loads one library by path, or by name ("simulator", "libvisnav_simulator.so") looked up
  /// on the search path. Errors: not found (lists every path tried), dlopen failure (dlerror
  /// text), missing entry symbol, ABI mismatch, bad descriptor. Loading the same file twice
  /// returns the first load.
  Result<const PluginLibraryInfo*> load_library(std::string_view path_or_name);

  /// Loaded libraries in load order.
  [[nodiscard]] std::vector<const PluginLibraryInfo*> libraries() const;
  /// Libraries that failed to load or were shadowed by an earlier file of the same name.
  [[nodiscard]] const std::vector<PluginProblem>& problems() const { return problems_; }
  /// All indexed types.
  [[nodiscard]] std::vector<PluginTypeInfo> types() const;
  /// Parameter docs of a type (empty when the plugin declares none).
  [[nodiscard]] Result<std::vector<ParamDoc>> param_docs(PluginKind kind, std::string_view type_name,
                                                         std::string_view library = {}) const;
  /// The descriptor entry of a type (e.g. for its check_params, which creates nothing); valid
  /// while the loader lives. Errors as find_type.
  [[nodiscard]] Result<const TypeEntry*> type_entry(PluginKind kind, std::string_view type_name,
                                                    std::string_view library = {}) const;
  /// The library providing (kind, type_name); with `library` non-empty, only that library
  /// (name, file name or path) is considered. Errors list the search path and the types known.
  [[nodiscard]] Result<PluginTypeInfo> find_type(PluginKind kind, std::string_view type_name,
                                                 std::string_view library = {}) const;

  /// Creates an object of (kind, type_name) through the plugin factory (exceptions are caught
  /// here as well). `library` pins the providing library (loaded on demand if not yet).
  Result<PluginPtr<PluginObject>> create_object(PluginKind kind, std::string_view type_name,
                                                const ConfigNode& params, HostServices& host,
                                                std::string_view library = {});

  /// Typed creation: T is Robot (kind robot), Camera (camera) or Detector (detector).
  template <typename T>
  Result<PluginPtr<T>> create(std::string_view type_name, const ConfigNode& params, HostServices& host,
                              std::string_view library = {});

  /// Nodes plugins, in load order (descriptor kind == nodes).
  struct NodesPlugin {
    const PluginLibraryInfo* library;
    NodesRegistrar register_nodes;
  };
  [[nodiscard]] std::vector<NodesPlugin> nodes_plugins() const;

  /// All plugin-contributed CLI commands (first library wins on a name clash).
  [[nodiscard]] std::vector<PluginCommandInfo> commands() const;

  /// All plugin-provided payload body readers (first library wins on a kind clash).
  [[nodiscard]] std::vector<PayloadCheckInfo> payload_checks() const;
  /// Registers every payload_checks() entry with `map`; the loader must outlive that use.
  void install_payload_checks(MapStore& map) const;

 private:
  struct Loaded;
  Result<const PluginLibraryInfo*> load_path(const std::string& absolute_path);
  Result<std::string> resolve_library(std::string_view path_or_name, std::vector<std::string>* tried) const;
  const Loaded* find_loaded(std::string_view library) const;

  std::vector<std::string> search_dirs_;
  std::vector<std::unique_ptr<Loaded>> loaded_;
  std::vector<PluginProblem> problems_;
};

/// Kind for an SDK interface type.
template <typename T> struct PluginKindOf;
template <> struct PluginKindOf<Robot> { static constexpr PluginKind value = PluginKind::robot; };
template <> struct PluginKindOf<Camera> { static constexpr PluginKind value = PluginKind::camera; };
template <> struct PluginKindOf<Detector> { static constexpr PluginKind value = PluginKind::detector; };

/// Parses a kind name ("robot", "camera", "detector", "nodes").
[[nodiscard]] std::optional<PluginKind> plugin_kind_from_string(std::string_view text);

template <typename T>
Result<PluginPtr<T>> PluginLoader::create(std::string_view type_name, const ConfigNode& params, HostServices& host,
                                          std::string_view library) {
  auto made = create_object(PluginKindOf<T>::value, type_name, params, host, library);
  if (!made) return std::move(made).error();
  PluginPtr<PluginObject> object = std::move(made).value();
  T* typed = dynamic_cast<T*>(object.get());
  if (typed == nullptr)
    return fail(std::string(to_string(PluginKindOf<T>::value)) + " type '" + std::string(type_name) +
                "': the factory returned an object that is not a " + to_string(PluginKindOf<T>::value));
  PluginObjectDeleter deleter = object.get_deleter();
  (void)object.release();
  return PluginPtr<T>(typed, std::move(deleter));
}

}  // namespace visnav
