// The path-following core on synthetic gravel-in-grass scenes (issue 5): segmentation quality,
// steering sign, curved paths, horizon, bad inputs, appearance adaptation, buffer reuse.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "synthetic.hpp"
#include "visnav/path_following/path_follower.hpp"
#include "visnav/path_following/stages.hpp"
#include "visnav/path_following/taught_offset.hpp"
#include "error_expect.hpp"

namespace pf = visnav::path_following;
using pf::testing::make_scene;
using pf::testing::mask_iou;
using pf::testing::SceneSpec;

using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;

namespace {

pf::PathFollower make_follower(pf::PathFollowerParams p = {}) {
  auto f = pf::PathFollower::create(p);
  EXPECT_TRUE(f.ok()) << (f.ok() ? "" : f.error().message);
  return std::move(f).value();
}

pf::PathEstimate run(pf::PathFollower& follower, const cv::Mat& bgr) {
  auto r = follower.process(bgr);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return r.ok() ? std::move(r).value() : pf::PathEstimate{};
}

}  // namespace

TEST(PathFollower, StraightCentredBandIsSegmentedWithHighIoU) {
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    SceneSpec spec;
    spec.seed = seed;
    const auto scene = make_scene(spec);
    auto follower = make_follower();
    const auto est = run(follower, scene.bgr);
    ASSERT_EQ(est.status, pf::PathStatus::ok) << pf::to_string(est.status);
    const double iou = mask_iou(est.mask, scene.truth, est.ground_top_px);
    EXPECT_GE(iou, 0.9) << "seed " << seed;
    EXPECT_LT(std::abs(est.command.angular_radps), 0.05);
    EXPECT_GT(est.command.linear_mps, 0.1);
    EXPECT_GT(est.area_share, 0.1);
    EXPECT_LT(est.area_share, 0.6);
    EXPECT_FALSE(est.contour.empty());
  }
}

TEST(PathFollower, AutomaticHorizonFindsTheSkyGroundBoundary) {
  for (int horizon : {50, 72, 110}) {
    SceneSpec spec;
    spec.horizon_row = horizon;
    const auto scene = make_scene(spec);
    cv::Mat scratch;
    const auto h = pf::detect_horizon(scene.bgr, pf::PathFollowerParams{}, scratch);
    EXPECT_TRUE(h.detected);
    EXPECT_NEAR(h.row_px, horizon, 2) << "true horizon " << horizon;
  }
}

TEST(PathFollower, ConfiguredHorizonModes) {
  const auto scene = make_scene(SceneSpec{});
  cv::Mat scratch;
  pf::PathFollowerParams p;
  p.horizon_mode = "row";
  p.horizon_row_px = 100;
  EXPECT_EQ(pf::detect_horizon(scene.bgr, p, scratch).row_px, 100);
  p.horizon_row_px = 10000;  // clamped so that kMinGroundRowsPx remain
  EXPECT_EQ(pf::detect_horizon(scene.bgr, p, scratch).row_px, 240 - pf::kMinGroundRowsPx);
  p.horizon_mode = "ratio";
  p.horizon_ratio = 0.5;
  EXPECT_EQ(pf::detect_horizon(scene.bgr, p, scratch).row_px, 120);
  // Auto without a visible boundary falls back to the ratio.
  p.horizon_mode = "auto";
  const cv::Mat flat(240, 320, CV_8UC3, cv::Scalar(90, 90, 90));
  const auto h = pf::detect_horizon(flat, p, scratch);
  EXPECT_FALSE(h.detected);
  EXPECT_EQ(h.row_px, 120);
}

TEST(PathFollower, SteersTowardsAnOffCentrePath) {
  // Path right of centre → turn right → negative ω (CCW positive); left → positive ω.
  // (At ±70 px the trapezoid is half grass, half gravel: ambiguous by construction.)
  for (double shift : {-60.0, -35.0, 35.0, 60.0}) {
    SceneSpec spec;
    spec.centre_px = [shift](double) { return 160.0 + shift; };
    const auto scene = make_scene(spec);
    auto follower = make_follower();
    const auto est = run(follower, scene.bgr);
    ASSERT_EQ(est.status, pf::PathStatus::ok) << "shift " << shift;
    EXPECT_GE(mask_iou(est.mask, scene.truth, est.ground_top_px), 0.85) << "shift " << shift;
    if (shift > 0) {
      EXPECT_GT(est.mean_offset, 0.0);
      EXPECT_LT(est.command.angular_radps, -0.05) << "shift " << shift;
    } else {
      EXPECT_LT(est.mean_offset, 0.0);
      EXPECT_GT(est.command.angular_radps, 0.05) << "shift " << shift;
    }
  }
}

