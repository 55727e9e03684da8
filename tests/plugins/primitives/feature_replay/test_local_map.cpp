// Map style B (seed 002 Sec. 2.3-2.4): local maps by distance, recorded commands replayed by
// distance, the histogram correction on a curved synthetic path, overshoot carry-over on closed
// paths, low-confidence behaviour, payload round trip and rejection of damaged payloads.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <memory>
#include <random>

#include <opencv2/imgproc.hpp>

#include "test_support.hpp"
#include "visnav/feature_replay/local_map.hpp"

namespace fr = visnav::feature_replay;
using visnav::Features;
using visnav::Pose2D;
using visnav::Twist;

namespace {

Twist taught_command(double d) {
  if (d < 3.0) return {0.3, 0.0};
  return {0.3, 0.04};
}

// Points uniformly in a box, at least 1.5 m from the taught path.
fr_test::SyntheticScene curved_scene(const std::vector<Pose2D>& path) {
  fr_test::SyntheticScene s;
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> ux(-3.0, 35.0), uy(-12.0, 25.0), uz(0.0, 3.0);
  s.descriptors.create(0, 32, CV_8UC1);
  cv::Mat row(1, 32, CV_8UC1);
  while (s.points.size() < 2500) {
    const cv::Point3d p(ux(rng), uy(rng), uz(rng));
    bool near = false;
    for (const auto& q : path) near = near || std::hypot(p.x - q.x_m, p.y - q.y_m) < 1.5;
    if (near) continue;
    s.points.push_back(p);
    cv::randu(row, 0, 256);
    s.descriptors.push_back(row);
  }
  return s;
}

struct TaughtB {
  std::vector<Pose2D> poses;
  fr_test::SyntheticScene scene;
  std::shared_ptr<const fr::LocalMapPath> path;
  Pose2D end;
};

const TaughtB& taught() {
  static const TaughtB t = [] {
    TaughtB r;
    const double dt = 0.1;
    Pose2D p{};
    for (double d = 0.0; d < 12.0; d += 0.3 * dt) {
      r.poses.push_back(p);
      fr_test::integrate(p, taught_command(d), dt);
    }
    r.scene = curved_scene(r.poses);
    std::mt19937 rng(5);
    fr::LocalMapTeacher teacher;
    p = Pose2D{};
    double d = 0.0;
    while (d < 12.0) {
      teacher.record_command(d, taught_command(d));
      EXPECT_TRUE(teacher.add_frame(d, r.scene.observe(p, rng)).ok());
      fr_test::integrate(p, taught_command(d), dt);
      d += 0.3 * dt;
    }
    r.end = p;
    auto path = teacher.finish(d, r.scene.observe(p, rng));
    EXPECT_TRUE(path.ok());
    r.path = std::make_shared<const fr::LocalMapPath>(std::move(path).value());
    return r;
  }();
  return t;
}

double replay_end_error(double gain, double y0, double* heading_out = nullptr) {
  fr::LocalMapReplayParams params;
  params.gain_radps_per_px = gain;
  fr::LocalMapReplayer rep(taught().path, params);
  std::mt19937 rng(8);
  Pose2D pose{0.0, y0, 0.0};
  double odo = 0.0;
  rep.begin(odo);
  const double dt = 0.1;
  for (int i = 0; i < 2000; ++i) {
    const auto out = rep.step(odo, taught().scene.observe(pose, rng), 640.0);
    if (out.finished) break;
    fr_test::integrate(pose, out.command, dt);
    odo += std::abs(out.command.linear_mps) * dt;
  }
  if (heading_out != nullptr) *heading_out = pose.heading_rad - taught().end.heading_rad;
  return std::hypot(pose.x_m - taught().end.x_m, pose.y_m - taught().end.y_m);
}

}  // namespace

