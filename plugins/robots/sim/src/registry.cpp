// Process-wide registry of simulated robots (weak references, guarded by one mutex).
#include "visnav_sim/registry.hpp"

#include <mutex>
#include <utility>

#include "visnav_sim/robot.hpp"

namespace visnav::sim {
namespace {

struct Registry {
  std::mutex mutex;
  std::vector<std::pair<std::string, std::weak_ptr<RobotCore>>> robots;

  void prune() {
    std::erase_if(robots, [](const auto& entry) { return entry.second.expired(); });
  }
};

Registry& registry() {
  static Registry r;
  return r;
}

}  // namespace

Status register_robot(const std::string& name, const std::shared_ptr<RobotCore>& core) {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  r.prune();
  for (const auto& [n, weak] : r.robots)
    if (n == name) return fail("a simulated robot named '" + name + "' already exists (give the robot another 'name')");
  r.robots.emplace_back(name, core);
  return ok();
}

void unregister_robot(const std::string& name, const RobotCore* core) {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  std::erase_if(r.robots, [&](const auto& entry) {
    auto locked = entry.second.lock();
    return entry.first == name && (locked == nullptr || locked.get() == core);
  });
  r.prune();
}

Result<std::shared_ptr<RobotCore>> find_robot(const std::string& name) {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  r.prune();
  std::string names;
  for (const auto& [n, weak] : r.robots) {
    if (name.empty() || n == name) {
      if (auto core = weak.lock()) return core;
    }
    names += (names.empty() ? "" : ", ") + n;
  }
  if (name.empty()) return fail("no simulated robot exists (create a robot of type 'sim' before the 'sim' camera)");
  return fail("no simulated robot named '" + name + "' (existing: " + (names.empty() ? "none" : names) + ")");
}

std::vector<std::string> robot_names() {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  r.prune();
  std::vector<std::string> out;
  for (const auto& [n, weak] : r.robots) out.push_back(n);
  return out;
}

}  // namespace visnav::sim
