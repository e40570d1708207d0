#include "common/cli.h"

#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <system_error>

#include "common/errors.h"

namespace rrslam {
namespace {

int RunWithArgs(std::vector<std::string> args, const std::function<void()>& body,
                int* value = nullptr) {
  std::vector<char*> argv;
  args.insert(args.begin(), "rrslam-test");
  for (std::string& a : args) argv.push_back(a.data());
  int local = 0;
  int* bound = value != nullptr ? value : &local;
  return RunTool(
      static_cast<int>(argv.size()), argv.data(), {"test", "A test tool."},
      [&](CLI::App& app) {
        app.add_option("--value", *bound, "A value")->check(CLI::Range(0, 10));
      },
      body);
}

TEST(RunTool, MapsErrorsToExitCodes) {
  EXPECT_EQ(RunWithArgs({}, [] {}), 0);
  EXPECT_EQ(RunWithArgs({}, [] { throw UsageError("u"); }), 64);
  EXPECT_EQ(RunWithArgs({}, [] { throw DataError("d"); }), 65);
  EXPECT_EQ(RunWithArgs({}, [] { throw NoInputError("n"); }), 66);
  EXPECT_EQ(RunWithArgs({}, [] { throw std::logic_error("bug"); }), 70);
  EXPECT_EQ(RunWithArgs({}, [] { throw CantCreateError("c"); }), 73);
  EXPECT_EQ(RunWithArgs({}, [] { throw AlgorithmError("a"); }), 75);
  // A thread the system refuses (std::thread's EAGAIN) is a lack of
  // resources, not an internal error.
  EXPECT_EQ(RunWithArgs({},
                        [] {
                          throw std::system_error(
                              std::make_error_code(std::errc::resource_unavailable_try_again));
                        }),
            75);
}

TEST(RunTool, BadFlagsAreUsageErrors) {
  bool ran = false;
  EXPECT_EQ(RunWithArgs({"--no-such-flag"}, [&] { ran = true; }), 64);
  EXPECT_EQ(RunWithArgs({"--value", "11"}, [&] { ran = true; }), 64);
  EXPECT_FALSE(ran);
  int value = 0;
  EXPECT_EQ(RunWithArgs(
                {"--value", "7", "--quiet"}, [] {}, &value),
            0);
  EXPECT_EQ(value, 7);
}

TEST(RunTool, HelpAndVersionExitZeroWithoutRunning) {
  bool ran = false;
  ::testing::internal::CaptureStdout();
  EXPECT_EQ(RunWithArgs({"--help"}, [&] { ran = true; }), 0);
  const std::string help = ::testing::internal::GetCapturedStdout();
  EXPECT_NE(help.find("Exit codes"), std::string::npos);
  EXPECT_NE(help.find("--quiet"), std::string::npos);
  ::testing::internal::CaptureStdout();
  EXPECT_EQ(RunWithArgs({"--version"}, [&] { ran = true; }), 0);
  EXPECT_NE(::testing::internal::GetCapturedStdout().find("rrslam-test"), std::string::npos);
  EXPECT_FALSE(ran);
}

TEST(Producer, NamesToolAndVersion) {
  EXPECT_EQ(Producer("extract").rfind("rrslam-extract ", 0), 0u);
}

}  // namespace
}  // namespace rrslam
