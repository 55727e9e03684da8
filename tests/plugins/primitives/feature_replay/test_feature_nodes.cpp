// TeachFeatureEdge / ReplayFeatureEdge loaded from the real libvisnav_feature_replay.so through
// the real loader, on a kinematic fake robot, a fake detector (synthetic features with fixed
// random descriptors) and a fresh map folder:
//  * teaching writes an edge of the right kind with a payload the core parses, the protocol's
//    length/azimuth/end_heading_rad and the statistics, and never commands the robot;
//  * replaying an edge of an unknown kind or with a corrupted payload fails with a clear logged
//    message and never moves the robot;
//  * bad inputs (empty frame, wrong-size frame, no features, a few features on one side) do not
//    crash, are reported in telemetry and keep the recorded command (style B) / drive straight
//    (style A) instead of steering on noise.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <random>
#include <utility>

#include <opencv2/core.hpp>

#include "visnav/bt/registry.hpp"
#include "visnav/bt/tree.hpp"
#include "visnav/feature_replay/experience.hpp"
#include "visnav/feature_replay/local_map.hpp"
#include "visnav/feature_replay/segment_map.hpp"
#include "visnav/loader.hpp"
#include "visnav/map.hpp"
#include "visnav/runtime_host.hpp"

#include "fake_devices.hpp"

namespace fs = std::filesystem;
using namespace visnav;
using bt::NodeStatus;
using visnav::test::KinematicRobot;
namespace fr = visnav::feature_replay;

namespace {

/// Returns `next` (an error for an empty image, like the real detectors).
class FakeDetector final : public Detector {
 public:
  Status detect(const cv::Mat& image, Features& out) override {
    if (image.empty()) return fail("empty image");
    out.keypoints = next.keypoints;
    next.descriptors.copyTo(out.descriptors);
    out.norm = DescriptorNorm::hamming;
    return ok();
  }
  [[nodiscard]] DescriptorNorm norm() const override { return DescriptorNorm::hamming; }
  Features next;
};

class CaptureLogger final : public Logger {
 public:
  void log(LogLevel level, std::string_view component, std::string_view message) override {
    std::lock_guard lock(mutex_);
    text_ += (level == LogLevel::error ? "E " : "I ") + std::string(component) + ": " + std::string(message) + "\n";
  }
  [[nodiscard]] std::string text() const {
    std::lock_guard lock(mutex_);
    return text_;
  }

 private:
  mutable std::mutex mutex_;
  std::string text_;
};

class CaptureTelemetry final : public Telemetry {
 public:
  void publish(const NavStatus& status) override { statuses.push_back(status); }
  std::vector<NavStatus> statuses;
};

/// A scene of `n` features with fixed random 32-byte descriptors at random image positions.
struct Scene {
  std::vector<cv::Point2f> positions;
  cv::Mat descriptors;
  explicit Scene(int n, unsigned seed = 7) : descriptors(n, 32, CV_8UC1) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(20.f, 300.f), v(20.f, 220.f);
    std::uniform_int_distribution<int> byte(0, 255);
    for (int i = 0; i < n; ++i) {
      positions.emplace_back(u(rng), v(rng));
      for (int j = 0; j < 32; ++j) descriptors.at<std::uint8_t>(i, j) = static_cast<std::uint8_t>(byte(rng));
    }
  }
  /// The scene shifted horizontally by `du_px`; only features with u < max_u_px, at most `limit`.
  [[nodiscard]] Features view(float du_px, float max_u_px = 1e9f, int limit = 1 << 30) const {
    Features f;
    std::vector<int> rows;
    for (int i = 0; i < static_cast<int>(positions.size()) && static_cast<int>(rows.size()) < limit; ++i) {
      if (positions[i].x + du_px >= max_u_px) continue;
      f.keypoints.emplace_back(positions[i].x + du_px, positions[i].y, 7.f, -1.f, 10.f);
      rows.push_back(i);
    }
    f.descriptors.create(static_cast<int>(rows.size()), 32, CV_8UC1);
    for (std::size_t r = 0; r < rows.size(); ++r) descriptors.row(rows[r]).copyTo(f.descriptors.row(static_cast<int>(r)));
    return f;
  }
};

