#include "sim_session_util.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <iomanip>
#include <sstream>

#include <unistd.h>

#ifndef VISNAV_SOURCE_DIR
#error "VISNAV_SOURCE_DIR must name the source tree (target_compile_definitions)"
#endif

namespace fs = std::filesystem;

namespace visnav::simop {

std::string project_file(const std::string& path) {
  if (path.empty() || fs::exists(path) || fs::path(path).is_absolute()) return path;
  const fs::path in_source = fs::path(VISNAV_SOURCE_DIR) / path;
  return fs::exists(in_source) ? in_source.string() : path;
}

Result<double> parse_number(const std::string& text, double lo, double hi, const std::string& what) {
  char* end = nullptr;
  const double x = std::strtod(text.c_str(), &end);
  if (text.empty() || end == text.c_str() || *end != '\0' || !std::isfinite(x) || !(x >= lo && x <= hi))
  {
    std::ostringstream range;  // shortest form: [1, 100], [0.05, 2]
    range << "[" << lo << ", " << hi << "]";
    return fail(what + ": '" + text + "' is not a number in " + range.str());
  }
  return x;
}

std::string fixed(double v, int precision) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(precision) << v;
  return s.str();
}

std::string join(const std::vector<std::string>& v, const std::string& sep) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : sep) + x;
  return s;
}

bool print_help_if_asked(int argc, char** argv, const char* usage) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      std::cout << usage;
      return true;
    }
  }
  return false;
}

int usage_error(const std::string& command, const Error& error, const char* usage) {
  std::cerr << command << ": " << error.message << "\n" << usage;
  return 2;
}

bool OptionReader::next() {
  if (i_ + 1 >= argc_) return false;
  arg_ = argv_[++i_];
  return true;
}

Result<std::string> OptionReader::value() {
  if (i_ + 1 >= argc_) return fail(arg_ + " needs a value");
  return std::string(argv_[++i_]);
}

Result<double> OptionReader::number(double lo, double hi) {
  VISNAV_ASSIGN(std::string v, value());
  return parse_number(v, lo, hi, arg_);
}

ProgressLine::ProgressLine(int phase_width) : phase_width_(phase_width), terminal_(isatty(fileno(stderr)) != 0) {}

void ProgressLine::show(const std::string& phase, double done, double total, const std::string& unit) {
  if (phase != last_phase_) {
    last_phase_ = phase;
    drawn_full_ = false;
    last_tenth_ = -1;
  }
  const double share = total > 0 ? std::clamp(done / total, 0.0, 1.0) : 0.0;
  const bool full = share >= 1.0;
  if (terminal_) {
    const auto now = std::chrono::steady_clock::now();
    const bool first_full = full && !drawn_full_;
    if (drawn_ && now - last_ < std::chrono::milliseconds(500) && !first_full) return;
    last_ = now;
  } else {
    const int tenth = static_cast<int>(share * 10.0);
    if (tenth == last_tenth_) return;
    last_tenth_ = tenth;
  }
  drawn_full_ = drawn_full_ || full;
  const int width = 30;
  const int filled = static_cast<int>(share * width);
  std::fprintf(stderr, "%s  %-*s [%s%s] %6.1f / %.1f %s%s", terminal_ ? "\r" : "", phase_width_, phase.c_str(),
               std::string(filled, '#').c_str(), std::string(width - filled, '.').c_str(), done, total, unit.c_str(),
               terminal_ ? "   " : "\n");
  std::fflush(stderr);
  drawn_ = terminal_;  // a non-terminal line is already ended
}

void ProgressLine::end() {
  if (!drawn_) return;
  std::fprintf(stderr, "\n");
  drawn_ = false;
}

}  // namespace visnav::simop
