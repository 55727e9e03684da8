// Interop tests against independent npm implementations (tests/interop/package.json): node and
// the packages are needed; without node the tests skip saying so. The packages are installed
// into tests/interop/node_modules on first use (under a file lock: ctest runs cases in parallel).
#pragma once

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>

namespace visnav::interop {

inline const std::filesystem::path kInteropDir = std::filesystem::path(VISNAV_TEST_SOURCE_DIR) / "tests" / "interop";

inline std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) {
    if (c == '\'') q += "'\\''"; else q.push_back(c);
  }
  return q + "'";
}

/// Runs a shell command; returns the exit status and stdout+stderr.
inline int run_shell(const std::string& cmd, std::string& output) {
  output.clear();
  FILE* p = ::popen((cmd + " 2>&1").c_str(), "r");
  if (p == nullptr) return -1;
  std::array<char, 4096> buffer{};
  while (std::size_t n = std::fread(buffer.data(), 1, buffer.size(), p)) output.append(buffer.data(), n);
  const int status = ::pclose(p);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// True when node and npm are on the PATH (otherwise the interop tests skip, saying so).
inline bool have_node() {
  std::string out;
  return run_shell("command -v node && command -v npm", out) == 0;
}

/// Installs tests/interop/package.json's packages unless `probe_package` is there. Returns an
/// empty string on success, else npm's output (a failure, not a skip: node is there).
inline std::string ensure_npm_packages(const std::string& probe_package) {
  std::string out;
  const auto probe = kInteropDir / "node_modules" / probe_package / "package.json";
  if (std::filesystem::exists(probe)) return {};
  const std::string lock_path = (kInteropDir / ".npm-install.lock").string();
  const int lock = ::open(lock_path.c_str(), O_CREAT | O_RDWR, 0644);
  if (lock >= 0) ::flock(lock, LOCK_EX);
  std::string why;
  if (!std::filesystem::exists(probe) &&
      run_shell("npm install --no-audit --no-fund --prefix " + shell_quote(kInteropDir.string()), out) != 0)
    why = "npm install in tests/interop failed (offline?):\n" + out;
  if (lock >= 0) {
    ::flock(lock, LOCK_UN);
    ::close(lock);
  }
  return why;
}

}  // namespace visnav::interop
