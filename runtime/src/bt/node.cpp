// TreeNode: port access helpers, observers and the fallback clock.
#include "visnav/bt/node.hpp"

#include <chrono>

namespace visnav::bt {

namespace detail {

void TreeContext::notify(const TreeNode& node, NodeStatus from, NodeStatus to) const {
  const double t_s = clock != nullptr ? clock->now_s() : fallback_clock().now_s();
  // Index loop: an observer may add observers (they see the next transition).
  for (std::size_t i = 0; i < observers.size(); ++i) observers[i].second(t_s, node, from, to);
}

namespace {
class MonotonicClock final : public Clock {
 public:
  [[nodiscard]] double now_s() const override {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  }
};
}  // namespace

const Clock& fallback_clock() noexcept {
  static const MonotonicClock clock;
  return clock;
}

}  // namespace detail

std::string NodePath::str() const {
  std::size_t length = 0;
  std::size_t depth = 0;
  for (const NodePath* p = this; p != nullptr; p = p->parent.get()) {
    length += p->component.size() + 1;
    ++depth;
  }
  std::string out(length > 0 ? length - 1 : 0, '/');
  std::size_t end = out.size();
  for (const NodePath* p = this; p != nullptr; p = p->parent.get()) {
    end -= p->component.size();
    out.replace(end, p->component.size(), p->component);
    if (end > 0) --end;  // the '/' separator already in place
  }
  return out;
}

std::shared_ptr<const NodePath> NodePath::make(std::shared_ptr<const NodePath> parent, std::string component) {
  auto p = std::make_shared<NodePath>();
  p->parent = std::move(parent);
  p->component = std::move(component);
  return p;
}

NodePath::~NodePath() {
  // Each step copies the grandparent before dropping the parent, so the parent's destructor
  // sees its own parent still shared and stops: constant stack depth.
  std::shared_ptr<const NodePath> p = std::move(parent);
  while (p && p.use_count() == 1) {
    std::shared_ptr<const NodePath> next = p->parent;
    p = std::move(next);
  }
}

TreeNode::TreeNode(const std::string& name, const NodeConfig& config) : name_(name), config_(config) {
  if (!config_.blackboard) config_.blackboard = Blackboard::create();
}

Error TreeNode::port_error(std::string_view port_name, std::string_view message) const {
  std::string where = config_.path ? config_.path->str() : name_;
  return Error{where + ": port '" + std::string(port_name) + "' " + std::string(message)};
}

const Blackboard::Entry* TreeNode::input_entry(const PortBinding& b) const {
  if (b.cached_entry != nullptr) return b.cached_entry;
  Blackboard::Entry* e = config_.blackboard->find_entry(b.key);
  if (e != nullptr) b.cached_entry = e;  // entries are never removed
  return e;
}

Blackboard::Entry* TreeNode::output_entry(const PortBinding& b) {
  if (b.cached_entry != nullptr) return b.cached_entry;
  Blackboard::Entry* e = &config_.blackboard->get_or_create_entry(b.key);
  b.cached_entry = e;
  return e;
}

}  // namespace visnav::bt
