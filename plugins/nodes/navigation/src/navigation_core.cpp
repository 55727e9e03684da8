#include "visnav_navigation/navigation_core.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <optional>
#include <limits>
#include <numbers>

namespace visnav::nav {

namespace {
std::string trim(std::string_view text) {
  std::size_t b = 0;
  std::size_t e = text.size();
  while (b < e && std::isspace(static_cast<unsigned char>(text[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(text[e - 1]))) --e;
  return std::string(text.substr(b, e - b));
}

Result<std::pair<std::string, std::string>> split_entry(const std::string& entry) {
  const auto eq = entry.find('=');
  if (eq == std::string::npos)
    return Error{"entry '" + entry + "' is not of the form kind=value", ErrorCode::invalid_value, {{}, 0, entry}};
  std::string key = trim(std::string_view(entry).substr(0, eq));
  std::string value = trim(std::string_view(entry).substr(eq + 1));
  if (key.empty() || value.empty()) return fail("entry '" + entry + "' has an empty kind or value");
  return std::make_pair(std::move(key), std::move(value));
}
}  // namespace

double wrap_angle_rad(double angle_rad) {
  double a = std::remainder(angle_rad, 2.0 * std::numbers::pi);
  if (a <= -std::numbers::pi) a += 2.0 * std::numbers::pi;
  return a;
}

Status TurnParams::validate() const {
  if (!(gain_per_s > 0.0)) return fail("gain_per_s must be > 0");
  if (!(max_angular_radps > 0.0)) return fail("max_angular_radps must be > 0");
  if (min_angular_radps < 0.0 || min_angular_radps > max_angular_radps)
    return fail("min_angular_radps must be within [0, max_angular_radps]");
  if (!(tolerance_rad > 0.0) || tolerance_rad > 0.5) return fail("tolerance_rad must be within (0, 0.5]");
  return ok();
}

double turn_command_radps(double error_rad, const TurnParams& params) {
  if (std::abs(error_rad) <= params.tolerance_rad) return 0.0;
  double w = params.gain_per_s * error_rad;
  const double magnitude = std::clamp(std::abs(w), params.min_angular_radps, params.max_angular_radps);
  return std::copysign(magnitude, error_rad);
}

Status ArcTurnParams::validate() const {
  if (!(min_turning_radius_m >= 0.0 && min_turning_radius_m <= 100.0))
    return fail(ErrorCode::out_of_range, {"", 0, "min_turning_radius_m"},
                "value " + std::to_string(min_turning_radius_m) + " must be in [0, 100] m");
  if (!(speed_mps > 0.0 && speed_mps <= 2.0))
    return fail(ErrorCode::out_of_range, {"", 0, "arc_speed_mps"},
                "value " + std::to_string(speed_mps) + " must be in (0, 2] m/s");
  return ok();
}

Twist arc_turn_command(double error_rad, const TurnParams& turn, const ArcTurnParams& arc) {
  if (!arc.arcs()) return Twist{0.0, turn_command_radps(error_rad, turn)};
  if (!(std::abs(error_rad) > turn.tolerance_rad)) return Twist{};
  // The curvature bound is a bound on ω/v: at the arc's speed, ω may not exceed v / R.
  const double w_max = std::min(turn.max_angular_radps, arc.speed_mps / arc.min_turning_radius_m);
  const double w = std::clamp(std::abs(turn.gain_per_s * error_rad), std::min(turn.min_angular_radps, w_max), w_max);
  return Twist{arc.speed_mps, std::copysign(w, error_rad)};
}

double turn_between_edges_rad(const EdgeRecord& previous, const EdgeRecord& next) {
  double end_heading = previous.azimuth_rad;
  if (auto it = previous.statistics.find("end_heading_rad"); it != previous.statistics.end()) end_heading = it->second;
  return wrap_angle_rad(next.azimuth_rad - end_heading);
}

double carried_distance_m(double beyond_end_m, double taught_gap_m, double turn_rad, double max_carry_m) {
  if (!std::isfinite(beyond_end_m) || !std::isfinite(taught_gap_m) || !std::isfinite(turn_rad) || !(max_carry_m > 0.0))
    return 0.0;
  return std::clamp((beyond_end_m - taught_gap_m) * std::cos(turn_rad), -max_carry_m, max_carry_m);
}

Status DistanceScaleParams::validate() const {
  if (!(min_baseline_m > 0.0) || !std::isfinite(min_baseline_m))
    return fail(ErrorCode::out_of_range, {"", 0, "scale_min_baseline_m"},
                "value " + std::to_string(min_baseline_m) + " must be a finite distance > 0");
  if (!(max_deviation > 0.0 && max_deviation <= 0.5))
    return fail(ErrorCode::out_of_range, {"", 0, "scale_max_deviation"},
                "value " + std::to_string(max_deviation) + " must be in (0, 0.5]");
  return ok();
}

void DistanceScaleEstimator::add_fix(double taught_m, double odometry_m) {
  if (!std::isfinite(taught_m) || !std::isfinite(odometry_m)) return;
  if (n_ == 0) {
    t0_ = taught_m;
    d0_ = odometry_m;
    t_min_ = t_max_ = taught_m;
  }
  const double t = taught_m - t0_, d = odometry_m - d0_;
  ++n_;
  sum_t_ += t;
  sum_d_ += d;
  sum_tt_ += t * t;
  sum_td_ += t * d;
  t_min_ = std::min(t_min_, taught_m);
  t_max_ = std::max(t_max_, taught_m);
}

void DistanceScaleEstimator::reset() { *this = DistanceScaleEstimator(params_); }

double DistanceScaleEstimator::scale() const {
  if (n_ < 2 || t_max_ - t_min_ < params_.min_baseline_m) return 1.0;
  const double n = static_cast<double>(n_);
  const double var_t = sum_tt_ - sum_t_ * sum_t_ / n;
  if (!(var_t > 0.0)) return 1.0;
  const double slope = (sum_td_ - sum_t_ * sum_d_ / n) / var_t;
  if (!std::isfinite(slope)) return 1.0;
  return std::clamp(slope, 1.0 - params_.max_deviation, 1.0 + params_.max_deviation);
}

Result<KindMap> parse_kind_map(const std::vector<std::string>& entries) {
  KindMap out;
  for (const auto& entry : entries) {
    if (trim(entry).empty()) continue;
    VISNAV_ASSIGN(auto kv, split_entry(entry));
    if (find_kind(out, kv.first) != nullptr) return fail("kind '" + kv.first + "' is mapped twice");
    out.push_back(std::move(kv));
  }
  return out;
}

const std::string* find_kind(const KindMap& map, std::string_view kind) {
  for (const auto& [k, id] : map)
    if (k == kind) return &id;
  return nullptr;
}

Result<RouteCost> parse_kind_costs(const std::vector<std::string>& entries) {
  RouteCost cost;
  for (const auto& entry : entries) {
    if (trim(entry).empty()) continue;
    VISNAV_ASSIGN(auto kv, split_entry(entry));
    double multiplier = 0.0;
    if (kv.second == "inf") {
      multiplier = std::numeric_limits<double>::infinity();
    } else {
      auto parsed = detail::parse_double(kv.second);
      if (!parsed) return fail("entry '" + entry + "': " + parsed.error().message);
      multiplier = *parsed;
    }
    if (!(multiplier > 0.0)) return fail("entry '" + entry + "': the multiplier must be > 0");
    cost.kind_multiplier[kv.first] = multiplier;
  }
  return cost;
}

std::string format_progress(const ProgressCheckpoint& progress) {
  char distance[48];
  std::snprintf(distance, sizeof distance, "%.3f", progress.distance_m);
  std::string text = "# visnav progress checkpoint (FollowRoute checkpoint=\"true\"); `visnav run --resume` reads it\n";
  text.append("resume_edge: ").append(progress.edge).append("\n");
  text.append("resume_distance_m: ").append(distance).append("\n");
  text.append("resume_goal: ").append(progress.goal).append("\n");
  return text;
}

Status write_progress(const std::string& map_dir, const ProgressCheckpoint& progress) {
  const std::string text = format_progress(progress);
  return write_file_durably(map_dir, kProgressFile,
                            std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}

Status clear_progress(const std::string& map_dir) {
  std::error_code ec;
  std::filesystem::remove(std::filesystem::path(map_dir) / kProgressFile, ec);
  if (ec) return fail(ErrorCode::io, map_dir + "/" + kProgressFile + ": cannot remove: " + ec.message());
  return ok();
}

Result<Route> plan_from_edge(const MapStore& map, std::string_view edge_id, std::string_view goal, const RouteCost& cost) {
  const EdgeRecord* edge = map.find_edge(edge_id);
  if (edge == nullptr)
    return fail(ErrorCode::not_found, "no edge '" + std::string(edge_id) + "' in map " + map.dir());
  VISNAV_ASSIGN(const NodeRecord* goal_node, map.resolve_node(goal));
  Route route;
  route.from = edge->from;
  route.to = goal_node->id;
  route.edge_ids.push_back(edge->id);
  route.length_m = edge->length_m;
  auto it = cost.kind_multiplier.find(edge->kind);
  route.cost = edge->length_m * (it != cost.kind_multiplier.end() ? it->second : cost.default_multiplier) + cost.per_edge_cost;
  if (edge->to == goal_node->id) return route;
  VISNAV_ASSIGN(Route rest, plan_route(map, edge->to, goal_node->id, cost));
  route.edge_ids.insert(route.edge_ids.end(), rest.edge_ids.begin(), rest.edge_ids.end());
  route.length_m += rest.length_m;
  route.cost += rest.cost;
  return route;
}

Result<Route> plan_cycle(const MapStore& map, std::string_view node, const RouteCost& cost) {
  VISNAV_ASSIGN(const NodeRecord* start, map.resolve_node(node));
  // The cheapest cycle through `start` is an outgoing edge start→x followed by the cheapest
  // route x→start; try every outgoing edge.
  std::optional<Route> best;
  for (const EdgeRecord* first : map.outgoing(start->id)) {
    const double multiplier = cost.kind_multiplier.count(first->kind) ? cost.kind_multiplier.at(first->kind)
                                                                      : cost.default_multiplier;
    if (std::isinf(multiplier)) continue;
    Route candidate;
    candidate.from = start->id;
    candidate.to = start->id;
    candidate.edge_ids.push_back(first->id);
    candidate.length_m = first->length_m;
    candidate.cost = first->length_m * multiplier + cost.per_edge_cost;
    if (first->to != start->id) {
      auto rest = plan_route(map, first->to, start->id, cost);
      if (!rest) continue;
      candidate.edge_ids.insert(candidate.edge_ids.end(), rest->edge_ids.begin(), rest->edge_ids.end());
      candidate.length_m += rest->length_m;
      candidate.cost += rest->cost;
    }
    if (!best || candidate.cost < best->cost) best = std::move(candidate);
  }
  if (!best)
    return Error{"node '" + std::string(node) + "' lies on no closed route", ErrorCode::not_found, {{}, 0, std::string(node)}};
  return std::move(*best);
}

}  // namespace visnav::nav