TEST(PathFollower, LargerOffsetSteersHarderAndSlower) {
  auto est_for = [](double shift) {
    SceneSpec spec;
    spec.centre_px = [shift](double) { return 160.0 + shift; };
    auto follower = make_follower();
    return run(follower, make_scene(spec).bgr);
  };
  const auto small = est_for(25.0);
  const auto large = est_for(60.0);  // the robot still stands on the path
  ASSERT_EQ(small.status, pf::PathStatus::ok);
  ASSERT_EQ(large.status, pf::PathStatus::ok);
  EXPECT_LT(large.command.angular_radps, small.command.angular_radps);
  EXPECT_LT(large.command.linear_mps, small.command.linear_mps);
}

TEST(PathFollower, MiddlePointsFollowACurvedBand) {
  SceneSpec spec;
  // Curves to the right towards the horizon (t = 0), centred at the bottom (t = 1).
  spec.centre_px = [](double t) { return 160.0 + 90.0 * (1.0 - t) * (1.0 - t); };
  spec.half_width_near_px = 70.0;
  const auto scene = make_scene(spec);
  auto follower = make_follower();
  const auto est = run(follower, scene.bgr);
  ASSERT_EQ(est.status, pf::PathStatus::ok);
  EXPECT_GE(mask_iou(est.mask, scene.truth, est.ground_top_px), 0.85);
  ASSERT_GT(est.middle_points.size(), 100u);
  std::vector<double> errors;
  for (const auto& p : est.middle_points) {
    const int y = static_cast<int>(p.y);
    const double t = (y - spec.horizon_row) / static_cast<double>(spec.height - 1 - spec.horizon_row);
    errors.push_back(std::abs(p.x - spec.centre_px(t)));
  }
  std::sort(errors.begin(), errors.end());
  EXPECT_LT(errors[errors.size() / 2], 3.0) << "median middle-point error (px)";
  EXPECT_LT(errors[errors.size() * 9 / 10], 8.0) << "90th percentile middle-point error (px)";
  // The far points lie right of the near points, so the robot turns right.
  EXPECT_GT(est.middle_points.front().x, est.middle_points.back().x + 40.0);
  EXPECT_LT(est.command.angular_radps, 0.0);
}

TEST(PathFollower, UniformGroundIsReportedAsPathFillingTheImage) {
  // Everything below the horizon looks like the reference: path and surroundings are
  // indistinguishable (also what "no path in view" looks like to this method).
  for (bool gravel : {true, false}) {
    SceneSpec spec;
    spec.draw_band = gravel;
    if (gravel) spec.half_width_near_px = spec.half_width_far_px = 400.0;
    const auto scene = make_scene(spec);
    auto follower = make_follower();
    const auto est = run(follower, scene.bgr);
    EXPECT_EQ(est.status, pf::PathStatus::path_fills_image) << pf::to_string(est.status);
    EXPECT_GT(est.area_share, 0.97);
    EXPECT_EQ(est.command.linear_mps, 0.0);
    EXPECT_EQ(est.command.angular_radps, 0.0);
  }
}

TEST(PathFollower, SmallPathPatchIsReportedAsPathLost) {
  // A short gravel patch under the robot, grass everywhere else: the connected region is small.
  SceneSpec spec;
  const auto scene = make_scene(spec);
  cv::Mat bgr = make_scene([] { SceneSpec s; s.draw_band = false; return s; }()).bgr;
  const cv::Rect patch(110, 190, 100, 50);
  scene.bgr(patch).copyTo(bgr(patch));
  pf::PathFollowerParams p;
  p.min_area_share = 0.1;
  auto follower = make_follower(p);
  const auto est = run(follower, bgr);
  EXPECT_EQ(est.status, pf::PathStatus::path_lost) << pf::to_string(est.status) << " share " << est.area_share;
  EXPECT_LT(est.area_share, 0.1);
  EXPECT_EQ(est.command.linear_mps, 0.0);
}