TEST(LocalMapTeacher, MapsEveryIntervalAndCommandsOnChange) {
  const auto& path = *taught().path;
  ASSERT_TRUE(path.validate().ok());
  EXPECT_NEAR(path.length_m, 12.0, 0.05);
  // a local map at 0 and every 0.2 m (frames every 0.03 m: first frame past each 0.2 m step)
  ASSERT_GE(path.maps.size(), 50u);
  EXPECT_DOUBLE_EQ(path.maps.front().distance_m, 0.0);
  for (std::size_t i = 1; i < path.maps.size() - 1; ++i) {
    const double gap = path.maps[i].distance_m - path.maps[i - 1].distance_m;
    EXPECT_GE(gap, 0.2 - 1e-6);
    EXPECT_LT(gap, 0.2 + 0.031);
  }
  // commands: start (0.3, 0) at 0, the turn at ~3 m, the stop at the end
  ASSERT_EQ(path.commands.size(), 3u);
  EXPECT_DOUBLE_EQ(path.commands[0].distance_m, 0.0);
  EXPECT_NEAR(path.commands[1].distance_m, 3.0, 0.031);
  EXPECT_DOUBLE_EQ(path.commands[1].command.angular_radps, 0.04);
  EXPECT_DOUBLE_EQ(path.commands[2].command.linear_mps, 0.0);
  const auto blob = path.serialize();
  std::cout << "[ style B ] " << path.maps.size() << " local maps, " << blob.size() << " B for " << path.length_m
            << " m = " << blob.size() / path.length_m / 1000.0 << " KB/m (synthetic scene, no images)\n";
}

TEST(LocalMapPath, CommandAndMapLookupByDistance) {
  fr::LocalMapPath p;
  p.length_m = 6.0;
  p.commands = {{0.0, {0.2, 0.0}}, {2.0, {0.3, 0.1}}, {4.0, {0.3, -0.1}}, {6.0, {0.0, 0.0}}};
  for (int i = 0; i <= 30; ++i) p.maps.push_back(fr::LocalMap{i * 0.2, {}, {}, {}});
  EXPECT_DOUBLE_EQ(p.command_at(-1.0).linear_mps, 0.2);  // before the start: the first command
  EXPECT_DOUBLE_EQ(p.command_at(0.0).linear_mps, 0.2);
  EXPECT_DOUBLE_EQ(p.command_at(1.999).angular_radps, 0.0);
  EXPECT_DOUBLE_EQ(p.command_at(2.0).angular_radps, 0.1);
  EXPECT_DOUBLE_EQ(p.command_at(5.0).angular_radps, -0.1);
  EXPECT_DOUBLE_EQ(p.command_at(7.0).linear_mps, 0.0);
  EXPECT_EQ(p.nearest_map(0.0), 0);
  EXPECT_EQ(p.nearest_map(0.09), 0);
  EXPECT_EQ(p.nearest_map(0.11), 1);
  EXPECT_EQ(p.nearest_map(3.05), 15);
  EXPECT_EQ(p.nearest_map(100.0), 30);
  EXPECT_EQ(fr::LocalMapPath{}.nearest_map(1.0), -1);
}

TEST(LocalMapReplayer, AppliesRecordedCommandsByDistanceAndCarriesOvershoot) {
  auto p = std::make_shared<fr::LocalMapPath>();
  p->length_m = 6.0;
  p->commands = {{0.0, {0.2, 0.0}}, {2.0, {0.3, 0.1}}, {6.0, {0.0, 0.0}}};
  fr::LocalMapReplayParams params;
  params.laps = 3;
  fr::LocalMapReplayer rep(p, params);
  rep.begin(10.0);
  auto out = rep.step(11.0, Features{}, 640.0);
  EXPECT_EQ(out.state, fr::ReplayState::no_features);  // no maps: recorded command only
  EXPECT_DOUBLE_EQ(out.command.linear_mps, 0.2);
  out = rep.step(12.5, Features{}, 640.0);
  EXPECT_DOUBLE_EQ(out.command.angular_radps, 0.1);
  EXPECT_EQ(out.lap, 0);
  // passing the end at 16.07: lap 1 starts at the overshoot 0.07 m, not at 0
  out = rep.step(16.07, Features{}, 640.0);
  EXPECT_TRUE(out.lap_completed);
  EXPECT_EQ(out.lap, 1);
  EXPECT_NEAR(out.distance_m, 0.07, 1e-9);
  EXPECT_FALSE(out.finished);
  out = rep.step(18.2, Features{}, 640.0);  // lap 1 started at 16.0: 2.2 m into it
  EXPECT_NEAR(out.distance_m, 2.2, 1e-9);
  EXPECT_DOUBLE_EQ(out.command.angular_radps, 0.1);
  EXPECT_FALSE(out.lap_completed);
  out = rep.step(22.1, Features{}, 640.0);  // lap 2 at 0.1 (overshoots accumulate exactly)
  EXPECT_EQ(out.lap, 2);
  EXPECT_NEAR(out.distance_m, 0.1, 1e-9);
  out = rep.step(28.05, Features{}, 640.0);
  EXPECT_TRUE(out.finished);
  EXPECT_EQ(out.command.linear_mps, 0.0);
  EXPECT_EQ(out.command.angular_radps, 0.0);
  EXPECT_NEAR(rep.overshoot_m(28.05), 0.05, 1e-9);
}