class FeatureNodes : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = visnav::test::fresh_test_dir("visnav_fr_nodes");
    ASSERT_TRUE(visnav::test::attach_scratch_map(host_, bus_, robot_, map_, dir_));
    host_.set_active_detector(&detector_);
    host_.set_telemetry(&telemetry_);
    ASSERT_TRUE(visnav::test::register_plugin_nodes(loader_, "feature_replay", registry_, host_));
  }
  void TearDown() override { fs::remove_all(dir_); }

  bt::Tree load(const std::string& body) { return visnav::test::load_main_tree(body, registry_, &clock_); }

  void publish_frame(int width = 320, int height = 240) {
    Frame f;
    f.timestamp_s = clock_.now_s();
    f.sequence = ++sequence_;
    if (width > 0) {
      // A live camera never delivers the same pixels twice (the lost policy stops on a frozen one).
      f.image = cv::Mat(height, width, CV_8UC1, cv::Scalar(128));
      f.image.at<unsigned char>(0, 0) = static_cast<unsigned char>(sequence_ & 0xff);
      f.image.at<unsigned char>(0, 1) = static_cast<unsigned char>((sequence_ >> 8) & 0xff);
    }
    bus_.publish_frame(f);
  }

  /// One tick: publish a frame with `features`, tick, move the robot 0.1 s.
  NodeStatus tick(bt::Tree& tree, const Features& features, int width = 320, int height = 240) {
    detector_.next = features;
    publish_frame(width, height);
    const NodeStatus s = tree.tick_once();
    robot_.step(0.1);
    clock_.advance(0.1);
    return s;
  }

  /// Teaches one edge while the "operator" (the test) drives `commands` for 10 ticks each.
  std::string teach(const std::string& style, const std::vector<Twist>& commands) {
    auto tree = load("<TeachFeatureEdge style=\"" + style +
                     "\" edge_from=\"\" edge_to=\"\" finish=\"{finish_edge}\" edge=\"{taught_edge}\"/>");
    int frame = 0;
    for (const Twist& c : commands) {
      robot_.command_ = c;  // the operator; the node itself never commands
      for (int i = 0; i < 10; ++i, ++frame) EXPECT_EQ(tick(tree, scene_.view(-1.5f * frame)), NodeStatus::running);
    }
    tree.blackboard().set("finish_edge", true);
    EXPECT_EQ(tick(tree, scene_.view(-1.5f * frame)), NodeStatus::success) << logger_.text();
    auto id = tree.blackboard().get<std::string>("taught_edge");
    EXPECT_TRUE(id.ok());
    return id ? *id : std::string();
  }

  /// An edge between two new nodes (a segment joins two places; the body checks refuse a segment
  /// onto its own node), or, with `closed_loop`, from a new node back to itself.
  std::string add_edge(const std::string& kind, const std::vector<std::uint8_t>& body, double length_m = 5.0,
                       bool closed_loop = false) {
    NodeRecord n;
    const std::string a = *map_->add_node(n);
    const std::string b = closed_loop ? a : *map_->add_node(n);
    EdgeRecord e;
    e.from = a;
    e.to = b;
    e.kind = kind;
    e.length_m = length_m;
    e.statistics["image_width_px"] = 320;  // as TeachFeatureEdge records them
    e.statistics["image_height_px"] = 240;
    auto id = map_->add_edge(e, body);
    EXPECT_TRUE(id.ok()) << id.error().message;
    return *id;
  }

  /// A 3 m feature_localmaps edge from a node back to itself (or, `closed_loop` false, between two
  /// nodes): the scene at every 0.5 m, `command` recorded from 0 m, a stop at 3 m.
  std::string add_scene_localmaps_edge(const Twist& command, bool closed_loop = true) {
    fr::LocalMapPath path;
    path.length_m = 3.0;
    for (int i = 0; i <= 6; ++i) {
      fr::LocalMap m;
      m.distance_m = 0.5 * i;
      m.positions_px = scene_.positions;
      m.descriptors = scene_.descriptors.clone();
      path.maps.push_back(std::move(m));
    }
    path.commands.push_back({0.0, command});
    path.commands.push_back({3.0, Twist{}});
    return add_edge("feature_localmaps", path.serialize(), 3.0, closed_loop);
  }

  fs::path dir_;
  PluginLoader loader_{std::vector<std::string>{VISNAV_TEST_PLUGIN_DIR}};
  CaptureLogger logger_;
  ManualClock clock_;
  RuntimeHost host_{loader_, logger_, clock_};
  bt::NodeRegistry registry_;
  FrameBus bus_;
  KinematicRobot robot_{bus_};
  FakeDetector detector_;
  CaptureTelemetry telemetry_;
  std::optional<MapStore> map_;
  Scene scene_{200};
  std::uint64_t sequence_ = 0;
};