TEST(PathFollower, DarkFrameGivesDarkStatusAndNoCommand) {
  cv::Mat dark(240, 320, CV_8UC3);
  cv::randn(dark, cv::Scalar(6, 6, 6), cv::Scalar(3, 3, 3));
  auto follower = make_follower();
  const auto est = run(follower, dark);
  EXPECT_EQ(est.status, pf::PathStatus::dark_frame);
  EXPECT_EQ(est.command.linear_mps, 0.0);
  EXPECT_EQ(est.command.angular_radps, 0.0);
  EXPECT_EQ(cv::countNonZero(est.mask), 0);
  // Drawing a dark frame works too.
  const cv::Mat drawn = pf::render_stages(dark, est, follower.stages(), follower.params());
  EXPECT_EQ(drawn.cols, 5 * 320);
}

TEST(PathFollower, ReferenceWithoutADominantAppearanceGivesNoReference) {
  // Eight differently coloured vertical stripes cover the reference region: no merged model
  // reaches ref_min_coverage.
  cv::Mat bgr = make_scene(SceneSpec{}).bgr;
  const cv::Scalar colours[] = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {255, 255, 0},
                                {255, 0, 255}, {0, 255, 255}, {20, 20, 20}, {255, 255, 255}};
  for (int i = 0; i < 8; ++i) cv::rectangle(bgr, cv::Rect(96 + 16 * i, 150, 16, 90), colours[i], cv::FILLED);
  pf::PathFollowerParams p;
  p.ref_bottom_width_ratio = p.ref_top_width_ratio = 0.4;  // exactly the striped 128 px
  auto follower = make_follower(p);
  const auto est = run(follower, bgr);
  EXPECT_EQ(est.status, pf::PathStatus::no_reference) << pf::to_string(est.status);
  EXPECT_EQ(est.reference_models, 0);
  EXPECT_EQ(est.command.linear_mps, 0.0);
}

TEST(PathFollower, BadInputsAreErrorsNotCrashes) {
  auto follower = make_follower();
  auto empty = follower.process(cv::Mat());
  EXPECT_TRUE(fails_with(empty, ErrorCode::invalid_value));

  auto tiny = follower.process(cv::Mat(10, 10, CV_8UC3, cv::Scalar(100, 100, 100)));
  EXPECT_TRUE(fails_with(tiny, ErrorCode::out_of_range));
  EXPECT_NE(tiny.error().message.find("10x10"), std::string::npos) << tiny.error().message;  // tells the size

  auto gray = follower.process(cv::Mat(240, 320, CV_8UC1, cv::Scalar(100)));
  EXPECT_TRUE(fails_with(gray, ErrorCode::invalid_value));

  auto floats = follower.process(cv::Mat(240, 320, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5)));
  EXPECT_TRUE(fails_with(floats, ErrorCode::invalid_value));

  // Smallest accepted image works.
  const cv::Mat smallest(pf::kMinImageHeightPx, pf::kMinImageWidthPx, CV_8UC3, cv::Scalar(90, 120, 90));
  EXPECT_TRUE(follower.process(smallest).ok());
  // A non-continuous view (ROI of a larger image) is fine.
  const auto scene = make_scene(SceneSpec{.width = 400, .height = 300});
  const auto view = run(follower, scene.bgr(cv::Rect(40, 30, 320, 240)));
  EXPECT_NE(view.status, pf::PathStatus::dark_frame);
}

TEST(PathFollower, ParamsAreValidated) {
  pf::PathFollowerParams p;
  EXPECT_TRUE(p.validate().ok());
  p.median_blur_px = 4;
  EXPECT_FALSE(pf::PathFollower::create(p).ok());
  p = {};
  p.horizon_search_min_ratio = 0.8;
  EXPECT_FALSE(p.validate().ok());
  p = {};
  p.min_area_share = 0.99;
  EXPECT_FALSE(p.validate().ok());

  visnav::ConfigNode node = visnav::ConfigNode::make_map({"cfg.yaml", 3});
  node.set("seg_k", visnav::ConfigNode::make_scalar("500", {"cfg.yaml", 4}));
  node.set("horizon_mode", visnav::ConfigNode::make_scalar("ratio", {"cfg.yaml", 5}));
  auto parsed = pf::PathFollowerParams::schema().parse(node);
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  EXPECT_EQ(parsed->seg_k, 500.0);
  EXPECT_EQ(parsed->horizon_mode, "ratio");

  node.set("horizon_mode", visnav::ConfigNode::make_scalar("sideways", {"cfg.yaml", 5}));
  auto bad_mode = pf::PathFollowerParams::schema().parse(node);
  EXPECT_TRUE(fails_with(bad_mode, ErrorCode::out_of_range, At{"cfg.yaml", 5, "horizon_mode"}));

  visnav::ConfigNode unknown = visnav::ConfigNode::make_map({"cfg.yaml", 3});
  unknown.set("segk", visnav::ConfigNode::make_scalar("5", {"cfg.yaml", 7}));
  auto bad_key = pf::PathFollowerParams::schema().parse(unknown);
  EXPECT_TRUE(fails_with(bad_key, ErrorCode::unknown_key, At{"cfg.yaml", 7, "segk"}));
}