TEST(LocalMapReplayer, HistogramCorrectionSignAndLowConfidence) {
  const auto& t = taught();
  fr::LocalMapReplayer rep(t.path);
  rep.begin(0.0);
  std::mt19937 rng(2);
  const Pose2D on = t.poses[100];  // 3 m along the path
  const double d = 100 * 0.03;
  // turned left of the taught heading: content right, correction negative
  auto out = rep.step(d, t.scene.observe({on.x_m, on.y_m, on.heading_rad + 0.05}, rng), 640.0);
  ASSERT_EQ(out.state, fr::ReplayState::steering);
  EXPECT_GT(out.estimate.offset_px, 15.0);
  EXPECT_LT(out.correction_radps, 0.0);
  EXPECT_DOUBLE_EQ(out.command.angular_radps, out.recorded.angular_radps + out.correction_radps);
  // on the path: almost no correction
  out = rep.step(d, t.scene.observe(on, rng), 640.0);
  ASSERT_EQ(out.state, fr::ReplayState::steering);
  EXPECT_NEAR(out.estimate.offset_px, 0.0, 3.0);
  // noise features: low confidence -> exactly the recorded command
  Features noise;
  noise.descriptors.create(300, 32, CV_8UC1);
  cv::randu(noise.descriptors, 0, 256);
  std::uniform_real_distribution<float> ux(0, 640), uy(0, 480);
  for (int i = 0; i < 300; ++i) noise.keypoints.emplace_back(ux(rng), uy(rng), 7.0f);
  out = rep.step(d, noise, 640.0);
  EXPECT_NE(out.state, fr::ReplayState::steering);
  EXPECT_EQ(out.correction_radps, 0.0);
  EXPECT_DOUBLE_EQ(out.command.linear_mps, out.recorded.linear_mps);
  EXPECT_DOUBLE_EQ(out.command.angular_radps, out.recorded.angular_radps);
  // wrong-size / wrong-type features: recorded command, bad_input
  Features broken = t.scene.observe(on, rng);
  broken.keypoints.pop_back();
  out = rep.step(d, broken, 640.0);
  EXPECT_EQ(out.state, fr::ReplayState::bad_input);
  EXPECT_DOUBLE_EQ(out.command.angular_radps, out.recorded.angular_radps);
  Features flt = t.scene.observe(on, rng);
  flt.descriptors = cv::Mat(flt.descriptors.rows, 8, CV_32FC1, cv::Scalar(0.1));
  out = rep.step(d, flt, 640.0);
  EXPECT_EQ(out.state, fr::ReplayState::bad_input);
  out = rep.step(d, Features{}, 640.0);
  EXPECT_EQ(out.state, fr::ReplayState::no_features);
  EXPECT_DOUBLE_EQ(out.command.angular_radps, out.recorded.angular_radps);
}

TEST(LocalMapReplayer, CorrectionReducesTheErrorOfADisplacedStart) {
  double heading_err = 0.0;
  const double open_loop = replay_end_error(0.0, 0.5);
  const double corrected = replay_end_error(fr::LocalMapReplayParams{}.gain_radps_per_px, 0.5, &heading_err);
  std::cout << "[ style B ] curved 12 m path, start 0.5 m sideways: end error " << open_loop
            << " m replaying commands only, " << corrected << " m with the histogram correction\n";
  EXPECT_GT(open_loop, 0.4);
  EXPECT_LT(corrected, 0.75 * open_loop);
  EXPECT_LT(std::abs(heading_err), 0.15);
}

TEST(LocalMapTeacher, FeatureCapAndImages) {
  fr::LocalMapTeachParams p;
  p.max_features_per_map = 50;
  p.store_image = true;
  p.map_interval_m = 0.5;
  fr::LocalMapTeacher teacher(p);
  std::mt19937 rng(1);
  cv::Mat image(120, 160, CV_8UC3);
  cv::randu(image, 0, 256);
  for (int i = 0; i <= 10; ++i) {
    Features f = taught().scene.observe(taught().poses[static_cast<std::size_t>(i * 10)], rng);
    for (std::size_t k = 0; k < f.keypoints.size(); ++k) f.keypoints[k].response = static_cast<float>(k);
    ASSERT_TRUE(teacher.add_frame(i * 0.1, f, image).ok());
  }
  auto path = teacher.finish(1.05, Features{});
  ASSERT_TRUE(path.ok());
  ASSERT_EQ(path->maps.size(), 3u);  // 0, 0.5, 1.0
  for (const auto& m : path->maps) {
    EXPECT_EQ(m.positions_px.size(), 50u);
    EXPECT_FALSE(m.jpeg.empty());
    EXPECT_EQ(m.jpeg[0], 0xff);
    EXPECT_EQ(m.jpeg[1], 0xd8);
  }
  auto back = fr::LocalMapPath::deserialize(path->serialize());
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->maps[1].jpeg, path->maps[1].jpeg);
}

