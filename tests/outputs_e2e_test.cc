// No run destroys what it reads (issue 16's data-loss cases): every tool
// refuses an output that is, contains or lies inside one of its inputs with
// exit 64 and one line naming both, before reading anything, and the input is
// left exactly as it was. The inputs need not be valid: the rule is checked
// first (common/output_path.h).
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "common/atomic_file.h"
#include "common/testing.h"
#include "common/text.h"

namespace rrslam {
namespace {

namespace fs = std::filesystem;
using testing::RunTool;

using testing::Quote;

class OutputsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(seq() / "rgb");
    for (const char* name : {"settings.yaml", "rgb.txt", "depth.txt", "groundtruth.txt"}) {
      testing::WriteTextFile(seq() / name, std::string("content of ") + name + "\n");
    }
    testing::WriteTextFile(seq() / "rgb" / "1.png", "image");
    testing::WriteTextFile(dir_ / "f.h5", "features");
    testing::WriteTextFile(dir_ / "tree.h5", "tree");
    testing::WriteTextFile(dir_ / "voc.rrv", "vocabulary");
    fs::create_directories(dir_ / "run");
    testing::WriteTextFile(dir_ / "run" / "ate.json", "{}");
  }

  fs::path seq() const { return dir_ / "seq"; }

  // Runs a tool that must refuse: exit 64, a line naming `input`, every
  // fixture file unchanged.
  void ExpectRefused(const std::string& stage, const std::string& args, const fs::path& input) {
    const auto r = RunTool(stage, args);
    EXPECT_EQ(r.exit_code, 64) << stage << " " << args << "\n" << r.output;
    EXPECT_NE(r.output.find(input.string()), std::string::npos) << r.output;
    for (const char* name : {"settings.yaml", "rgb.txt", "depth.txt", "groundtruth.txt"}) {
      EXPECT_EQ(ReadFileToString(seq() / name), std::string("content of ") + name + "\n") << name;
    }
    EXPECT_TRUE(fs::exists(seq() / "rgb" / "1.png"));
    EXPECT_EQ(ReadFileToString(dir_ / "f.h5"), "features");
    EXPECT_EQ(ReadFileToString(dir_ / "voc.rrv"), "vocabulary");
    EXPECT_EQ(ReadFileToString(dir_ / "run" / "ate.json"), "{}");
  }

  testing::TempDir dir_;
};

TEST_F(OutputsTest, TrackNeverReplacesTheSequenceFolder) {
  const std::string common = "--sequence " + Quote(seq()) + " --settings " +
                             Quote(seq() / "settings.yaml") + " --vocab " + Quote(dir_ / "voc.rrv");
  ExpectRefused("track", common + " --out " + Quote(seq()), seq());
  ExpectRefused("track", common + " --out " + Quote(dir_.path()), seq());  // A parent of it.
  ExpectRefused("track", common + " --out " + Quote(seq() / ".." / "seq"), seq());
  ExpectRefused("track",
                common + " --out " + Quote(dir_ / "t") + " --save-map " + Quote(dir_ / "voc.rrv"),
                dir_ / "voc.rrv");
  ExpectRefused(
      "track",
      common + " --out " + Quote(dir_ / "t") + " --save-map " + Quote(dir_ / "t" / "m.rrm"),
      dir_ / "t");
}

