// `visnav record` from the simulator and `visnav play` of the recording: the played-back mission
// makes the live run's decisions, tick for tick (commands and telemetry byte-identical); a changed
// frame changes them (the comparison can fail); a killed recording keeps what it wrote.
#include <gtest/gtest.h>

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <chrono>
#include <regex>
#include <set>
#include <sstream>
#include <thread>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "recorded_test_support.hpp"
#include "visnav/recorded/run_format.hpp"

extern char** environ;

using namespace visnav::testing;

namespace {

struct Recorded {
  SimSetup setup;
  std::string run;
  int record_exit = -1;
  std::string record_log;
};

/// One live recording shared by the tests of this file (per process).
const Recorded& recorded() {
  static const Recorded r = [] {
    Recorded x;
    // ctest runs each case in its own process (in parallel): one folder per recording process.
    x.setup = make_setup(std::string("record_play_") + ::testing::UnitTest::GetInstance()->current_test_info()->name(), 2.0);
    x.run = x.setup.dir + "/run";
    x.record_log = x.setup.dir + "/record.log";
    x.record_exit = shell("'" + x.setup.cli + "' record --config " + x.setup.config + " -o " + x.run + " --tree " + x.setup.tree +
                              " --set run.telemetry_file=" + x.setup.dir + "/live.jsonl",
                          x.record_log);
    return x;
  }();
  return r;
}

}  // namespace

TEST(RecordPlay, RecordingWritesTheRunFolder) {
  const Recorded& r = recorded();
  ASSERT_EQ(r.record_exit, 0) << slurp(r.record_log);
  const auto frames = lines_of(r.run + "/frames.csv");
  const auto commands = lines_of(r.run + "/commands.csv");
  const auto odometry = lines_of(r.run + "/odometry.csv");
  ASSERT_GT(frames.size(), 30u);                     // ~4 s at 10 Hz
  EXPECT_EQ(commands.size(), frames.size());         // one frame per tick (sim camera, lock-step)
  EXPECT_GE(odometry.size(), frames.size());
  EXPECT_TRUE(fs::exists(r.run + "/ground_truth.csv"));
  EXPECT_TRUE(fs::exists(r.run + "/config.yaml"));
  const std::string info = slurp(r.run + "/run.yaml");
  EXPECT_NE(info.find("complete: true"), std::string::npos) << info;
  EXPECT_NE(info.find("outcome: \"success\""), std::string::npos) << info;
  // the commands really depend on the images: the steering varies from tick to tick
  std::set<std::string> omegas;
  for (std::size_t i = 1; i < commands.size(); ++i) {
    std::stringstream row(commands[i]);
    std::string field;
    for (int k = 0; k < 5 && std::getline(row, field, ','); ++k) {}
    omegas.insert(field);  // angular_radps
  }
  EXPECT_GT(omegas.size(), commands.size() / 2);
  // Every NavStatus of the mission is in telemetry.jsonl, as run.telemetry_file saw it.
  const auto live = lines_of(r.setup.dir + "/live.jsonl");
  const auto recorded_tm = lines_of(r.run + "/telemetry.jsonl");
  ASSERT_GT(live.size(), 30u);
  ASSERT_EQ(recorded_tm.size(), live.size());
  auto field = [](const std::string& line, const std::string& key) {
    std::smatch m;
    return std::regex_search(line, m, std::regex("\"" + key + "\":(\"[^\"]*\"|[-0-9.e]+)")) ? m[1].str() : std::string("?");
  };
  for (std::size_t i = 0; i < live.size(); ++i) {
    EXPECT_EQ(field(recorded_tm[i], "edge"), field(live[i], "edge")) << i;
    EXPECT_EQ(field(recorded_tm[i], "matches"), field(live[i], "matches")) << i;
    EXPECT_EQ(field(recorded_tm[i], "status"), field(live[i], "status")) << i;
  }
}

TEST(RecordPlay, PlaybackMakesTheSameDecisionsTickForTick) {
  const Recorded& r = recorded();
  ASSERT_EQ(r.record_exit, 0) << slurp(r.record_log);
  const std::string out = r.setup.dir + "/play_commands.csv";
  const std::string log = r.setup.dir + "/play.log";
  const int rc = shell("'" + r.setup.cli + "' play " + r.run + " --tree " + r.setup.tree + " --commands-out " + out +
                           " --set run.telemetry_file=" + r.setup.dir + "/play.jsonl",
                       log);
  const std::string text = slurp(log);
  ASSERT_EQ(rc, 0) << text;
  const auto live = lines_of(r.run + "/commands.csv");
  const auto played = lines_of(out);
  ASSERT_EQ(played.size(), live.size()) << text;
  for (std::size_t i = 0; i < live.size(); ++i) EXPECT_EQ(played[i], live[i]) << "tick " << i;
  const std::string n = std::to_string(live.size() - 1);
  EXPECT_NE(text.find("decisions: " + n + " of " + n + " ticks identical"), std::string::npos) << text;
  // telemetry (per-tick NavStatus with the node's offset and command) is identical too
  const std::string live_tm = slurp(r.setup.dir + "/live.jsonl");
  EXPECT_GT(live_tm.size(), 100u);
  EXPECT_EQ(slurp(r.setup.dir + "/play.jsonl"), live_tm);
}