TEST_F(FeatureNodes, TeachSegmentWritesAParsableEdgeWithTheProtocolFields) {
  robot_.odom_.pose.heading_rad = 0.3;
  robot_.publish();
  const std::string id = teach("segment", {{1.0, 0.05}, {1.0, 0.05}});
  const EdgeRecord* e = map_->find_edge(id);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->kind, "feature_segment");
  EXPECT_NEAR(e->length_m, 2.0, 1e-6);
  EXPECT_NEAR(e->azimuth_rad, 0.3, 1e-9);
  EXPECT_NEAR(e->statistics.at("end_heading_rad"), 0.4, 1e-6);
  EXPECT_GT(e->statistics.at("landmarks"), 100.0);
  EXPECT_EQ(e->statistics.at("image_width_px"), 320.0);
  EXPECT_EQ(map_->find_node(e->from)->name, "start");
  EXPECT_EQ(map_->find_node(e->to)->name, "end");
  auto body = map_->read_payload(id);
  ASSERT_TRUE(body.ok()) << body.error().message;
  EXPECT_EQ(e->statistics.at("bytes"), static_cast<double>(body->size()));
  auto seg = fr::SegmentMap::deserialize(*body);
  ASSERT_TRUE(seg.ok()) << seg.error().message;
  EXPECT_EQ(static_cast<double>(seg->landmarks.size()), e->statistics.at("landmarks"));
  EXPECT_EQ(robot_.commands_, 0) << "the teach node must never command the robot";

  // Replaying it with bad frames drives straight at the set speed (omega 0), never steering.
  robot_.odom_ = Odometry{};
  robot_.publish();
  auto replay = load("<ReplayFeatureEdge scan_deg=\"0\" edge=\"" + id + "\" speed_mps=\"0.3\"/>");
  EXPECT_EQ(tick(replay, scene_.view(0.f), 0), NodeStatus::running);  // empty frame
  EXPECT_EQ(telemetry_.statuses.back().status, "bad frame");
  EXPECT_EQ(robot_.command_.linear_mps, 0.3);
  EXPECT_EQ(robot_.command_.angular_radps, 0.0);
  EXPECT_EQ(tick(replay, Features{}), NodeStatus::running);  // no features
  EXPECT_EQ(telemetry_.statuses.back().status, "no features");
  EXPECT_EQ(robot_.command_.angular_radps, 0.0);
  EXPECT_EQ(tick(replay, scene_.view(-3.f)), NodeStatus::running);  // the scene as taught
  EXPECT_EQ(telemetry_.statuses.back().status, "steering");
  EXPECT_GT(telemetry_.statuses.back().inliers, 50);
  EXPECT_EQ(telemetry_.statuses.back().edge, id);
}

// Issue 39: beyond the last taught landmark a frame without a match counts as blind, so a replay
// past the edge's evidence stops with a reason within max_blind_m. Here the landmarks cover 0-3 m
// of a 6 m edge (within the map check's slack) and the camera sees nothing known after 3 m:
// before, such frames were "uninformative" (the map expects nothing there), the blind count
// paused and the robot drove the whole edge on odometry.
TEST_F(FeatureNodes, ReplayPastTheLastLandmarkStopsWithinMaxBlind) {
  fr::SegmentMap seg;
  seg.length_m = 6.0;
  seg.descriptors = scene_.descriptors.clone();
  for (const cv::Point2f& p : scene_.positions) {
    fr::Landmark l;
    l.count = 10;
    l.first_px = p;
    l.last_px = p;
    l.first_distance_m = 0.0f;
    l.last_distance_m = 3.0f;
    seg.landmarks.push_back(l);
  }
  seg.max_span_m = 3.0;
  const std::string id = add_edge("feature_segment", seg.serialize(), 6.0);
  auto tree = load("<ReplayFeatureEdge scan_deg=\"0\" edge=\"" + id +
                   "\" speed_mps=\"0.5\" slow_after_m=\"0.5\" max_blind_m=\"1.5\"/>");
  const Scene elsewhere(200, 99);  // what the camera sees past the taught landmarks
  NodeStatus s = NodeStatus::running;
  for (int i = 0; i < 300 && s == NodeStatus::running; ++i)
    s = tick(tree, robot_.odom_.distance_m < 3.0 ? scene_.view(0.f) : elsewhere.view(0.f));
  EXPECT_EQ(s, NodeStatus::failure) << logger_.text();
  EXPECT_NE(logger_.text().find("lost"), std::string::npos) << logger_.text();
  EXPECT_GT(robot_.odom_.distance_m, 3.0);
  // max_blind_m after the last confident frame; the 5-frame confidence window (0.05 m per frame)
  // lets the last confident frame lie up to ~0.25 m past the landmarks.
  EXPECT_LT(robot_.odom_.distance_m, 3.0 + 1.5 + 0.35) << "stopped later than max_blind_m past the last landmark";
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
}

TEST_F(FeatureNodes, TeachLocalMapsRecordsTheOperatorsCommands) {
  const std::string id = teach("localmaps", {{0.5, 0.2}, {0.5, -0.1}});
  const EdgeRecord* e = map_->find_edge(id);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->kind, "feature_localmaps");
  EXPECT_NEAR(e->length_m, 1.0, 1e-6);
  auto body = map_->read_payload(id);
  ASSERT_TRUE(body.ok()) << body.error().message;
  auto path = fr::LocalMapPath::deserialize(*body);
  ASSERT_TRUE(path.ok()) << path.error().message;
  EXPECT_GE(path->maps.size(), 5u);
  EXPECT_EQ(static_cast<double>(path->maps.size()), e->statistics.at("local_maps"));
  EXPECT_NEAR(path->command_at(0.2).angular_radps, 0.2, 1e-6);
  EXPECT_NEAR(path->command_at(0.8).angular_radps, -0.1, 1e-6);
  EXPECT_NEAR(path->command_at(0.8).linear_mps, 0.5, 1e-6);
  EXPECT_EQ(robot_.commands_, 0);
}

