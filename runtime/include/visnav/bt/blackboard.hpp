// visnav behaviour trees — the blackboard: typed key/value storage shared by the nodes of a tree.
//
// Values are stored type-erased (std::any). `get<T>` returns the stored T, or converts:
//  * a stored std::string to T with PortConverter<T> (so `SetBlackboard value="3.5"` can be read
//    as a double),
//  * int <-> double <-> unsigned (to an integer only when integral and in range), int -> enum,
//  * int / unsigned / double / bool -> std::string.
//
// Scopes (SubTree): every SubTree instance gets a child blackboard whose parent is the
// blackboard of the tree that contains the SubTree node. A child resolves a key as follows
// (BehaviorTree.CPP v4 semantics):
//  1. a key starting with '@' is looked up (and created) in the root blackboard;
//  2. a key with an explicit remapping (add_subtree_remapping) resolves to the parent's entry;
//  3. with auto-remapping on, a key that is not private (private keys start with '_') resolves
//     to the parent's entry of the same name;
//  4. otherwise the entry is local.
// Writes to a missing key create the entry where the lookup would have found it.
// Entries are never removed, so an Entry* stays valid as long as its blackboard lives (nodes
// cache them).
//
// Ownership: blackboards are shared (std::shared_ptr); a child keeps its parent alive.
// Thread-safety: none. Use from the tick thread only (or while no tree is being ticked).
#pragma once

#include <any>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <typeindex>
#include <typeinfo>
#include <unordered_map>
#include <vector>

#include "visnav/bt/ports.hpp"
#include "visnav/result.hpp"

namespace visnav::bt {

namespace detail {
struct StringHash {
  using is_transparent = void;
  std::size_t operator()(std::string_view s) const noexcept { return std::hash<std::string_view>{}(s); }
};
/// Human-readable name of the type held by an any ("double", "std::string", or the mangled name).
std::string any_type_name(const std::any& value);

/// Reads `value` as T with the blackboard's conversion rules (see file comment).
template <typename T>
Result<T> any_to(const std::any& value, const EnumTables* enums) {
  if (const T* v = std::any_cast<T>(&value)) return *v;
  if (!value.has_value()) return fail("entry has no value");
  if constexpr (!std::is_same_v<T, std::string>) {
    if (const auto* s = std::any_cast<std::string>(&value)) return PortConverter<T>::parse(*s, enums);
  }
  if constexpr (std::is_same_v<T, double>) {
    if (const int* i = std::any_cast<int>(&value)) return static_cast<double>(*i);
    if (const unsigned* u = std::any_cast<unsigned>(&value)) return static_cast<double>(*u);
  } else if constexpr (std::is_same_v<T, int>) {
    if (const double* d = std::any_cast<double>(&value)) {
      if (std::trunc(*d) == *d && std::fabs(*d) < 2147483647.0) return static_cast<int>(*d);
    }
    if (const unsigned* u = std::any_cast<unsigned>(&value)) {
      if (*u <= 2147483647u) return static_cast<int>(*u);
    }
  } else if constexpr (std::is_same_v<T, unsigned>) {
    if (const int* i = std::any_cast<int>(&value)) {
      if (*i >= 0) return static_cast<unsigned>(*i);
    }
    if (const double* d = std::any_cast<double>(&value)) {
      if (std::trunc(*d) == *d && *d >= 0.0 && *d <= 4294967295.0) return static_cast<unsigned>(*d);
    }
  } else if constexpr (std::is_enum_v<T>) {
    if (const int* i = std::any_cast<int>(&value)) return static_cast<T>(*i);
  } else if constexpr (std::is_same_v<T, std::string>) {
    if (const int* i = std::any_cast<int>(&value)) return std::to_string(*i);
    if (const unsigned* u = std::any_cast<unsigned>(&value)) return std::to_string(*u);
    if (const bool* b = std::any_cast<bool>(&value)) return std::string(*b ? "true" : "false");
    if (const double* d = std::any_cast<double>(&value)) {
      char buf[64];
      auto [p, ec] = std::to_chars(buf, buf + sizeof(buf), *d);
      return std::string(buf, ec == std::errc{} ? p : buf);
    }
  }
  return fail("holds a value of type " + any_type_name(value) + ", not " + PortConverter<T>::type_name());
}
}  // namespace detail

class Blackboard {
 public:
  using Ptr = std::shared_ptr<Blackboard>;

