// The SDK's command-line helpers (visnav/command_line.hpp) that plugin commands share.
#include <gtest/gtest.h>

#include <iostream>
#include <memory>
#include <stdexcept>
#include <sstream>
#include <string>
#include <vector>

#include "visnav/command_line.hpp"
#include "visnav/plugin.hpp"

namespace cli = visnav::cli;
using visnav::ErrorCode;

TEST(CommandLine, NumbersAreWholeFiniteAndInRangeWithErrorsNamingTheOption) {
  EXPECT_DOUBLE_EQ(*cli::parse_number("2.5", 0, 10, "--x"), 2.5);
  const auto junk = cli::parse_number("2.5m", 0, 10, "--x");
  ASSERT_FALSE(junk.ok());
  EXPECT_EQ(junk.error().code, ErrorCode::invalid_value);
  EXPECT_EQ(junk.error().message, "--x: '2.5m' is not a number in [0, 10]");  // content: the usage line printed
  const auto far = cli::parse_number("11", 0, 10, "--x");
  ASSERT_FALSE(far.ok());
  EXPECT_EQ(far.error().code, ErrorCode::out_of_range);
  EXPECT_FALSE(cli::parse_number("nan", 0, 10, "--x").ok());
  EXPECT_FALSE(cli::parse_number("", 0, 10, "--x").ok());
}

TEST(CommandLine, OptionReaderWalksOptionsAndNamesTheOneWithoutAValue) {
  std::vector<std::string> words = {"cmd", "--seeds", "5", "--out", "dir", "--rate"};
  std::vector<char*> argv;
  for (auto& w : words) argv.push_back(w.data());
  cli::OptionReader r(static_cast<int>(argv.size()), argv.data());
  ASSERT_TRUE(r.next());
  EXPECT_EQ(r.arg(), "--seeds");
  EXPECT_DOUBLE_EQ(*r.number(1, 100), 5.0);
  ASSERT_TRUE(r.next());
  EXPECT_EQ(*r.value(), "dir");
  ASSERT_TRUE(r.next());
  const auto missing = r.number(1, 100);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::missing);
  EXPECT_EQ(missing.error().message, "--rate needs a value");  // content: the usage line printed
  EXPECT_FALSE(r.next());
}

TEST(CommandLine, ProgressInALogWritesALinePerTenthAndRestartsPerPhase) {
  // ctest's stderr is not a terminal: the log mode is what CI sees.
  std::ostringstream captured;
  std::streambuf* old = std::cerr.rdbuf(captured.rdbuf());
  {
    cli::ProgressLine progress(8);
    for (int i = 0; i <= 1000; ++i) progress.show("loops", i, 1000, "scenarios");
    progress.show("replay", 1, 4, "loops");
    progress.show("drive", 0.918005, 9.18, "km");
    progress.end();
  }
  std::cerr.rdbuf(old);
  std::vector<std::string> lines;
  std::istringstream in(captured.str());
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  ASSERT_EQ(lines.size(), 13u) << captured.str();  // 0 %, 10 %, ..., 100 % and the next phases
  EXPECT_EQ(lines[0].rfind("  loops    [..............................]   0 % 0/1000 scenarios", 0), 0u) << lines[0];
  EXPECT_NE(lines[10].find("[##############################] 100 % 1000/1000 scenarios"), std::string::npos) << lines[10];
  EXPECT_EQ(lines[11].rfind("  replay   [#######.......................]  25 % 1/4 loops", 0), 0u) << lines[11];
  EXPECT_NE(lines[12].find("]  10 % 0.92/9.18 km"), std::string::npos) << lines[12];
}

namespace {

class RecordingHost final : public visnav::HostServices {
 public:
  struct Log final : visnav::Logger {
    void log(visnav::LogLevel, std::string_view component, std::string_view message) override {
      lines.push_back(std::string(component) + ": " + std::string(message));
    }
    std::vector<std::string> lines;
  } log;
  visnav::Logger& logger() override { return log; }
  const visnav::Clock& clock() override { return clock_; }
  visnav::Result<std::unique_ptr<visnav::Detector>> create_detector(std::string_view, const visnav::ConfigNode&) override {
    return visnav::fail("none");
  }

 private:
  struct Zero final : visnav::Clock {
    [[nodiscard]] double now_s() const override { return 0.0; }
  } clock_;
};

int throws(int, char**, visnav::HostServices&) { throw std::runtime_error("disk on fire"); }
int returns_three(int, char**, visnav::HostServices&) { return 3; }

}  // namespace

TEST(CommandLine, AGuardedCommandKeepsExceptionsOnThePluginsSide) {
  RecordingHost host;
  std::string name = "align";
  char* argv[] = {name.data(), nullptr};
  EXPECT_EQ(visnav::guarded_command<&returns_three>(1, argv, host), 3);
  EXPECT_EQ(visnav::guarded_command<&throws>(1, argv, host), 1);
  ASSERT_EQ(host.log.lines.size(), 1u);
  EXPECT_EQ(host.log.lines[0], "align: unexpected exception: disk on fire");
}
