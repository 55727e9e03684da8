// Plugin loader: search path, dlopen, ABI check, type index, object creation.
#include "visnav/loader.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <map>
#include <set>
#include <system_error>
#include <utility>

namespace visnav {

namespace fs = std::filesystem;

namespace detail {

/// One dlopen'ed library. dlclose runs when the last owner (loader or object deleter) lets go.
struct LibraryHandle {
  void* handle = nullptr;
  std::string path;

  LibraryHandle(void* h, std::string p) : handle(h), path(std::move(p)) {}
  LibraryHandle(const LibraryHandle&) = delete;
  LibraryHandle& operator=(const LibraryHandle&) = delete;
  ~LibraryHandle() {
    if (handle != nullptr) dlclose(handle);
  }
};

}  // namespace detail

void PluginObjectDeleter::operator()(PluginObject* object) const noexcept {
  // The object's destructor lives in the library: run it while `library` still holds the handle.
  delete object;
}

struct PluginLoader::Loaded {
  std::shared_ptr<detail::LibraryHandle> library;
  const PluginDescriptor* descriptor = nullptr;
  PluginLibraryInfo info;
};

namespace {

constexpr std::string_view kPrefix = "libvisnav_";
constexpr std::string_view kSuffix = ".so";

bool is_plugin_file_name(std::string_view name) {
  return name.size() > kPrefix.size() + kSuffix.size() && name.substr(0, kPrefix.size()) == kPrefix &&
         name.substr(name.size() - kSuffix.size()) == kSuffix;
}

std::string library_name_of(std::string_view file_name) {
  if (!is_plugin_file_name(file_name)) return std::string(file_name);
  return std::string(file_name.substr(kPrefix.size(), file_name.size() - kPrefix.size() - kSuffix.size()));
}

std::string absolute_path(const std::string& path) {
  std::error_code ec;
  fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
  if (ec) return path;
  return p.string();
}

std::string join(const std::vector<std::string>& items, const std::string& separator) {
  std::string out;
  for (const auto& item : items) {
    if (!out.empty()) out += separator;
    out += item;
  }
  return out;
}

std::string describe_search_path(const std::vector<std::string>& dirs) {
  if (dirs.empty()) return "(search path is empty)";
  std::vector<std::string> parts;
  for (const auto& d : dirs) {
    std::error_code ec;
    parts.push_back(fs::is_directory(d, ec) ? d : d + " (missing)");
  }
  return join(parts, ", ");
}

}  // namespace

std::optional<PluginKind> plugin_kind_from_string(std::string_view text) {
  if (text == "robot") return PluginKind::robot;
  if (text == "camera") return PluginKind::camera;
  if (text == "detector") return PluginKind::detector;
  if (text == "nodes") return PluginKind::nodes;
  return std::nullopt;
}

std::vector<std::string> PluginLoader::default_search_path() {
  std::vector<std::string> dirs{VISNAV_BUILD_PLUGIN_DIR, VISNAV_INSTALL_PLUGIN_DIR};
  if (const char* env = std::getenv("VISNAV_PLUGIN_PATH"); env != nullptr) {
    std::string current;
    for (const char* c = env;; ++c) {
      if (*c == ':' || *c == '\0') {
        if (!current.empty()) dirs.push_back(current);
        current.clear();
        if (*c == '\0') break;
      } else {
        current.push_back(*c);
      }
    }
  }
  return dirs;
}

PluginLoader::PluginLoader(std::vector<std::string> search_dirs) : search_dirs_(std::move(search_dirs)) {}

PluginLoader PluginLoader::with_default_path(const std::vector<std::string>& extra_dirs) {
  auto dirs = default_search_path();
  dirs.insert(dirs.end(), extra_dirs.begin(), extra_dirs.end());
  return PluginLoader(std::move(dirs));
}

PluginLoader::PluginLoader(PluginLoader&&) noexcept = default;
PluginLoader& PluginLoader::operator=(PluginLoader&&) noexcept = default;

PluginLoader::~PluginLoader() {
  // Newest first, so a library loaded later (possibly depending on an earlier one) goes first.
  while (!loaded_.empty()) loaded_.pop_back();
}

void PluginLoader::add_search_dir(std::string dir) { search_dirs_.push_back(std::move(dir)); }

Result<std::size_t> PluginLoader::scan() {
  std::size_t count = 0;
  std::map<std::string, std::string> first_by_name;  // file name -> absolute path
  for (const auto& l : loaded_) first_by_name.emplace(l->info.file_name, l->info.path);
  std::set<std::string> known_problems;
  for (const auto& p : problems_) known_problems.insert(p.path);

  for (const auto& dir : search_dirs_) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) continue;
    std::vector<fs::path> files;
    fs::directory_iterator it(dir, ec);
    if (ec) return fail(ErrorCode::io, {dir}, "cannot read plugin directory " + dir + ": " + ec.message());
    for (const auto& entry : it) {
      std::error_code fec;
      if (!entry.is_regular_file(fec)) continue;
      if (is_plugin_file_name(entry.path().filename().string())) files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
    for (const auto& file : files) {
      const std::string path = absolute_path(file.string());
      const std::string name = file.filename().string();
      auto first = first_by_name.find(name);
      if (first != first_by_name.end()) {
        if (first->second != path && known_problems.insert(path).second)
          problems_.push_back({path, "shadowed by " + first->second + " (earlier on the search path)"});
        continue;
      }
      if (known_problems.count(path) != 0) continue;
      auto loaded = load_path(path);
      if (!loaded) {
        std::string message = loaded.error().message;
        if (message.rfind(path + ": ", 0) == 0) message.erase(0, path.size() + 2);  // path is kept separately
        problems_.push_back({path, std::move(message)});
        known_problems.insert(path);
        continue;
      }
      first_by_name.emplace(name, path);
      ++count;
    }
  }
  return count;
}

