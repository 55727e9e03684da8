// Internal: keeps the C++ stack that ticking and halting use bounded, whatever the tree's depth.
//
// execute_tick() and halt_node() are plain calls from parent to child (the SDK contract, as in
// BehaviorTree.CPP), so a tree N levels deep nests N calls. The loader marks every
// kCheckpointInterval-th level of the expanded tree as a checkpoint (its node gets a NodeScripts
// with `checkpoint` set, which routes it through the out-of-line path of execute_tick()).
// At a checkpoint, StackSegments::run() looks at how much of the stack in use lies between
// the top of that stack and the current frame: under kBudgetBytes the node runs in place; over
// it, the node and everything below it continue on a separate stack segment (mmap'ed, with a
// guard page) and the call returns to the original stack when the node's tick/halt returns.
// So the thread's own stack holds at most kBudgetBytes plus one stretch of
// kCheckpointInterval levels, and a very deep tree uses one segment per budget's worth of
// levels. Segments are kept and reused (LIFO) for the tree's lifetime; a tree that never
// exceeds the budget (every realistic mission) never allocates one.
//
// Exceptions thrown below a switch are caught on the segment and rethrown on the caller's
// stack. AddressSanitizer is told about each switch (fiber annotations).
//
// Thread-safety: one instance per tree, used from the tick thread only.
#pragma once

#include <cstddef>
#include <vector>

namespace visnav::bt::detail {

class StackSegments {
 public:
  static constexpr int kCheckpointInterval = 64;               ///< levels between checkpoints
  static constexpr std::size_t kBudgetBytes = 256 * 1024;       ///< stack used before switching
  static constexpr std::size_t kSegmentBytes = 8 * 1024 * 1024;  ///< as a default thread stack

  StackSegments() = default;
  ~StackSegments();
  StackSegments(const StackSegments&) = delete;
  StackSegments& operator=(const StackSegments&) = delete;

  /// Calls fn(arg) in place or on a fresh segment (see the file comment). Exceptions thrown by
  /// fn propagate to the caller. If a segment cannot be mapped, fn runs in place.
  void run(void (*fn)(void*), void* arg);

  /// Calls f() through run().
  template <typename F>
  void run(F& f) {
    run([](void* p) { (*static_cast<F*>(p))(); }, &f);
  }

  /// Segments mapped so far (for tests).
  [[nodiscard]] std::size_t segments() const noexcept { return pool_.size(); }
  /// Times a call moved to a segment (for tests).
  [[nodiscard]] std::size_t switches() const noexcept { return switches_; }

 private:
  struct Segment {
    char* base = nullptr;  ///< lowest address of the mapping (the guard page)
    std::size_t size = 0;  ///< whole mapping, guard page included
  };
  char* top_ = nullptr;  ///< highest address of the stack in use, nullptr outside a call
  std::vector<Segment> pool_;
  std::size_t in_use_ = 0;
  std::size_t switches_ = 0;
};

}  // namespace visnav::bt::detail
