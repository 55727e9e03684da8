// Route planning: Dijkstra over the directed map graph.
#include <cmath>
#include <limits>
#include <queue>
#include <unordered_map>

#include "map/graph_io.hpp"
#include "visnav/map.hpp"

namespace visnav {

Result<Route> plan_route(const MapStore& map, std::string_view from, std::string_view to, const RouteCost& cost) {
  const double inf = std::numeric_limits<double>::infinity();
  if (!(cost.default_multiplier > 0.0)) return Error{"route cost: default_multiplier must be > 0 (or +inf)", ErrorCode::out_of_range, {{}, 0, "default_multiplier"}};
  if (!(cost.per_edge_cost >= 0.0) || std::isinf(cost.per_edge_cost)) return Error{"route cost: per_edge_cost must be finite and >= 0", ErrorCode::out_of_range, {{}, 0, "per_edge_cost"}};
  for (const auto& [kind, m] : cost.kind_multiplier) {
    if (!(m > 0.0)) return Error{"route cost: multiplier of kind '" + kind + "' must be > 0 (or +inf to forbid it), got " +
                                map_detail::format_double(m), ErrorCode::out_of_range, {{}, 0, kind}};
  }
  VISNAV_ASSIGN(const NodeRecord* start, map.resolve_node(from));
  VISNAV_ASSIGN(const NodeRecord* goal, map.resolve_node(to));

  const auto& nodes = map.nodes();
  const auto& edges = map.edges();
  std::unordered_map<std::string_view, std::size_t> node_index;
  node_index.reserve(nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) node_index.emplace(nodes[i].id, i);
  // Adjacency (CSR) by edge order so ties resolve deterministically.
  std::vector<std::size_t> first(nodes.size() + 1, 0);
  std::vector<std::size_t> edge_from(edges.size()), edge_to(edges.size());
  for (std::size_t e = 0; e < edges.size(); ++e) {
    edge_from[e] = node_index.at(edges[e].from);
    edge_to[e] = node_index.at(edges[e].to);
    ++first[edge_from[e] + 1];
  }
  for (std::size_t i = 0; i < nodes.size(); ++i) first[i + 1] += first[i];
  std::vector<std::size_t> adjacency(edges.size());
  {
    std::vector<std::size_t> fill(first.begin(), first.end() - 1);
    for (std::size_t e = 0; e < edges.size(); ++e) adjacency[fill[edge_from[e]]++] = e;
  }
  auto edge_cost = [&](const EdgeRecord& e) {
    auto it = cost.kind_multiplier.find(e.kind);
    const double m = it == cost.kind_multiplier.end() ? cost.default_multiplier : it->second;
    if (std::isinf(m)) return inf;
    return e.length_m * m + cost.per_edge_cost;
  };

  const std::size_t s = node_index.at(start->id);
  const std::size_t g = node_index.at(goal->id);
  constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
  std::vector<double> dist(nodes.size(), inf);
  std::vector<std::size_t> via(nodes.size(), kNone);
  using Item = std::pair<double, std::size_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> open;
  dist[s] = 0.0;
  open.emplace(0.0, s);
  while (!open.empty()) {
    const auto [d, u] = open.top();
    open.pop();
    if (d > dist[u]) continue;
    if (u == g) break;
    for (std::size_t k = first[u]; k < first[u + 1]; ++k) {
      const std::size_t e = adjacency[k];
      const double c = edge_cost(edges[e]);
      if (std::isinf(c)) continue;
      const std::size_t v = edge_to[e];
      if (d + c < dist[v]) {
        dist[v] = d + c;
        via[v] = e;
        open.emplace(dist[v], v);
      }
    }
  }
  if (std::isinf(dist[g])) {
    return fail(ErrorCode::not_found, map.dir() + ": no route from '" + start->id + "' to '" + goal->id + "'" +
                (cost.kind_multiplier.empty() ? "" : " with the given kind costs"));
  }
  Route route;
  route.from = start->id;
  route.to = goal->id;
  route.cost = dist[g];
  for (std::size_t v = g; v != s; v = edge_from[via[v]]) route.edge_ids.push_back(edges[via[v]].id);
  std::reverse(route.edge_ids.begin(), route.edge_ids.end());
  for (const auto& id : route.edge_ids) route.length_m += map.find_edge(id)->length_m;
  return route;
}

}  // namespace visnav
