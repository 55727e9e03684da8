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

}  // namespace visnav::simop
