#include "visnav/visual_memory/controllers.hpp"

#include <algorithm>
#include <cmath>

namespace visnav::visual_memory {

std::optional<Controller> controller_from_string(std::string_view name) {
  if (name == "centroid") return Controller::centroid;
  if (name == "RH") return Controller::RH;
  if (name == "IJP") return Controller::IJP;
  if (name == "IJPU") return Controller::IJPU;
  if (name == "IJC") return Controller::IJC;
  if (name == "IJCU") return Controller::IJCU;
  if (name == "AIJCA") return Controller::AIJCA;
  return std::nullopt;
}

const char* to_string(Controller c) {
  switch (c) {
    case Controller::centroid: return "centroid";
    case Controller::RH: return "RH";
    case Controller::IJP: return "IJP";
    case Controller::IJPU: return "IJPU";
    case Controller::IJC: return "IJC";
    case Controller::IJCU: return "IJCU";
    case Controller::AIJCA: return "AIJCA";
  }
  return "?";
}

bool needs_pose(Controller c) { return c == Controller::RH || c == Controller::IJP || c == Controller::IJC; }

namespace {

double median(std::vector<double> v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  if (v.size() % 2 == 1) return *mid;
  const double upper = *mid;
  const double lower = *std::max_element(v.begin(), mid);
  return 0.5 * (lower + upper);
}

ControlOutput evaluated(double omega) {
  if (!std::isfinite(omega)) return {std::nullopt, "control law gave a non-finite value"};
  return {omega, {}};
}

/// Law (3) for column vectors L_v, L_ω and error e (same length k).
ControlOutput law3(const std::vector<double>& Lv, const std::vector<double>& Lw, const std::vector<double>& e,
                   double lambda, double v) {
  double ww = 0.0, wr = 0.0;
  for (std::size_t i = 0; i < Lw.size(); ++i) {
    ww += Lw[i] * Lw[i];
    wr += Lw[i] * (lambda * e[i] + Lv[i] * v);
  }
  if (!(ww > 1e-12)) return {std::nullopt, "image Jacobian L_S,omega is zero"};
  return evaluated(-wr / ww);
}

}  // namespace

ControlOutput compute_control(Controller c, const ControlInput& in, const ControlGains& gains) {
  const std::size_t n = in.current_norm.size();
  if (c == Controller::RH) {
    if (!in.heading_change_rad || !std::isfinite(*in.heading_change_rad))
      return {std::nullopt, "RH needs the relative pose (none this frame)"};
    return evaluated(-gains.lambda * *in.heading_change_rad);
  }
  if (n == 0 || in.reference_norm.size() != n) return {std::nullopt, "no matched points"};
  if (c == Controller::centroid || c == Controller::AIJCA) {
    std::vector<double> dx(n);
    for (std::size_t j = 0; j < n; ++j) dx[j] = in.current_norm[j].x - in.reference_norm[j].x;
    if (c == Controller::centroid) {
      double offset = 0.0;
      if (gains.centroid_median) {
        offset = median(dx);
      } else {
        for (double d : dx) offset += d;
        offset /= static_cast<double>(n);
      }
      return evaluated(-gains.centroid_gain_radps * offset);
    }
    double e = 0.0;
    for (double d : dx) e += d;  // X_G - X_iG = mean of the differences
    return evaluated(-gains.lambda * e / static_cast<double>(n));
  }
  const bool uniform = c == Controller::IJPU || c == Controller::IJCU;
  if (!uniform && in.depth_m.size() != n) return {std::nullopt, std::string(to_string(c)) + " needs the point depths (none this frame)"};
  auto depth = [&](std::size_t j) { return uniform ? gains.uniform_depth_m : in.depth_m[j]; };
  for (std::size_t j = 0; j < n; ++j)
    if (!(depth(j) > 0.0) || !std::isfinite(depth(j))) return {std::nullopt, "a point depth is not positive"};
  const double delta = in.camera_forward_m;
  if (c == Controller::IJP || c == Controller::IJPU) {
    std::vector<double> Lv(2 * n), Lw(2 * n), e(2 * n);
    for (std::size_t j = 0; j < n; ++j) {
      const double X = in.current_norm[j].x, Y = in.current_norm[j].y, z = depth(j);
      Lv[2 * j] = X / z;
      Lv[2 * j + 1] = Y / z;
      Lw[2 * j] = delta / z + 1.0 + X * X;
      Lw[2 * j + 1] = X * Y;
      e[2 * j] = X - in.reference_norm[j].x;
      e[2 * j + 1] = Y - in.reference_norm[j].y;
    }
    return law3(Lv, Lw, e, gains.lambda, in.speed_mps);
  }
  // IJC / IJCU: centroid features, Jacobian rows averaged over the points (eq. (4)).
  std::vector<double> Lv(2, 0.0), Lw(2, 0.0), e(2, 0.0);
  for (std::size_t j = 0; j < n; ++j) {
    const double X = in.current_norm[j].x, Y = in.current_norm[j].y, z = depth(j);
    Lv[0] += X / z;
    Lv[1] += Y / z;
    Lw[0] += delta / z + 1.0 + X * X;
    Lw[1] += X * Y;
    e[0] += X - in.reference_norm[j].x;
    e[1] += Y - in.reference_norm[j].y;
  }
  for (int i = 0; i < 2; ++i) {
    Lv[static_cast<std::size_t>(i)] /= static_cast<double>(n);
    Lw[static_cast<std::size_t>(i)] /= static_cast<double>(n);
    e[static_cast<std::size_t>(i)] /= static_cast<double>(n);
  }
  return law3(Lv, Lw, e, gains.lambda, in.speed_mps);
}

double image_error_px(const std::vector<cv::Point2f>& current, const std::vector<cv::Point2f>& reference) {
  if (current.empty() || current.size() != reference.size()) return 0.0;
  double sum = 0.0;
  for (std::size_t j = 0; j < current.size(); ++j) sum += cv::norm(current[j] - reference[j]);
  return sum / static_cast<double>(current.size());
}

}  // namespace visnav::visual_memory
