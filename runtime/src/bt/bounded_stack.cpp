// StackSegments: calling a function on a fresh stack segment (see bounded_stack.hpp).
// On x86-64 the switch is a six-instruction assembly function (save the frame pointer, load
// the segment's top, call, restore); elsewhere it uses ucontext, whose swapcontext costs
// system calls (the signal mask). Either way switches happen only at checkpoints and only past
// the budget: ordinary trees never switch.
#include "bounded_stack.hpp"

#include <sys/mman.h>
#include <unistd.h>
#if !defined(__x86_64__)
#include <ucontext.h>
#endif

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

#if defined(__x86_64__)
// visnav_bt_call_on_stack(arg, fn, top): calls fn(arg) with the stack pointer at `top` (16-byte
// aligned) and returns on the original stack. A real function with call-frame information:
// rbp holds the caller's frame, so debuggers, profilers and unwinders walk from the segment
// back to the original stack.
asm(R"(
  .pushsection .text
  .p2align 4
  .globl visnav_bt_call_on_stack
  .hidden visnav_bt_call_on_stack
  .type visnav_bt_call_on_stack, @function
visnav_bt_call_on_stack:
  .cfi_startproc
  pushq %rbp
  .cfi_def_cfa_offset 16
  .cfi_offset %rbp, -16
  movq %rsp, %rbp
  .cfi_def_cfa_register %rbp
  movq %rdx, %rsp
  callq *%rsi
  movq %rbp, %rsp
  popq %rbp
  .cfi_def_cfa %rsp, 8
  ret
  .cfi_endproc
  .size visnav_bt_call_on_stack, .-visnav_bt_call_on_stack
  .popsection
)");
extern "C" __attribute__((visibility("hidden"))) void visnav_bt_call_on_stack(void* arg, void (*fn)(void*), char* top);
#endif

namespace visnav::bt::detail {

namespace {

struct Call {
  void (*fn)(void*) = nullptr;
  void* arg = nullptr;
  std::exception_ptr error;
  const void* caller_stack_bottom = nullptr;  // for the ASan annotations
  std::size_t caller_stack_size = 0;
#if !defined(__x86_64__)
  ucontext_t caller{};
#endif
};

// Runs on the segment: the call, with every exception caught (no unwinding may cross the
// switch; it is rethrown on the caller's stack).
void run_call(Call* call) {
#ifdef VISNAV_ASAN_FIBERS
  __sanitizer_finish_switch_fiber(nullptr, &call->caller_stack_bottom, &call->caller_stack_size);
#endif
  try {
    call->fn(call->arg);
  } catch (...) {
    call->error = std::current_exception();
  }
#ifdef VISNAV_ASAN_FIBERS
  // This fiber ends here (the segment starts afresh on its next use).
  __sanitizer_start_switch_fiber(nullptr, call->caller_stack_bottom, call->caller_stack_size);
#endif
}

#if defined(__x86_64__)
void call_on_segment(Call* call, char* top) {
  visnav_bt_call_on_stack(call, [](void* c) { run_call(static_cast<Call*>(c)); }, top);
}
#else
// makecontext passes int arguments only: the Call pointer travels as two halves.
void trampoline(unsigned hi, unsigned lo) {
  auto* call = reinterpret_cast<Call*>((static_cast<std::uintptr_t>(hi) << 32) | static_cast<std::uintptr_t>(lo));
  run_call(call);
  setcontext(&call->caller);
}

void call_on_segment(Call* call, char* base, std::size_t size) {
  ucontext_t target{};
  getcontext(&target);
  target.uc_stack.ss_sp = base;
  target.uc_stack.ss_size = size;
  target.uc_link = nullptr;  // trampoline() never returns; it resumes `call->caller`
  const auto bits = reinterpret_cast<std::uintptr_t>(call);
  makecontext(&target, reinterpret_cast<void (*)()>(&trampoline), 2, static_cast<unsigned>(bits >> 32),
              static_cast<unsigned>(bits & 0xffffffffu));
  swapcontext(&call->caller, &target);
}
#endif

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
#ifdef VISNAV_ASAN_FIBERS
  void* fake_stack = nullptr;
  __sanitizer_start_switch_fiber(&fake_stack, segment.base, segment.size);
#endif
#if defined(__x86_64__)
  call_on_segment(&call, segment.base + segment.size);
#else
  call_on_segment(&call, segment.base, segment.size);
#endif
#ifdef VISNAV_ASAN_FIBERS
  __sanitizer_finish_switch_fiber(fake_stack, nullptr, nullptr);
#endif
  --in_use_;
  if (call.error) std::rethrow_exception(call.error);
}

}  // namespace visnav::bt::detail