TEST(ControlLaw, SignNormalisationAndClamps) {
  pf::PathFollowerParams p;
  p.alpha_radps = 0.8;
  p.beta_mps = 0.4;
  p.turn_slowdown_mps_per_radps = 0.5;
  p.max_linear_mps = 0.5;
  p.max_angular_radps = 1.0;
  double offset = 0.0;
  std::vector<cv::Point2f> centred(100, cv::Point2f(160.0f, 0.0f));
  auto cmd = pf::steering_command(centred, 320, 200, p, offset);
  EXPECT_DOUBLE_EQ(offset, 0.0);
  EXPECT_DOUBLE_EQ(cmd.angular_radps, 0.0);
  EXPECT_DOUBLE_EQ(cmd.linear_mps, 0.4 * 100.0 / 200.0);

  std::vector<cv::Point2f> right(200, cv::Point2f(240.0f, 0.0f));  // offset +0.5
  cmd = pf::steering_command(right, 320, 200, p, offset);
  EXPECT_DOUBLE_EQ(offset, 0.5);
  EXPECT_DOUBLE_EQ(cmd.angular_radps, -0.4);
  EXPECT_DOUBLE_EQ(cmd.linear_mps, 0.4 - 0.5 * 0.4);

  std::vector<cv::Point2f> far_left(200, cv::Point2f(0.0f, 0.0f));  // offset −1
  p.alpha_radps = 3.0;
  cmd = pf::steering_command(far_left, 320, 200, p, offset);
  EXPECT_DOUBLE_EQ(cmd.angular_radps, 1.0);  // clamped
  EXPECT_DOUBLE_EQ(cmd.linear_mps, 0.0);     // 0.4 − 0.5 clamped at 0

  cmd = pf::steering_command({}, 320, 200, p, offset);
  EXPECT_EQ(cmd.linear_mps, 0.0);
  EXPECT_EQ(cmd.angular_radps, 0.0);
}

TEST(ControlLaw, SteersToTheTargetOffsetNotToTheCentre) {
  pf::PathFollowerParams p;
  p.alpha_radps = 0.8;
  double offset = 0.0;
  std::vector<cv::Point2f> right(200, cv::Point2f(240.0f, 0.0f));  // offset +0.5
  // The taught view had the path's middle there: no turn.
  auto cmd = pf::steering_command(right, 320, 200, p, offset, -1, 0.5);
  EXPECT_DOUBLE_EQ(offset, 0.5);
  EXPECT_DOUBLE_EQ(cmd.angular_radps, 0.0);
  // Taught at +0.25: the path lies further right than taught, turn right (negative) by 0.8 * 0.25.
  cmd = pf::steering_command(right, 320, 200, p, offset, -1, 0.25);
  EXPECT_DOUBLE_EQ(cmd.angular_radps, -0.2);
  // Centred path, taught 0.25 right: turn left, away from the middle.
  std::vector<cv::Point2f> centred(100, cv::Point2f(160.0f, 0.0f));
  cmd = pf::steering_command(centred, 320, 200, p, offset, -1, 0.25);
  EXPECT_DOUBLE_EQ(cmd.angular_radps, 0.2);
}

