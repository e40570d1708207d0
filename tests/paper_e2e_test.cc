// End to end: `make paper` (pipelines/paper.mk) on a small data root: one
// rendered room standing in for a real sequence, one synthetic sequence of
// the pipeline's own, small vocabularies (k = 6, L = 3), the committed tiny
// DBoW2 vocabularies of the fuzz corpus for the load table, one start-up per
// vocabulary form. Checks every table, figure and the report, and that a
// second run does no work.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "common/atomic_file.h"
#include "common/testing.h"
#include "common/text.h"

namespace rrslam {
namespace {

namespace fs = std::filesystem;

using testing::Quote;
using testing::SourceDir;

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

class PaperPipelineTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(data());
    const auto r = testing::RunTool("synth", "--quiet --out " + Quote(data() / "room") +
                                                 " --trajectory loop --frames 90 --seed 3");
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  fs::path data() const { return dir_.path() / "data"; }
  fs::path root() const { return dir_.path() / "paper"; }
  // A made-up "seed paper" figure, to check the report prints it beside ours.
  fs::path reference() const { return dir_.path() / "reference.csv"; }

  // `make paper` with the test's executables (no build step); the outer
  // make's job server is not inherited (MAKEFLAGS unset).
  testing::CommandResult MakePaper() const {
    return testing::RunCommand(
        "env -u MAKEFLAGS -u MFLAGS -u MAKELEVEL make --no-print-directory -C " +
        Quote(SourceDir()) + " paper PAPER_DATA=" + Quote(data()) + " PAPER_ROOT=" + Quote(root()) +
        " BIN=" + Quote(fs::absolute(testing::BinDir())) +
        " SKIP_BUILD=1 PAPER_SYNTH=sweep PAPER_SYNTH_FRAMES=60 VOCAB_K=6 VOCAB_L=3"
        " PAPER_STARTUP_RUNS=1 PAPER_ORBVOC=0 PAPER_VOCABS=" +
        Quote(SourceDir() / "stages" / "vocab" / "fuzz" / "corpus") +
        " PAPER_REFERENCE=" + Quote(reference()));
  }

  testing::TempDir dir_;
};

TEST_F(PaperPipelineTest, MakesEveryTableAndFigureAndRerunsNothing) {
  ASSERT_TRUE(fs::exists(SourceDir() / "pipelines" / "paper.mk")) << SourceDir();
  testing::WriteTextFile(reference(), "sequence,variant,ate_rmse_cm\nroom,own,9.87\n");
  const auto first = MakePaper();
  ASSERT_EQ(first.exit_code, 0) << first.output;

  // Table 3/4: every variant's cells; the transfer vocabulary is room's.
  for (const char* run : {"runs/own/room", "runs/own/synth-sweep", "runs/general/room",
                          "runs/general/synth-sweep", "runs/transfer/synth-sweep"}) {
    EXPECT_TRUE(fs::exists(root() / run / "ate.json")) << run;
  }
  EXPECT_FALSE(fs::exists(root() / "runs/transfer/room"));
  const std::string table = ReadFileToString(root() / "ate-table.csv");
  for (const char* cell : {"room,own", "room,general", "synth-sweep,transfer"}) {
    EXPECT_TRUE(Contains(table, cell)) << cell << "\n" << table;
  }
  EXPECT_TRUE(fs::exists(root() / "ate-bars.png"));
  EXPECT_TRUE(fs::exists(root() / "figures/room/trajectory_top.png"));
  EXPECT_TRUE(fs::exists(root() / "figures/synth-sweep/trajectory_top.png"));

  // Table 1/2: each corpus vocabulary, text and binary.
  const std::string load = ReadFileToString(root() / "vocab-load.csv");
  EXPECT_TRUE(Contains(load, "k3_l2,")) << load;
  EXPECT_TRUE(Contains(load, ",binary,")) << load;

  // Start-up on a saved map, for the data root's sequence only.
  const std::string startup = ReadFileToString(root() / "startup/room.csv");
  EXPECT_TRUE(Contains(startup, "room,binary,1,")) << startup;
  EXPECT_TRUE(Contains(startup, "room,text,1,")) << startup;
  EXPECT_FALSE(fs::exists(root() / "startup/synth-sweep.csv"));

  const std::string report = ReadFileToString(root() / "report.md");
  for (const char* part :
       {"## Table 1/2", "## Table 3/4", "## Start-up", "145.3", "room", "synth-sweep",
        "ate-bars.png", "figures/room/trajectory_top.png", "| room | own | 9.87 | "}) {
    EXPECT_TRUE(Contains(report, part)) << part;
  }
  EXPECT_FALSE(Contains(report, "| room | own | 9.87 | not run |")) << report;

  // Nothing changed: nothing runs, nothing is rewritten.
  const auto report_time = fs::last_write_time(root() / "report.md");
  const auto again = MakePaper();
  ASSERT_EQ(again.exit_code, 0) << again.output;
  for (const char* tool : {"rrslam-track", "rrslam-extract", "rrslam-cluster", "rrslam-eval",
                           "rrslam-render", "startup.sh", "vocab_load.sh"}) {
    EXPECT_FALSE(Contains(again.output, tool)) << tool << "\n" << again.output;
  }
  EXPECT_EQ(fs::last_write_time(root() / "report.md"), report_time);
}

}  // namespace
}  // namespace rrslam