TEST_F(FeatureNodes, UnknownKindFailsWithAClearMessageAndNeverMoves) {
  const std::string id = add_edge("path_following", {1, 2, 3});
  auto tree = load("<ReplayFeatureEdge scan_deg=\"0\" edge=\"" + id + "\"/>");
  EXPECT_EQ(tick(tree, scene_.view(0.f)), NodeStatus::failure);
  EXPECT_NE(logger_.text().find("has kind 'path_following'"), std::string::npos) << logger_.text();
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
  EXPECT_EQ(robot_.odom_.distance_m, 0.0);
}

TEST_F(FeatureNodes, CorruptedPayloadFailsWithAClearMessageAndNeverMoves) {
  const std::string id = add_edge("feature_segment", {'V', 'N', 'F', 'A', 9, 9, 9, 9, 1, 2, 3});
  auto tree = load("<ReplayFeatureEdge scan_deg=\"0\" edge=\"" + id + "\"/>");
  EXPECT_EQ(tick(tree, scene_.view(0.f)), NodeStatus::failure);
  EXPECT_NE(logger_.text().find("edge " + id + " payload"), std::string::npos) << logger_.text();
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
  EXPECT_EQ(robot_.odom_.distance_m, 0.0);
  // An unknown edge id fails the same way.
  auto tree2 = load("<ReplayFeatureEdge scan_deg=\"0\" edge=\"nope\"/>");
  EXPECT_EQ(tick(tree2, scene_.view(0.f)), NodeStatus::failure);
  EXPECT_NE(logger_.text().find("unknown edge 'nope'"), std::string::npos);
  EXPECT_EQ(robot_.odom_.distance_m, 0.0);
}

TEST_F(FeatureNodes, BadInputsKeepTheRecordedCommand) {
  const std::string id = add_scene_localmaps_edge(Twist{0.5, 0.2});
  auto tree = load("<ReplayFeatureEdge scan_deg=\"0\" edge=\"" + id + "\" correction_gain_radps_per_px=\"0.004\"/>");
  // A good frame with the scene 20 px to the right: the robot is turned left -> steer right.
  EXPECT_EQ(tick(tree, scene_.view(20.f)), NodeStatus::running);
  EXPECT_EQ(telemetry_.statuses.back().status, "steering");
  EXPECT_NEAR(telemetry_.statuses.back().offset_px, 20.0, 0.5);
  EXPECT_NEAR(robot_.command_.angular_radps, 0.2 - 0.004 * 20.0, 0.003);
  struct Case {
    const char* what;
    Features features;
    int width, height;
    const char* status;
  };
  const Case cases[] = {
      {"empty frame", scene_.view(20.f), 0, 0, "bad frame"},
      {"wrong-size frame", scene_.view(20.f), 640, 480, "bad frame"},
      {"no features", Features{}, 320, 240, "no features"},
      {"all features on one side", scene_.view(20.f, 60.f, 4), 320, 240, "low confidence"},
  };
  for (const Case& c : cases) {
    EXPECT_EQ(tick(tree, c.features, c.width, c.height), NodeStatus::running) << c.what;
    EXPECT_EQ(telemetry_.statuses.back().status, c.status) << c.what;
    EXPECT_NEAR(robot_.command_.linear_mps, 0.5, 1e-6) << c.what;  // payload stores f32
    EXPECT_NEAR(robot_.command_.angular_radps, 0.2, 1e-6) << c.what << ": the recorded command must be kept";
  }
  // Drive to the end: SUCCESS with the robot stopped.
  NodeStatus s = NodeStatus::running;
  for (int i = 0; i < 200 && s == NodeStatus::running; ++i) s = tick(tree, scene_.view(0.f));
  EXPECT_EQ(s, NodeStatus::success);
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
  EXPECT_NEAR(robot_.odom_.distance_m, 3.0, 0.15);
}

// Issue 38: laps > 1 drives a closed one-edge loop (from == to) again from its start. On an open
// edge the node fails before the robot moves, naming the edge, the laps value and both nodes
// (before, it drove the edge again and again until the lost policy stopped it); laps=1 on the
// same edge and laps=2 on a loop run as before.
TEST_F(FeatureNodes, LapsOnAnOpenEdgeFailBeforeMovingNamingTheEdgeAndItsNodes) {
  const std::string open = add_scene_localmaps_edge(Twist{1.0, 0.0}, /*closed_loop=*/false);
  const EdgeRecord* e = map_->find_edge(open);
  ASSERT_NE(e, nullptr);
  ASSERT_NE(e->from, e->to);
  auto drive = [&](const std::string& id, int laps) {
    robot_.odom_ = Odometry{};
    robot_.command_ = Twist{};
    robot_.publish();
    auto tree = load("<ReplayFeatureEdge scan_deg=\"0\" edge=\"" + id + "\" laps=\"" + std::to_string(laps) + "\"/>");
    NodeStatus s = NodeStatus::running;
    for (int i = 0; i < 200 && s == NodeStatus::running; ++i) s = tick(tree, scene_.view(0.f));
    return s;
  };
  EXPECT_EQ(drive(open, 2), NodeStatus::failure);
  const std::string expected = "laps=2 on edge " + open + ", which runs from node '" + e->from + "' to node '" + e->to +
                               "': laps > 1 drives only a closed one-edge loop";
  EXPECT_NE(logger_.text().find(expected), std::string::npos) << logger_.text();
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
  EXPECT_EQ(robot_.odom_.distance_m, 0.0) << "the robot moved before the laps check";

  EXPECT_EQ(drive(open, 1), NodeStatus::success) << logger_.text();
  EXPECT_NEAR(robot_.odom_.distance_m, 3.0, 0.15);

  const std::string loop = add_scene_localmaps_edge(Twist{1.0, 0.0}, /*closed_loop=*/true);
  EXPECT_EQ(drive(loop, 2), NodeStatus::success) << logger_.text();
  EXPECT_NEAR(robot_.odom_.distance_m, 6.0, 0.25);
}

}  // namespace

