// visnav_recorded_common: CSV dialect, odometry logs and their synchronisation with frames, the
// image pipeline, pacing and the adaptive exposure controller.
#include <gtest/gtest.h>

#include <cmath>

#include "camera_test_support.hpp"
#include "error_expect.hpp"
#include "visnav/recorded/csv.hpp"
#include "visnav/recorded/exposure.hpp"
#include "visnav/recorded/image_pipeline.hpp"
#include "visnav/recorded/odometry_log.hpp"
#include "visnav/recorded/pacing.hpp"
#include "visnav/recorded/run_format.hpp"

namespace vr = visnav::recorded;
using namespace visnav::testing;
using visnav::ErrorCode;
using visnav::test::At;
using visnav::test::fails_with;

TEST(RecordedCsv, PartialLastLineIsDroppedAndFieldCountsChecked) {
  auto t = vr::parse_csv("a,b\n1,2\n# comment\n\n3,4\n5,", "x.csv");
  ASSERT_TRUE(t.ok()) << t.error().message;
  EXPECT_EQ(t->rows.size(), 2u);
  EXPECT_TRUE(t->dropped_partial_line);
  EXPECT_EQ(t->rows[1].line, 5);
  auto bad = vr::parse_csv("a,b\n1,2\n3\n", "x.csv");
  ASSERT_FALSE(bad.ok());
  EXPECT_TRUE(fails_with(bad, ErrorCode::parse_error, At{"x.csv", 3}));
  auto missing = vr::read_csv("/no/such/file.csv");
  ASSERT_FALSE(missing.ok());
  EXPECT_TRUE(fails_with(missing, ErrorCode::not_found, At{"/no/such/file.csv"}));
}

TEST(OdometryLog, CsvWithPoseDerivesDistanceAndTwist) {
  const std::string dir = scratch();
  write_text(dir + "/odo.csv", "t,x,y,theta\n0,0,0,0\n1,3,4,0.5\n2,3,4,1.0\n");
  auto log = vr::OdometryLog::load(dir + "/odo.csv");
  ASSERT_TRUE(log.ok()) << log.error().message;
  ASSERT_EQ(log->samples().size(), 3u);
  EXPECT_DOUBLE_EQ(log->samples()[1].distance_m, 5.0);
  EXPECT_DOUBLE_EQ(log->samples()[1].twist.linear_mps, 5.0);
  EXPECT_DOUBLE_EQ(log->samples()[2].twist.angular_radps, 0.5);
}

TEST(OdometryLog, DistanceOnlyYamlAndSync) {
  const std::string dir = scratch();
  write_text(dir + "/odo.yaml", "odometry:\n  - {t_s: 0, distance_m: 0}\n  - {t_s: 1, distance_m: 2}\n");
  auto log = vr::OdometryLog::load(dir + "/odo.yaml");
  ASSERT_TRUE(log.ok()) << log.error().message;
  EXPECT_FALSE(log->sample_at(-0.1, vr::OdometrySync::latest).has_value());
  EXPECT_DOUBLE_EQ(log->sample_at(0.75, vr::OdometrySync::latest)->distance_m, 0.0);
  const auto interp = log->sample_at(0.75, vr::OdometrySync::interpolate);
  EXPECT_DOUBLE_EQ(interp->distance_m, 1.5);
  EXPECT_DOUBLE_EQ(interp->pose.x_m, 1.5);
  EXPECT_DOUBLE_EQ(interp->timestamp_s, 0.75);
  EXPECT_DOUBLE_EQ(log->sample_at(5.0, vr::OdometrySync::interpolate)->distance_m, 2.0);
}

TEST(OdometryLog, OutOfOrderTimestampsNameFileAndLine) {
  const std::string dir = scratch();
  write_text(dir + "/odo.csv", "t_s,distance_m\n0,0\n0.2,0.1\n0.1,0.2\n");
  auto log = vr::OdometryLog::load(dir + "/odo.csv");
  ASSERT_FALSE(log.ok());
  EXPECT_TRUE(fails_with(log, ErrorCode::inconsistent, At{"odo.csv", 4}));
  write_text(dir + "/odo.yaml", "- {t_s: 1, distance_m: 0}\n- {t_s: 1, distance_m: 1}\n");
  auto ylog = vr::OdometryLog::load(dir + "/odo.yaml");
  ASSERT_FALSE(ylog.ok());
  EXPECT_TRUE(fails_with(ylog, ErrorCode::inconsistent, At{"odo.yaml", 2}));
  write_text(dir + "/bad.csv", "t_s,distance_m\n0,zero\n");
  auto bad = vr::OdometryLog::load(dir + "/bad.csv");
  ASSERT_FALSE(bad.ok());
  EXPECT_TRUE(fails_with(bad, ErrorCode::invalid_value, At{"bad.csv", 2, "distance_m"}));
}

