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
  EXPECT_NE(table.find("| kitchen | evaluated | 1000 | 998 | 2 | 61 | 4.12 | 3.71 | 9.34 | 11.3 |"),
            std::string::npos)
      << table;
  EXPECT_NE(table.find("| room | evaluated | - | - | - | - | 2.00 | 1.00 | 5.00 | - |"),
            std::string::npos)
      << table;
  EXPECT_NE(
      table.find("| broken | failed: tracking lost on every frame | 1000 | 998 | 2 | 61 | - | "
                 "- | - | 11.3 |"),
      std::string::npos)
      << table;
  EXPECT_NE(table.find("| mean of 2 evaluated | 1 failed | | | | | 3.06 | | | |\n"),
            std::string::npos)
      << table;
  EXPECT_EQ(table.find("reference"), std::string::npos) << table;  // No column without one.
  const auto json = SummaryToJson(runs);
  EXPECT_EQ(json["runs"][0]["ate_m"]["rmse"], 0.0412);
  EXPECT_EQ(json["runs"][2]["evaluated"], false);
  EXPECT_EQ(json["runs"][2]["status"], "failed");
  EXPECT_EQ(json["runs"][2]["failure"], "tracking lost on every frame");
  EXPECT_FALSE(json.contains("reference"));
}

// eval-all writes skipped.txt for a sequence it does not run (too short); the
// run is neither evaluated nor failed, and a result left over from an earlier
// run beside it is not shown.
TEST(Summary, ListsSkippedRunsApartFromFailures) {
  testing::TempDir dir;
  MakeRun(dir / "kitchen", kAte, kRun);
  MakeRun(dir / "fr1_desk", "", "");
  testing::WriteTextFile(dir / "fr1_desk" / "skipped.txt",
                         "too short (9 frames < EVAL_MIN_FRAMES = 30)\n");
  MakeRun(dir / "stale", kAte, kRun);
  testing::WriteTextFile(dir / "stale" / "skipped.txt", "too short (2 frames < 30)\n");
  MakeRun(dir / "broken", "", "");
  const std::vector<RunSummary> runs = {
      ReadRunSummary(dir / "kitchen"), ReadRunSummary(dir / "fr1_desk"),
      ReadRunSummary(dir / "stale"), ReadRunSummary(dir / "broken")};
  EXPECT_TRUE(runs[1].skipped);
  EXPECT_FALSE(runs[1].evaluated);
  EXPECT_EQ(runs[1].failure, "too short (9 frames < EVAL_MIN_FRAMES = 30)");
  EXPECT_TRUE(runs[2].skipped);
  EXPECT_FALSE(runs[2].evaluated);
  EXPECT_FALSE(runs[2].frames.has_value());
  EXPECT_FALSE(runs[3].skipped);
  const std::string table = FormatSummaryTable(runs);
  EXPECT_NE(table.find("| fr1_desk | skipped: too short (9 frames < EVAL_MIN_FRAMES = 30) | - | - "
                       "| - | - | - | - | - | - |"),
            std::string::npos)
      << table;
  EXPECT_NE(table.find("| broken | failed: no ate.json |"), std::string::npos) << table;
  EXPECT_NE(table.find("| mean of 1 evaluated | 1 failed, 2 skipped | | | | | 4.12 |"),
            std::string::npos)
      << table;
  const auto json = SummaryToJson(runs);
  EXPECT_EQ(json["runs"][1]["status"], "skipped");
  EXPECT_EQ(json["runs"][1]["skipped"], "too short (9 frames < EVAL_MIN_FRAMES = 30)");
  EXPECT_FALSE(json["runs"][1].contains("failure"));
  EXPECT_FALSE(json["runs"][2].contains("ate_m"));
  EXPECT_EQ(json["runs"][3]["status"], "failed");
}

