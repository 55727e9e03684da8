// bench_dds — the visnav DDS layer over loopback, beside Cyclone's own `ddsperf`.
//
//  BM_CmdVelRoundTrip        geometry_msgs/Twist (48 B payload) ping -> pong process -> back;
//                            median / p90 round trip; ddsperf ping/pong with `size 48`, in
//                            waitset mode (same triggering as visnav) and listener mode
//                            (ddsperf prints half round trips; converted to round trips).
//  BM_Image640x480Throughput sensor_msgs/Image bgr8 640x480 (921,600 B) published as fast as
//                            possible by a child process (reliable, keep-all) and received
//                            here by a Subscription (waitset thread); ddsperf pub/sub waitset
//                            with `size 921600` (its defaults: reliable, keep-all). Two
//                            interleaved rounds each, best round reported.
// Both sides run as separate processes (like ddsperf) on 127.0.0.1 only, each on a random
// domain. Ratios: latency = ours / ddsperf, throughput = ddsperf / ours (goal: <= 1.2).
// Total run time ~20 s.
#include <benchmark/benchmark.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "dds_test_util.hpp"
#include "visnav/dds.hpp"

extern char** environ;

namespace dds = visnav::dds;
using Clock = std::chrono::steady_clock;

namespace {

constexpr int kImageWidth = 640;
constexpr int kImageHeight = 480;
constexpr int kThroughputSeconds = 2;  // per round; 2 rounds each, interleaved with ddsperf

const dds::Qos kPingQos{dds::Reliability::reliable, dds::Durability::volatile_data, 1, 0.0};
const dds::Qos kImageQos{dds::Reliability::reliable, dds::Durability::volatile_data, 0, 0.0};  // keep-all

// ---- child processes ----------------------------------------------------------------------------

/// Spawns `args` (PATH lookup) with stdout (and stderr) to a pipe; returns pid and the read end.
std::pair<pid_t, int> spawn(const std::vector<std::string>& args) {
  int out[2];
  if (::pipe(out) != 0) return {-1, -1};
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_adddup2(&fa, out[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&fa, out[1], STDERR_FILENO);
  posix_spawn_file_actions_addclose(&fa, out[0]);
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = -1;
  if (posix_spawnp(&pid, argv[0], &fa, nullptr, argv.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&fa);
  ::close(out[1]);
  return {pid, out[0]};
}

/// Reads everything until EOF (the child exited) or `timeout_s`.
std::string read_all(int fd, double timeout_s) {
  std::string text;
  const auto end = Clock::now() + std::chrono::duration<double>(timeout_s);
  while (Clock::now() < end) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 50) <= 0) continue;
    char buf[4096];
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n <= 0) break;
    text.append(buf, static_cast<std::size_t>(n));
  }
  return text;
}

void finish(pid_t pid, int fd) {
  if (pid > 0) {
    ::kill(pid, SIGTERM);
    int st = 0;
    ::waitpid(pid, &st, 0);
  }
  if (fd >= 0) ::close(fd);
}

std::string self_exe() {
  char buf[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof buf - 1);
  return n > 0 ? std::string(buf, static_cast<std::size_t>(n)) : std::string("bench_dds");
}

/// `bench_dds --pong DOMAIN`: echoes rt/bench/ping to rt/bench/pong until killed.
int run_pong(int domain) {
  auto p = dds::Participant::create(domain);
  if (!p) return 1;
  auto reader = dds::Reader<dds::msg::Twist>::create(*p, {"rt/bench/ping", kPingQos, ""});
  auto writer = dds::Writer<dds::msg::Twist>::create(*p, {"rt/bench/pong", kPingQos, ""});
  if (!reader || !writer) return 1;
  for (;;) {
    auto ready = reader->wait(1.0);
    if (!ready) return 1;
    if (!*ready) continue;
    (void)reader->take([&](dds::msg::Twist&& t, const dds::SampleInfo&) { (void)writer->write(t); });
  }
}

/// `bench_dds --publish-images DOMAIN SECONDS`: publishes 640x480 bgr8 images back to back.
int run_image_publisher(int domain, double seconds) {
  auto p = dds::Participant::create(domain);
  if (!p) return 1;
  auto writer = dds::Writer<dds::msg::Image>::create(*p, {"rt/bench/image", kImageQos, ""});
  if (!writer) return 1;
  if (!writer->wait_for_readers(1, 10.0)) return 1;
  dds::msg::Image image;
  image.width = kImageWidth;
  image.height = kImageHeight;
  image.encoding = "bgr8";
  image.step = kImageWidth * 3;
  image.data.assign(static_cast<std::size_t>(image.step) * kImageHeight, 0x5A);
  image.header.frame_id = "camera";
  const auto end = Clock::now() + std::chrono::duration<double>(seconds);
  while (Clock::now() < end) {
    image.header.stamp = dds::msg::Time::from_seconds(dds::epoch_now_s());
    (void)writer->write(image);  // keep-all: blocks (up to 100 ms) while the reader catches up
  }
  return 0;
}