TEST_F(FeatureNodes, ReplayCountsTheDistanceFollowRouteCarriedIntoTheEdge) {
  // FollowRoute writes {edge_carried_m}: the distance of the edge the robot already covered when
  // it starts (the previous edge's overshoot). A 3 m edge with 1 m carried ends after 2 m of
  // odometry; with the entry unset (standalone use) the whole 3 m are driven.
  const std::string id = add_scene_localmaps_edge(Twist{1.0, 0.0});
  auto drive = [&](std::optional<double> carried) {
    robot_.odom_ = Odometry{};
    robot_.command_ = Twist{};
    robot_.publish();
    auto tree = load("<ReplayFeatureEdge scan_deg=\"0\" edge=\"" + id + "\"/>");
    if (carried) tree.blackboard().set("edge_carried_m", *carried);
    EXPECT_EQ(tick(tree, scene_.view(0.f)), NodeStatus::running);
    const double first_distance_m = telemetry_.statuses.back().distance_m;
    NodeStatus s = NodeStatus::running;
    for (int i = 0; i < 100 && s == NodeStatus::running; ++i) s = tick(tree, scene_.view(0.f));
    EXPECT_EQ(s, NodeStatus::success);
    return std::make_pair(first_distance_m, robot_.odom_.distance_m);
  };
  const auto [start_carried, end_carried] = drive(1.0);
  EXPECT_NEAR(start_carried, 1.0, 1e-9);
  EXPECT_NEAR(end_carried, 2.0, 0.11);
  const auto [start_plain, end_plain] = drive(std::nullopt);
  EXPECT_NEAR(start_plain, 0.0, 1e-9);
  EXPECT_NEAR(end_plain, 3.0, 0.11);
}

// ------------------------------------------------------------------ appearance experiences

namespace {

/// The first `shared` features of `taught` (seen again) followed by every feature of `changed`
/// (new appearance): a "winter" view that still shows a few summer features.
Features mixed_view(const Features& taught, int shared, const Features& changed) {
  Features f;
  const int n = std::min(shared, static_cast<int>(taught.keypoints.size()));
  f.keypoints.assign(taught.keypoints.begin(), taught.keypoints.begin() + n);
  f.keypoints.insert(f.keypoints.end(), changed.keypoints.begin(), changed.keypoints.end());
  cv::vconcat(taught.descriptors.rowRange(0, n), changed.descriptors, f.descriptors);
  return f;
}

}  // namespace

class FeatureExperiences : public FeatureNodes {
 protected:
  /// Replays edge `id` to its end (at most 200 ticks) with `view` every frame; returns the status.
  NodeStatus replay(const std::string& id, const std::string& attributes, const Features& view) {
    robot_.odom_ = Odometry{};
    robot_.command_ = Twist{};
    robot_.publish();
    auto tree = load("<ReplayFeatureEdge scan_deg=\"0\" edge=\"" + id + "\" " + attributes + "/>");
    NodeStatus s = NodeStatus::running;
    for (int i = 0; i < 200 && s == NodeStatus::running; ++i) s = tick(tree, view);
    return s;
  }
  std::string experience_file(const std::string& id) const { return fr::experience_path(dir_.string(), id); }

  Scene winter_{200, 11};
};