TEST(Summary, CanonicalSequenceNamesShortenTumFolders) {
  EXPECT_EQ(CanonicalSequenceName("rgbd_dataset_freiburg1_desk"), "fr1_desk");
  EXPECT_EQ(CanonicalSequenceName("rgbd_dataset_freiburg3_long_office_household"),
            "fr3_long_office_household");
  EXPECT_EQ(CanonicalSequenceName("fr1_desk"), "fr1_desk");
  EXPECT_EQ(CanonicalSequenceName("7scenes-kitchen"), "7scenes-kitchen");
  EXPECT_EQ(CanonicalSequenceName("rgbd_dataset_freiburg_x"), "rgbd_dataset_freiburg_x");
  EXPECT_EQ(CanonicalSequenceName("rgbd_dataset_freiburg1"), "rgbd_dataset_freiburg1");
}

const char* kReference =
    "# ATE RMSE of another system\n"
    "sequence,ate_rmse_cm,source\n"
    "fr1_desk,1.6,\"Paper, Table III\"\n"
    "\n"
    "rgbd_dataset_freiburg1_room , 4.7 , Paper\r\n"
    "fr3_long_office_household,1.0,\"Paper, Table III\"\n";

TEST(Summary, ReferenceColumnMatchesShortAndLongTumNames) {
  testing::TempDir dir;
  testing::WriteTextFile(dir / "reference.csv", kReference);
  const std::vector<ReferenceAte> references = ReadReferenceAte(dir / "reference.csv");
  ASSERT_EQ(references.size(), 3u);
  EXPECT_EQ(references[0].sequence, "fr1_desk");
  EXPECT_DOUBLE_EQ(references[0].ate_rmse_m, 0.016);
  EXPECT_EQ(references[0].source, "Paper, Table III");
  EXPECT_EQ(references[1].sequence, "rgbd_dataset_freiburg1_room");
  EXPECT_EQ(references[1].source, "Paper");

  MakeRun(dir / "rgbd_dataset_freiburg1_desk", kAte, kRun);
  MakeRun(dir / "fr1_room", kAte, "");
  MakeRun(dir / "kitchen", kAte, kRun);
  MakeRun(dir / "fr3_long_office_household", "", "");
  testing::WriteTextFile(dir / "fr3_long_office_household" / "skipped.txt", "too short\n");
  std::vector<RunSummary> runs = {ReadRunSummary(dir / "rgbd_dataset_freiburg1_desk"),
                                  ReadRunSummary(dir / "fr1_room"), ReadRunSummary(dir / "kitchen"),
                                  ReadRunSummary(dir / "fr3_long_office_household")};
  AttachReferences(references, &runs);
  ASSERT_TRUE(runs[0].reference.has_value());
  EXPECT_EQ(runs[0].reference->sequence, "fr1_desk");
  ASSERT_TRUE(runs[1].reference.has_value());
  EXPECT_DOUBLE_EQ(runs[1].reference->ate_rmse_m, 0.047);
  EXPECT_FALSE(runs[2].reference.has_value());
  EXPECT_TRUE(runs[3].reference.has_value());

  const ReferenceColumn column{"ORB-SLAM2", "reference.csv"};
  const std::string table = FormatSummaryTable(runs, column);
  EXPECT_NE(table.find("| ATE RMSE cm | ORB-SLAM2 ATE RMSE cm | ATE mean cm |"), std::string::npos)
      << table;
  EXPECT_NE(table.find("| rgbd_dataset_freiburg1_desk | evaluated | 1000 | 998 | 2 | 61 | 4.12 | "
                       "1.6 [1] | 3.71 | 9.34 | 11.3 |"),
            std::string::npos)
      << table;
  EXPECT_NE(table.find("| fr1_room | evaluated | - | - | - | - | 4.12 | 4.7 [2] | 3.71 |"),
            std::string::npos)
      << table;
  EXPECT_NE(table.find("| kitchen | evaluated | 1000 | 998 | 2 | 61 | 4.12 | | 3.71 |"),
            std::string::npos)
      << table;
  EXPECT_NE(table.find("| fr3_long_office_household | skipped: too short | - | - | - | - | - | "
                       "1.0 [1] | - | - | - |"),
            std::string::npos)
      << table;
  EXPECT_NE(table.find("| mean of 3 evaluated | 1 skipped | | | | | 4.12 | | | | |\n"),
            std::string::npos)
      << table;
  EXPECT_NE(table.find("ORB-SLAM2 ATE RMSE from reference.csv:\n- [1] Paper, Table III\n"
                       "- [2] Paper\n"),
            std::string::npos)
      << table;

  const auto json = SummaryToJson(runs, column);
  EXPECT_EQ(json["reference"]["name"], "ORB-SLAM2");
  EXPECT_EQ(json["reference"]["file"], "reference.csv");
  EXPECT_DOUBLE_EQ(json["runs"][0]["reference_ate_m"]["rmse"].get<double>(), 0.016);
  EXPECT_EQ(json["runs"][0]["reference_ate_m"]["source"], "Paper, Table III");
  EXPECT_FALSE(json["runs"][2].contains("reference_ate_m"));
}