  struct Entry {
    std::any value;
    std::uint64_t sequence = 0;  ///< incremented on every write (lets readers detect updates)
    /// Declared type: set by the first port that references the key when the tree is loaded
    /// (typed blackboard); typeid(void) while untyped. Writes of strings (SetBlackboard,
    /// scripts) are converted to it with `parse`.
    std::type_index type = std::type_index(typeid(void));
    std::string type_name;              ///< e.g. "int", for messages
    PortInfo::Parser parse = nullptr;   ///< text -> value of `type`
  };

  /// A new blackboard; with a parent it is a SubTree scope (no remapping until configured).
  /// A child inherits the parent's enum tables.
  [[nodiscard]] static Ptr create(Ptr parent = nullptr);

  Blackboard(const Blackboard&) = delete;
  Blackboard& operator=(const Blackboard&) = delete;
  /// Releases a chain of parents held only by this scope iteratively (SubTree depth is
  /// configurable; destruction must not recurse once per level).
  ~Blackboard();

  /// Writes `value` (stored as std::decay_t<T>; string literals as std::string).
  template <typename T>
  void set(std::string_view key, T value) {
    if constexpr (std::is_convertible_v<T, std::string_view> && !std::is_same_v<std::decay_t<T>, std::string>) {
      set_any(key, std::any(std::string(std::string_view(value))));
    } else {
      set_any(key, std::any(std::move(value)));
    }
  }
  void set_any(std::string_view key, std::any value);

  /// Reads `key` as T (see conversion rules above). Error names the key.
  template <typename T>
  [[nodiscard]] Result<T> get(std::string_view key) const {
    const Entry* e = find_entry(key);
    if (e == nullptr) return fail("blackboard key '" + std::string(key) + "' is not set");
    auto v = detail::any_to<T>(e->value, enums_.get());
    if (!v) return v.error().with_context("blackboard key '" + std::string(key) + "'");
    return v;
  }

  /// Stored value, or nullptr when the key is not set.
  [[nodiscard]] const std::any* get_any(std::string_view key) const;
  /// True when `key` resolves to an entry holding a value.
  [[nodiscard]] bool has(std::string_view key) const { return get_any(key) != nullptr; }
  /// Removes the value of `key` (UnsetBlackboard); the entry and its declared type stay, so
  /// cached Entry pointers remain valid. Counts as a write (sequence is incremented).
  void unset(std::string_view key);

  /// The entry `key` resolves to (see scope rules), or nullptr.
  [[nodiscard]] Entry* find_entry(std::string_view key);
  [[nodiscard]] const Entry* find_entry(std::string_view key) const;
  /// The entry `key` resolves to, created (empty) if missing.
  Entry& get_or_create_entry(std::string_view key);

  /// SubTree remapping: `internal` in this blackboard is `external` in the parent
  /// (`external` may start with '@' for the root).
  void add_subtree_remapping(std::string internal, std::string external);
  void enable_auto_remapping(bool enabled) noexcept { auto_remapping_ = enabled; }
  [[nodiscard]] bool auto_remapping() const noexcept { return auto_remapping_; }

  [[nodiscard]] Blackboard* parent() const noexcept { return parent_.get(); }
  [[nodiscard]] Blackboard& root() noexcept;

  /// Keys stored locally in this blackboard (not the parent's), sorted.
  [[nodiscard]] std::vector<std::string> keys() const;

  /// Enum tables used for string -> enum conversion (set by the tree loader).
  void set_enum_tables(std::shared_ptr<const EnumTables> enums) { enums_ = std::move(enums); }
  [[nodiscard]] const EnumTables* enums() const noexcept { return enums_.get(); }

 private:
  struct PrivateTag {};

 public:
  Blackboard(PrivateTag, Ptr parent);  // use create()

 private:
  Entry* resolve(std::string_view key, bool create);

  Ptr parent_;
  std::unordered_map<std::string, std::unique_ptr<Entry>, detail::StringHash, std::equal_to<>> storage_;
  std::unordered_map<std::string, std::string, detail::StringHash, std::equal_to<>> remapping_;
  bool auto_remapping_ = false;
  std::shared_ptr<const EnumTables> enums_;
};

}  // namespace visnav::bt