Result<std::string> PluginLoader::resolve_library(std::string_view path_or_name,
                                                  std::vector<std::string>* tried) const {
  const std::string text(path_or_name);
  if (text.find('/') != std::string::npos) {
    if (tried != nullptr) tried->push_back(text);
    std::error_code ec;
    if (fs::is_regular_file(text, ec)) return absolute_path(text);
    return fail(ErrorCode::not_found, "plugin library " + text + " not found");
  }
  const std::string file_name = is_plugin_file_name(text) ? text : std::string(kPrefix) + text + std::string(kSuffix);
  for (const auto& dir : search_dirs_) {
    const std::string candidate = (fs::path(dir) / file_name).string();
    if (tried != nullptr) tried->push_back(candidate);
    std::error_code ec;
    if (fs::is_regular_file(candidate, ec)) return absolute_path(candidate);
  }
  return fail(ErrorCode::not_found, "plugin library '" + text + "' not found");
}

Result<const PluginLibraryInfo*> PluginLoader::load_library(std::string_view path_or_name) {
  if (const Loaded* l = find_loaded(path_or_name); l != nullptr) return &l->info;
  std::vector<std::string> tried;
  auto path = resolve_library(path_or_name, &tried);
  if (!path) {
    return fail(ErrorCode::not_found, "plugin library '" + std::string(path_or_name) + "' not found; tried: " +
                (tried.empty() ? std::string("(search path is empty)") : join(tried, ", ")));
  }
  return load_path(*path);
}

namespace {

using OpenedPlugin = std::pair<std::shared_ptr<detail::LibraryHandle>, const PluginDescriptor*>;

/// dlopen, the entry symbol and the checks made before any other field is read: the ABI
/// version, the descriptor's size and its name. The library stays open while the handle lives.
Result<OpenedPlugin> open_plugin(const std::string& path) {
  dlerror();  // clear
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* why = dlerror();
    return fail(ErrorCode::plugin, {path}, std::string("dlopen failed: ") + (why != nullptr ? why : "unknown error"));
  }
  auto library = std::make_shared<detail::LibraryHandle>(handle, path);

  dlerror();
  void* symbol = dlsym(handle, VISNAV_PLUGIN_ENTRY_SYMBOL);
  if (symbol == nullptr) {
    return fail(ErrorCode::plugin, {path}, "not a visnav plugin: entry symbol '" VISNAV_PLUGIN_ENTRY_SYMBOL
                "' not found (define it with VISNAV_PLUGIN(...))");
  }
  using EntryFn = const PluginDescriptor* (*)();
  auto entry = reinterpret_cast<EntryFn>(symbol);
  const PluginDescriptor* descriptor = nullptr;
  try {
    descriptor = entry();
  } catch (...) {
    return fail(ErrorCode::plugin, {path}, VISNAV_PLUGIN_ENTRY_SYMBOL "() threw an exception");
  }
  if (descriptor == nullptr) return fail(ErrorCode::plugin, {path}, VISNAV_PLUGIN_ENTRY_SYMBOL "() returned null");

