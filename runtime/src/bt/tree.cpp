// Tree: ticking, halting, observers; TraceWriter.
#include "visnav/bt/tree.hpp"

#include <algorithm>
#include <thread>

namespace visnav::bt {

Tree::Tree() = default;

namespace {
// Children are created after their parents, so destroying from the back frees every NodePath
// while its parent's node still holds the parent path: no release chain as deep as the tree.
void destroy_nodes(std::vector<std::unique_ptr<TreeNode>>& nodes) {
  while (!nodes.empty()) nodes.pop_back();
}
}  // namespace

Tree::Tree(Tree&& other) noexcept
    : context_(std::move(other.context_)),
      nodes_(std::move(other.nodes_)),
      root_(std::exchange(other.root_, nullptr)),
      blackboard_(std::move(other.blackboard_)),
      main_tree_id_(std::move(other.main_tree_id_)),
      last_error_(std::move(other.last_error_)) {}

Tree& Tree::operator=(Tree&& other) noexcept {
  if (this != &other) {
    if (root_ != nullptr && root_->status() == NodeStatus::running) root_->halt_node();
    destroy_nodes(nodes_);
    context_ = std::move(other.context_);
    nodes_ = std::move(other.nodes_);
    root_ = std::exchange(other.root_, nullptr);
    blackboard_ = std::move(other.blackboard_);
    main_tree_id_ = std::move(other.main_tree_id_);
    last_error_ = std::move(other.last_error_);
  }
  return *this;
}

Tree::~Tree() {
  if (root_ != nullptr && root_->status() == NodeStatus::running) root_->halt_node();
  destroy_nodes(nodes_);  // before the context the nodes point to
}

NodeStatus Tree::tick_once() {
  if (is_completed(root_->status()) || root_->status() == NodeStatus::skipped) root_->reset_status();
  try {
    return root_->execute_tick();
  } catch (const std::exception& e) {
    last_error_ = std::string("exception during tick: ") + e.what();
  } catch (...) {
    last_error_ = "non-standard exception during tick";
  }
  halt_after_exception();
  return NodeStatus::failure;
}

void Tree::halt_after_exception() noexcept {
  // Halt every RUNNING node (deepest first) even if the throwing node left its parents
  // inconsistent, then reset everything to IDLE.
  std::vector<TreeNode*> order;
  order.reserve(nodes_.size());
  try {
    visit([&order](TreeNode& n) { order.push_back(&n); });
  } catch (...) {
    return;
  }
  for (auto it = order.rbegin(); it != order.rend(); ++it) {
    try {
      (*it)->halt_node();
    } catch (...) {
      // keep halting the others
    }
  }
}

NodeStatus Tree::tick_while_running(std::chrono::nanoseconds sleep) {
  NodeStatus s = tick_once();
  while (s == NodeStatus::running) {
    if (sleep.count() > 0) std::this_thread::sleep_for(sleep);
    s = tick_once();
  }
  return s;
}

void Tree::halt() { root_->halt_node(); }

NodeStatus Tree::status() const noexcept { return root_->status(); }

const Clock& Tree::clock() const noexcept {
  return context_ && context_->clock != nullptr ? *context_->clock : detail::fallback_clock();
}

void Tree::visit(const std::function<void(TreeNode&)>& visitor) const {
  std::vector<TreeNode*> stack{root_};
  while (!stack.empty()) {
    TreeNode* n = stack.back();
    stack.pop_back();
    visitor(*n);
    auto children = n->children();
    for (auto it = children.rbegin(); it != children.rend(); ++it) stack.push_back(*it);
  }
}

TreeNode* Tree::find_node(std::string_view path) const {
  for (const auto& n : nodes_)
    if (n->path() == path) return n.get();
  return nullptr;
}

std::uint64_t Tree::add_observer(StatusObserver observer) {
  const std::uint64_t id = context_->next_observer_id++;
  context_->observers.emplace_back(id, std::move(observer));
  return id;
}

void Tree::remove_observer(std::uint64_t id) {
  auto& obs = context_->observers;
  obs.erase(std::remove_if(obs.begin(), obs.end(), [id](const auto& o) { return o.first == id; }), obs.end());
}

// ---- TraceWriter ---------------------------------------------------------------------------

Result<std::unique_ptr<TraceWriter>> TraceWriter::attach(Tree& tree, const std::filesystem::path& file) {
  std::FILE* f = std::fopen(file.string().c_str(), "w");
  if (f == nullptr) return fail(ErrorCode::io, {file.string()}, "cannot open the trace file for writing");
  return std::unique_ptr<TraceWriter>(new TraceWriter(tree, f));
}

TraceWriter::TraceWriter(Tree& tree, std::FILE* file) : context_(tree.context_.get()), file_(file) {
  observer_id_ = tree.add_observer(
      [this](double t_s, const TreeNode& node, NodeStatus from, NodeStatus to) { write(t_s, node, from, to); });
}

TraceWriter::~TraceWriter() {
  auto& obs = context_->observers;
  const std::uint64_t id = observer_id_;
  obs.erase(std::remove_if(obs.begin(), obs.end(), [id](const auto& o) { return o.first == id; }), obs.end());
  std::fclose(file_);
}

void TraceWriter::flush() { std::fflush(file_); }

void TraceWriter::write(double t_s, const TreeNode& node, NodeStatus from, NodeStatus to) {
  std::fprintf(file_, "{\"t\":%.6f,\"node\":\"", t_s);
  for (const char c : node.path()) {
    switch (c) {
      case '"': std::fputs("\\\"", file_); break;
      case '\\': std::fputs("\\\\", file_); break;
      case '\n': std::fputs("\\n", file_); break;
      case '\t': std::fputs("\\t", file_); break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          std::fprintf(file_, "\\u%04x", static_cast<unsigned>(c));
        } else {
          std::fputc(c, file_);
        }
    }
  }
  std::fprintf(file_, "\",\"from\":\"%s\",\"to\":\"%s\"}\n", to_string(from), to_string(to));
  ++lines_;
}

}  // namespace visnav::bt