TEST_F(OutputsTest, StagesNeverOverwriteTheirInputs) {
  ExpectRefused("cluster", "--features " + Quote(dir_ / "f.h5") + " --out " + Quote(dir_ / "f.h5"),
                dir_ / "f.h5");
  const std::string extract =
      "--sequence " + Quote(seq()) + " --settings " + Quote(seq() / "settings.yaml") + " --out ";
  ExpectRefused("extract", extract + Quote(seq() / "settings.yaml"), seq() / "settings.yaml");
  ExpectRefused("extract", extract + Quote(seq() / "rgb.txt"), seq());
  ExpectRefused("vocab",
                "query --vocab " + Quote(dir_ / "voc.rrv") + " --features " + Quote(dir_ / "f.h5") +
                    " --frame 0 --out " + Quote(dir_ / "f.h5"),
                dir_ / "f.h5");
  ExpectRefused("vocab",
                "build --tree " + Quote(dir_ / "tree.h5") + " --out " + Quote(dir_ / "voc.rrv") +
                    " --features " + Quote(dir_ / "f.h5") + " " + Quote(dir_ / "voc.rrv"),
                dir_ / "voc.rrv");
  ExpectRefused("eval",
                "summary " + Quote(dir_ / "run") + " --out " + Quote(dir_ / "run" / "ate.json"),
                dir_ / "run");
  ExpectRefused("eval",
                "ate --gt " + Quote(seq() / "groundtruth.txt") + " --est " + Quote(dir_ / "f.h5") +
                    " --out " + Quote(seq() / "groundtruth.txt"),
                seq() / "groundtruth.txt");
}

TEST_F(OutputsTest, ALostStdoutIsAnErrorAndCommonFlagsFollowSubcommands) {
  const std::string trajectory =
      "1.0 0 0 0 0 0 0 1\n2.0 1 0 0 0 0 0 1\n3.0 1 1 0 0 0 0 1\n4.0 0 1 0 0 0 0 1\n";
  testing::WriteTextFile(dir_ / "gt.txt", trajectory);
  testing::WriteTextFile(dir_ / "est.txt", trajectory);
  const std::string ate =
      "ate --gt " + Quote(dir_ / "gt.txt") + " --est " + Quote(dir_ / "est.txt");
  auto r = RunTool("eval", ate + " --quiet");  // --quiet after the subcommand.
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("absolute_translational_error.rmse"), std::string::npos) << r.output;
  // In a subshell, so that its stderr goes to the file, not to /dev/full.
  const std::string eval = Quote(testing::BinDir() / "rrslam-eval");
  r = testing::RunCommand("(" + eval + " " + ate + " -v 2> " + Quote(dir_ / "stderr.txt") +
                          " > /dev/full)");
  EXPECT_EQ(r.exit_code, 73) << r.output;
  EXPECT_NE(ReadFileToString(dir_ / "stderr.txt").find("cannot write to standard output"),
            std::string::npos);
}

// Issue 36: --help and --version whose text is lost exit 73 as any other
// stdout write; an unsigned option refuses a minus sign instead of wrapping.
TEST_F(OutputsTest, HelpIntoAFullDiskFailsAndUnsignedOptionsRefuseMinus) {
  for (const char* stage :
       {"extract", "cluster", "vocab", "track", "mapstore", "render", "eval", "synth"}) {
    for (const char* flag : {"--help", "--version"}) {
      const std::string tool = Quote(testing::BinDir() / (std::string("rrslam-") + stage));
      const auto r = testing::RunCommand("(" + tool + " " + flag + " 2> " +
                                         Quote(dir_ / "stderr.txt") + " > /dev/full)");
      EXPECT_EQ(r.exit_code, 73) << stage << " " << flag;
      EXPECT_NE(ReadFileToString(dir_ / "stderr.txt").find("cannot write to standard output"),
                std::string::npos)
          << stage << " " << flag;
    }
  }
  auto r = RunTool("synth", "--seed -1 --out " + Quote(dir_ / "s"));
  EXPECT_EQ(r.exit_code, 64) << r.output;
  EXPECT_NE(r.output.find("--seed: must not be negative"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir_ / "s"));
  r = RunTool("cluster", "--features " + Quote(dir_ / "f.h5") + " --out " + Quote(dir_ / "t.h5") +
                             " --max-descriptors -5");
  EXPECT_EQ(r.exit_code, 64) << r.output;
  EXPECT_NE(r.output.find("must not be negative"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace rrslam