  // The ABI version is the first field and the only one read before it is known to match.
  const std::uint32_t abi = *reinterpret_cast<const std::uint32_t*>(descriptor);
  if (abi != kPluginAbiVersion) {
    return fail(ErrorCode::plugin, {path}, "plugin ABI version " + std::to_string(abi) + " does not match the runtime's ABI version " +
                std::to_string(kPluginAbiVersion) + "; rebuild the plugin against this SDK");
  }
  if (descriptor->descriptor_size != sizeof(PluginDescriptor)) {
    return fail(ErrorCode::plugin, {path}, "descriptor size " + std::to_string(descriptor->descriptor_size) + " does not match " +
                std::to_string(sizeof(PluginDescriptor)) + " (plugin built against different SDK headers)");
  }
  if (descriptor->name == nullptr || descriptor->name[0] == '\0') return fail(ErrorCode::plugin, {path}, "descriptor has no name");

  return OpenedPlugin{library, descriptor};
}

/// The descriptor's type, command and payload-check tables, checked, into `info`.
Status read_tables(const PluginDescriptor* descriptor, const std::string& path, PluginLibraryInfo& info) {
  if (descriptor->type_count > 0 && descriptor->types == nullptr)
    return fail(ErrorCode::plugin, {path}, "descriptor declares " + std::to_string(descriptor->type_count) + " types but no table");
  for (std::size_t i = 0; i < descriptor->type_count; ++i) {
    const TypeEntry& t = descriptor->types[i];
    if (t.type_name == nullptr || t.type_name[0] == '\0') return fail(ErrorCode::plugin, {path}, "type #" + std::to_string(i) + " has no name");
    const auto kind_value = static_cast<std::uint32_t>(t.kind);
    if (t.kind != PluginKind::robot && t.kind != PluginKind::camera && t.kind != PluginKind::detector)
      return fail(ErrorCode::plugin, {path}, "type '" + std::string(t.type_name) + "' has kind " + std::to_string(kind_value) +
                  " (robot, camera or detector expected)");
    if (t.create == nullptr) return fail(ErrorCode::plugin, {path}, "type '" + std::string(t.type_name) + "' has no factory");
    for (std::size_t j = 0; j < i; ++j)
      if (descriptor->types[j].kind == t.kind && std::string_view(descriptor->types[j].type_name) == t.type_name)
        return fail(ErrorCode::plugin, {path}, std::string(to_string(t.kind)) + " type '" + std::string(t.type_name) +
                    "' is listed twice in the descriptor");
    info.types.push_back({t.kind, t.type_name});
  }
  info.kinds = descriptor_kinds(*descriptor);
  if (info.kinds.empty() && descriptor->command_count == 0)
    return fail(ErrorCode::plugin, {path}, "plugin '" + info.name + "' provides nothing (no types, no nodes, no commands)");
  if (descriptor->command_count > 0 && descriptor->commands == nullptr)
    return fail(ErrorCode::plugin, {path}, "descriptor declares commands but no table");
  for (std::size_t i = 0; i < descriptor->command_count; ++i) {
    const CommandEntry& c = descriptor->commands[i];
    if (c.name == nullptr || c.name[0] == '\0' || c.run == nullptr)
      return fail(ErrorCode::plugin, {path}, "command #" + std::to_string(i) + " has no name or no run function");
    info.command_names.emplace_back(c.name);
  }

  if (descriptor->payload_check_count > 0 && descriptor->payload_checks == nullptr)
    return fail(ErrorCode::plugin, {path}, "descriptor declares payload checks but no table");
  for (std::size_t i = 0; i < descriptor->payload_check_count; ++i) {
    const PayloadCheckEntry& c = descriptor->payload_checks[i];
    if (c.kind == nullptr || !map_format::valid_kind(c.kind) || c.check == nullptr)
      return fail(ErrorCode::plugin, {path}, "payload check #" + std::to_string(i) + " has no valid edge kind or no check function");
  }

  return ok();
}

}  // namespace