TEST(TaughtOffsetProfile, WindowedMeanGainAndNoTargetWithoutSamples) {
  std::vector<visnav::path_payload::OffsetSample> samples;
  for (int i = 0; i <= 20; ++i) {
    const double d = 0.25 * i;                            // 0 .. 5 m
    const double wobble = (i % 2 == 0) ? 0.02 : -0.02;   // the teacher's heading wobble
    samples.push_back({d, 0.1 + wobble, -0.05});
  }
  samples.push_back({9.0, 0.4, 0.3});  // a gap from 5 to 9 m
  pf::TaughtOffsetParams params;
  EXPECT_EQ(params.gain, 0.0);  // off by default (trees/subtrees/traverse_route.xml turns it on)
  params.gain = 1.0;
  ASSERT_TRUE(params.validate().ok());
  const pf::TaughtOffsetProfile profile(params, samples);
  EXPECT_TRUE(profile.active());
  auto t = profile.target(2.5, false);  // 2.0 .. 3.0: 5 samples, 3 at +0.12, 2 at +0.08
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(*t, 0.104, 1e-9);
  t = profile.target(2.5, true);  // the junction-mode offsets
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(*t, -0.05, 1e-9);
  EXPECT_FALSE(profile.target(7.0, false).has_value());  // nothing taught within 0.5 m
  t = profile.target(9.3, false);
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(*t, 0.4, 1e-12);

  params.gain = 0.5;
  const pf::TaughtOffsetProfile half(params, samples);
  t = half.target(9.0, false);
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(*t, 0.2, 1e-12);
  params.gain = 0.0;  // off: today's centring
  const pf::TaughtOffsetProfile off(params, samples);
  EXPECT_FALSE(off.active());
  EXPECT_FALSE(off.target(2.5, false).has_value());
  params.gain = 1.0;
  EXPECT_FALSE(pf::TaughtOffsetProfile(params, {}).target(1.0, false).has_value());  // VPF1 / VPF2 edge

  // Where the taught view changes quickly (a road coming into view: the offset ramps by 0.3 over
  // 1 m), there is no target; the flat stretch before it still has one.
  std::vector<visnav::path_payload::OffsetSample> ramp;
  for (int i = 0; i <= 20; ++i) ramp.push_back({0.1 * i, i <= 10 ? 0.02 : 0.02 + 0.03 * (i - 10), 0.0});
  const pf::TaughtOffsetProfile ramped(params, ramp);
  EXPECT_FALSE(ramped.target(1.55, false).has_value());
  t = ramped.target(0.4, false);
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(*t, 0.02, 1e-12);
  params.max_sd = 2.0;  // gate off
  t = pf::TaughtOffsetProfile(params, ramp).target(1.55, false);
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(*t, 0.02 + 0.03 * 5.5, 1e-9);  // the samples at 1.1 .. 2.0 m: ramp steps 1 .. 10
  params.max_sd = 0.03;

  params.gain = 1.5;
  EXPECT_FALSE(params.validate().ok());
  params.gain = 1.0;
  params.window_m = 0.0;
  EXPECT_FALSE(params.validate().ok());
}

TEST(ColourModel, HueWrapAroundIsContinuous) {
  // Hue 179 and hue 0 (both red) are neighbours in the cone feature, far from hue 90 (cyan).
  const auto a = pf::hsv_cone_feature(179, 200, 150);
  const auto b = pf::hsv_cone_feature(0, 200, 150);
  const auto c = pf::hsv_cone_feature(90, 200, 150);
  EXPECT_LT((a - b).norm(), 10.0);
  EXPECT_GT((a - c).norm(), 350.0);
  // Grey pixels: hue is irrelevant.
  EXPECT_LT((pf::hsv_cone_feature(10, 3, 120) - pf::hsv_cone_feature(120, 3, 120)).norm(), 7.0);

  pf::ColourMoments m;
  m.add(a);
  m.add(b);
  const auto model = m.model();
  EXPECT_NEAR(model.mean.x(), 200.0, 1.0);
  EXPECT_LT(std::abs(model.mean.y()), 5.0);
  EXPECT_EQ(model.pixels, 2.0);
  EXPECT_GE(model.cov(1, 1), 0.0);
}

