// Live config reload: params applied through reconfigure, detector swap, invalid files rejected.
#include <thread>

#include "error_expect.hpp"
#include "run_test_util.hpp"

using namespace visnav;
using visnav::test::CaptureLogger;
using visnav::test::contains;
using visnav::test::fixture_config;
using visnav::test::TempDir;

namespace {

struct Reload {
  TempDir dir;
  CaptureLogger log;
  std::string config_file;
  std::unique_ptr<Session> session;

  explicit Reload(const std::string& config) {
    config_file = dir.write("c.yaml", config);
    auto s = visnav::test::fixture_session(config_file, &log);
    if (!s) {
      ADD_FAILURE() << s.error().message;
      return;
    }
    session = std::move(s).value();
  }
  void rewrite(const std::string& config) { dir.write("c.yaml", config); }
};

/// Keypoints the active detector finds on a fixed checkerboard.
std::size_t keypoints(Session& s) {
  cv::Mat image(96, 96, CV_8UC1);
  for (int v = 0; v < 96; ++v)
    for (int u = 0; u < 96; ++u) image.at<std::uint8_t>(v, u) = ((u / 6 + v / 6) & 1) != 0 ? 200 : 20;
  Features f;
  EXPECT_TRUE(s.detector()->detect(image, f));
  return f.keypoints.size();
}

int frame_width(Session& s) {
  auto frame = s.camera().grab(0.0);
  EXPECT_TRUE(frame && frame->has_value());
  return frame && frame->has_value() ? (**frame).image.cols : -1;
}

}  // namespace

using visnav::test::At;
using visnav::test::fails_with;

TEST(Reload, CameraParamChangeIsAppliedThroughReconfigure) {
  Reload r(fixture_config("{}", "{width_px: 160}"));
  ASSERT_TRUE(r.session);
  Camera* before = &r.session->camera();
  EXPECT_EQ(frame_width(*r.session), 160);
  r.rewrite(fixture_config("{}", "{width_px: 320}"));
  auto applied = r.session->reload_config();
  ASSERT_TRUE(applied) << applied.error().message;
  EXPECT_TRUE(*applied);
  EXPECT_EQ(&r.session->camera(), before);  // same object, new params
  EXPECT_EQ(frame_width(*r.session), 320);
  EXPECT_EQ(r.session->reloads_applied(), 1);
  EXPECT_TRUE(r.log.saw("camera 'fixture' params updated")) << r.log.all();
}

TEST(Reload, DetectorTypeChangeSwapsTheActiveDetector) {
  Reload r(fixture_config());
  ASSERT_TRUE(r.session);
  EXPECT_EQ(r.session->detector()->norm(), DescriptorNorm::hamming);
  r.rewrite(fixture_config("{}", "{}", "{}", "grid_l2"));
  auto applied = r.session->reload_config();
  ASSERT_TRUE(applied) << applied.error().message;
  EXPECT_EQ(r.session->detector()->norm(), DescriptorNorm::l2);
  EXPECT_EQ(r.session->host().active_detector(), r.session->detector());
  EXPECT_EQ(r.session->config().detector->type, "grid_l2");
  EXPECT_TRUE(r.log.saw("active detector is now 'grid_l2'")) << r.log.all();
}

TEST(Reload, DetectorParamChangeReconfiguresInPlace) {
  Reload r(fixture_config("{}", "{}", "{}", "grid_hamming", "{cell_px: 8}"));
  ASSERT_TRUE(r.session);
  Detector* before = r.session->detector();
  const std::size_t fine = keypoints(*r.session);
  r.rewrite(fixture_config("{}", "{}", "{}", "grid_hamming", "{cell_px: 32}"));
  ASSERT_TRUE(r.session->reload_config());
  EXPECT_EQ(r.session->detector(), before);
  EXPECT_LT(keypoints(*r.session), fine);
}

TEST(Reload, YamlSyntaxErrorIsRejectedAndTheOldConfigKept) {
  Reload r(fixture_config("{}", "{width_px: 160}"));
  ASSERT_TRUE(r.session);
  Detector* before = r.session->detector();
  r.rewrite("robot: {type: fixture\ncamera: [\n");
  auto applied = r.session->reload_config();
  ASSERT_FALSE(applied);
  EXPECT_TRUE(fails_with(applied, ErrorCode::parse_error, At{r.config_file}));
  EXPECT_EQ(r.session->detector(), before);
  EXPECT_EQ(frame_width(*r.session), 160);
  EXPECT_EQ(r.session->reloads_rejected(), 1);
  EXPECT_TRUE(r.log.saw("rejected, keeping the running config")) << r.log.all();
}

TEST(Reload, OutOfRangeDetectorParamIsRejected) {
  Reload r(fixture_config("{}", "{}", "{}", "grid_hamming", "{cell_px: 8}"));
  ASSERT_TRUE(r.session);
  Detector* before = r.session->detector();
  const std::size_t n = keypoints(*r.session);
  r.rewrite(fixture_config("{}", "{}", "{}", "grid_hamming", "{cell_px: 1}"));
  auto applied = r.session->reload_config();
  ASSERT_FALSE(applied);
  EXPECT_TRUE(fails_with(applied, ErrorCode::out_of_range, At{r.config_file, 3, "detector.params.cell_px"}));
  EXPECT_EQ(r.session->detector(), before);
  EXPECT_EQ(keypoints(*r.session), n);
}

