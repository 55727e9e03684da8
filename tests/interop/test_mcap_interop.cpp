// visnav's MCAP against the independent @mcap/core implementation (npm): @mcap/core's stream
// and indexed readers read a recorded run written by visnav (CRCs, summary, indexes, zstd
// chunks), and visnav converts a ROS 2 bag written by @mcap/core's writer into a run folder.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "interop_util.hpp"
#include "visnav/mcap.hpp"

namespace fs = std::filesystem;
using namespace visnav;

namespace {

fs::path scratch(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("visnav_interop_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(p);
  return p;
}

long json_int(const std::string& json, const std::string& key) {
  std::smatch m;
  if (!std::regex_search(json, m, std::regex("\"" + key + "\":(-?[0-9]+)"))) return -999;
  return std::stol(m[1].str());
}

class McapInterop : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!interop::have_node()) GTEST_SKIP() << "node/npm not found: the @mcap/core interop test needs Node.js";
    const std::string why = interop::ensure_npm_packages("lz4js");  // installs @mcap/core with it
    ASSERT_TRUE(why.empty()) << why;
  }
  int node(const std::string& mode, const fs::path& file, std::string& out, const std::string& compression = "") {
    return interop::run_shell("cd " + interop::shell_quote(interop::kInteropDir.string()) + " && node mcap_interop.mjs " +
                                  mode + " " + interop::shell_quote(file.string()) + (compression.empty() ? "" : " " + compression),
                              out);
  }
};

TEST_F(McapInterop, McapCoreReadsARecordedRunWrittenByVisnav) {
  const fs::path file = scratch("run.mcap");
  {
    mcap::WriterOptions o;
    o.chunk_size_bytes = 8192;  // several chunks
    auto w = mcap::RunMcapWriter::create(file.string(), true, o);
    ASSERT_TRUE(w.ok()) << w.error().message;
    cv::Mat img(48, 64, CV_8UC1);
    std::vector<std::uint8_t> png;
    for (int i = 0; i < 30; ++i) {
      const double t = 0.1 * i;
      cv::randu(img, 0, 255);
      ASSERT_TRUE(cv::imencode(".png", img, png));
      ASSERT_TRUE((*w)->frame(i, t, static_cast<std::uint64_t>(i), png, "png").ok());
      Odometry od;
      od.timestamp_s = t;
      od.pose = {0.05 * i, 0.0, 0.0};
      od.distance_m = 0.05 * i;
      ASSERT_TRUE((*w)->odometry(od).ok());
      ASSERT_TRUE((*w)->tick(static_cast<std::uint64_t>(i + 1), t, i, {0.5, 0.25}, static_cast<std::uint64_t>(i + 1)).ok());
      ASSERT_TRUE((*w)->truth(t, {0.05 * i, 0.01, 0.0}).ok());
    }
    ASSERT_TRUE((*w)->attach("run.yaml", "format: visnav-recorded-run\n", 3.0).ok());
    ASSERT_TRUE((*w)->close().ok());
  }
  std::string out;
  ASSERT_EQ(node("read", file, out), 0) << out;
  EXPECT_NE(out.find("\"profile\":\"ros2\""), std::string::npos) << out;
  EXPECT_EQ(json_int(out, "messages"), 30 * 8);
  EXPECT_EQ(json_int(out, "indexed_messages"), 30 * 8);
  EXPECT_EQ(json_int(out, "statistics_message_count"), 30 * 8);
  EXPECT_GT(json_int(out, "chunks"), 1);
  EXPECT_NE(out.find("\"indexed_in_time_order\":true"), std::string::npos) << out;
  if (mcap::zstd_available()) {
    EXPECT_NE(out.find("\"chunk_compression\":[\"zstd\"]"), std::string::npos) << out;
  }
  EXPECT_NE(out.find("\"/camera/image_raw/compressed\":{\"count\":30,\"schema\":\"sensor_msgs/msg/CompressedImage\",\"encoding\":\"cdr\"}"),
            std::string::npos) << out;
  EXPECT_NE(out.find("\"/odom\":{\"count\":30,\"schema\":\"nav_msgs/msg/Odometry\""), std::string::npos) << out;
  EXPECT_NE(out.find("\"/cmd_vel\":{\"count\":30,\"schema\":\"geometry_msgs/msg/Twist\""), std::string::npos) << out;
  EXPECT_NE(out.find("\"first_twist\":{\"linear_x\":0.5,\"angular_z\":0.25}"), std::string::npos) << out;
  EXPECT_NE(out.find("\"indexed_attachments\":[\"run.yaml\"]"), std::string::npos) << out;
  fs::remove(file);
}