TEST_F(FeatureExperiences, ALearnedExperienceIsChosenWhereTheTaughtOneNoLongerMatches) {
  const std::string id = add_scene_localmaps_edge(Twist{1.0, 0.0});
  const Features pure_winter = winter_.view(0.f);
  // Without experiences the winter view matches nothing: no steering.
  {
    robot_.odom_ = Odometry{};
    robot_.publish();
    auto tree = load("<ReplayFeatureEdge scan_deg=\"0\" edge=\"" + id + "\"/>");
    EXPECT_EQ(tick(tree, pure_winter), NodeStatus::running);
    EXPECT_NE(telemetry_.statuses.back().status, "steering");
    EXPECT_LT(telemetry_.statuses.back().inliers, 6);
  }
  EXPECT_FALSE(fs::exists(dir_ / "experiences")) << "nothing is written without learn_experiences";
  // An early-winter replay still sees 40 summer features: it steers on them and learns its view,
  // 10 px to the right of the reference heading.
  const Features early_winter = mixed_view(scene_.view(10.f), 40, winter_.view(10.f));
  ASSERT_EQ(replay(id, "learn_experiences=\"true\"", early_winter), NodeStatus::success) << logger_.text();
  ASSERT_TRUE(fs::exists(experience_file(id))) << logger_.text();
  EXPECT_NE(logger_.text().find("learned experience 1"), std::string::npos) << logger_.text();
  auto set = fr::read_experience_file(experience_file(id), id);
  ASSERT_TRUE(set.ok()) << set.error().message;
  ASSERT_EQ(set->learned.size(), 1u);
  auto learned = fr::LocalMapPath::deserialize(set->learned[0].body);
  ASSERT_TRUE(learned.ok()) << learned.error().message;
  EXPECT_GE(learned->maps.size(), 10u);
  EXPECT_NEAR(learned->length_m, 3.0, 1e-6);
  EXPECT_NEAR(learned->command_at(1.0).linear_mps, 1.0, 1e-6) << "the taught commands are kept";
  // The learned view is registered to the reference heading: the winter features sit where they
  // would be seen on the taught heading (10 px to the left of where this replay saw them).
  int winter_features = 0;
  const fr::LocalMap& m = learned->maps[3];
  for (int r = 0; r < m.descriptors.rows; ++r) {
    for (int j = 0; j < winter_.descriptors.rows; ++j) {
      if (cv::norm(m.descriptors.row(r), winter_.descriptors.row(j), cv::NORM_HAMMING) != 0) continue;
      EXPECT_NEAR(m.positions_px[static_cast<std::size_t>(r)].x, winter_.positions[static_cast<std::size_t>(j)].x, 0.25);
      ++winter_features;
    }
  }
  EXPECT_GT(winter_features, 100);

  // Deep winter, no summer feature left, robot turned so the scene is 15 px right: the learned
  // experience is chosen and the robot steers back.
  robot_.odom_ = Odometry{};
  robot_.publish();
  auto tree = load("<ReplayFeatureEdge scan_deg=\"0\" edge=\"" + id + "\" correction_gain_radps_per_px=\"0.004\"/>");
  EXPECT_EQ(tick(tree, winter_.view(15.f)), NodeStatus::running);
  EXPECT_EQ(telemetry_.statuses.back().status, "steering");
  EXPECT_GT(telemetry_.statuses.back().inliers, 100);
  EXPECT_NEAR(telemetry_.statuses.back().offset_px, 15.0, 0.5);
  EXPECT_NEAR(robot_.command_.angular_radps, -0.004 * 15.0, 0.003);
  EXPECT_NE(logger_.text().find("2 appearance experiences"), std::string::npos) << logger_.text();
  // Summer again: still steered right (by the summer features of either experience).
  for (int i = 0; i < 3; ++i) EXPECT_EQ(tick(tree, scene_.view(-5.f)), NodeStatus::running);
  EXPECT_EQ(telemetry_.statuses.back().status, "steering");
  EXPECT_NEAR(telemetry_.statuses.back().offset_px, -5.0, 0.5);
}

TEST_F(FeatureExperiences, LearningIsBoundedAndEvictsTheOldestLearned) {
  const std::string id = add_scene_localmaps_edge(Twist{1.0, 0.0});
  for (int run = 0; run < 4; ++run)
    ASSERT_EQ(replay(id, "learn_experiences=\"true\" max_experiences=\"3\"", scene_.view(0.f)), NodeStatus::success)
        << logger_.text();
  auto set = fr::read_experience_file(experience_file(id), id);
  ASSERT_TRUE(set.ok()) << set.error().message;
  ASSERT_EQ(set->learned.size(), 2u);
  EXPECT_EQ(set->learned[0].number, 3u);
  EXPECT_EQ(set->learned[1].number, 4u);
  EXPECT_EQ(set->next_number, 5u);
  EXPECT_NE(logger_.text().find("evicted experience 2"), std::string::npos) << logger_.text();
  // The taught payload is untouched and the map still validates.
  EXPECT_TRUE(map_->validate().empty());
}

TEST_F(FeatureExperiences, SegmentEdgesLearnToo) {
  const std::string id = teach("segment", {{1.0, 0.0}, {1.0, 0.0}});
  ASSERT_FALSE(id.empty());
  robot_.odom_ = Odometry{};
  robot_.publish();
  auto tree = load("<ReplayFeatureEdge scan_deg=\"0\" edge=\"" + id + "\" speed_mps=\"1\" learn_experiences=\"true\"/>");
  NodeStatus s = NodeStatus::running;
  for (int frame = 0; frame < 100 && s == NodeStatus::running; ++frame) {
    // The taught motion of the scene (1.5 px per 0.1 m) plus 40 summer features kept.
    const float du = -15.f * static_cast<float>(robot_.odom_.distance_m);
    s = tick(tree, mixed_view(scene_.view(du), 40, winter_.view(du)));
  }
  ASSERT_EQ(s, NodeStatus::success) << logger_.text();
  auto set = fr::read_experience_file(experience_file(id), id);
  ASSERT_TRUE(set.ok()) << set.error().message;
  ASSERT_EQ(set->learned.size(), 1u);
  auto learned = fr::SegmentMap::deserialize(set->learned[0].body);
  ASSERT_TRUE(learned.ok()) << learned.error().message;
  EXPECT_GT(learned->landmarks.size(), 100u);
  EXPECT_NEAR(learned->length_m, map_->find_edge(id)->length_m, 0.05);
}

