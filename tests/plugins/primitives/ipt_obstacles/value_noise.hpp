// Deterministic smooth texture for the ray-cast test frames (near triangulation, back-off,
// standing watch): bilinear value noise in [0, 255] over a grid of `cell_m` on a 2-D
// coordinate of the surface.
#pragma once

#include <cmath>
#include <cstdint>

namespace visnav::ipt::testing {

inline double value_noise(double a, double b, double cell_m) {
  auto hash = [](long i, long j) {
    std::uint64_t h = static_cast<std::uint64_t>(i) * 73856093ULL ^ static_cast<std::uint64_t>(j) * 19349663ULL;
    h ^= h >> 13;
    h *= 0x5bd1e995ULL;
    h ^= h >> 15;
    return static_cast<double>(h % 256);
  };
  const double u = a / cell_m, v = b / cell_m;
  const long i = static_cast<long>(std::floor(u)), j = static_cast<long>(std::floor(v));
  const double fu = u - static_cast<double>(i), fv = v - static_cast<double>(j);
  const double top = hash(i, j) * (1 - fu) + hash(i + 1, j) * fu;
  const double bottom = hash(i, j + 1) * (1 - fu) + hash(i + 1, j + 1) * fu;
  return top * (1 - fv) + bottom * fv;
}

}  // namespace visnav::ipt::testing
