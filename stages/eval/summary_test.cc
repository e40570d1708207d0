#include "stages/eval/summary.h"

#include <gtest/gtest.h>

#include <sstream>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/testing.h"

namespace rrslam {
namespace {
namespace fs = std::filesystem;

void MakeRun(const fs::path& dir, const std::string& ate, const std::string& run) {
  fs::create_directories(dir / "track");
  if (!ate.empty()) testing::WriteTextFile(dir / "ate.json", ate);
  if (!run.empty()) testing::WriteTextFile(dir / "track" / "run.json", run);
}

const char* kAte =
    R"({"pairs": 998, "ate_m": {"rmse": 0.0412, "mean": 0.0371, "median": 0.03, "std": 0.01,
        "min": 0.001, "max": 0.0934}})";
const char* kRun =
    R"({"counts": {"frames": 1000, "tracked": 998, "lost": 2, "keyframes": 61},
        "timings": {"tracking": {"median_ms": 11.26}}})";

TEST(Summary, TabulatesRunsInCentimetres) {
  testing::TempDir dir;
  MakeRun(dir / "kitchen", kAte, kRun);
  MakeRun(dir / "room", R"({"pairs": 10, "ate_m": {"rmse": 0.02, "mean": 0.01, "max": 0.05}})", "");
  MakeRun(dir / "broken", "", kRun);
  testing::WriteTextFile(dir / "broken" / "error.txt", "tracking lost on every frame\nmore\n");
  std::vector<RunSummary> runs = {ReadRunSummary(dir / "kitchen"), ReadRunSummary(dir / "room"),
                                  ReadRunSummary(dir / "broken")};
  EXPECT_EQ(*runs[0].tracked, 998);
  EXPECT_DOUBLE_EQ(*runs[0].tracking_median_ms, 11.26);
  EXPECT_FALSE(runs[1].frames.has_value());
  EXPECT_FALSE(runs[2].evaluated);
  const std::string table = FormatSummaryTable(runs);
  EXPECT_NE(table.find("| kitchen | 1000 | 998 | 2 | 61 | 4.12 | 3.71 | 9.34 | 11.3 |"),
            std::string::npos)
      << table;
  EXPECT_NE(table.find("| room | - | - | - | - | 2.00 | 1.00 | 5.00 | - |"), std::string::npos)
      << table;
  EXPECT_NE(table.find("failed: tracking lost on every frame"), std::string::npos) << table;
  EXPECT_NE(table.find("| mean of 2 evaluated | | | | | 3.06 |"), std::string::npos) << table;
  const auto json = SummaryToJson(runs);
  EXPECT_EQ(json["runs"][0]["ate_m"]["rmse"], 0.0412);
  EXPECT_EQ(json["runs"][2]["evaluated"], false);
}

TEST(Summary, RejectsMalformedFilesAndMissingFolders) {
  testing::TempDir dir;
  MakeRun(dir / "bad", "{not json", "");
  EXPECT_THROW(ReadRunSummary(dir / "bad"), DataError);
  MakeRun(dir / "shape", R"({"pairs": "many"})", "");
  EXPECT_THROW(ReadRunSummary(dir / "shape"), DataError);
  EXPECT_THROW(ReadRunSummary(dir / "absent"), NoInputError);
  EvalSummaryOptions options;
  std::ostringstream out;
  EXPECT_THROW(RunEvalSummary(options, out), UsageError);
}

TEST(Summary, ToolWritesTheTableAtomically) {
  testing::TempDir dir;
  MakeRun(dir / "kitchen", kAte, kRun);
  const auto r = testing::RunTool(
      "eval", "summary " + (dir / "kitchen").string() + " --out " + (dir / "summary.md").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(ReadFileToString(dir / "summary.md").find("| kitchen |"), std::string::npos);
  EXPECT_EQ(testing::RunTool("eval", "summary " + (dir / "absent").string()).exit_code, 66);
}

}  // namespace
}  // namespace rrslam
