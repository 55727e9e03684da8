// `visnav evaluate`: a simulated run against a style-B map taught from a live run of the same
// route (LocalMapTeacher over the recorded frames): where the run passes the taught places the
// offsets are ~0 with many inliers; against a run that starts rotated by 8° they are not.
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/imgcodecs.hpp>

#include "camera_test_support.hpp"
#include "recorded_test_support.hpp"
#include "visnav/evaluation/evaluate.hpp"
#include "visnav/feature_replay/local_map.hpp"
#include "visnav/map.hpp"
#include "visnav/recorded/odometry_log.hpp"
#include "visnav/recorded/run_format.hpp"

using namespace visnav::testing;
namespace vr = visnav::recorded;
namespace fr = visnav::feature_replay;

namespace {

/// Records the route with the given start heading error; returns the run folder ("" on failure).
std::string record(const std::string& name, double heading_deg, std::string* log_text) {
  const SimSetup s = make_setup(name, 2.0, heading_deg);
  const std::string run = s.dir + "/run";
  const std::string log = s.dir + "/record.log";
  const int rc = shell("'" + s.cli + "' record --config " + s.config + " -o " + run + " --tree " + s.tree, log);
  *log_text = slurp(log);
  return rc == 0 ? run : "";
}

/// Teaches a one-edge localmaps map from a recorded run (every frame, 0.2 m apart).
void teach(const std::string& run, const std::string& map_dir, visnav::Detector& detector) {
  auto frames = vr::read_run_frames(run);
  ASSERT_TRUE(frames.ok()) << frames.error().message;
  auto odo = vr::OdometryLog::load(run + "/odometry.csv");
  ASSERT_TRUE(odo.ok()) << odo.error().message;
  fr::LocalMapTeacher teacher;
  teacher.begin();
  visnav::Features features;
  double d0 = 0.0;
  double d = 0.0;
  for (std::size_t i = 0; i < frames->frames.size(); ++i) {
    const cv::Mat img = cv::imread(frames->frames[i].path, cv::IMREAD_ANYCOLOR);
    ASSERT_TRUE(detector.detect(img, features).ok());
    const auto o = odo->sample_at(frames->frames[i].t_s, vr::OdometrySync::latest);
    ASSERT_TRUE(o.has_value());
    if (i == 0) d0 = o->distance_m;
    d = o->distance_m - d0;
    if (i + 1 < frames->frames.size()) {
      ASSERT_TRUE(teacher.add_frame(d, features).ok());
    }
  }
  auto path = teacher.finish(d, features);
  ASSERT_TRUE(path.ok()) << path.error().message;
  fs::remove_all(map_dir);
  auto map = visnav::MapStore::create(map_dir, "eval");
  ASSERT_TRUE(map.ok()) << map.error().message;
  visnav::NodeRecord start;
  start.name = "start";
  visnav::NodeRecord end;
  end.name = "end";
  auto a = map->add_node(start);
  auto b = map->add_node(end);
  ASSERT_TRUE(a.ok() && b.ok());
  visnav::EdgeRecord e;
  e.from = *a;
  e.to = *b;
  e.kind = "feature_localmaps";
  e.length_m = path->length_m;
  auto edge = map->add_edge(e, path->serialize());
  ASSERT_TRUE(edge.ok()) << edge.error().message;
}

}  // namespace

TEST(Evaluate, RunAgainstAMapTaughtFromItAndFromAnotherStart) {
  std::string log;
  const std::string taught = record("evaluate_taught", 0.0, &log);
  ASSERT_FALSE(taught.empty()) << log;
  const std::string rotated = record("evaluate_rotated", 8.0, &log);
  ASSERT_FALSE(rotated.empty()) << log;

  LoaderHost h;
  auto detector = h.loader.create<visnav::Detector>("orb", yaml("target_keypoints: 300\n"), h.host, "detectors_opencv");
  ASSERT_TRUE(detector.ok()) << detector.error().message;
  const std::string map_dir = fs::path(taught).parent_path().string() + "/map";
  teach(taught, map_dir, **detector);
  if (HasFatalFailure()) return;

  auto map = visnav::MapStore::open(map_dir);
  ASSERT_TRUE(map.ok()) << map.error().message;
  visnav::evaluation::EvaluationOptions options;
  auto same = visnav::evaluation::evaluate_run(*map, taught, **detector, options);
  ASSERT_TRUE(same.ok()) << same.error().message;
  const auto s = visnav::evaluation::summarize(*same);
  EXPECT_GT(s.valid, s.frames * 8 / 10) << s.valid << " of " << s.frames;
  EXPECT_LT(s.median_abs_offset_px, 1.5);
  int exact = 0;
  for (const auto& row : *same) {
    EXPECT_EQ(row.edge, map->edges().front().id);
    if (std::abs(row.map_distance_m - row.edge_distance_m) < 1e-5 && row.estimate.valid) {  // payload distances are float32
      EXPECT_NEAR(row.estimate.offset_px, 0.0, 1.0);  // the very image the local map was made from
      ++exact;
    }
  }
  EXPECT_GT(exact, 5);

  auto other = visnav::evaluation::evaluate_run(*map, rotated, **detector, options);
  ASSERT_TRUE(other.ok()) << other.error().message;
  // The rotated run starts 8° to the left: the scene appears shifted right (positive offset)
  // early on, about 120 px · 8° / 60° ≈ 16 px, before the steering pulls it back.
  double early = 0.0;
  int n = 0;
  for (const auto& row : *other)
    if (row.estimate.valid && row.run_distance_m < 0.3) {
      early += row.estimate.offset_px;
      ++n;
    }
  ASSERT_GT(n, 0);
  EXPECT_GT(early / n, 5.0);

  // The CLI writes the same rows, and a plot.
  const std::string csv = map_dir + "/../eval.csv";
  const std::string png = map_dir + "/../eval.png";
  const std::string cli_log = map_dir + "/../eval.log";
  ASSERT_EQ(shell("'" + std::string(VISNAV_TEST_CLI) + "' evaluate --map " + map_dir + " --run " + rotated +
                      " --detector orb --param target_keypoints=300 -o " + csv + " --plot " + png,
                  cli_log),
            0)
      << slurp(cli_log);
  EXPECT_EQ(lines_of(csv).size(), other->size() + 1);
  EXPECT_FALSE(cv::imread(png).empty());
  EXPECT_NE(slurp(cli_log).find("frames " + std::to_string(other->size())), std::string::npos) << slurp(cli_log);
  EXPECT_EQ(shell("'" + std::string(VISNAV_TEST_CLI) + "' evaluate --map " + map_dir + " --run /no/such/run -o " + csv, cli_log), 1);
  EXPECT_NE(slurp(cli_log).find("/no/such/run"), std::string::npos) << slurp(cli_log);
}
