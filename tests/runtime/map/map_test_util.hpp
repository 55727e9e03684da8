// Helpers shared by the map tests: a self-deleting temporary folder and file byte I/O.
#pragma once

#include <sys/wait.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "visnav/map.hpp"

namespace visnav::test {

class TempDir {
 public:
  TempDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "visnav_map_test_XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] std::string operator/(const std::string& child) const { return path_ + "/" + child; }

 private:
  std::string path_;
};

inline std::vector<std::uint8_t> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

inline void write_bytes(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

inline std::string read_text(const std::string& path) {
  auto b = read_bytes(path);
  return {b.begin(), b.end()};
}

inline void write_text(const std::string& path, const std::string& text) {
  write_bytes(path, std::vector<std::uint8_t>(text.begin(), text.end()));
}

/// prefix + number ("n12"). (Spelled out: GCC 12 -O3 warns falsely on "n" + std::to_string(i).)
inline std::string numbered(const char* prefix, long long i) {
  std::string s(prefix);
  s += std::to_string(i);
  return s;
}

/// Deterministic pseudo-random payload body.
inline std::vector<std::uint8_t> make_body(std::size_t n, std::uint32_t seed) {
  std::vector<std::uint8_t> out(n);
  std::uint32_t x = seed * 2654435761U + 1U;
  for (auto& b : out) {
    x ^= x << 13; x ^= x >> 17; x ^= x << 5;
    b = static_cast<std::uint8_t>(x);
  }
  return out;
}

inline EdgeRecord edge(const std::string& from, const std::string& to, const std::string& kind, double length_m,
                       double azimuth_rad = 0.0, const std::string& id = {}) {
  EdgeRecord e;
  e.id = id;
  e.from = from;
  e.to = to;
  e.kind = kind;
  e.length_m = length_m;
  e.azimuth_rad = azimuth_rad;
  return e;
}

inline NodeRecord node(const std::string& id, const std::string& name = {}) {
  NodeRecord n;
  n.id = id;
  n.name = name;
  return n;
}

/// Runs a shell command; returns {exit status, combined stdout+stderr}.
inline std::pair<int, std::string> run(const std::string& command) {
  std::string out;
  FILE* p = ::popen((command + " 2>&1").c_str(), "r");
  if (p == nullptr) return {-1, ""};
  char buf[4096];
  std::size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  const int status = ::pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

}  // namespace visnav::test
