// Internal: the node a `<SubTree ID="X">` element becomes (kind SubTree, one child: the
// root of tree X, instantiated with its own child blackboard).
#pragma once

#include "visnav/bt/node.hpp"

namespace visnav::bt::detail {

class SubTreeNode final : public DecoratorNode {
 public:
  SubTreeNode(const std::string& name, const NodeConfig& config, std::string subtree_id)
      : DecoratorNode(name, config), subtree_id_(std::move(subtree_id)) {}
  [[nodiscard]] NodeKind kind() const noexcept override { return NodeKind::subtree; }
  [[nodiscard]] const std::string& subtree_id() const noexcept { return subtree_id_; }

 protected:
  NodeStatus tick() override {
    if (status() == NodeStatus::idle) set_status(NodeStatus::running);
    const NodeStatus s = child_->execute_tick();
    if (is_completed(s)) reset_child();
    return s;
  }

 private:
  std::string subtree_id_;
};

}  // namespace visnav::bt::detail