// A bad reference file is one DataError naming the file and the line at fault.
TEST(Summary, RejectsBadReferenceFilesNamingTheLine) {
  testing::TempDir dir;
  const auto message = [&](const std::string& content) -> std::string {
    testing::WriteTextFile(dir / "ref.csv", content);
    try {
      ReadReferenceAte(dir / "ref.csv");
    } catch (const DataError& e) {
      return e.what();
    }
    return "no error";
  };
  const std::string file = (dir / "ref.csv").string();
  const std::string header = "# comment\nsequence,ate_rmse_cm,source\n";
  EXPECT_EQ(message(header + "fr1_desk,1.6,Paper\nfr1_room,4.7\n"),
            file + " line 4: expected 3 fields 'sequence,ate_rmse_cm,source', got 2");
  EXPECT_EQ(message(header + "fr1_desk,1.6 cm,Paper\n"),
            file + " line 3: '1.6 cm' is not a number");
  EXPECT_EQ(message(header + "fr1_desk,0,Paper\n"), file + " line 3: ATE RMSE 0 cm; must be > 0");
  EXPECT_EQ(message(header + "fr1_desk,1.6,\n"), file + " line 3: no source for fr1_desk's figure");
  EXPECT_EQ(message(header + ",1.6,Paper\n"), file + " line 3: empty sequence name");
  EXPECT_EQ(message(header + "fr1_desk,1.6,\"Paper, Table III\n"),
            file + " line 3: unterminated quoted field");
  EXPECT_EQ(message(header + "fr1_desk,1.6,\"Paper\" III\n"),
            file + " line 3: text after a closing quote");
  EXPECT_EQ(message(header + "fr1_desk,1.6,Paper\nrgbd_dataset_freiburg1_desk,1.7,Other\n"),
            file + " line 4: sequence rgbd_dataset_freiburg1_desk is already listed on line 3");
  EXPECT_EQ(message("sequence,ate_cm,source\nfr1_desk,1.6,Paper\n"),
            file + " line 1: expected the header 'sequence,ate_rmse_cm,source'");
  EXPECT_EQ(message("# only a comment\n"),
            file + ": empty; expected the header 'sequence,ate_rmse_cm,source'");
  EXPECT_THROW(ReadReferenceAte(dir / "absent.csv"), NoInputError);
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

TEST(Summary, ToolAddsTheReferenceColumnAndRejectsABadFile) {
  testing::TempDir dir;
  MakeRun(dir / "fr1_desk", kAte, kRun);
  testing::WriteTextFile(dir / "reference.csv", kReference);
  const std::string runs = (dir / "fr1_desk").string();
  const auto r = testing::RunTool("eval", "summary " + runs + " --reference " +
                                              (dir / "reference.csv").string() +
                                              " --reference-name ORB-SLAM2 --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("\"reference_ate_m\""), std::string::npos) << r.output;
  testing::WriteTextFile(dir / "bad.csv", "sequence,ate_rmse_cm,source\nfr1_desk,x,Paper\n");
  const auto bad =
      testing::RunTool("eval", "summary " + runs + " --reference " + (dir / "bad.csv").string());
  EXPECT_EQ(bad.exit_code, 65) << bad.output;
  EXPECT_NE(bad.output.find((dir / "bad.csv").string() + " line 2: 'x' is not a number"),
            std::string::npos)
      << bad.output;
  EXPECT_EQ(testing::RunTool("eval", "summary " + runs + " --reference-name 'a|b'").exit_code, 64);
}

}  // namespace
}  // namespace rrslam