TEST(PathFollower, AppearanceAdaptationBlendsWithThePreviousModels) {
  SceneSpec a;
  a.gravel = {140, 140, 140};
  a.seed = 5;
  SceneSpec b = a;
  b.gravel = {170, 170, 170};
  b.seed = 6;
  const auto sa = make_scene(a);
  const auto sb = make_scene(b);

  auto v_of_largest = [](const std::vector<pf::ColourModel>& models) {
    const auto it = std::max_element(models.begin(), models.end(),
                                     [](const auto& x, const auto& y) { return x.pixels < y.pixels; });
    return it->mean.z();
  };
  pf::PathFollowerParams p;
  p.ref_merge_distance = 4.0;  // the two gravel shades are the "same" surface
  auto plain = make_follower(p);
  (void)run(plain, sa.bgr);
  (void)run(plain, sb.bgr);
  const double v_plain = v_of_largest(plain.reference_models());

  p.model_blend = 0.5;
  auto blended = make_follower(p);
  (void)run(blended, sa.bgr);
  const double v_first = v_of_largest(blended.reference_models());
  (void)run(blended, sb.bgr);
  const double v_blend = v_of_largest(blended.reference_models());
  EXPECT_NEAR(v_blend, 0.5 * (v_first + v_plain), 2.0);
  EXPECT_GT(v_plain - v_first, 20.0);

  // reset() forgets the previous models.
  const auto models_a = [&] {
    auto f = make_follower(p);
    (void)run(f, sa.bgr);
    return f.reference_models();
  }();
  blended.reset();
  (void)run(blended, sb.bgr);
  EXPECT_NEAR(v_of_largest(blended.reference_models()), v_plain, 1.0);

  // Priming with a stored appearance summary is the same as having seen that frame.
  auto primed = make_follower(p);
  primed.set_prior_models(models_a);
  (void)run(primed, sb.bgr);
  EXPECT_NEAR(v_of_largest(primed.reference_models()), v_blend, 1e-9);
}

TEST(PathFollower, BuffersAreReusedAcrossFramesAndHorizons) {
  SceneSpec s1;
  s1.horizon_row = 60;
  SceneSpec s2;
  s2.horizon_row = 100;
  s2.seed = 9;
  const auto a = make_scene(s1);
  const auto b = make_scene(s2);
  auto follower = make_follower();
  pf::PathEstimate est;
  ASSERT_TRUE(follower.process(a.bgr, est).ok());
  const auto* mask_data = est.mask.data;
  const auto* labels_data = follower.stages().labels.data;
  const auto* blurred_data = follower.stages().blurred.data;
  const auto middle_capacity = est.middle_points.capacity();
  ASSERT_TRUE(follower.process(b.bgr, est).ok());
  EXPECT_NE(follower.stages().labels.rows, 0);
  EXPECT_EQ(est.mask.data, mask_data);
  EXPECT_EQ(follower.stages().labels.data, labels_data);
  EXPECT_EQ(follower.stages().blurred.data, blurred_data);
  EXPECT_GE(est.middle_points.capacity(), std::min<std::size_t>(middle_capacity, est.middle_points.size()));
  EXPECT_NEAR(est.horizon.row_px, 100, 2);
  EXPECT_EQ(est.status, pf::PathStatus::ok);
}

TEST(Stages, RenderHasFivePanelsWithTheFinalRegionTinted) {
  const auto scene = make_scene(SceneSpec{});
  auto follower = make_follower();
  const auto est = run(follower, scene.bgr);
  const cv::Mat drawn = pf::render_stages(scene.bgr, est, follower.stages(), follower.params());
  ASSERT_EQ(drawn.type(), CV_8UC3);
  EXPECT_EQ(drawn.cols, 5 * scene.bgr.cols);
  EXPECT_EQ(drawn.rows, scene.bgr.rows);
  // Panel 4 (classification) is white on the band near the bottom centre.
  const cv::Vec3b cls = drawn.at<cv::Vec3b>(230, 3 * 320 + 160);
  EXPECT_EQ(cls, cv::Vec3b(255, 255, 255));
  // Panel 2 (superpixels) differs from black below the horizon.
  EXPECT_NE(drawn.at<cv::Vec3b>(200, 320 + 20), cv::Vec3b(0, 0, 0));
}

// ---------------------------------------------------------------------- appearance summary

namespace {

pf::ColourModel colour_model(double s_cos, double s_sin, double v, double sd, double pixels = 1000.0) {
  pf::ColourModel m;
  m.mean = Eigen::Vector3d(s_cos, s_sin, v);
  m.cov = Eigen::Matrix3d::Identity() * sd * sd;
  m.pixels = pixels;
  return m;
}

}  // namespace