TEST(OdometryLog, FramesFarFromOdometryNameTheFramesFileAndLine) {
  auto log = vr::OdometryLog::from_samples({{0.0, {}, 0.0, {}}, {1.0, {}, 0.5, {}}}, "odo");
  ASSERT_TRUE(log.ok());
  EXPECT_TRUE(log->check_coverage({{0.5, 2}, {1.2, 3}}, "frames.csv", 0.5, vr::OdometrySync::latest).ok());
  auto far = log->check_coverage({{0.5, 2}, {3.0, 3}}, "frames.csv", 0.5, vr::OdometrySync::latest);
  ASSERT_FALSE(far.ok());
  EXPECT_TRUE(fails_with(far, ErrorCode::inconsistent, At{"frames.csv", 3}));
  EXPECT_NE(far.error().message.find("max_frame_gap_s"), std::string::npos) << far.error().message;  // names the knob
  auto before = log->check_coverage({{-1.0, 7}}, "frames.csv", 0.5, vr::OdometrySync::latest);
  ASSERT_FALSE(before.ok());
  EXPECT_TRUE(fails_with(before, ErrorCode::inconsistent, At{"frames.csv", 7}));
  // interpolation also needs a sample after the frame
  auto gap = vr::OdometryLog::from_samples({{0.0, {}, 0.0, {}}, {2.0, {}, 1.0, {}}}, "odo");
  EXPECT_FALSE(gap->check_coverage({{0.3, 4}}, "frames.csv", 0.5, vr::OdometrySync::interpolate).ok());
}

TEST(ImagePipeline, CropTopHalfResizeGrey) {
  vr::ImageOptions o;
  o.crop_rows = {0.0, 0.5};
  o.resize_width_px = 32;
  o.grey = true;
  auto p = vr::ImagePipeline::create(o);
  ASSERT_TRUE(p.ok()) << p.error().message;
  const cv::Mat in = test_image(3, 64, 48);
  cv::Mat out;
  ASSERT_TRUE(p->apply(in, out).ok());
  EXPECT_EQ(out.size(), cv::Size(32, 12));
  EXPECT_EQ(out.type(), CV_8UC1);
  // crop_px takes exactly the rectangle and hands over its own buffer
  vr::ImageOptions c;
  c.crop_px = {8, 4, 16, 10};
  auto pc = vr::ImagePipeline::create(c);
  ASSERT_TRUE(pc.ok());
  ASSERT_TRUE(pc->apply(in, out).ok());
  EXPECT_EQ(out.size(), cv::Size(16, 10));
  EXPECT_EQ(cv::norm(out, in(cv::Rect(8, 4, 16, 10)), cv::NORM_INF), 0.0);
  EXPECT_NE(out.data, in.ptr(4, 8));
  c.crop_px = {60, 0, 16, 10};
  auto outside = vr::ImagePipeline::create(c);
  ASSERT_TRUE(outside.ok());
  auto st = outside->apply(in, out);
  EXPECT_TRUE(fails_with(st, ErrorCode::inconsistent, visnav::test::key_only("crop_px")));
  EXPECT_NE(st.error().message.find("64x48"), std::string::npos) << st.error().message;  // tells the image size
  vr::ImageOptions both = c;
  both.crop_rows = {0, 0.5};
  EXPECT_TRUE(fails_with(vr::ImagePipeline::create(both), ErrorCode::inconsistent));
}

TEST(ImagePipeline, UndistortionFromCalibrationFile) {
  const std::string dir = scratch();
  write_text(dir + "/calib.yaml",
             "%YAML:1.0\n---\nimage_width: 64\nimage_height: 48\n"
             "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 60., 0., 32., 0., 60., 24., 0., 0., 1. ]\n"
             "distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ -0.3, 0.1, 0., 0., 0. ]\n");
  vr::ImageOptions o;
  o.calibration_file = "calib.yaml";
  auto p = vr::ImagePipeline::create(o, dir);
  ASSERT_TRUE(p.ok()) << p.error().message;
  cv::Mat out;
  const cv::Mat in = test_image(1, 64, 48);
  ASSERT_TRUE(p->apply(in, out).ok());
  EXPECT_EQ(out.size(), in.size());
  EXPECT_GT(cv::norm(out, in, cv::NORM_L1), 0.0);  // barrel distortion removed: pixels moved
  // the centre pixel stays where it is
  EXPECT_EQ(out.at<cv::Vec3b>(24, 32), in.at<cv::Vec3b>(24, 32));
  auto wrong_size = p->apply(test_image(1, 80, 60), out);
  EXPECT_TRUE(fails_with(wrong_size, ErrorCode::inconsistent, At{"calib.yaml", 0, "calibration_file"}));

  write_text(dir + "/nomatrix.yaml", "%YAML:1.0\n---\nimage_width: 64\n");
  o.calibration_file = dir + "/nomatrix.yaml";
  auto missing = vr::ImagePipeline::create(o);
  EXPECT_TRUE(fails_with(missing, ErrorCode::missing, At{"nomatrix.yaml", 0, "camera_matrix"}));
  o.calibration_file = dir + "/absent.yaml";
  auto absent = vr::ImagePipeline::create(o);
  EXPECT_TRUE(fails_with(absent, ErrorCode::not_found, At{"absent.yaml", 0, "calibration_file"}));
}

