// Blackboard: entries, SubTree remapping and root references.
#include "visnav/bt/blackboard.hpp"

#include <algorithm>
#include <cxxabi.h>
#include <cstdlib>

namespace visnav::bt {

namespace detail {
std::string any_type_name(const std::any& value) {
  const std::type_info& t = value.type();
  if (t == typeid(std::string)) return "std::string";
  if (t == typeid(int)) return "int";
  if (t == typeid(double)) return "double";
  if (t == typeid(bool)) return "bool";
  if (t == typeid(void)) return "nothing";
  int status = 0;
  char* demangled = abi::__cxa_demangle(t.name(), nullptr, nullptr, &status);
  std::string out = status == 0 && demangled != nullptr ? demangled : t.name();
  std::free(demangled);  // NOLINT(cppcoreguidelines-no-malloc)
  return out;
}
}  // namespace detail

Blackboard::Blackboard(PrivateTag, Ptr parent) : parent_(std::move(parent)) {
  if (parent_) enums_ = parent_->enums_;
}

Blackboard::~Blackboard() {
  Ptr p = std::move(parent_);
  while (p && p.use_count() == 1) {
    Ptr next = p->parent_;  // p's destructor then sees its parent shared and stops
    p = std::move(next);
  }
}

Blackboard::Ptr Blackboard::create(Ptr parent) { return std::make_shared<Blackboard>(PrivateTag{}, std::move(parent)); }

Blackboard& Blackboard::root() noexcept {
  Blackboard* b = this;
  while (b->parent_) b = b->parent_.get();
  return *b;
}

// A loop, not recursion: a remapped key may climb as many scopes as SubTrees nest.
Blackboard::Entry* Blackboard::resolve(std::string_view key, bool create) {
  Blackboard* b = this;
  for (;;) {
    if (!key.empty() && key.front() == '@') {
      b = &b->root();
      key.remove_prefix(1);
      continue;
    }
    if (auto it = b->storage_.find(key); it != b->storage_.end()) return it->second.get();
    if (b->parent_) {
      if (auto rm = b->remapping_.find(key); rm != b->remapping_.end()) {
        key = rm->second;
        b = b->parent_.get();
        continue;
      }
      if (b->auto_remapping_ && (key.empty() || key.front() != '_')) {
        b = b->parent_.get();
        continue;
      }
    }
    if (!create) return nullptr;
    auto [it, inserted] = b->storage_.emplace(std::string(key), std::make_unique<Entry>());
    return it->second.get();
  }
}

Blackboard::Entry* Blackboard::find_entry(std::string_view key) {
  if (key.empty()) return nullptr;
  return resolve(key, false);
}

const Blackboard::Entry* Blackboard::find_entry(std::string_view key) const {
  if (key.empty()) return nullptr;
  return const_cast<Blackboard*>(this)->resolve(key, false);  // resolve(…, false) does not modify
}

Blackboard::Entry& Blackboard::get_or_create_entry(std::string_view key) { return *resolve(key, true); }

void Blackboard::set_any(std::string_view key, std::any value) {
  Entry& e = get_or_create_entry(key);
  e.value = std::move(value);
  ++e.sequence;
}

void Blackboard::unset(std::string_view key) {
  if (Entry* e = find_entry(key); e != nullptr && e->value.has_value()) {
    e->value.reset();
    ++e->sequence;
  }
}

const std::any* Blackboard::get_any(std::string_view key) const {
  const Entry* e = find_entry(key);
  return e != nullptr && e->value.has_value() ? &e->value : nullptr;
}

void Blackboard::add_subtree_remapping(std::string internal, std::string external) {
  remapping_[std::move(internal)] = std::move(external);
}

std::vector<std::string> Blackboard::keys() const {
  std::vector<std::string> out;
  out.reserve(storage_.size());
  for (const auto& [k, v] : storage_) out.push_back(k);
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace visnav::bt
