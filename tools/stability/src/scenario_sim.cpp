// Seed 002 Sec. 3.8: random closed routes, paired replays, convergence of the initial error.
#include "visnav_stability/scenario_sim.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <numbers>
#include <string>
#include <thread>

namespace visnav::stability {
namespace {

constexpr double kPi = std::numbers::pi;

double wrap_pi(double a) {
  a = std::remainder(a, 2.0 * kPi);
  return a <= -kPi ? a + 2.0 * kPi : a;
}

std::string num(double v) { return std::to_string(v); }

// The error state of one robot in the reference frame.
struct ErrorState {
  double x = 0.0, y = 0.0;
};

// d(x, y)/ds for one metre driven (see the header's equation).
inline void derivative(const ErrorState& e, double kappa, double ref_rate, double inv_l, double cos_d, double sin_d,
                       double& dx, double& dy) {
  const double u = e.y * inv_l;                  // tan of the angle the robot corrects by
  const double c = 1.0 / std::sqrt(1.0 + u * u);  // cos(atan u)
  const double cos_phi = c * cos_d + u * c * sin_d;  // φ = −atan(u) + δ
  const double sin_phi = c * sin_d - u * c * cos_d;
  dx = kappa * ref_rate * e.y - ref_rate + cos_phi;
  dy = -kappa * ref_rate * e.x + sin_phi;
}

inline void rk2(ErrorState& e, double h, double kappa, double ref_rate, double inv_l, double cos_d, double sin_d) {
  double dx1, dy1, dx2, dy2;
  derivative(e, kappa, ref_rate, inv_l, cos_d, sin_d, dx1, dy1);
  const ErrorState mid{e.x + 0.5 * h * dx1, e.y + 0.5 * h * dy1};
  derivative(mid, kappa, ref_rate, inv_l, cos_d, sin_d, dx2, dy2);
  e.x += h * dx2;
  e.y += h * dy2;
}

inline void rotate_frame(ErrorState& e, double c, double s) {
  // The reference frame turns by τ: coordinates rotate by −τ.
  const double x = c * e.x + s * e.y;
  const double y = -s * e.x + c * e.y;
  e.x = x;
  e.y = y;
}

double quantile(std::vector<double>& v, double q) {
  if (v.empty()) return 0.0;
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(std::floor(q * static_cast<double>(v.size() - 1) + 0.5)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

}  // namespace

Status ScenarioRanges::validate() const {
  if (!(curvature_min_per_m > 0.0 && curvature_min_per_m <= curvature_max_per_m && std::isfinite(curvature_max_per_m)))
    return Error{"curvature range must satisfy 0 < min <= max, got [" + num(curvature_min_per_m) + ", " +
                     num(curvature_max_per_m) + "] 1/m",
                 ErrorCode::out_of_range, {{}, 0, "curvature_min_per_m"}};
  if (!(landmark_min_m > 0.0 && landmark_min_m <= landmark_max_m && std::isfinite(landmark_max_m)))
    return Error{"landmark distance range must satisfy 0 < min <= max, got [" + num(landmark_min_m) + ", " +
                     num(landmark_max_m) + "] m",
                 ErrorCode::out_of_range, {{}, 0, "landmark_min_m"}};
  if (!(initial_error_max_m >= 0.0 && std::isfinite(initial_error_max_m)))
    return Error{"initial_error_max_m must be >= 0, got " + num(initial_error_max_m), ErrorCode::out_of_range,
                 {{}, 0, "initial_error_max_m"}};
  if (!(odom_error_max >= 0.0 && odom_error_max < 0.5)) return fail("odom_error_max must be in [0, 0.5), got " + num(odom_error_max));
  if (!(heading_error_max_deg >= 0.0 && heading_error_max_deg < 45.0))
    return fail("heading_error_max_deg must be in [0, 45), got " + num(heading_error_max_deg));
  if (corners_min < 3 || corners_max < corners_min || corners_max > 64)
    return fail("corners must satisfy 3 <= min <= max <= 64, got [" + std::to_string(corners_min) + ", " +
                std::to_string(corners_max) + "]");
  if (!(radius_min_m > 0.0 && radius_min_m <= radius_max_m && std::isfinite(radius_max_m)))
    return fail("radius range must satisfy 0 < min <= max, got [" + num(radius_min_m) + ", " + num(radius_max_m) + "] m");
  if (!(local_map_spacing_m > 0.0 && std::isfinite(local_map_spacing_m)))
    return fail("local_map_spacing_m must be > 0, got " + num(local_map_spacing_m));
  return ok();
}

Status SimParams::validate() const {
  if (loops < 1 || loops > 1000) return fail("loops must be in [1, 1000], got " + std::to_string(loops));
  if (!(converged_ratio > 0.0 && converged_ratio < 1.0)) return fail("converged_ratio must be in (0, 1), got " + num(converged_ratio));
  if (!(min_step_m > 0.0 && min_step_m <= max_step_m && max_step_m <= 1.0))
    return fail("steps must satisfy 0 < min_step_m <= max_step_m <= 1, got " + num(min_step_m) + ", " + num(max_step_m));
  return ok();
}

double Scenario::length_m() const {
  double s = 0.0;
  for (const Arc& a : arcs) s += a.length_m;
  return s;
}

Scenario draw_scenario(const ScenarioRanges& r, std::uint64_t seed) {
  Rng rng(seed);
  Scenario s;
  s.seed = seed;
  const int n = r.corners_min + static_cast<int>(rng.next() % static_cast<std::uint64_t>(r.corners_max - r.corners_min + 1));
  // A star-shaped polygon: jittered, increasing angles around the centre, so it never crosses itself.
  const double rotation = rng.uniform(0.0, 2.0 * kPi);
  std::vector<double> angle(static_cast<std::size_t>(n)), radius(static_cast<std::size_t>(n));
  double size_m = rng.uniform(r.radius_min_m, r.radius_max_m);
  for (int j = 0; j < n; ++j) {
    angle[static_cast<std::size_t>(j)] = rotation + 2.0 * kPi * (j + rng.uniform(0.0, 0.7)) / n;
    radius[static_cast<std::size_t>(j)] = rng.uniform(0.5, 1.0);
  }
  // Curvature per side: log-uniform magnitude, random sign.
  std::vector<double> kappa(static_cast<std::size_t>(n));
  const double log_lo = std::log(r.curvature_min_per_m), log_hi = std::log(r.curvature_max_per_m);
  for (auto& k : kappa) {
    k = std::exp(rng.uniform(log_lo, log_hi));
    if (rng.next() & 1u) k = -k;
  }
  // An arc of curvature κ spans a chord c only if |κ|·c/2 ≤ 1; keep it ≤ 0.95 (sweep ≤ 144°) by
  // shrinking the polygon rather than changing the drawn curvature.
  auto corner = [&](int j, double scale) {
    const auto i = static_cast<std::size_t>((j % n + n) % n);
    return std::pair<double, double>{scale * radius[i] * std::cos(angle[i]), scale * radius[i] * std::sin(angle[i])};
  };
  double shrink = 1.0;
  for (int j = 0; j < n; ++j) {
    const auto [ax, ay] = corner(j, size_m);
    const auto [bx, by] = corner(j + 1, size_m);
    const double c = std::hypot(bx - ax, by - ay);
    const double need = 1.9 / (std::abs(kappa[static_cast<std::size_t>(j)]) * c);
    shrink = std::min(shrink, need);
  }
  size_m *= shrink;
  s.radius_m = size_m;
  double prev_end_heading = 0.0;
  for (int j = 0; j < n; ++j) {
    const auto [ax, ay] = corner(j, size_m);
    const auto [bx, by] = corner(j + 1, size_m);
    const double c = std::hypot(bx - ax, by - ay);
    const double k = kappa[static_cast<std::size_t>(j)];
    const double half_sweep = std::asin(std::clamp(k * c / 2.0, -1.0, 1.0));  // signed
    const double chord_dir = std::atan2(by - ay, bx - ax);
    Arc a;
    a.x_m = ax;
    a.y_m = ay;
    a.heading_rad = chord_dir - half_sweep;
    a.curvature_per_m = k;
    a.length_m = std::abs(k) * c < 1e-9 ? c : 2.0 * half_sweep / k;
    s.corner_turn_rad.push_back(j == 0 ? 0.0 : wrap_pi(a.heading_rad - prev_end_heading));
    prev_end_heading = chord_dir + half_sweep;
    s.arcs.push_back(a);
  }
  s.corner_turn_rad[0] = wrap_pi(s.arcs[0].heading_rad - prev_end_heading);
  s.landmark_m = rng.uniform(r.landmark_min_m, r.landmark_max_m);
  s.x0_m = rng.uniform(0.0, r.initial_error_max_m) * ((rng.next() & 1u) ? 1.0 : -1.0);
  s.y0_m = rng.uniform(0.0, r.initial_error_max_m) * ((rng.next() & 1u) ? 1.0 : -1.0);
  s.odom_scale_error = rng.uniform(-r.odom_error_max, r.odom_error_max);
  s.heading_error_bound_rad = rng.uniform(0.0, r.heading_error_max_deg) * kPi / 180.0;
  s.local_map_spacing_m = r.local_map_spacing_m;
  return s;
}

namespace {
// Heading-estimation error of local map `index` in loop `loop`: uniform in [−b, b].
double heading_error(const Scenario& s, int loop, std::int64_t index) {
  if (s.heading_error_bound_rad == 0.0) return 0.0;
  Rng rng(s.seed * 0x9E3779B97F4A7C15ull ^ (static_cast<std::uint64_t>(loop) << 40) ^ static_cast<std::uint64_t>(index));
  rng.next();
  return rng.uniform(-s.heading_error_bound_rad, s.heading_error_bound_rad);
}
}  // namespace

ScenarioOutcome simulate(const Scenario& s, const SimParams& p) {
  ScenarioOutcome out;
  ErrorState a{s.x0_m, s.y0_m}, b{0.0, 0.0};
  out.initial_error_m = std::hypot(s.x0_m, s.y0_m);
  const double inv_l = 1.0 / s.landmark_m;
  const double ref_rate = 1.0 + s.odom_scale_error;  // reference metres per metre driven
  const double h_true = std::clamp(s.landmark_m / 4.0, p.min_step_m, p.max_step_m);
  const double h_ref = h_true * ref_rate;
  const double spacing = s.local_map_spacing_m;
  std::vector<double> turn_c(s.arcs.size()), turn_s(s.arcs.size());
  for (std::size_t j = 0; j < s.arcs.size(); ++j) {
    turn_c[j] = std::cos(s.corner_turn_rad[j]);
    turn_s[j] = std::sin(s.corner_turn_rad[j]);
  }
  for (int loop = 0; loop < p.loops; ++loop) {
    double route_pos = 0.0;  // reference distance from the route start
    for (std::size_t j = 0; j < s.arcs.size(); ++j) {
      if (loop > 0 || j > 0) {
        rotate_frame(a, turn_c[j], turn_s[j]);
        rotate_frame(b, turn_c[j], turn_s[j]);
      }
      const double kappa = s.arcs[j].curvature_per_m;
      double left = s.arcs[j].length_m;
      std::int64_t map_index = -1;
      double cos_d = 1.0, sin_d = 0.0;
      while (left > 1e-12) {
        const double step_ref = std::min(h_ref, left);
        const auto idx = static_cast<std::int64_t>((route_pos + 0.5 * step_ref) / spacing);
        if (idx != map_index) {
          map_index = idx;
          const double d = heading_error(s, loop, idx);
          cos_d = std::cos(d);
          sin_d = std::sin(d);
        }
        const double h = step_ref / ref_rate;
        rk2(a, h, kappa, ref_rate, inv_l, cos_d, sin_d);
        rk2(b, h, kappa, ref_rate, inv_l, cos_d, sin_d);
        left -= step_ref;
        route_pos += step_ref;
      }
    }
    out.loop_error_m.push_back(std::hypot(a.x, a.y));
  }
  out.finite = std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(b.x) && std::isfinite(b.y);
  const double gap = std::hypot(a.x - b.x, a.y - b.y);
  out.gap_ratio = out.initial_error_m > 0.0 ? gap / out.initial_error_m : 0.0;
  out.steady_error_m = std::hypot(b.x, b.y);
  out.converged = out.finite && out.gap_ratio <= p.converged_ratio;
  const double mid = out.loop_error_m[static_cast<std::size_t>((p.loops - 1) / 2)];
  const double last = out.loop_error_m.back();
  out.growing = !out.finite || (last > 1.5 * std::max(out.initial_error_m, mid) && last > 1.0);
  return out;
}

Result<BatchSummary> run_batch(const ScenarioRanges& ranges, const SimParams& params, std::uint64_t first_seed,
                               std::uint64_t count, int threads, const std::function<void(std::uint64_t)>& progress) {
  VISNAV_TRY(ranges.validate());
  VISNAV_TRY(params.validate());
  if (threads < 1 || threads > 256) return fail("threads must be in [1, 256], got " + std::to_string(threads));
  const auto t0 = std::chrono::steady_clock::now();
  struct Partial {
    std::uint64_t converged = 0, not_finite = 0, growing = 0, assumption_met = 0, assumption_met_converged = 0;
    std::vector<std::uint64_t> failed;
    std::vector<double> gap, steady, first;
    double worst = -1.0;
    std::uint64_t worst_seed = 0;
  };
  std::vector<Partial> parts(static_cast<std::size_t>(threads));
  std::atomic<std::uint64_t> next{0}, done{0};
  constexpr std::uint64_t kChunk = 256;
  auto worker = [&](Partial& part) {
    for (;;) {
      const std::uint64_t begin = next.fetch_add(kChunk);
      if (begin >= count) break;
      const std::uint64_t end = std::min(count, begin + kChunk);
      for (std::uint64_t i = begin; i < end; ++i) {
        const std::uint64_t seed = first_seed + i;
        const Scenario sc = draw_scenario(ranges, seed);
        const ScenarioOutcome o = simulate(sc, params);
        if (o.initial_error_m < sc.landmark_m) {
          ++part.assumption_met;
          if (o.converged) ++part.assumption_met_converged;
        }
        if (o.converged) {
          ++part.converged;
        } else if (part.failed.size() < 20) {
          part.failed.push_back(seed);
        }
        if (!o.finite) ++part.not_finite;
        if (!o.converged && o.growing) ++part.growing;
        part.gap.push_back(o.gap_ratio);
        part.steady.push_back(o.steady_error_m);
        part.first.push_back(o.initial_error_m > 0.0 ? o.loop_error_m.front() / o.initial_error_m : 0.0);
        if (o.gap_ratio > part.worst) {
          part.worst = o.gap_ratio;
          part.worst_seed = seed;
        }
      }
      done.fetch_add(end - begin);
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(worker, std::ref(parts[static_cast<std::size_t>(t)]));
  while (done.load() < count) {
    if (progress) progress(done.load());
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  for (auto& th : pool) th.join();
  if (progress) progress(done.load());

  BatchSummary sum;
  sum.scenarios = count;
  std::vector<double> gap, steady, first;
  gap.reserve(count);
  steady.reserve(count);
  first.reserve(count);
  for (auto& part : parts) {
    sum.converged += part.converged;
    sum.not_finite += part.not_finite;
    sum.growing += part.growing;
    sum.assumption_met += part.assumption_met;
    sum.assumption_met_converged += part.assumption_met_converged;
    for (auto f : part.failed) sum.failed_seeds.push_back(f);
    gap.insert(gap.end(), part.gap.begin(), part.gap.end());
    steady.insert(steady.end(), part.steady.begin(), part.steady.end());
    first.insert(first.end(), part.first.begin(), part.first.end());
    if (part.worst > sum.worst_gap_ratio) {
      sum.worst_gap_ratio = part.worst;
      sum.worst_gap_seed = part.worst_seed;
    }
  }
  std::sort(sum.failed_seeds.begin(), sum.failed_seeds.end());
  if (sum.failed_seeds.size() > 20) sum.failed_seeds.resize(20);
  for (double q : {0.5, 0.9, 0.99, 0.999, 1.0}) {
    sum.gap_ratio_quantiles.push_back(quantile(gap, q));
    sum.steady_error_quantiles_m.push_back(quantile(steady, q));
    sum.first_loop_ratio_quantiles.push_back(quantile(first, q));
  }
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return sum;
}

}  // namespace visnav::stability