TEST(FramePacer, ClockAndRealtimeAndFast) {
  const std::vector<double> t = {1.0, 1.1, 1.2, 1.3};
  vr::FramePacer clock(vr::Pacing::clock);
  EXPECT_FALSE(clock.due(t, 0, 0.0, 0.9).has_value());
  EXPECT_EQ(clock.due(t, 0, 0.0, 1.0), std::optional<std::size_t>(0));
  EXPECT_EQ(clock.due(t, 1, 0.0, 1.25), std::optional<std::size_t>(2));  // newest due, 1 skipped
  EXPECT_DOUBLE_EQ(clock.stamp(t, 2, 1.25), 1.2);
  vr::FramePacer rt(vr::Pacing::realtime);
  EXPECT_EQ(rt.due(t, 0, 10.0, 0.0), std::optional<std::size_t>(0));  // origin: wall 10 s
  EXPECT_FALSE(rt.due(t, 1, 10.05, 0.0).has_value());
  EXPECT_NEAR(rt.wait_s(t, 1, 10.05), 0.05, 1e-12);
  EXPECT_EQ(rt.due(t, 1, 10.21, 0.0), std::optional<std::size_t>(2));
  vr::FramePacer fast(vr::Pacing::fast);
  EXPECT_EQ(fast.due(t, 3, 0.0, 0.0), std::optional<std::size_t>(3));
  EXPECT_FALSE(fast.due(t, 4, 0.0, 0.0).has_value());
}

TEST(AdaptiveExposure, ConvergesOnALinearSensorAndHoldsInTheDeadBand) {
  // A sensor whose mean brightness is proportional to exposure (saturating at 255).
  const double scene = 0.2;  // grey levels per exposure unit
  vr::AdaptiveExposure ae({110.0, 5.0, 0.6, 2.0, 1.0, 5000.0}, 100.0);
  auto brightness = [&](double e) { return std::min(255.0, scene * e); };
  for (int i = 0; i < 30; ++i) ae.update(brightness(ae.exposure()));
  EXPECT_NEAR(brightness(ae.exposure()), 110.0, 5.0);
  const double settled = ae.exposure();
  ae.update(112.0);
  EXPECT_DOUBLE_EQ(ae.exposure(), settled);
  // step limit: a black frame at most doubles the exposure
  vr::AdaptiveExposure dark({110.0, 5.0, 1.0, 2.0, 1.0, 5000.0}, 100.0);
  EXPECT_DOUBLE_EQ(dark.update(0.0), 200.0);
  const cv::Mat grey(10, 10, CV_8UC1, cv::Scalar(77));
  EXPECT_DOUBLE_EQ(vr::AdaptiveExposure::mean_brightness(grey, 1), 77.0);
}

TEST(ImageFolderList, NaturalOrderTimestampsAndErrors) {
  const std::string dir = scratch();
  for (int i : {10, 2, 1}) cv::imwrite(dir + "/img" + std::to_string(i) + ".png", test_image(i));
  write_text(dir + "/notes.txt", "not an image");
  auto list = vr::list_image_folder(dir, "", 5.0);
  ASSERT_TRUE(list.ok()) << list.error().message;
  ASSERT_EQ(list->frames.size(), 3u);
  EXPECT_NE(list->frames[1].path.find("img2.png"), std::string::npos);
  EXPECT_DOUBLE_EQ(list->frames[2].t_s, 0.4);
  write_text(dir + "/timestamps.csv", "file,t_s\nimg1.png,5.0\nimg2.png,5.5\nimg10.png,5.2\n");
  auto bad = vr::list_image_folder(dir, "", 5.0);
  EXPECT_TRUE(fails_with(bad, ErrorCode::inconsistent, At{"timestamps.csv", 4}));
  write_text(dir + "/timestamps.csv", "file,t_s\nimg1.png,5.0\nimg2.png,5.5\nimg10.png,6\n");
  auto good = vr::list_image_folder(dir, "", 5.0);
  ASSERT_TRUE(good.ok()) << good.error().message;
  EXPECT_DOUBLE_EQ(good->frames[2].t_s, 6.0);
  const std::string empty = scratch("_empty");
  auto none = vr::list_image_folder(empty, "", 5.0);
  EXPECT_TRUE(fails_with(none, ErrorCode::missing, At{empty}));
}
