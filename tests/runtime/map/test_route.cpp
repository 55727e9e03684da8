// Route planning over the directed map graph.
#include <cmath>
#include <limits>

#include "error_expect.hpp"
#include "map_test_util.hpp"

namespace visnav {
namespace {

using test::edge;
using test::make_body;
using test::node;
using test::TempDir;

//      A --feature 10--> B --feature 10--> D
//      A --path 12-----> C --path 12-----> D --path 5--> A        E (isolated)
class RouteMap : public ::testing::Test {
 protected:
  void SetUp() override {
    auto map = MapStore::create(tmp_ / "m", "routes");
    ASSERT_TRUE(map);
    map->set_sync(false);
    for (const auto& [id, name] : std::vector<std::pair<std::string, std::string>>{
             {"A", "lab"}, {"B", "hall"}, {"C", "garden"}, {"D", "gate"}, {"E", "island"}}) {
      ASSERT_TRUE(map->add_node(node(id, name)));
    }
    const auto body = make_body(8, 1);
    ASSERT_TRUE(map->add_edge(edge("A", "B", "feature_segment", 10.0, 0.0, "ab"), body));
    ASSERT_TRUE(map->add_edge(edge("B", "D", "feature_segment", 10.0, 0.0, "bd"), body));
    ASSERT_TRUE(map->add_edge(edge("A", "C", "path_following", 12.0, 1.0, "ac"), body));
    ASSERT_TRUE(map->add_edge(edge("C", "D", "path_following", 12.0, -1.0, "cd"), body));
    ASSERT_TRUE(map->add_edge(edge("D", "A", "path_following", 5.0, 3.0, "da"), body));
    map_ = std::make_unique<MapStore>(std::move(map).value());
  }
  TempDir tmp_;
  std::unique_ptr<MapStore> map_;
};

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;
using visnav::test::key_only;

TEST_F(RouteMap, ShortestByLength) {
  auto r = plan_route(*map_, "A", "D");
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r->edge_ids, (std::vector<std::string>{"ab", "bd"}));
  EXPECT_DOUBLE_EQ(r->length_m, 20.0);
  EXPECT_DOUBLE_EQ(r->cost, 20.0);
  EXPECT_EQ(r->from, "A");
  EXPECT_EQ(r->to, "D");
}

TEST_F(RouteMap, PerKindCostChangesTheRoute) {
  RouteCost cost;
  cost.kind_multiplier["feature_segment"] = 2.0;  // prefer path following
  auto r = plan_route(*map_, "A", "D", cost);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r->edge_ids, (std::vector<std::string>{"ac", "cd"}));
  EXPECT_DOUBLE_EQ(r->length_m, 24.0);
  EXPECT_DOUBLE_EQ(r->cost, 24.0);
  cost.kind_multiplier["path_following"] = 3.0;
  r = plan_route(*map_, "A", "D", cost);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->edge_ids, (std::vector<std::string>{"ab", "bd"}));
  EXPECT_DOUBLE_EQ(r->cost, 40.0);
}

TEST_F(RouteMap, RoutesAreDirectedAndResolveNames) {
  auto r = plan_route(*map_, "hall", "lab");  // B -> D -> A, never against an edge
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r->edge_ids, (std::vector<std::string>{"bd", "da"}));
  r = plan_route(*map_, "C", "B");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->edge_ids, (std::vector<std::string>{"cd", "da", "ab"}));
  r = plan_route(*map_, "A", "A");
  ASSERT_TRUE(r);
  EXPECT_TRUE(r->edge_ids.empty());
  EXPECT_EQ(r->length_m, 0.0);
}

TEST_F(RouteMap, UnreachableGoalAndForbiddenKinds) {
  auto r = plan_route(*map_, "A", "E");
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, ErrorCode::not_found) << r.error().message;
  EXPECT_NE(r.error().message.find("no route from 'A' to 'E'"), std::string::npos) << r.error().message;  // says which
  RouteCost no_paths;
  no_paths.kind_multiplier["path_following"] = std::numeric_limits<double>::infinity();
  r = plan_route(*map_, "D", "A", no_paths);  // only a path edge leads back
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, ErrorCode::not_found) << r.error().message;
  EXPECT_TRUE(plan_route(*map_, "A", "D", no_paths));
}

TEST_F(RouteMap, UnknownNodesAndInvalidCosts) {
  auto r = plan_route(*map_, "A", "mars");
  EXPECT_TRUE(fails_with(r, ErrorCode::not_found, key_only("mars")));
  EXPECT_FALSE(plan_route(*map_, "", "A"));
  RouteCost bad;
  bad.kind_multiplier["feature_segment"] = 0.0;
  EXPECT_FALSE(plan_route(*map_, "A", "D", bad));
  bad = {};
  bad.default_multiplier = -1.0;
  EXPECT_FALSE(plan_route(*map_, "A", "D", bad));
  bad = {};
  bad.per_edge_cost = std::nan("");
  EXPECT_FALSE(plan_route(*map_, "A", "D", bad));
}

TEST_F(RouteMap, PerEdgeCostPrefersFewerEdges) {
  // Add a direct A->D edge slightly longer than A->B->D.
  ASSERT_TRUE(map_->add_edge(edge("A", "D", "feature_segment", 21.0, 0.0, "ad"), make_body(8, 2)));
  EXPECT_EQ(plan_route(*map_, "A", "D")->edge_ids, (std::vector<std::string>{"ab", "bd"}));
  RouteCost cost;
  cost.per_edge_cost = 2.0;
  EXPECT_EQ(plan_route(*map_, "A", "D", cost)->edge_ids, (std::vector<std::string>{"ad"}));
}

}  // namespace
}  // namespace visnav
