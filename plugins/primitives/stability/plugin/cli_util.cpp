#include "cli_util.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <thread>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <iostream>
#include <sstream>
#include <iomanip>

extern char** environ;

namespace visnav::stability::cli {

Result<double> parse_number(const std::string& text, double lo, double hi, const std::string& what) {
  double v = 0.0;
  try {
    std::size_t used = 0;
    v = std::stod(text, &used);
    if (used != text.size()) return fail(what + ": '" + text + "' is not a number");
  } catch (const std::exception&) {
    return fail(what + ": '" + text + "' is not a number");
  }
  if (!std::isfinite(v) || v < lo || v > hi)
    return fail(what + ": " + text + " is outside [" + fixed(lo, 6) + ", " + fixed(hi, 6) + "]");
  return v;
}

bool help_asked(int argc, char** argv, const char* usage) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      std::cout << usage;
      return true;
    }
  }
  return false;
}

int usage_error(const std::string& command, const std::string& message, const char* usage) {
  std::cerr << command << ": " << message << "\n\n" << usage;
  return 2;
}

bool Options::next() {
  if (++i_ >= argc_) return false;
  arg_ = argv_[i_];
  return true;
}

Result<std::string> Options::value() {
  if (i_ + 1 >= argc_) return fail(arg_ + " needs a value");
  return std::string(argv_[++i_]);
}

Result<double> Options::number(double lo, double hi) {
  const std::string name = arg_;
  auto v = value();
  if (!v) return v.error();
  return parse_number(*v, lo, hi, name);
}

Progress::Progress(std::string label)
    : label_(std::move(label)), terminal_(::isatty(STDERR_FILENO) == 1), start_(std::chrono::steady_clock::now()) {}

void Progress::show(double done, double total, const std::string& unit) {
  const auto now = std::chrono::steady_clock::now();
  const double share = total > 0.0 ? std::clamp(done / total, 0.0, 1.0) : 1.0;
  const int tenth = static_cast<int>(share * 10.0);
  if (terminal_) {
    if (drawn_ && share < 1.0 && now - last_ < std::chrono::milliseconds(500)) return;
  } else if (tenth == last_tenth_) {
    return;
  }
  last_ = now;
  last_tenth_ = tenth;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  constexpr int kWidth = 30;
  const int filled = static_cast<int>(share * kWidth);
  std::ostringstream line;
  line << "  " << label_ << " [" << std::string(static_cast<std::size_t>(filled), '#')
       << std::string(static_cast<std::size_t>(kWidth - filled), '.') << "] " << std::setw(3)
       << static_cast<int>(share * 100.0) << " % " << static_cast<long long>(done) << "/" << static_cast<long long>(total)
       << " " << unit << "  " << static_cast<long long>(elapsed) << " s";
  if (share > 0.0 && share < 1.0) line << ", ~" << static_cast<long long>(elapsed / share - elapsed) << " s left";
  if (terminal_) {
    std::cerr << "\r" << line.str() << "\x1b[K" << std::flush;
  } else {
    std::cerr << line.str() << "\n" << std::flush;
  }
  drawn_ = true;
}

void Progress::end() {
  if (drawn_ && terminal_) std::cerr << "\n";
  drawn_ = false;
  last_tenth_ = -1;
}

std::vector<std::string> split_spaces(const std::string& s) {
  std::vector<std::string> out;
  std::istringstream in(s);
  for (std::string t; in >> t;) out.push_back(t);
  return out;
}

std::string self_exe() {
  std::error_code ec;
  auto p = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string("visnav") : p.string();
}

// Runs argv with stdout and stderr to `log`; the exit status, or an error when it cannot start.
// A child still running after timeout_s is killed (SIGKILL) and reported as status 124.
Result<int> run_child(const std::vector<std::string>& args, const std::string& log, double timeout_s) {
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&fa, STDOUT_FILENO, STDERR_FILENO);
  posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawnp(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0) return fail("cannot start '" + args[0] + "': " + std::strerror(rc));
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    int st = 0;
    const pid_t w = ::waitpid(pid, &st, WNOHANG);
    if (w == pid) return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + (WIFSIGNALED(st) ? WTERMSIG(st) : 0);
    if (w < 0) return fail("waitpid failed for '" + args[0] + "'");
    if (std::chrono::steady_clock::now() > end) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &st, 0);
      return 124;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

std::string fixed(double v, int precision) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(precision) << v;
  return o.str();
}

}  // namespace visnav::stability::cli