// ---- ddsperf ------------------------------------------------------------------------------------

bool have_ddsperf() {
  auto [pid, fd] = spawn({"ddsperf", "help"});
  if (pid < 0) return false;
  (void)read_all(fd, 5.0);
  int st = 0;
  ::waitpid(pid, &st, 0);
  ::close(fd);
  return WIFEXITED(st) && WEXITSTATUS(st) != 127;
}

/// Round-trip median from `ddsperf ping`: ddsperf prints (t_receive_pong - t_send_ping) / 2,
/// i.e. half the round trip (ddsperf.c, process_pong -> update_roundtrip(..., / 2)), so the
/// per-second "50% Xus" figures (first second skipped) are doubled here.
/// `mode` is ddsperf's triggering mode: "waitset" (what visnav uses) or "listener".
std::optional<double> ddsperf_rtt_median_us(int domain, const std::string& mode) {
  auto [pong_pid, pong_fd] = spawn({"ddsperf", "-i", std::to_string(domain), "-D6", "pong", mode});
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  auto [ping_pid, ping_fd] = spawn({"ddsperf", "-i", std::to_string(domain), "-D3", "ping", "size", "48", mode});
  const std::string out = read_all(ping_fd, 15.0);
  finish(ping_pid, ping_fd);
  finish(pong_pid, pong_fd);
  std::vector<double> medians;
  const std::regex re(R"(size 48 mean [0-9.]+us min [0-9.]+us 50% ([0-9.]+)us)");
  for (auto it = std::sregex_iterator(out.begin(), out.end(), re); it != std::sregex_iterator(); ++it)
    medians.push_back(std::stod((*it)[1]));
  if (medians.size() > 1) medians.erase(medians.begin());
  if (medians.empty()) return std::nullopt;
  std::sort(medians.begin(), medians.end());
  return 2.0 * medians[medians.size() / 2];
}

