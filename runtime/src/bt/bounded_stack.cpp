// StackSegments: switching to a fresh stack segment with ucontext (see bounded_stack.hpp).
// swapcontext costs a system call (the signal mask), which is why switches happen only at
// checkpoints and only past the budget: ordinary trees never pay it.
#include "bounded_stack.hpp"

#include <sys/mman.h>
#include <ucontext.h>
#include <unistd.h>

#include <cstdint>
#include <exception>

#if defined(__SANITIZE_ADDRESS__)
#define VISNAV_ASAN_FIBERS 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define VISNAV_ASAN_FIBERS 1
#endif
#endif
#ifdef VISNAV_ASAN_FIBERS
#include <sanitizer/common_interface_defs.h>
#endif

namespace visnav::bt::detail {

namespace {

struct Call {
  void (*fn)(void*) = nullptr;
  void* arg = nullptr;
  std::exception_ptr error;
  ucontext_t caller{};
  const void* caller_stack_bottom = nullptr;  // for the ASan annotations
  std::size_t caller_stack_size = 0;
};

// makecontext passes int arguments only: the Call pointer travels as two halves.
void trampoline(unsigned hi, unsigned lo) {
  auto* call = reinterpret_cast<Call*>((static_cast<std::uintptr_t>(hi) << 32) | static_cast<std::uintptr_t>(lo));
#ifdef VISNAV_ASAN_FIBERS
  __sanitizer_finish_switch_fiber(nullptr, &call->caller_stack_bottom, &call->caller_stack_size);
#endif
  try {
    call->fn(call->arg);
  } catch (...) {
    call->error = std::current_exception();  // rethrown on the caller's stack
  }
#ifdef VISNAV_ASAN_FIBERS
  // This fiber ends here (the segment is prepared afresh for its next use).
  __sanitizer_start_switch_fiber(nullptr, call->caller_stack_bottom, call->caller_stack_size);
#endif
  setcontext(&call->caller);
}

struct ResetTop {
  char*& top;
  char* saved;
  ~ResetTop() { top = saved; }
};

}  // namespace

StackSegments::~StackSegments() {
  for (const Segment& s : pool_) munmap(s.base, s.size);
}

void StackSegments::run(void (*fn)(void*), void* arg) {
  char* const here = static_cast<char*>(__builtin_frame_address(0));
  if (top_ == nullptr) {  // outermost checkpoint of this call chain: the stack's top is here
    ResetTop reset{top_, nullptr};
    top_ = here;
    fn(arg);
    return;
  }
  if (here > top_ || static_cast<std::size_t>(top_ - here) < kBudgetBytes) {
    fn(arg);
    return;
  }
  if (in_use_ == pool_.size()) {
    const std::size_t page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
    void* m = mmap(nullptr, kSegmentBytes + page, PROT_READ | PROT_WRITE,
                   MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE | MAP_STACK, -1, 0);
    if (m == MAP_FAILED) {  // no memory for a segment: carry on in place
      fn(arg);
      return;
    }
    mprotect(m, page, PROT_NONE);  // guard page: an overflow faults instead of corrupting
    pool_.push_back(Segment{static_cast<char*>(m), kSegmentBytes + page});
  }
  const Segment segment = pool_[in_use_];  // a copy: nested calls may grow pool_
  ++in_use_;
  ++switches_;
  ResetTop reset{top_, top_};
  top_ = segment.base + segment.size;

  Call call;
  call.fn = fn;
  call.arg = arg;
  ucontext_t target{};
  getcontext(&target);
  target.uc_stack.ss_sp = segment.base;
  target.uc_stack.ss_size = segment.size;
  target.uc_link = nullptr;  // trampoline() never returns; it resumes `call.caller`
  const auto bits = reinterpret_cast<std::uintptr_t>(&call);
  makecontext(&target, reinterpret_cast<void (*)()>(&trampoline), 2, static_cast<unsigned>(bits >> 32),
              static_cast<unsigned>(bits & 0xffffffffu));
#ifdef VISNAV_ASAN_FIBERS
  void* fake_stack = nullptr;
  __sanitizer_start_switch_fiber(&fake_stack, segment.base, segment.size);
#endif
  swapcontext(&call.caller, &target);
#ifdef VISNAV_ASAN_FIBERS
  __sanitizer_finish_switch_fiber(fake_stack, nullptr, nullptr);
#endif
  --in_use_;
  if (call.error) std::rethrow_exception(call.error);
}

}  // namespace visnav::bt::detail