TEST_F(FeatureExperiences, NothingIsLearnedFromAnEdgeThatDidNotSucceed) {
  const std::string id = add_scene_localmaps_edge(Twist{1.0, 0.0});
  robot_.odom_ = Odometry{};
  robot_.publish();
  {
    auto tree = load("<ReplayFeatureEdge scan_deg=\"0\" edge=\"" + id + "\" learn_experiences=\"true\"/>");
    for (int i = 0; i < 10; ++i) EXPECT_EQ(tick(tree, scene_.view(0.f)), NodeStatus::running);
    tree.halt();
  }
  EXPECT_FALSE(fs::exists(experience_file(id)));
}

TEST_F(FeatureExperiences, ADamagedExperienceFileFailsTheEdgeNamingTheFileBeforeMoving) {
  const std::string id = add_scene_localmaps_edge(Twist{1.0, 0.0});
  ASSERT_EQ(replay(id, "learn_experiences=\"true\"", scene_.view(0.f)), NodeStatus::success) << logger_.text();
  {
    std::fstream f(experience_file(id), std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(-20, std::ios::end);
    f.put('\x33');
  }
  robot_.odom_ = Odometry{};
  robot_.command_ = Twist{};
  robot_.publish();
  auto tree = load("<ReplayFeatureEdge scan_deg=\"0\" edge=\"" + id + "\"/>");
  EXPECT_EQ(tick(tree, scene_.view(0.f)), NodeStatus::failure);
  EXPECT_NE(logger_.text().find("experiences/" + id + ".bin"), std::string::npos) << logger_.text();
  EXPECT_NE(logger_.text().find("edge " + id), std::string::npos) << logger_.text();
  EXPECT_EQ(robot_.command_.linear_mps, 0.0);
  EXPECT_EQ(robot_.odom_.distance_m, 0.0);
}

namespace {

/// Runs the visnav command line; returns (exit status, stdout + stderr).
std::pair<int, std::string> run_cli(const std::string& args) {
  const std::string cmd = std::string(VISNAV_TEST_CLI) + " " + args + " 2>&1";
  std::string out;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (p == nullptr) return {-1, out};
  char buf[512];
  while (std::fgets(buf, sizeof buf, p) != nullptr) out += buf;
  const int status = ::pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

}  // namespace

TEST_F(FeatureExperiences, MapExperiencesListsThemAndMapValidateChecksThem) {
  const std::string id = add_scene_localmaps_edge(Twist{1.0, 0.0});
  {
    const auto [rc, out] = run_cli("map experiences " + dir_.string());
    EXPECT_EQ(rc, 0) << out;
    EXPECT_NE(out.find("edge " + id + " (feature_localmaps, 3.00 m): 1 experience\n"), std::string::npos) << out;
    EXPECT_NE(out.find("0 learned experiences"), std::string::npos) << out;
  }
  ASSERT_EQ(replay(id, "learn_experiences=\"true\"", scene_.view(0.f)), NodeStatus::success) << logger_.text();
  {
    const auto [rc, out] = run_cli("map experiences " + dir_.string());
    EXPECT_EQ(rc, 0) << out;
    EXPECT_NE(out.find("edge " + id + " (feature_localmaps, 3.00 m): 2 experiences\n"), std::string::npos) << out;
    EXPECT_NE(out.find("  1  learned "), std::string::npos) << out;
    EXPECT_NE(out.find("local maps"), std::string::npos) << out;
    const auto [vrc, vout] = run_cli("map validate " + dir_.string());
    EXPECT_EQ(vrc, 0) << vout;
  }
  {
    std::fstream f(experience_file(id), std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(-20, std::ios::end);
    f.put('\x33');
  }
  const auto [rc, out] = run_cli("map-experiences " + dir_.string() + " --check");
  EXPECT_EQ(rc, 1) << out;
  EXPECT_NE(out.find("experiences/" + id + ".bin"), std::string::npos) << out;
  const auto [vrc, vout] = run_cli("map validate " + dir_.string());
  EXPECT_EQ(vrc, 1) << vout;
  EXPECT_NE(vout.find("experiences/" + id + ".bin"), std::string::npos) << vout;
  EXPECT_NE(vout.find("INVALID"), std::string::npos) << vout;
}

// A supervised drive (the route driven again in winter, taught into a scratch map) added to the
// taught map with `visnav map experiences MAP --add-from DRIVE` through the real plugin command,
// then chosen by ReplayFeatureEdge where the taught view matches nothing.
TEST_F(FeatureExperiences, ASupervisedDriveAddedAsExperienceIsChosenInTheNewSeason) {
  const std::string id = add_scene_localmaps_edge(Twist{1.0, 0.0});
  const std::vector<std::uint8_t> teach_body = *map_->read_payload(id);
  const EdgeRecord taught = *map_->find_edge(id);
  // The drive: the same edge (id, nodes, kind), winter features, odometry 10 % long, the
  // operator a little faster.
  const fs::path drive_dir = dir_.string() + "_winter_drive";  // beside the map, removed at the end
  auto make_drive = [&](double length_m) {
    fs::remove_all(drive_dir);
    auto drive = MapStore::create(drive_dir.string(), "winter drive");
    ASSERT_TRUE(drive.ok()) << drive.error().message;
    NodeRecord n;
    n.name = "a";
    ASSERT_EQ(*drive->add_node(n), taught.from);
    fr::LocalMapPath path;
    path.length_m = length_m;
    for (int i = 0; i <= 6; ++i) {
      fr::LocalMap m;
      m.distance_m = length_m * i / 6.0;
      m.positions_px = winter_.positions;
      m.descriptors = winter_.descriptors.clone();
      path.maps.push_back(std::move(m));
    }
    path.commands.push_back({0.0, Twist{1.2, 0.0}});
    path.commands.push_back({length_m, Twist{}});
    EdgeRecord e = taught;
    e.length_m = length_m;
    auto added = drive->add_edge(e, path.serialize());
    ASSERT_TRUE(added.ok()) << added.error().message;
    ASSERT_EQ(*added, id);
  };
  // A drive of another stretch (5 m for 3 m) is refused and nothing is written.
  make_drive(5.0);
  {
    const auto [rc, out] = run_cli("map experiences " + dir_.string() + " --add-from " + drive_dir.string());
    EXPECT_EQ(rc, 1) << out;
    EXPECT_NE(out.find("edge " + id + ": REFUSED"), std::string::npos) << out;
    EXPECT_FALSE(fs::exists(experience_file(id)));
  }
  make_drive(3.3);
  {
    const auto [rc, out] = run_cli("map experiences " + dir_.string() + " --add-from " + drive_dir.string());
    EXPECT_EQ(rc, 0) << out;
    EXPECT_NE(out.find("edge " + id + ": added experience 1"), std::string::npos) << out;
  }
  // The taught payload and graph are unchanged; the experience is aligned to the taught edge.
  {
    auto reopened = MapStore::open(dir_.string());
    ASSERT_TRUE(reopened.ok());
    EXPECT_EQ(*reopened->read_payload(id), teach_body);
    EXPECT_DOUBLE_EQ(reopened->find_edge(id)->length_m, 3.0);
  }
  auto set = fr::load_experiences(dir_.string(), id, teach_body);
  ASSERT_TRUE(set.ok()) << set.error().message;
  ASSERT_EQ(set->learned.size(), 1u);
  EXPECT_NE(set->learned[0].source.find("supervised drive"), std::string::npos);
  auto learned = fr::LocalMapPath::deserialize(set->learned[0].body);
  ASSERT_TRUE(learned.ok());
  EXPECT_NEAR(learned->length_m, 3.0, 1e-9);
  EXPECT_NEAR(learned->maps.back().distance_m, 3.0, 1e-6);
  EXPECT_NEAR(learned->maps[3].distance_m, 1.5, 1e-6);
  EXPECT_NEAR(learned->command_at(1.0).linear_mps, 1.0, 1e-6) << "the taught commands are kept";
  {
    const auto [vrc, vout] = run_cli("map validate " + dir_.string());
    EXPECT_EQ(vrc, 0) << vout;
  }

  // Deep winter, the robot turned so the scene is 15 px right: the drive's experience is chosen
  // and the robot steers back.
  robot_.odom_ = Odometry{};
  robot_.publish();
  auto tree = load("<ReplayFeatureEdge scan_deg=\"0\" edge=\"" + id + "\" correction_gain_radps_per_px=\"0.004\"/>");
  EXPECT_EQ(tick(tree, winter_.view(15.f)), NodeStatus::running);
  EXPECT_EQ(telemetry_.statuses.back().status, "steering");
  EXPECT_GT(telemetry_.statuses.back().inliers, 100);
  EXPECT_NEAR(telemetry_.statuses.back().offset_px, 15.0, 0.5);
  EXPECT_NEAR(robot_.command_.angular_radps, -0.004 * 15.0, 0.003);
  EXPECT_NE(logger_.text().find("2 appearance experiences"), std::string::npos) << logger_.text();

  // A drive map without the edge: "not driven", nothing added, exit 1.
  fs::remove_all(drive_dir);
  ASSERT_TRUE(MapStore::create(drive_dir.string(), "empty drive").ok());
  const auto [rc, out] = run_cli("map experiences " + dir_.string() + " --add-from " + drive_dir.string());
  EXPECT_EQ(rc, 1) << out;
  EXPECT_NE(out.find("edge " + id + ": not driven"), std::string::npos) << out;
  fs::remove_all(drive_dir);
}
