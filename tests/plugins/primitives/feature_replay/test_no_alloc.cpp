// The per-frame paths do not allocate once warmed up: global operator new is counted while a
// replayer step / estimate runs on inputs of sizes already seen. (cv::Mat buffers come from
// cv::fastMalloc, not operator new; the core keeps those in capacity buffers too.)
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <memory>
#include <new>
#include <random>

#include "test_support.hpp"
#include "visnav/feature_replay/heading.hpp"
#include "visnav/feature_replay/local_map.hpp"
#include "visnav/feature_replay/segment_map.hpp"

namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};
}  // namespace

void* operator new(std::size_t n) {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
// The nothrow form too (std::stable_sort's temporary buffer uses it): left to the toolchain (the
// ASan runtime provides its own), its memory came back here to free() -- an
// alloc-dealloc-mismatch under ASan, and counting only half of the allocations.
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
  return std::malloc(n == 0 ? 1 : n);
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }

namespace fr = visnav::feature_replay;
using visnav::Features;
using visnav::Pose2D;

namespace {
struct Counting {
  Counting() { g_allocations = 0; g_counting = true; }
  ~Counting() { g_counting = false; }
  long count() const { return g_allocations.load(); }
};
}  // namespace

TEST(NoAllocation, ReplayStepsAfterWarmUp) {
  const auto scene = fr_test::SyntheticScene::around(-2.0, 30.0, -0.5, 0.5, 1200);
  std::mt19937 rng(1);
  fr::SegmentTeacher teach_a;
  fr::LocalMapTeacher teach_b;
  teach_a.begin(0.0);
  std::vector<Features> frames;
  for (double d = 0.0; d <= 4.0 + 1e-9; d += 0.05) {
    frames.push_back(scene.observe(Pose2D{d, 0.0, 0.0}, rng));
    ASSERT_TRUE(teach_a.add_frame(d, frames.back()).ok());
    teach_b.record_command(d, {0.3, 0.0});
    ASSERT_TRUE(teach_b.add_frame(d, frames.back()).ok());
  }
  auto a = teach_a.finish(4.0);
  auto b = teach_b.finish(4.0, frames.back());
  ASSERT_TRUE(a.ok() && b.ok());
  fr::SegmentReplayer rep_a(std::make_shared<const fr::SegmentMap>(std::move(a).value()));
  fr::LocalMapReplayer rep_b(std::make_shared<const fr::LocalMapPath>(std::move(b).value()));
  rep_a.begin(0.0);
  rep_b.begin(0.0);
  // Current views 0.3 m to the side; warm up over the whole sequence once.
  std::vector<Features> current;
  for (std::size_t i = 0; i < frames.size(); ++i) current.push_back(scene.observe(Pose2D{i * 0.05, 0.3, 0.0}, rng));
  for (std::size_t i = 0; i < current.size(); ++i) {
    (void)rep_a.step(i * 0.05, current[i], 640.0);
    (void)rep_b.step(i * 0.05, current[i], 640.0);
  }
  int steering = 0;
  Counting counting;
  for (std::size_t i = 0; i < current.size(); ++i) {
    steering += rep_a.step(i * 0.05, current[i], 640.0).state == fr::ReplayState::steering ? 1 : 0;
    steering += rep_b.step(i * 0.05, current[i], 640.0).state == fr::ReplayState::steering ? 1 : 0;
  }
  const long allocations = counting.count();
  EXPECT_EQ(allocations, 0);
  EXPECT_GT(steering, static_cast<int>(current.size()));
}
