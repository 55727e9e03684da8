// `visnav map info|validate|render|route` run as a user would, plus the dead-reckoned layout.
#include <cmath>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "map/render.hpp"
#include "map_test_util.hpp"

namespace visnav {
namespace {

using test::edge;
using test::make_body;
using test::node;
using test::run;
using test::TempDir;

const std::string kCli = VISNAV_TEST_CLI;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

/// A 10 m square: feature edges on two sides, path following on the others.
void make_square(const std::string& dir) {
  auto map = MapStore::create(dir, "square");
  ASSERT_TRUE(map);
  map->set_sync(false);
  for (const char* n : {"a", "b", "c", "d"}) ASSERT_TRUE(map->add_node(node(n, std::string("corner ") + n)));
  ASSERT_TRUE(map->add_edge(edge("a", "b", "feature_segment", 10.0, 0.0), make_body(100000, 1)));
  ASSERT_TRUE(map->add_edge(edge("b", "c", "path_following", 10.0, M_PI / 2), make_body(1000, 2)));
  ASSERT_TRUE(map->add_edge(edge("c", "d", "feature_segment", 10.0, M_PI), make_body(100000, 3)));
  ASSERT_TRUE(map->add_edge(edge("d", "a", "path_following", 10.0, -M_PI / 2), make_body(1000, 4)));
}

TEST(MapLayout, DeadReckonsNodesFromAzimuthsAndLengths) {
  TempDir tmp;
  make_square(tmp / "sq");
  auto map = MapStore::open(tmp / "sq");
  ASSERT_TRUE(map);
  const auto layout = map_detail::layout_map(*map);
  const auto near = [](cv::Point2d p, double x, double y) { return std::abs(p.x - x) < 1e-9 && std::abs(p.y - y) < 1e-9; };
  EXPECT_TRUE(near(layout.node_xy_m.at("a"), 0, 0));
  EXPECT_TRUE(near(layout.node_xy_m.at("b"), 10, 0));
  EXPECT_TRUE(near(layout.node_xy_m.at("c"), 10, 10));
  EXPECT_TRUE(near(layout.node_xy_m.at("d"), 0, 10));
  // The closing edge d->a dead-reckons back onto a.
  EXPECT_TRUE(near(layout.edges[3].end_m, 0, 0));
}

TEST(MapLayout, PositionHintsAnchorTheLayout) {
  TempDir tmp;
  auto map = MapStore::create(tmp / "m", "m");
  ASSERT_TRUE(map);
  NodeRecord a = node("a");
  a.position_hint = Pose2D{100.0, 50.0, 0.0};
  ASSERT_TRUE(map->add_node(a));
  ASSERT_TRUE(map->add_node(node("b")));
  ASSERT_TRUE(map->add_node(node("lonely")));
  ASSERT_TRUE(map->add_edge(edge("b", "a", "feature_segment", 5.0, M_PI / 2), {}));
  const auto layout = map_detail::layout_map(*map);
  // b is reached backwards along b->a: 5 m south of a.
  EXPECT_NEAR(layout.node_xy_m.at("b").x, 100.0, 1e-9);
  EXPECT_NEAR(layout.node_xy_m.at("b").y, 45.0, 1e-9);
  EXPECT_GT(layout.node_xy_m.at("lonely").x, 100.0);  // unconnected: placed beside, not on top
}

TEST(MapLayout, RenderDrawsTheMarksAnEdgeStatesAlongIt) {
  TempDir tmp;
  auto map = MapStore::create(tmp / "marks", "marks");
  ASSERT_TRUE(map);
  map->set_sync(false);
  ASSERT_TRUE(map->add_node(node("a", "a")));
  ASSERT_TRUE(map->add_node(node("b", "b")));
  auto e = edge("a", "b", "visual_memory", 10.0, 0.0);
  ASSERT_TRUE(map->add_edge(e, make_body(1000, 1)));
  auto plain = map_detail::render_map(*map, 800);
  ASSERT_TRUE(plain);
  auto marked_map = MapStore::create(tmp / "marks2", "marks");
  ASSERT_TRUE(marked_map);
  marked_map->set_sync(false);
  ASSERT_TRUE(marked_map->add_node(node("a", "a")));
  ASSERT_TRUE(marked_map->add_node(node("b", "b")));
  e.statistics["mark.r000_m"] = 2.5;
  e.statistics["mark.r001_m"] = 5.0;
  e.statistics["marks_total"] = 7.5;  // not a mark (no "mark." prefix): not drawn
  ASSERT_TRUE(marked_map->add_edge(e, make_body(1000, 1)));
  auto marked = map_detail::render_map(*marked_map, 800);
  ASSERT_TRUE(marked);
  ASSERT_EQ(plain->size(), marked->size());
  // The two images differ in two small patches only: a tick a quarter and half way along.
  cv::Mat diff;
  cv::absdiff(*plain, *marked, diff);
  cv::cvtColor(diff, diff, cv::COLOR_BGR2GRAY);
  std::vector<cv::Point> changed;
  cv::findNonZero(diff > 0, changed);
  ASSERT_FALSE(changed.empty());
  const cv::Rect box = cv::boundingRect(changed);
  EXPECT_LT(box.height, 30);                      // ticks, not a redrawn map
  EXPECT_NEAR(box.width, 0.25 * (800 - 140), 12);  // from 2.5 m to 5.0 m of a 10 m edge drawn 660 px long
}

TEST(MapCli, InfoShowsKindsLengthsAndBytesPerMetre) {
  TempDir tmp;
  make_square(tmp / "sq");
  const auto [status, out] = run(kCli + " map info " + tmp / "sq");
  EXPECT_EQ(status, 0) << out;
  EXPECT_TRUE(contains(out, "nodes: 4")) << out;
  EXPECT_TRUE(contains(out, "edges: 4")) << out;
  EXPECT_TRUE(contains(out, "length: 40.00 m")) << out;
  EXPECT_TRUE(contains(out, "feature_segment")) << out;
  EXPECT_TRUE(contains(out, "path_following")) << out;
  EXPECT_TRUE(contains(out, "10004.9")) << out;  // 2 x (100000 + 32 + 15 + 2) B / 20 m
}

TEST(MapCli, ValidatePassesThenFailsNamingTheDamagedFile) {
  // The square's bodies are synthetic: --no-plugins checks files, headers and sizes only (bodies
  // decoded by the primitives' readers: tests/integration/security).
  TempDir tmp;
  make_square(tmp / "sq");
  auto [status, out] = run(kCli + " map validate " + tmp / "sq" + " --no-plugins");
  EXPECT_EQ(status, 0) << out;
  EXPECT_TRUE(contains(out, "OK")) << out;
  const std::string e1 = tmp / "sq/edges/e1.bin";
  auto bytes = test::read_bytes(e1);
  bytes[bytes.size() / 2] ^= 0x10;
  test::write_bytes(e1, bytes);
  const std::string e2 = tmp / "sq/edges/e2.bin";
  bytes = test::read_bytes(e2);
  bytes.resize(100);
  test::write_bytes(e2, bytes);
  std::tie(status, out) = run(kCli + " map validate " + tmp / "sq" + " --no-plugins");
  EXPECT_EQ(status, 1) << out;
  EXPECT_TRUE(contains(out, e1 + ": damaged body: checksum mismatch")) << out;
  EXPECT_TRUE(contains(out, e2 + ": truncated")) << out;
  EXPECT_TRUE(contains(out, "INVALID (2 problems)")) << out;
  // A broken graph: one line naming graph.yaml and the line.
  test::write_text(tmp / "sq/graph.yaml", "format: visnav-map\nversion: 1\nname: [oops\n");
  std::tie(status, out) = run(kCli + " map validate " + tmp / "sq" + " --no-plugins");
  EXPECT_EQ(status, 1) << out;
  EXPECT_TRUE(contains(out, tmp / "sq/graph.yaml:")) << out;
}

TEST(MapCli, RenderWritesAPictureOfTheLayout) {
  TempDir tmp;
  make_square(tmp / "sq");
  const std::string png = tmp / "map.png";
  const auto [status, out] = run(kCli + " map render " + tmp / "sq" + " -o " + png + " --width 800");
  ASSERT_EQ(status, 0) << out;
  const cv::Mat img = cv::imread(png);
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 800);
  // Both kind colours appear (red feature edges, blue path edges).
  const cv::Scalar red = map_detail::kind_colour("feature_segment");
  const cv::Scalar blue = map_detail::kind_colour("path_following");
  int red_px = 0, blue_px = 0;
  for (int y = 0; y < img.rows; ++y) {
    for (int x = 0; x < img.cols; ++x) {
      const auto p = img.at<cv::Vec3b>(y, x);
      if (p == cv::Vec3b(static_cast<uchar>(red[0]), static_cast<uchar>(red[1]), static_cast<uchar>(red[2]))) ++red_px;
      if (p == cv::Vec3b(static_cast<uchar>(blue[0]), static_cast<uchar>(blue[1]), static_cast<uchar>(blue[2]))) ++blue_px;
    }
  }
  EXPECT_GT(red_px, 500);
  EXPECT_GT(blue_px, 500);
  // An empty map renders too; a bad output path is an error, not a crash.
  ASSERT_TRUE(MapStore::create(tmp / "empty", "empty"));
  EXPECT_EQ(run(kCli + " map render " + tmp / "empty" + " -o " + tmp / "empty.png").first, 0);
  EXPECT_EQ(run(kCli + " map render " + tmp / "sq" + " -o " + tmp / "no/such/dir/x.png").first, 1);
}

TEST(MapCli, RouteAndUsageErrors) {
  TempDir tmp;
  make_square(tmp / "sq");
  auto [status, out] = run(kCli + " map route " + tmp / "sq" + " a d");
  EXPECT_EQ(status, 0) << out;
  EXPECT_TRUE(contains(out, "3 edges, 30.00 m")) << out;
  std::tie(status, out) = run(kCli + " map route " + tmp / "sq" + " a d --cost path_following=inf");
  EXPECT_EQ(status, 1) << out;
  EXPECT_TRUE(contains(out, "no route")) << out;
  EXPECT_EQ(run(kCli + " map").first, 2);
  EXPECT_EQ(run(kCli + " map frobnicate " + tmp / "sq").first, 2);
  EXPECT_EQ(run(kCli + " map render " + tmp / "sq").first, 2);
  std::tie(status, out) = run(kCli + " map info " + tmp / "missing");
  EXPECT_EQ(status, 1);
  EXPECT_TRUE(contains(out, "missing")) << out;
}

}  // namespace
}  // namespace visnav