Result<const PluginLibraryInfo*> PluginLoader::load_path(const std::string& path) {
  for (const auto& l : loaded_)
    if (l->info.path == path) return &l->info;
  VISNAV_ASSIGN(OpenedPlugin opened, open_plugin(path));
  const PluginDescriptor* descriptor = opened.second;
  auto loaded = std::make_unique<Loaded>();
  loaded->library = std::move(opened.first);
  loaded->descriptor = descriptor;
  PluginLibraryInfo& info = loaded->info;
  info.path = path;
  info.file_name = fs::path(path).filename().string();
  info.library_name = library_name_of(info.file_name);
  info.name = descriptor->name;
  info.version = descriptor->version != nullptr ? descriptor->version : "";
  info.description = descriptor->description != nullptr ? descriptor->description : "";
  info.abi_version = descriptor->abi_version;
  VISNAV_TRY(read_tables(descriptor, path, info));

  // Report type clashes with libraries loaded earlier (both stay loaded; see find_type).
  for (const auto& type : info.types) {
    for (const auto& other : loaded_) {
      if (std::find(other->info.types.begin(), other->info.types.end(), type) != other->info.types.end()) {
        problems_.push_back({path, std::string("duplicate ") + to_string(type.kind) + " type '" + type.name +
                                       "': provided by both " + other->info.path + " and " + path});
      }
    }
  }

  loaded_.push_back(std::move(loaded));
  return &loaded_.back()->info;
}

const PluginLoader::Loaded* PluginLoader::find_loaded(std::string_view library) const {
  for (const auto& l : loaded_) {
    if (l->info.library_name == library || l->info.file_name == library || l->info.path == library ||
        l->info.name == library)
      return l.get();
  }
  if (library.find('/') != std::string_view::npos) {
    const std::string abs = absolute_path(std::string(library));
    for (const auto& l : loaded_)
      if (l->info.path == abs) return l.get();
  }
  return nullptr;
}

std::vector<const PluginLibraryInfo*> PluginLoader::libraries() const {
  std::vector<const PluginLibraryInfo*> out;
  for (const auto& l : loaded_) out.push_back(&l->info);
  return out;
}

std::vector<PluginTypeInfo> PluginLoader::types() const {
  std::vector<PluginTypeInfo> out;
  for (const auto& l : loaded_) {
    for (std::size_t i = 0; i < l->descriptor->type_count; ++i) {
      const TypeEntry& t = l->descriptor->types[i];
      out.push_back({t.kind, t.type_name, t.description != nullptr ? t.description : "", l->info.path});
    }
  }
  return out;
}

Result<PluginTypeInfo> PluginLoader::find_type(PluginKind kind, std::string_view type_name,
                                               std::string_view library) const {
  const std::string kind_name = to_string(kind);
  if (!library.empty()) {
    const Loaded* l = find_loaded(library);
    if (l == nullptr)
      return fail(ErrorCode::not_found, "plugin library '" + std::string(library) + "' is not loaded (search path: " +
                  describe_search_path(search_dirs_) + ")");
    if (!l->info.provides(kind))
      return fail(ErrorCode::not_found, "plugin library " + l->info.path + " provides no " + kind_name + " types (it provides: " +
                  l->info.kinds_text() + ")");
    for (std::size_t i = 0; i < l->descriptor->type_count; ++i) {
      const TypeEntry& t = l->descriptor->types[i];
      if (t.kind == kind && type_name == t.type_name)
        return PluginTypeInfo{kind, t.type_name, t.description != nullptr ? t.description : "", l->info.path};
    }
    return fail(ErrorCode::not_found, "plugin library " + l->info.path + " provides no " + kind_name + " type '" + std::string(type_name) +
                "' (its " + kind_name + " types: " + join(l->info.type_names(kind), ", ") + ")");
  }

  std::vector<PluginTypeInfo> matches;
  std::vector<std::string> known;
  for (const auto& t : types()) {
    if (t.kind != kind) continue;
    if (t.type_name == type_name) matches.push_back(t);
    known.push_back(t.type_name + " (" + fs::path(t.library_path).filename().string() + ")");
  }
  if (matches.size() == 1) return matches.front();
  if (matches.size() > 1) {
    std::vector<std::string> paths;
    for (const auto& m : matches) paths.push_back(m.library_path);
    return fail(ErrorCode::inconsistent, "duplicate " + kind_name + " type '" + std::string(type_name) + "': provided by both " +
                join(paths, " and ") + "; pin one with 'plugin: <library>'");
  }
  std::string message = "no " + kind_name + " plugin provides type '" + std::string(type_name) + "'; known " +
                        kind_name + " types: " + (known.empty() ? std::string("none") : join(known, ", ")) +
                        "; searched: " + describe_search_path(search_dirs_);
  if (!problems_.empty()) {
    std::vector<std::string> failed;
    for (const auto& p : problems_) failed.push_back(p.path + ": " + p.message);
    message += "; libraries not used: " + join(failed, "; ");
  }
  return fail(ErrorCode::not_found, std::move(message));
}