TEST_F(McapInterop, VisnavReadsARos2BagWrittenByMcapCore) {
  const fs::path file = scratch("ros2.mcap");
  std::string out;
  ASSERT_EQ(node("write", file, out), 0) << out;
  // Straight read: the Twist values as @mcap/core wrote them.
  std::vector<double> turn;
  mcap::ReadHandlers h;
  h.on_message = [&](const mcap::Channel& ch, const mcap::Schema*, const mcap::Message& m) -> Status {
    if (ch.topic != "/cmd_vel") return ok();
    VISNAV_ASSIGN(auto t, ros2::decode_twist(m.data));
    turn.push_back(t.angular.z);
    return ok();
  };
  auto r = mcap::read_file(file.string(), h);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(turn.size(), 20U);
  EXPECT_DOUBLE_EQ(turn[7], 0.07);
  // As a recorded run: frames from the Image topic, odometry with its path length.
  const fs::path dir = scratch("ros2_run");
  mcap::RunTopics topics;
  topics.image = "/camera/image_raw";
  auto conv = mcap::mcap_to_run_folder(file.string(), dir.string(), topics);
  ASSERT_TRUE(conv.ok()) << conv.error().message;
  EXPECT_FALSE(conv->exact);
  EXPECT_EQ(conv->frames, 10);
  EXPECT_EQ(conv->odometry_samples, 20);
  cv::Mat first = cv::imread((dir / "frames" / "000000.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(first.empty());
  EXPECT_EQ(first.cols, 8);
  EXPECT_EQ(first.rows, 6);
  EXPECT_EQ(first.at<std::uint8_t>(0, 1), 5);
  std::ifstream odo(dir / "odometry.csv");
  std::string line, last;
  while (std::getline(odo, line)) last = line;
  std::vector<double> cols;
  std::stringstream row(last);
  for (std::string c; std::getline(row, c, ',');) cols.push_back(std::stod(c));
  ASSERT_EQ(cols.size(), 7U) << last;
  EXPECT_NEAR(cols[0], 101.9, 1e-9);  // log time of the last sample
  EXPECT_NEAR(cols[4], 0.95, 1e-9);   // odometric distance: 19 * 0.05 m
  EXPECT_NEAR(cols[6], 0.19, 1e-12);  // its yaw rate
  // The same through `visnav convert --config C`: the topics come from run.bag_image_topic /
  // run.bag_odom_topic of the robot's config; without them the default topic is not in the bag.
  const fs::path config = scratch("ros2_robot.yaml");
  std::ofstream(config) << "robot:\n  type: sim\ncamera:\n  type: sim\nrun:\n  bag_image_topic: /camera/image_raw\n"
                           "  bag_odom_topic: /odom\n";
  const fs::path by_config = scratch("ros2_run_config");
  std::string cli_out;
  EXPECT_EQ(interop::run_shell(std::string("'") + VISNAV_TEST_CLI + "' convert " + interop::shell_quote(file.string()) + " " +
                                   interop::shell_quote(by_config.string()) + " --config " + interop::shell_quote(config.string()),
                               cli_out),
            0)
      << cli_out;
  EXPECT_NE(cli_out.find("10 frames, 20 odometry samples"), std::string::npos) << cli_out;
  EXPECT_NE(interop::run_shell(std::string("'") + VISNAV_TEST_CLI + "' convert " + interop::shell_quote(file.string()) + " " +
                                   interop::shell_quote(scratch("ros2_run_default").string()),
                               cli_out),
            0);
  EXPECT_NE(cli_out.find("no image messages on topic '/camera/image_raw/compressed'"), std::string::npos) << cli_out;
  fs::remove_all(by_config);
  fs::remove(config);
  // A topic that is not there: the error lists the bag's topics.
  topics.image = "/camera/missing";
  auto missing = mcap::mcap_to_run_folder(file.string(), scratch("ros2_run2").string(), topics);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("/camera/image_raw (sensor_msgs/msg/Image)"), std::string::npos)
      << missing.error().message;
  fs::remove_all(dir);
  fs::remove(file);
}

TEST_F(McapInterop, McapCoreReadsLz4ChunksAndTelemetryWrittenByVisnav) {
  if (!mcap::lz4_available()) GTEST_SKIP() << "built without liblz4 (liblz4-dev)";
  const fs::path file = scratch("lz4.mcap");
  {
    mcap::WriterOptions o;
    o.chunk_size_bytes = 4096;
    o.compression = "lz4";
    auto w = mcap::RunMcapWriter::create(file.string(), false, o);
    ASSERT_TRUE(w.ok()) << w.error().message;
    for (int i = 0; i < 40; ++i) {
      NavStatus s;
      s.edge = "e" + std::to_string(i / 10);
      s.matches = 100 + i;
      s.confidence = 0.5;
      s.status = "steering";
      s.command = {0.3, 0.01 * i};
      ASSERT_TRUE((*w)->telemetry(0.1 * i, s).ok());
      ASSERT_TRUE((*w)->tick(static_cast<std::uint64_t>(i + 1), 0.1 * i, -1, s.command, static_cast<std::uint64_t>(i + 1)).ok());
    }
    ASSERT_TRUE((*w)->close().ok());
  }
  std::string out;
  ASSERT_EQ(node("read", file, out), 0) << out;
  EXPECT_NE(out.find("\"chunk_compression\":[\"lz4\"]"), std::string::npos) << out;
  EXPECT_GT(json_int(out, "chunks"), 1);
  EXPECT_EQ(json_int(out, "indexed_messages"), 40 * 4);
  EXPECT_NE(out.find("\"/visnav/telemetry\":{\"count\":40,\"schema\":\"visnav/msg/Telemetry\",\"encoding\":\"cdr\"}"),
            std::string::npos) << out;
  EXPECT_NE(out.find("\"first_status\":{\"t_s\":0,"), std::string::npos) << out;
  EXPECT_NE(out.find("\"matches\":100,"), std::string::npos) << out;
  EXPECT_NE(out.find("\"confidence\":0.5,"), std::string::npos) << out;
  fs::remove(file);
}

TEST_F(McapInterop, VisnavReadsAnLz4BagWrittenByMcapCore) {
  if (!mcap::lz4_available()) GTEST_SKIP() << "built without liblz4 (liblz4-dev)";
  const fs::path file = scratch("ros2_lz4.mcap");
  std::string out;
  ASSERT_EQ(node("write", file, out, "lz4"), 0) << out;
  std::vector<double> turn;
  long images = 0;
  mcap::ReadHandlers h;
  h.on_message = [&](const mcap::Channel& ch, const mcap::Schema*, const mcap::Message& m) -> Status {
    if (ch.topic == "/camera/image_raw") ++images;
    if (ch.topic != "/cmd_vel") return ok();
    VISNAV_ASSIGN(auto t, ros2::decode_twist(m.data));
    turn.push_back(t.angular.z);
    return ok();
  };
  auto r = mcap::read_file(file.string(), h);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_FALSE(r->truncated);
  ASSERT_EQ(turn.size(), 20U);
  EXPECT_DOUBLE_EQ(turn[13], 0.13);
  EXPECT_EQ(images, 10);
  fs::remove(file);
}

}  // namespace
