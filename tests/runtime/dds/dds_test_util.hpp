// Shared by the DDS tests (tests/runtime/dds, tests/plugins/*/dds, tests/integration/dds,
// bench/dds): loopback-only Cyclone configuration and per-test isolation.
#pragma once

#include <cstdlib>
#include <functional>
#include <random>
#include <string>
#include <thread>

#include <unistd.h>

#include "visnav/dds.hpp"

namespace visnav::dds::testing {

/// Pins Cyclone to 127.0.0.1 (unicast discovery, no multicast) for every domain created
/// afterwards in this process and in child processes that inherit the environment.
inline void use_loopback() { ::setenv("CYCLONEDDS_URI", loopback_config_xml().c_str(), 1); }

inline std::mt19937_64& rng() {
  static std::mt19937_64 r(std::random_device{}() ^ (static_cast<std::uint64_t>(::getpid()) << 20));
  return r;
}

/// A domain id in [100, 229], random per call (parallel test processes rarely share one; the
/// partition below isolates them when they do).
inline int random_domain_id() { return 100 + static_cast<int>(rng()() % 130); }

/// A partition name unique to this call.
inline std::string unique_partition(const std::string& prefix = "visnav_test") {
  return prefix + "_" + std::to_string(::getpid()) + "_" + std::to_string(rng()() % 1000000000ULL);
}

/// Polls `done` every 2 ms until it is true or `timeout_s` passed.
inline bool eventually(const std::function<bool()>& done, double timeout_s = 5.0) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!done()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

}  // namespace visnav::dds::testing