Result<std::vector<ParamDoc>> PluginLoader::param_docs(PluginKind kind, std::string_view type_name,
                                                       std::string_view library) const {
  VISNAV_ASSIGN(PluginTypeInfo info, find_type(kind, type_name, library));
  VISNAV_ASSIGN(const TypeEntry* t, type_entry(kind, type_name, info.library_path));
  if (t->param_docs == nullptr) return std::vector<ParamDoc>{};
  try {
    return t->param_docs();
  } catch (const std::exception& e) {
    return fail(ErrorCode::plugin, info.library_path + ": param docs of '" + std::string(type_name) + "' threw: " + e.what());
  } catch (...) {
    return fail(ErrorCode::plugin, info.library_path + ": param docs of '" + std::string(type_name) + "' threw");
  }
}

Result<const TypeEntry*> PluginLoader::type_entry(PluginKind kind, std::string_view type_name,
                                                  std::string_view library) const {
  VISNAV_ASSIGN(PluginTypeInfo info, find_type(kind, type_name, library));
  const Loaded* l = find_loaded(info.library_path);
  for (std::size_t i = 0; l != nullptr && i < l->descriptor->type_count; ++i) {
    const TypeEntry& t = l->descriptor->types[i];
    if (t.kind == kind && type_name == t.type_name) return &t;
  }
  return fail("internal: " + std::string(to_string(kind)) + " type '" + std::string(type_name) + "' vanished from " +
              info.library_path);
}

Result<PluginPtr<PluginObject>> PluginLoader::create_object(PluginKind kind, std::string_view type_name,
                                                            const ConfigNode& params, HostServices& host,
                                                            std::string_view library) {
  if (!library.empty() && find_loaded(library) == nullptr) {
    auto loaded = load_library(library);
    if (!loaded) return std::move(loaded).error();
  }
  VISNAV_ASSIGN(PluginTypeInfo info, find_type(kind, type_name, library));
  VISNAV_ASSIGN(const TypeEntry* entry, type_entry(kind, type_name, info.library_path));
  const Loaded* l = find_loaded(info.library_path);

  const std::string who = std::string(to_string(kind)) + " '" + std::string(type_name) + "' (" +
                          fs::path(info.library_path).filename().string() + ")";
  Result<std::unique_ptr<PluginObject>> made = fail("factory not called");
  try {
    made = entry->create(params, host);
  } catch (const std::exception& e) {
    return fail(ErrorCode::plugin, who + ": factory threw an exception: " + e.what());
  } catch (...) {
    return fail(ErrorCode::plugin, who + ": factory threw a non-standard exception");
  }
  if (!made) return made.error().with_context(who);
  std::unique_ptr<PluginObject> object = std::move(made).value();
  if (!object) return fail(ErrorCode::plugin, who + ": factory returned no object");
  return PluginPtr<PluginObject>(object.release(), PluginObjectDeleter{l->library});
}

std::vector<PluginLoader::NodesPlugin> PluginLoader::nodes_plugins() const {
  std::vector<NodesPlugin> out;
  for (const auto& l : loaded_)
    if (l->descriptor->register_nodes != nullptr) out.push_back({&l->info, l->descriptor->register_nodes});
  return out;
}

std::vector<PluginCommandInfo> PluginLoader::commands() const {
  std::vector<PluginCommandInfo> out;
  std::set<std::string> seen;
  for (const auto& l : loaded_) {
    for (std::size_t i = 0; i < l->descriptor->command_count; ++i) {
      const CommandEntry& c = l->descriptor->commands[i];
      if (!seen.insert(c.name).second) continue;
      out.push_back({c.name, c.summary != nullptr ? c.summary : "", l->info.path, c.run});
    }
  }
  return out;
}

std::vector<PayloadCheckInfo> PluginLoader::payload_checks() const {
  std::vector<PayloadCheckInfo> out;
  std::set<std::string, std::less<>> seen;
  for (const auto& l : loaded_) {
    for (std::size_t i = 0; i < l->descriptor->payload_check_count; ++i) {
      const PayloadCheckEntry& c = l->descriptor->payload_checks[i];
      if (!seen.insert(c.kind).second) continue;
      out.push_back({c.kind, c.check, l->info.path});
    }
  }
  return out;
}

void PluginLoader::install_payload_checks(MapStore& map) const {
  for (const auto& c : payload_checks()) map.set_payload_check(c.kind, c.check);
}

}  // namespace visnav