TEST(Reload, UnknownDetectorTypeIsRejected) {
  Reload r(fixture_config());
  ASSERT_TRUE(r.session);
  r.rewrite(fixture_config("{}", "{}", "{}", "grid_nonexistent"));
  auto applied = r.session->reload_config();
  ASSERT_FALSE(applied);
  EXPECT_TRUE(fails_with(applied, ErrorCode::not_found, At{r.config_file, 3, "detector.type"}));
  EXPECT_EQ(r.session->detector()->norm(), DescriptorNorm::hamming);
  EXPECT_EQ(r.session->config().detector->type, "grid_hamming");
}

TEST(Reload, InvalidRunValueIsRejectedWithItsLine) {
  Reload r(fixture_config());
  ASSERT_TRUE(r.session);
  r.rewrite(fixture_config("{}", "{}", "{rate_hz: 0}"));
  auto applied = r.session->reload_config();
  ASSERT_FALSE(applied);
  EXPECT_TRUE(fails_with(applied, ErrorCode::out_of_range, At{r.config_file, 4, "run.rate_hz"}));
  EXPECT_DOUBLE_EQ(r.session->config().run.rate_hz, 10.0);
}

TEST(Reload, ChangesThatNeedARestartAreRejected) {
  Reload r(fixture_config());
  ASSERT_TRUE(r.session);
  r.rewrite("robot: {type: other}\ncamera: {type: fixture}\nrun: {tick: rate}\n");
  auto applied = r.session->reload_config();
  ASSERT_FALSE(applied);
  EXPECT_TRUE(fails_with(applied, ErrorCode::inconsistent, At{r.config_file, 0, "robot"}));
  // Content: every setting that needs a restart is named, not only the first.
  EXPECT_TRUE(contains(applied.error().message, "run.tick")) << applied.error().message;
}

TEST(Reload, RefusedReconfigureKeepsThatObjectButAppliesTheRest) {
  Reload r(fixture_config("{}", "{width_px: 160}"));
  ASSERT_TRUE(r.session);
  r.rewrite(fixture_config("{simulated: false}", "{width_px: 200}", "{rate_hz: 20}"));
  auto applied = r.session->reload_config();
  ASSERT_TRUE(applied) << applied.error().message;
  EXPECT_TRUE(r.log.saw("robot 'fixture' kept its old params: 'simulated' cannot change while running")) << r.log.all();
  EXPECT_EQ(frame_width(*r.session), 200);
  EXPECT_DOUBLE_EQ(r.session->config().run.rate_hz, 20.0);
  EXPECT_TRUE(r.session->config().robot.params.is_null() || r.session->config().robot.params.entries().empty());
  EXPECT_NE(r.session->robot().simulation(), nullptr);
}

TEST(Reload, PollNoticesTheFileChange) {
  Reload r(fixture_config());
  ASSERT_TRUE(r.session);
  EXPECT_FALSE(r.session->poll_config_reload(true));  // unchanged
  r.rewrite(fixture_config("{}", "{}", "{}", "grid_l2"));
  EXPECT_TRUE(r.session->poll_config_reload(true));
  EXPECT_EQ(r.session->detector()->norm(), DescriptorNorm::l2);
  EXPECT_FALSE(r.session->poll_config_reload(true));  // stamp remembered
}

TEST(Reload, RunLoopSwapsTheDetectorBetweenTicksWithoutStoppingTheTree) {
  Reload r(fixture_config("{}", "{}", "{reload_poll_s: 0.001}"));
  ASSERT_TRUE(r.session);
  r.dir.write("tree.xml", visnav::test::drive_tree(1000.0));
  auto tree = r.session->load_tree(r.dir.file("tree.xml"));
  ASSERT_TRUE(tree) << tree.error().message;
  std::atomic<int> no_signal{0};
  RunOptions o;
  o.stop_requested = &no_signal;
  std::uint64_t swapped_at = 0;
  o.after_tick = [&](const TickInfo& t) {
    if (t.tick == 3) r.rewrite(fixture_config("{}", "{}", "{reload_poll_s: 0.001}", "grid_l2"));
    if (swapped_at == 0 && r.session->host().active_detector()->norm() == DescriptorNorm::l2) swapped_at = t.tick;
    if (t.tick > 3) std::this_thread::sleep_for(std::chrono::milliseconds(2));  // let the poll interval pass
    EXPECT_EQ(t.status, bt::NodeStatus::running);  // the mission keeps going
    return swapped_at == 0 && t.tick < 2000;
  };
  const RunReport report = run_tree(*r.session, *tree, o);
  EXPECT_EQ(report.outcome, RunOutcome::stopped);
  EXPECT_GT(swapped_at, 3u);
  EXPECT_LT(swapped_at, 10u);
  EXPECT_EQ(r.session->reloads_applied(), 1);
}