/// Median of the per-second "rate X kS/s" figures of `ddsperf sub waitset` (first and last
/// skipped) while `ddsperf pub size 921600` publishes as fast as it can for `seconds` + 1.
std::optional<double> ddsperf_images_per_s(int domain, int seconds) {
  auto [sub_pid, sub_fd] = spawn({"ddsperf", "-i", std::to_string(domain), "-D" + std::to_string(seconds + 4), "sub", "waitset"});
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  auto [pub_pid, pub_fd] = spawn({"ddsperf", "-i", std::to_string(domain), "-D" + std::to_string(seconds + 1), "pub",
                                  "size", std::to_string(kImageWidth * kImageHeight * 3)});
  (void)read_all(pub_fd, 15.0);
  finish(pub_pid, pub_fd);
  ::kill(sub_pid, SIGTERM);
  const std::string out = read_all(sub_fd, 5.0);
  finish(sub_pid, sub_fd);
  std::vector<double> rates;
  const std::regex re(R"(size 921600 total [0-9]+ lost [0-9]+ delta [0-9]+ lost [0-9]+ rate ([0-9.]+) kS/s)");
  for (auto it = std::sregex_iterator(out.begin(), out.end(), re); it != std::sregex_iterator(); ++it)
    rates.push_back(std::stod((*it)[1]) * 1000.0);
  if (rates.size() > 2) rates = std::vector<double>(rates.begin() + 1, rates.end() - 1);
  if (rates.empty()) return std::nullopt;
  std::sort(rates.begin(), rates.end());
  return rates[rates.size() / 2];
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

// ---- benchmarks ---------------------------------------------------------------------------------

void BM_CmdVelRoundTrip(benchmark::State& state) {
  const int domain = dds::testing::random_domain_id();
  auto [pong_pid, pong_fd] = spawn({self_exe(), "--pong", std::to_string(domain)});
  auto p = dds::Participant::create(domain);
  auto writer = dds::Writer<dds::msg::Twist>::create(*p, {"rt/bench/ping", kPingQos, ""});
  auto reader = dds::Reader<dds::msg::Twist>::create(*p, {"rt/bench/pong", kPingQos, ""});
  if (!p || !writer || !reader || !writer->wait_for_readers(1, 10.0) || !reader->wait_for_writers(1, 10.0)) {
    finish(pong_pid, pong_fd);
    state.SkipWithError("could not set up the ping/pong endpoints");
    return;
  }
  dds::msg::Twist t;
  std::size_t got = 0;
  auto round_trip = [&]() -> bool {
    t.linear.x += 1.0;
    if (!writer->write(t)) return false;
    for (;;) {
      auto ready = reader->wait(1.0);
      if (!ready || !*ready) return false;
      got = 0;
      (void)reader->take([&](dds::msg::Twist&&, const dds::SampleInfo&) { ++got; });
      if (got > 0) return true;
    }
  };
  for (int i = 0; i < 500; ++i)
    if (!round_trip()) break;  // warm-up
  std::vector<double> rtt_us;
  rtt_us.reserve(static_cast<std::size_t>(state.max_iterations));
  for (auto _ : state) {
    const auto t0 = Clock::now();
    if (!round_trip()) {
      state.SkipWithError("a pong did not arrive within 1 s");
      break;
    }
    rtt_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  finish(pong_pid, pong_fd);
  const double median = percentile(rtt_us, 0.5);
  state.counters["rtt_median_us"] = median;
  state.counters["rtt_p90_us"] = percentile(rtt_us, 0.9);
  state.counters["rtt_p99_us"] = percentile(rtt_us, 0.99);
  if (have_ddsperf()) {
    // Same triggering as visnav (waitset: a reader thread wakes the waiting thread) and
    // ddsperf's default (listener: the reply is written from Cyclone's receive thread).
    auto waitset = ddsperf_rtt_median_us(dds::testing::random_domain_id(), "waitset");
    auto listener = ddsperf_rtt_median_us(dds::testing::random_domain_id(), "listener");
    if (waitset) {
      state.counters["ddsperf_waitset_rtt_median_us"] = *waitset;
      state.counters["ratio_ours_vs_ddsperf_waitset"] = median / *waitset;
    }
    if (listener) {
      state.counters["ddsperf_listener_rtt_median_us"] = *listener;
      state.counters["ratio_ours_vs_ddsperf_listener"] = median / *listener;
    }
    std::printf("cmd_vel round trip (48 B): visnav median %.1f us; ddsperf waitset %.1f us (ratio %.2fx, goal <= 1.2x); "
                "ddsperf listener %.1f us (ratio %.2fx)\n",
                median, waitset.value_or(NAN), waitset ? median / *waitset : NAN, listener.value_or(NAN),
                listener ? median / *listener : NAN);
  }
}
BENCHMARK(BM_CmdVelRoundTrip)->Iterations(20000)->Unit(benchmark::kMicrosecond);

/// Images per second received by a visnav Subscription (waitset thread) while a child process
/// publishes for `seconds`.
double visnav_images_per_s(int domain, int seconds) {
  auto p = dds::Participant::create(domain);
  if (!p) return 0.0;
  std::atomic<std::uint64_t> received{0};
  Clock::time_point first{}, last{};
  std::atomic<bool> have_first{false};
  std::uint64_t bytes = 0;
  auto sub = dds::Subscription<dds::msg::Image>::create(
      *p, {"rt/bench/image", kImageQos, ""}, [&](dds::msg::Image&& m, const dds::SampleInfo&) {
        const auto now = Clock::now();
        if (!have_first.exchange(true)) {
          first = now;
        } else {
          last = now;
          ++received;
        }
        bytes += m.data.size();
      });
  if (!sub) return 0.0;
  auto [pub_pid, pub_fd] = spawn({self_exe(), "--publish-images", std::to_string(domain), std::to_string(seconds)});
  (void)read_all(pub_fd, seconds + 15.0);  // until the publisher exits
  finish(pub_pid, pub_fd);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  sub->reset();
  const double span_s = std::chrono::duration<double>(last - first).count();
  return span_s > 0 ? static_cast<double>(received.load()) / span_s : 0.0;
}

void BM_Image640x480Throughput(benchmark::State& state) {
  const bool ddsperf = have_ddsperf();
  for (auto _ : state) {
    // Interleaved rounds, best of each: the machine is shared, so the best round is the
    // least disturbed one for both tools.
    double ours = 0.0;
    double ref = 0.0;
    bool ref_ok = false;
    for (int round = 0; round < 2; ++round) {
      ours = std::max(ours, visnav_images_per_s(dds::testing::random_domain_id(), kThroughputSeconds));
      if (ddsperf)
        if (auto r = ddsperf_images_per_s(dds::testing::random_domain_id(), kThroughputSeconds)) {
          ref = std::max(ref, *r);
          ref_ok = true;
        }
    }
    state.SetIterationTime(2.0 * kThroughputSeconds);
    state.counters["images_per_s"] = ours;
    state.counters["MB_per_s"] = ours * kImageWidth * kImageHeight * 3 / 1e6;
    if (ref_ok) {
      state.counters["ddsperf_images_per_s"] = ref;
      state.counters["ratio_ddsperf_vs_ours"] = ref / std::max(ours, 1e-9);
    }
    std::printf("640x480 image throughput (reliable, keep-all, waitset): visnav %.0f images/s (%.0f MB/s); "
                "ddsperf size 921600 %.0f samples/s; ratio %.2fx (goal <= 1.2x)\n",
                ours, ours * kImageWidth * kImageHeight * 3 / 1e6, ref_ok ? ref : NAN,
                ref_ok ? ref / std::max(ours, 1e-9) : NAN);
  }
}
BENCHMARK(BM_Image640x480Throughput)->Iterations(1)->UseManualTime()->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  dds::testing::use_loopback();  // this process and every child (ours and ddsperf)
  if (argc >= 3 && std::strcmp(argv[1], "--pong") == 0) return run_pong(std::atoi(argv[2]));
  if (argc >= 4 && std::strcmp(argv[1], "--publish-images") == 0)
    return run_image_publisher(std::atoi(argv[2]), std::atof(argv[3]));
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