TEST(LocalMapPayload, RoundTripAndRejection) {
  const auto& path = *taught().path;
  const auto blob = path.serialize();
  auto back = fr::LocalMapPath::deserialize(blob);
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->maps.size(), path.maps.size());
  ASSERT_EQ(back->commands.size(), path.commands.size());
  EXPECT_DOUBLE_EQ(back->length_m, path.length_m);
  for (std::size_t i = 0; i < path.maps.size(); ++i) {
    EXPECT_NEAR(back->maps[i].distance_m, path.maps[i].distance_m, 1e-5);
    ASSERT_EQ(back->maps[i].positions_px.size(), path.maps[i].positions_px.size());
    if (!path.maps[i].positions_px.empty()) {
      EXPECT_NEAR(back->maps[i].positions_px[0].x, path.maps[i].positions_px[0].x, 1.0 / 16.0);
      EXPECT_EQ(cv::norm(back->maps[i].descriptors, path.maps[i].descriptors, cv::NORM_HAMMING), 0.0);
    }
  }
  for (std::size_t i = 0; i < path.commands.size(); ++i)
    EXPECT_NEAR(back->commands[i].command.angular_radps, path.commands[i].command.angular_radps, 1e-6);
  for (std::size_t n : {0ul, 3ul, 5ul, 12ul, 27ul, 31ul, 40ul, 60ul, blob.size() / 3, blob.size() - 1}) {
    EXPECT_FALSE(fr::LocalMapPath::deserialize(std::span<const std::uint8_t>(blob.data(), n)).ok()) << n;
  }
  auto longer = blob;
  longer.push_back(7);
  EXPECT_FALSE(fr::LocalMapPath::deserialize(longer).ok());
  auto huge = blob;
  huge[20] = 0xff; huge[21] = 0xff; huge[22] = 0xff; huge[23] = 0xff;  // map count
  EXPECT_FALSE(fr::LocalMapPath::deserialize(huge).ok());
  auto style_a = blob;
  style_a[3] = 'A';
  EXPECT_FALSE(fr::LocalMapPath::deserialize(style_a).ok());
  std::mt19937 rng(6);
  for (int trial = 0; trial < 300; ++trial) {
    std::vector<std::uint8_t> g(static_cast<std::size_t>(rng() % 300));
    for (auto& b : g) b = static_cast<std::uint8_t>(rng());
    if (g.size() >= 6 && trial % 2 == 0) { g[0] = 'V'; g[1] = 'N'; g[2] = 'F'; g[3] = 'B'; g[4] = 1; g[5] = 0; }
    (void)fr::LocalMapPath::deserialize(g);  // must not crash
  }
}

TEST(LocalMapReplayer, InconsistentPathIsNotReplayed) {
  auto p = std::make_shared<fr::LocalMapPath>(*taught().path);
  p->maps[3].positions_px.pop_back();  // positions vs descriptor rows
  fr::LocalMapReplayer rep(p);
  EXPECT_FALSE(rep.path_valid());
  const auto out = rep.step(1.0, Features{}, 640.0);
  EXPECT_EQ(out.state, fr::ReplayState::bad_input);
  EXPECT_EQ(out.command.linear_mps, 0.0);
  fr::LocalMapReplayer null_path(nullptr);
  EXPECT_EQ(null_path.step(0.0, Features{}, 640.0).state, fr::ReplayState::bad_input);
}

// The params' validate() runs their schema's ranges (declared once, in schema()).
TEST(LocalMapParams, ValidateEnforcesTheSchemaRanges) {
  EXPECT_TRUE(fr::LocalMapTeachParams{}.validate().ok());
  EXPECT_TRUE(fr::LocalMapReplayParams{}.validate().ok());
  fr::LocalMapTeachParams teach;
  teach.map_interval_m = 0.0;
  EXPECT_FALSE(teach.validate().ok());
  fr::LocalMapReplayParams replay;
  replay.laps = 0;
  const visnav::Status r = replay.validate();
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("key 'laps': value 0 is out of range"), std::string::npos) << r.error().message;
}
