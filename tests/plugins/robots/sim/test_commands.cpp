// `visnav sim ...` commands called directly.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "visnav_sim/commands.hpp"

namespace vs = visnav::sim;
namespace fs = std::filesystem;

namespace {
int run(const std::vector<std::string>& args, std::string* out_text = nullptr, std::string* err_text = nullptr) {
  std::ostringstream out, err;
  const int rc = vs::sim_main(args, out, err);
  if (out_text) *out_text = out.str();
  if (err_text) *err_text = err.str();
  return rc;
}
fs::path tmp(const std::string& name) {
  fs::path dir = fs::temp_directory_path() / ("visnav_sim_cmd_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir / name;
}
}  // namespace

TEST(SimCommands, HelpForEverySubcommand) {
  for (const char* c : {"snapshot", "topview", "drive", "teleop", "generate"}) {
    std::string out;
    EXPECT_EQ(run({c, "--help"}, &out), 0) << c;
    EXPECT_NE(out.find("usage: visnav sim"), std::string::npos) << c;
  }
  EXPECT_EQ(run({"--help"}), 0);
  EXPECT_EQ(run({"fly"}), 2);
  EXPECT_EQ(run({"snapshot", "--world", "campus", "--bogus", "1"}), 2);
}

TEST(SimCommands, SnapshotWritesImageAndLabels) {
  const auto png = tmp("view.png"), labels = tmp("labels.png"), ids = tmp("ids.png");
  std::string err;
  ASSERT_EQ(run({"snapshot", "--world", "straight6m", "--pose", "0,0,0", "-o", png.string(), "--width", "160", "--height",
                 "120", "--labels", labels.string(), "--label-ids", ids.string()},
                nullptr, &err),
            0)
      << err;
  const cv::Mat img = cv::imread(png.string());
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 160);
  EXPECT_EQ(img.rows, 120);
  EXPECT_FALSE(cv::imread(labels.string()).empty());
  const cv::Mat raw = cv::imread(ids.string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(raw.type(), CV_8UC1);
  EXPECT_EQ(raw.at<std::uint8_t>(119, 80), 1);  // path (LabelClass::path) under the robot
  EXPECT_EQ(run({"snapshot", "--world", "straight6m", "--pose", "0,0", "-o", png.string()}, nullptr, &err), 1);
  EXPECT_NE(err.find("--pose"), std::string::npos) << err;
}

TEST(SimCommands, TopviewAndDrive) {
  const auto top = tmp("top.png"), csv = tmp("traj.csv");
  std::string err;
  ASSERT_EQ(run({"topview", "--route", "lemniscate", "-o", top.string(), "--px-per-m", "20"}, nullptr, &err), 0) << err;
  EXPECT_FALSE(cv::imread(top.string()).empty());
  ASSERT_EQ(run({"drive", "--route", "straight6m", "-o", csv.string(), "--robot-param", "odom_scale_error_pct=1"}, nullptr, &err), 0)
      << err;
  std::ifstream f(csv);
  std::string header, line, last;
  std::getline(f, header);
  EXPECT_EQ(header.rfind("time_s,gt_x_m,gt_y_m,gt_heading_rad,odom_x_m", 0), 0u) << header;
  int rows = 0;
  while (std::getline(f, line)) { last = line; ++rows; }
  EXPECT_GT(rows, 100);
  EXPECT_EQ(run({"drive", "--route", "straight6m", "-o", csv.string(), "--robot-param", "odom_scale_error_pct=99"}, nullptr, &err), 1);
  EXPECT_NE(err.find("odom_scale_error_pct"), std::string::npos) << err;
}

TEST(SimCommands, TeleopKeys) {
  vs::TeleopState s;
  vs::apply_teleop_key(s, "\x1b[A");
  vs::apply_teleop_key(s, "w");
  vs::apply_teleop_key(s, "a");
  EXPECT_DOUBLE_EQ(s.command.linear_mps, 0.2);
  EXPECT_DOUBLE_EQ(s.command.angular_radps, 0.1);
  vs::apply_teleop_key(s, "\x1b[C");
  vs::apply_teleop_key(s, "\x1b[C");
  EXPECT_DOUBLE_EQ(s.command.angular_radps, -0.1);
  vs::apply_teleop_key(s, " ");
  EXPECT_EQ(s.command.linear_mps, 0.0);
  EXPECT_FALSE(s.quit);
  vs::apply_teleop_key(s, "q");
  EXPECT_TRUE(s.quit);
}
