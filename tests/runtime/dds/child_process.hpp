// A child process for the multi-process DDS tests (`visnav simd`, `visnav run`, `visnav
// monitor`): spawned with posix_spawn, stdout on a pipe that the test reads, stderr to a log
// file. The destructor SIGKILLs and reaps a child that is still running.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "dds_test_util.hpp"

extern char** environ;

namespace visnav::dds::testing {

class ChildProcess {
 public:
  /// Starts `args[0]` with `args` (the environment is inherited, e.g. CYCLONEDDS_URI).
  ChildProcess(const std::vector<std::string>& args, const std::string& stderr_path) {
    int out[2];
    if (::pipe(out) != 0) return;
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, out[1], STDOUT_FILENO);
    posix_spawn_file_actions_addclose(&fa, out[0]);
    posix_spawn_file_actions_addopen(&fa, STDERR_FILENO, stderr_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    if (posix_spawn(&pid_, argv[0], &fa, nullptr, argv.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&fa);
    ::close(out[1]);
    stdout_fd_ = out[0];
    ::fcntl(stdout_fd_, F_SETFL, O_NONBLOCK);
  }
  ~ChildProcess() {
    if (pid_ > 0 && !exited_) {
      ::kill(pid_, SIGKILL);
      int st = 0;
      ::waitpid(pid_, &st, 0);
    }
    if (stdout_fd_ >= 0) ::close(stdout_fd_);
  }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  [[nodiscard]] bool started() const { return pid_ > 0; }
  /// Reads stdout until `text` appears, the child exits, or `timeout_s` passes.
  bool wait_for_output(const std::string& text, double timeout_s) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < end) {
      if (output_.find(text) != std::string::npos) return true;
      drain(20);
      if (exited()) {
        drain(0);
        return output_.find(text) != std::string::npos;
      }
    }
    return output_.find(text) != std::string::npos;
  }
  /// stdout read so far (call wait_for_output or read_output to collect more).
  [[nodiscard]] const std::string& output() const { return output_; }
  /// Reads whatever stdout has buffered.
  const std::string& read_output() {
    drain(0);
    return output_;
  }
  void signal(int sig) const {
    if (pid_ > 0) ::kill(pid_, sig);
  }
  /// True once the process has exited (reaps it).
  bool exited() {
    if (exited_) return true;
    int st = 0;
    if (pid_ > 0 && ::waitpid(pid_, &st, WNOHANG) == pid_) {
      exited_ = true;
      status_ = st;
    }
    return exited_;
  }
  /// Waits for exit; returns the exit code (128+signal when killed), or -1 on timeout.
  int wait(double timeout_s) {
    if (!eventually([&] { return exited(); }, timeout_s)) return -1;
    return WIFEXITED(status_) ? WEXITSTATUS(status_) : 128 + WTERMSIG(status_);
  }

 private:
  void drain(int poll_ms) {
    pollfd p{stdout_fd_, POLLIN, 0};
    if (::poll(&p, 1, poll_ms) <= 0) return;
    char buf[4096];
    for (;;) {
      const ssize_t n = ::read(stdout_fd_, buf, sizeof buf);
      if (n <= 0) return;
      output_.append(buf, static_cast<std::size_t>(n));
    }
  }

  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  std::string output_;
  bool exited_ = false;
  int status_ = 0;
};

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

}  // namespace visnav::dds::testing
