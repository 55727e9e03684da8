#include "visnav/command_line.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>

namespace visnav::cli {

Result<double> parse_number(const std::string& text, double lo, double hi, const std::string& what) {
  char* end = nullptr;
  const double x = std::strtod(text.c_str(), &end);
  if (text.empty() || end == text.c_str() || *end != '\0' || !std::isfinite(x) || !(x >= lo && x <= hi)) {
    std::ostringstream range;  // shortest form: [1, 100], [0.05, 2]
    range << "[" << lo << ", " << hi << "]";
    return Error{what + ": '" + text + "' is not a number in " + range.str(),
                 end == text.c_str() || *end != '\0' || text.empty() ? ErrorCode::invalid_value : ErrorCode::out_of_range};
  }
  return x;
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

int usage_error(const std::string& command, const std::string& message, const char* usage) {
  std::cerr << command << ": " << message << "\n\n" << usage;
  return 2;
}

bool OptionReader::next() {
  if (i_ + 1 >= argc_) return false;
  arg_ = argv_[++i_];
  return true;
}

Result<std::string> OptionReader::value() {
  if (i_ + 1 >= argc_) return Error{arg_ + " needs a value", ErrorCode::missing};
  return std::string(argv_[++i_]);
}

Result<double> OptionReader::number(double lo, double hi) {
  const std::string option = arg_;
  VISNAV_ASSIGN(std::string v, value());
  return parse_number(v, lo, hi, option);
}

ProgressLine::ProgressLine(int phase_width) : phase_width_(phase_width), terminal_(::isatty(STDERR_FILENO) == 1) {}

void ProgressLine::show(const std::string& phase, double done, double total, const std::string& unit) {
  const auto now = std::chrono::steady_clock::now();
  // The clock measures one piece of work: it restarts when the total changes or the count goes
  // back, not when only the phase label changes ("runs 3/10 done" -> "runs 4/10 done").
  if (phase_start_ == std::chrono::steady_clock::time_point{} || total != total_ || done < done_) phase_start_ = now;
  total_ = total;
  done_ = done;
  if (phase != phase_) {
    if (drawn_) end();
    phase_ = phase;
    drawn_full_ = false;
    last_tenth_ = -1;
  }
  const double share = total > 0.0 ? std::clamp(done / total, 0.0, 1.0) : 0.0;
  const bool full = share >= 1.0;
  if (terminal_) {
    if (drawn_ && now - last_ < std::chrono::milliseconds(500) && !(full && !drawn_full_)) return;
  } else {
    const int tenth = static_cast<int>(share * 10.0);
    if (tenth == last_tenth_) return;
    last_tenth_ = tenth;
  }
  last_ = now;
  drawn_full_ = drawn_full_ || full;
  constexpr int kWidth = 30;
  const int filled = static_cast<int>(share * kWidth);
  const double elapsed_s = std::chrono::duration<double>(now - phase_start_).count();
  std::ostringstream line;
  line << "  " << phase;
  if (static_cast<int>(phase.size()) < phase_width_) line << std::string(phase_width_ - phase.size(), ' ');
  line << " [" << std::string(static_cast<std::size_t>(filled), '#') << std::string(kWidth - filled, '.') << "] ";
  // Counts print as integers (450000/1000000 scenarios), measures with two decimals (0.92/9.18 km).
  const auto amount = [](double v) {
    char text[32];
    if (std::abs(v) < 1e15 && v == std::floor(v)) std::snprintf(text, sizeof text, "%lld", static_cast<long long>(v));
    else std::snprintf(text, sizeof text, "%.2f", v);
    return std::string(text);
  };
  char head[16];
  std::snprintf(head, sizeof head, "%3d %% ", static_cast<int>(share * 100.0));
  line << head << amount(done) << "/" << amount(total) << " " << unit << "  " << static_cast<long long>(elapsed_s) << " s";
  if (share > 0.0 && share < 1.0) line << ", ~" << static_cast<long long>(elapsed_s / share - elapsed_s) << " s left";
  if (terminal_) {
    std::cerr << "\r" << line.str() << "\x1b[K" << std::flush;
    drawn_ = true;
  } else {
    std::cerr << line.str() << "\n" << std::flush;
  }
}

void ProgressLine::end() {
  if (drawn_ && terminal_) std::cerr << "\n" << std::flush;
  drawn_ = false;
}

}  // namespace visnav::cli