TEST(RecordPlay, AChangedFrameChangesTheDecisions) {
  const Recorded& r = recorded();
  ASSERT_EQ(r.record_exit, 0) << slurp(r.record_log);
  const std::string copy = r.setup.dir + "/run_changed";
  fs::remove_all(copy);
  fs::copy(r.run, copy, fs::copy_options::recursive);
  const std::string frame = copy + "/frames/000010.png";
  cv::Mat img = cv::imread(frame, cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(img.empty());
  cv::rectangle(img, cv::Rect(0, 0, img.cols / 3, img.rows), cv::Scalar::all(255), cv::FILLED);
  ASSERT_TRUE(cv::imwrite(frame, img));
  const std::string log = r.setup.dir + "/play_changed.log";
  const int rc = shell("'" + r.setup.cli + "' play " + copy + " --tree " + r.setup.tree, log);
  const std::string text = slurp(log);
  EXPECT_EQ(rc, 4) << text;
  EXPECT_NE(text.find("first difference at tick 11"), std::string::npos) << text;
}

TEST(RecordPlay, AKilledRecordingKeepsEverythingWrittenAndPlaysBack) {
  const SimSetup s = make_setup("record_killed", 1000.0);
  const std::string run = s.dir + "/run";
  const std::string log = s.dir + "/record.log";
  const std::string cmd = "exec '" + s.cli + "' record --config " + s.config + " -o " + run + " --tree " + s.tree + " > " + log + " 2>&1";
  pid_t pid = 0;
  const char* argv[] = {"/bin/sh", "-c", cmd.c_str(), nullptr};
  ASSERT_EQ(posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ), 0);
  const auto start = std::chrono::steady_clock::now();
  while (lines_of(run + "/frames.csv").size() < 17 && std::chrono::steady_clock::now() - start < std::chrono::seconds(60))
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_EQ(::kill(pid, SIGKILL), 0);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << slurp(log);

  auto frames = visnav::recorded::read_run_frames(run);  // every listed image exists
  ASSERT_TRUE(frames.ok()) << frames.error().message;
  ASSERT_GE(frames->frames.size(), 15u);  // 16 rows seen, the last one possibly cut by the kill
  for (const auto& f : frames->frames) EXPECT_FALSE(cv::imread(f.path, cv::IMREAD_UNCHANGED).empty()) << f.path;
  EXPECT_NE(slurp(run + "/run.yaml").find("complete: false"), std::string::npos);

  const std::string play_log = s.dir + "/play.log";
  const int rc = shell("'" + s.cli + "' play " + run + " --tree " + s.tree, play_log);
  const std::string text = slurp(play_log);
  EXPECT_EQ(rc, 0) << text;  // ends with the recording, every recorded decision reproduced
  EXPECT_NE(text.find("end of the recorded run"), std::string::npos) << text;
  EXPECT_NE(text.find("ticks identical to the recording"), std::string::npos) << text;
  EXPECT_EQ(text.find("first difference"), std::string::npos) << text;
}

TEST(RecordPlay, BadInvocationsAreClearErrors) {
  const SimSetup s = make_setup("record_bad", 1.0);
  const std::string log = s.dir + "/bad.log";
  EXPECT_EQ(shell("'" + s.cli + "' play " + s.dir + "/no_run --tree " + s.tree, log), 1);
  EXPECT_NE(slurp(log).find("no_run: not a recorded-run folder"), std::string::npos) << slurp(log);
  EXPECT_EQ(shell("'" + s.cli + "' record --config " + s.config, log), 2);
  EXPECT_NE(slurp(log).find("-o RUN"), std::string::npos) << slurp(log);
  fs::create_directories(s.dir + "/full");
  put(s.dir + "/full/x", "x");
  EXPECT_EQ(shell("'" + s.cli + "' record --config " + s.config + " -o " + s.dir + "/full --duration-s 0.5", log), 1);
  EXPECT_NE(slurp(log).find("not empty"), std::string::npos) << slurp(log);
}

TEST(RecordPlay, RecordingWithoutATreeStopsAfterTheDuration) {
  const SimSetup s = make_setup("record_notree", 1.0);
  const std::string run = s.dir + "/run";
  const std::string log = s.dir + "/record.log";
  ASSERT_EQ(shell("'" + s.cli + "' record --config " + s.config + " -o " + run + " --duration-s 1.0", log), 0) << slurp(log);
  const auto frames = lines_of(run + "/frames.csv");
  EXPECT_GE(frames.size(), 9u);
  EXPECT_LE(frames.size(), 12u);
  EXPECT_EQ(lines_of(run + "/commands.csv").size(), 1u);  // header only: no mission, no decisions
}