TEST(AppearanceSummary, PoolsTheRecurringSurfaceAndDropsOneCrossedBriefly) {
  // 10 frames of gravel with slight drift; 3 of them also show asphalt (a junction), and the edge
  // ends on the asphalt alone — the last frame's models would have been asphalt.
  const pf::PathFollowerParams params;
  pf::AppearanceSummary summary(params);
  for (int i = 0; i < 10; ++i) {
    const pf::ColourModel gravel = colour_model(20.0, 10.0, 150.0 + i, 12.0);
    if (i >= 7) {
      const std::vector<pf::ColourModel> both = {gravel, colour_model(2.0, 1.0, 85.0, 8.0)};
      summary.add_frame(both);
    } else {
      const std::vector<pf::ColourModel> one = {gravel};
      summary.add_frame(one);
    }
  }
  summary.add_frame({});  // path not seen: not a frame
  const std::vector<pf::ColourModel> asphalt_only = {colour_model(2.0, 1.0, 86.0, 8.0)};
  summary.add_frame(asphalt_only);
  EXPECT_EQ(summary.frames(), 11);
  const auto out = summary.summary();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR(out[0].mean.z(), 154.5, 1e-9);  // pooled gravel: mean of 150..159
  EXPECT_NEAR(out[0].pixels, 10000.0, 1e-9);
  EXPECT_GT(out[0].cov(2, 2), 144.0);  // the drift widens the pooled spread
  summary.clear();
  EXPECT_EQ(summary.frames(), 0);
  EXPECT_TRUE(summary.summary().empty());
}

TEST(AppearanceSummary, KeepsEverySurfaceSeenInMostFramesMostFrequentFirst) {
  const pf::PathFollowerParams params;
  pf::AppearanceSummary summary(params, 0.5);
  for (int i = 0; i < 6; ++i) {
    std::vector<pf::ColourModel> frame = {colour_model(20.0, 10.0, 150.0, 12.0)};
    if (i % 2 == 0 || i == 5) frame.push_back(colour_model(-30.0, 40.0, 120.0, 10.0));  // 4 of 6 frames
    summary.add_frame(frame);
  }
  const auto out = summary.summary();
  ASSERT_EQ(out.size(), 2u);
  EXPECT_NEAR(out[0].mean.z(), 150.0, 1e-9);
  EXPECT_NEAR(out[1].mean.z(), 120.0, 1e-9);
}

TEST(AppearanceSummary, PoolModelsIsTheMixtureMoments) {
  const pf::ColourModel a = colour_model(0.0, 0.0, 100.0, 2.0, 300.0);
  const pf::ColourModel b = colour_model(0.0, 0.0, 110.0, 4.0, 100.0);
  const pf::ColourModel m = pf::pool_models(a, b);
  EXPECT_NEAR(m.mean.z(), 102.5, 1e-12);
  // 0.75·(4 + 2.5²) + 0.25·(16 + 7.5²)
  EXPECT_NEAR(m.cov(2, 2), 0.75 * (4.0 + 6.25) + 0.25 * (16.0 + 56.25), 1e-9);
  EXPECT_NEAR(m.cov(0, 0), 0.75 * 4.0 + 0.25 * 16.0, 1e-12);
  EXPECT_NEAR(m.pixels, 400.0, 1e-12);
}

TEST(TaughtGate, RejectsADriftedModelAndFallsBackToTheTaughtOnesWithoutCrashing) {
  // Synthetic scene: the follower is given a taught model far from the scene's path colour, so
  // every re-learned model is rejected and the taught (wrong) model is used: a clear status, no
  // crash, the source reported.
  pf::PathFollowerParams params;
  auto follower = std::move(pf::PathFollower::create(params).value());
  const cv::Mat img = make_scene(SceneSpec{}).bgr;
  follower.set_taught_models({colour_model(200.0, -150.0, 30.0, 3.0)});
  pf::PathEstimate est;
  ASSERT_TRUE(follower.process(img, est).ok());
  EXPECT_GE(est.gated_models, 1);
  EXPECT_EQ(est.reference_source, pf::ReferenceSource::taught);
  EXPECT_NE(est.status, pf::PathStatus::ok);  // nothing in view looks like the taught surface
  // The next frame falls back to the previous accepted models (those the gate kept last frame).
  ASSERT_TRUE(follower.process(img, est).ok());
  EXPECT_EQ(est.reference_source, pf::ReferenceSource::previous);
  // Non-finite taught models are ignored; reset() clears them (gate inactive again).
  follower.reset();
  pf::ColourModel bad = colour_model(0, 0, 0, 1);
  bad.mean.x() = std::nan("");
  follower.set_taught_models({bad});
  EXPECT_TRUE(follower.taught_models().empty());
  ASSERT_TRUE(follower.process(img, est).ok());
  EXPECT_EQ(est.gated_models, 0);
  EXPECT_EQ(est.status, pf::PathStatus::ok);
}
