#include "stages/eval/compare.h"

#include <gtest/gtest.h>

#include <sstream>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/image_io.h"
#include "common/testing.h"

namespace rrslam {
namespace {
namespace fs = std::filesystem;

// A run folder as `make eval-all` leaves it: ate.json with `rmse_cm`, and
// track/run.json when `frames` > 0.
void MakeRun(const fs::path& dir, double rmse_cm, int frames = 0, int tracked = 0) {
  fs::create_directories(dir / "track");
  const double rmse_m = rmse_cm / 100;
  testing::WriteTextFile(dir / "ate.json", R"({"pairs": 500, "ate_m": {"rmse": )" +
                                               std::to_string(rmse_m) + R"(, "mean": )" +
                                               std::to_string(0.9 * rmse_m) + R"(, "max": )" +
                                               std::to_string(2 * rmse_m) + "}}");
  if (frames > 0) {
    testing::WriteTextFile(dir / "track" / "run.json",
                           R"({"counts": {"frames": )" + std::to_string(frames) +
                               R"(, "tracked": )" + std::to_string(tracked) + R"(, "lost": )" +
                               std::to_string(frames - tracked) + R"(, "keyframes": 40}})");
  }
}

void MakeFailed(const fs::path& dir, const std::string& error) {
  fs::create_directories(dir);
  testing::WriteTextFile(dir / "error.txt", error + "\nthe rest of the log\n");
}

void MakeSkipped(const fs::path& dir, const std::string& reason) {
  fs::create_directories(dir);
  testing::WriteTextFile(dir / "skipped.txt", reason + "\n");
}

// RUNS/<variant>/<sequence>: three variants on three sequences with an absent
// cell (transfer on the sequence it was trained on), a failed, a skipped run
// and a run that lost frames.
//
//            own      general   transfer
//   fr1_desk 2.00     1.75      (absent)
//   fr1_room 4.00     4.40      2.00, 540 of 594 frames tracked
//   fr1_xyz  failed   1.00      skipped
void MakeRuns(const fs::path& runs) {
  MakeRun(runs / "own" / "fr1_desk", 2.0, 573, 573);
  MakeRun(runs / "own" / "fr1_room", 4.0, 594, 594);
  MakeFailed(runs / "own" / "fr1_xyz", "tracking lost on every frame");
  MakeRun(runs / "general" / "fr1_desk", 1.75, 573, 573);
  MakeRun(runs / "general" / "fr1_room", 4.4, 594, 594);
  MakeRun(runs / "general" / "fr1_xyz", 1.0, 798, 798);
  MakeRun(runs / "transfer" / "fr1_room", 2.0, 594, 540);
  MakeSkipped(runs / "transfer" / "fr1_xyz", "too short (9 frames < EVAL_MIN_FRAMES = 30)");
  // Not sequences: files, hidden folders, AtomicOutput temporaries.
  testing::WriteTextFile(runs / "own" / "summary.md", "| run |\n");
  fs::create_directories(runs / "general" / ".cache");
  fs::create_directories(runs / "general" / "fr2_desk.a1b2c3.tmp");
}

std::vector<CompareColumn> Columns(const fs::path& runs) {
  return {{"own", runs / "own"}, {"general", runs / "general"}, {"transfer", runs / "transfer"}};
}

TEST(FormatChangePercent, OneDecimalWithASign) {
  EXPECT_EQ(FormatChangePercent(-12.5), "-12.5%");
  EXPECT_EQ(FormatChangePercent(3), "+3.0%");
  EXPECT_EQ(FormatChangePercent(0.04), "+0.0%");
  EXPECT_EQ(FormatChangePercent(-0.04), "+0.0%");  // Rounds to zero: no direction.
  EXPECT_EQ(FormatChangePercent(150), "+150.0%");
}

TEST(Compare, TableShowsChangesAgainstTheBaselineAndNotesLostFrames) {
  testing::TempDir dir;
  MakeRuns(dir.path());
  const CompareTable table = ReadCompareTable(Columns(dir.path()));
  ASSERT_EQ(table.sequences, (std::vector<std::string>{"fr1_desk", "fr1_room", "fr1_xyz"}));
  EXPECT_FALSE(table.cells[0][2].run.has_value());
  EXPECT_EQ(table.cells[0][2].status(), "absent");
  EXPECT_TRUE(table.cells[2][0].failed());
  EXPECT_TRUE(table.cells[2][2].skipped());
  EXPECT_TRUE(table.cells[1][2].lost_frames());
  EXPECT_FALSE(table.cells[0][0].change_pct.has_value());  // The baseline itself.
  ASSERT_TRUE(table.cells[0][1].change_pct.has_value());
  EXPECT_NEAR(*table.cells[0][1].change_pct, -12.5, 1e-9);
  EXPECT_FALSE(table.cells[2][1].change_pct.has_value());  // The baseline failed.

  const std::string text = FormatCompareTable(table, "ATE per vocabulary");
  EXPECT_EQ(text,
            "**ATE per vocabulary**\n"
            "\n"
            "| sequence | own | general | transfer |\n"
            "| --- | ---: | ---: | ---: |\n"
            "| fr1_desk | 2.00 | 1.75 (-12.5%) | |\n"
            "| fr1_room | 4.00 | 4.40 (+10.0%) | 2.00 (-50.0%) [1] |\n"
            "| fr1_xyz | failed [2] | 1.00 | skipped [3] |\n"
            "| mean of 1 evaluated in every column | 4.00 | 4.40 (+10.0%) | 2.00 (-50.0%) |\n"
            "\n"
            "ATE RMSE in cm; in parentheses the change against own, (variant - own) / own. Every "
            "other evaluated run tracked all of its frames.\n"
            "\n"
            "- [1] transfer/fr1_room: 540 of 594 frames tracked; its ATE is over those only\n"
            "- [2] own/fr1_xyz failed: tracking lost on every frame\n"
            "- [3] transfer/fr1_xyz skipped: too short (9 frames < EVAL_MIN_FRAMES = 30)\n");
}

TEST(Compare, BaselineOptionAndCompleteRuns) {
  testing::TempDir dir;
  MakeRun(dir / "a" / "fr1_desk", 2.0, 100, 100);
  MakeRun(dir / "a" / "fr1_room", 3.0);  // No run.json.
  MakeRun(dir / "b" / "fr1_desk", 1.0, 100, 100);
  MakeRun(dir / "b" / "fr1_room", 6.0, 200, 200);
  const CompareTable table = ReadCompareTable({{"a", dir / "a"}, {"b", dir / "b"}}, 1);
  const std::string text = FormatCompareTable(table);
  EXPECT_EQ(text.find("**"), std::string::npos) << text;  // No title.
  EXPECT_NE(text.find("| fr1_desk | 2.00 (+100.0%) | 1.00 |\n"
                      "| fr1_room | 3.00 (-50.0%) | 6.00 |\n"
                      "| mean of 2 evaluated in every column | 2.50 (-28.6%) | 3.50 |\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("in parentheses the change against b, (variant - b) / b. Every evaluated "
                      "run with a run.json tracked all of its frames.\n\n"
                      "- frames tracked unknown (no run.json): a/fr1_room\n"),
            std::string::npos)
      << text;
  MakeRun(dir / "a" / "fr1_room", 3.0, 200, 200);
  EXPECT_NE(FormatCompareTable(ReadCompareTable({{"a", dir / "a"}, {"b", dir / "b"}}))
                .find("(variant - a) / a. Every evaluated run tracked all of its frames.\n"),
            std::string::npos);
}

TEST(Compare, CsvHasOneLinePerCell) {
  testing::TempDir dir;
  MakeRuns(dir.path());
  MakeRun(dir / "own" / "room, lit", 1.0);  // A name that needs quoting.
  const std::string csv = FormatCompareCsv(ReadCompareTable(Columns(dir.path())));
  EXPECT_EQ(csv,
            "sequence,variant,ate_rmse_cm,change_pct,status,frames,tracked\n"
            "fr1_desk,own,2.0000,,evaluated,573,573\n"
            "fr1_desk,general,1.7500,-12.50,evaluated,573,573\n"
            "fr1_desk,transfer,,,absent,,\n"
            "fr1_room,own,4.0000,,evaluated,594,594\n"
            "fr1_room,general,4.4000,10.00,evaluated,594,594\n"
            "fr1_room,transfer,2.0000,-50.00,evaluated,594,540\n"
            "fr1_xyz,own,,,failed,,\n"
            "fr1_xyz,general,1.0000,,evaluated,798,798\n"
            "fr1_xyz,transfer,,,skipped,,\n"
            "\"room, lit\",own,1.0000,,evaluated,,\n"
            "\"room, lit\",general,,,absent,,\n"
            "\"room, lit\",transfer,,,absent,,\n");
}

TEST(Compare, JsonHasEveryCellAndTheMean) {
  testing::TempDir dir;
  MakeRuns(dir.path());
  const auto json = CompareToJson(ReadCompareTable(Columns(dir.path()), 0), {{"title", "t"}});
  EXPECT_EQ(json["command"], "compare");
  EXPECT_EQ(json["producer"].get<std::string>().rfind("rrslam-eval ", 0), 0u);
  EXPECT_EQ(json["options"]["title"], "t");
  EXPECT_EQ(json["baseline"], "own");
  ASSERT_EQ(json["columns"].size(), 3u);
  EXPECT_EQ(json["columns"][1]["name"], "general");
  EXPECT_EQ(json["columns"][1]["dir"], (dir / "general").string());
  EXPECT_EQ(json["columns"][0]["baseline"], true);
  EXPECT_EQ(json["columns"][1]["baseline"], false);
  ASSERT_EQ(json["sequences"].size(), 3u);
  const auto& desk = json["sequences"][0];
  EXPECT_EQ(desk["sequence"], "fr1_desk");
  EXPECT_DOUBLE_EQ(desk["cells"]["general"]["ate_m"]["rmse"].get<double>(), 0.0175);
  EXPECT_NEAR(desk["cells"]["general"]["change_pct"].get<double>(), -12.5, 1e-9);
  EXPECT_FALSE(desk["cells"]["own"].contains("change_pct"));
  EXPECT_EQ(desk["cells"]["transfer"]["status"], "absent");
  const auto& room = json["sequences"][1]["cells"]["transfer"];
  EXPECT_EQ(room["frames"], 594);
  EXPECT_EQ(room["tracked"], 540);
  const auto& xyz = json["sequences"][2]["cells"];
  EXPECT_EQ(xyz["own"]["status"], "failed");
  EXPECT_EQ(xyz["own"]["failure"], "tracking lost on every frame");
  EXPECT_EQ(xyz["transfer"]["status"], "skipped");
  EXPECT_EQ(xyz["transfer"]["skipped"], "too short (9 frames < EVAL_MIN_FRAMES = 30)");
  EXPECT_EQ(json["mean"]["sequences"].dump(), R"(["fr1_room"])");
  EXPECT_DOUBLE_EQ(json["mean"]["ate_rmse_m"]["general"].get<double>(), 0.044);
  EXPECT_NEAR(json["mean"]["change_pct"]["transfer"].get<double>(), -50, 1e-9);
  EXPECT_FALSE(json["mean"]["change_pct"].contains("own"));
}

int CountColour(const cv::Mat& image, const cv::Scalar& colour) {
  const cv::Vec3b bgr(static_cast<uint8_t>(colour[0]), static_cast<uint8_t>(colour[1]),
                      static_cast<uint8_t>(colour[2]));
  int count = 0;
  for (int r = 0; r < image.rows; ++r) {
    for (int c = 0; c < image.cols; ++c) count += image.at<cv::Vec3b>(r, c) == bgr ? 1 : 0;
  }
  return count;
}

TEST(Compare, ChartDrawsABarPerEvaluatedCellInItsVariantsColour) {
  testing::TempDir dir;
  MakeRuns(dir.path());
  const CompareTable table = ReadCompareTable(Columns(dir.path()));
  CompareChartOptions options;
  options.width_px = 900;
  options.height_px = 600;
  const cv::Mat image = RenderCompareChart(table, options, "ATE per vocabulary");
  ASSERT_EQ(image.type(), CV_8UC3);
  EXPECT_EQ(image.cols, 900);
  EXPECT_EQ(image.rows, 600);
  const int own = CountColour(image, CompareColumnColour(0));
  const int general = CountColour(image, CompareColumnColour(1));
  const int transfer = CountColour(image, CompareColumnColour(2));
  // Bar areas follow the values: own 2 + 4 cm, general 1.75 + 4.4 + 1 cm,
  // transfer 2 cm (the legend swatches add a little to each).
  EXPECT_GT(own, 3000);
  EXPECT_GT(general, own);
  EXPECT_GT(own, transfer);
  EXPECT_GT(transfer, 1000);
  EXPECT_EQ(image.at<cv::Vec3b>(0, 0), cv::Vec3b(255, 255, 255));
  options.width_px = 100;
  EXPECT_THROW(RenderCompareChart(table, options), UsageError);
}

TEST(Compare, ColumnSpecsAndOptionsAreChecked) {
  EXPECT_THROW(ParseCompareColumn("own"), UsageError);
  try {
    ParseCompareColumn("runs/own");
  } catch (const UsageError& e) {
    EXPECT_EQ(std::string(e.what()), "--column 'runs/own': expected NAME=DIR (e.g. own=runs/own)");
  }
  const CompareColumn column = ParseCompareColumn("a=b=c");
  EXPECT_EQ(column.name, "a");
  EXPECT_EQ(column.dir, "b=c");

  const auto why = [](const EvalCompareOptions& options) {
    std::string why;
    return options.Check(&why) ? std::string("ok") : why;
  };
  EvalCompareOptions options;
  EXPECT_EQ(why(options), "give at least one --column NAME=DIR");
  options.columns = {{"own", "runs/own"}, {"general", "runs/general"}};
  EXPECT_EQ(why(options), "ok");
  EXPECT_EQ(options.BaselineIndex(), 0u);
  options.baseline = "general";
  EXPECT_EQ(options.BaselineIndex(), 1u);
  options.baseline = "transfer";
  EXPECT_EQ(why(options), "--baseline 'transfer' is not a column name (own, general)");
  options.baseline.clear();
  options.columns.push_back({"own", "runs/other"});
  EXPECT_EQ(why(options), "--column name 'own' is given twice");
  options.columns.back() = {"", "runs/other"};
  EXPECT_EQ(why(options), "--column '=runs/other': empty NAME; expected NAME=DIR");
  options.columns.back() = {"other", ""};
  EXPECT_EQ(why(options), "--column 'other=': empty DIR; expected NAME=DIR");
  options.columns.back() = {"a|b", "runs/other"};
  EXPECT_EQ(why(options), "--column name 'a|b' must not hold '|' or line breaks");
  options.columns.pop_back();
  options.plot_path = "chart.jpg";
  EXPECT_EQ(why(options), "plot chart.jpg must be a .png file");
  options.plot_path = "chart.png";
  options.plot.height_px = 100;
  EXPECT_EQ(why(options), "plot height = 100 px; must be in [240, 8000]");
  options.plot.height_px = 700;
  options.out = "runs/own/compare.md";  // Inside an input.
  EXPECT_NE(why(options), "ok");
  options.out = "compare.md";
  options.csv_path = "compare.md";
  EXPECT_NE(why(options).find("name the same file"), std::string::npos) << why(options);
}

TEST(Compare, MissingAndMalformedInputs) {
  testing::TempDir dir;
  MakeRuns(dir.path());
  EXPECT_THROW(ReadCompareTable({{"own", dir / "own"}, {"gone", dir / "gone"}}), NoInputError);
  fs::create_directories(dir / "empty");
  EXPECT_THROW(ReadCompareTable({{"empty", dir / "empty"}}), NoInputError);
  testing::WriteTextFile(dir / "general" / "fr1_room" / "ate.json", "{not json");
  try {
    ReadCompareTable(Columns(dir.path()));
    ADD_FAILURE() << "no error";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find((dir / "general" / "fr1_room" / "ate.json").string()),
              std::string::npos)
        << e.what();
  }
  testing::WriteTextFile(dir / "general" / "fr1_room" / "ate.json", "{}");
  testing::WriteTextFile(dir / "general" / "fr1_room" / "track" / "run.json",
                         R"({"counts": {"frames": "many"}})");
  EXPECT_THROW(ReadCompareTable(Columns(dir.path())), DataError);
}

TEST(Compare, RunWritesEveryOutputAtomically) {
  testing::TempDir dir;
  MakeRuns(dir / "runs");
  EvalCompareOptions options;
  options.columns = Columns(dir / "runs");
  options.title = "ATE per vocabulary";
  options.out = dir / "compare.json";
  options.json = true;
  options.csv_path = dir / "compare.csv";
  options.plot_path = dir / "compare.png";
  std::ostringstream out;
  RunEvalCompare(options, out);
  EXPECT_EQ(out.str(), "");
  const auto json = nlohmann::json::parse(ReadFileToString(dir / "compare.json"));
  EXPECT_EQ(json["options"]["csv"], (dir / "compare.csv").string());
  EXPECT_EQ(json["options"]["plot_options"]["width_px"], 1200);
  EXPECT_EQ(ReadFileToString(dir / "compare.csv").rfind("sequence,variant,", 0), 0u);
  const cv::Mat png = ReadImage(dir / "compare.png", ImageReadMode::kColor);
  EXPECT_EQ(png.cols, 1200);
  EXPECT_EQ(png.rows, 700);
  EXPECT_GT(CountColour(png, CompareColumnColour(2)), 1000);
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});

  // A folder that does not exist: nothing is written, old files stay.
  options.csv_path = dir / "missing" / "compare.csv";
  options.plot_path = dir / "compare2.png";
  EXPECT_THROW(RunEvalCompare(options, out), CantCreateError);
  EXPECT_FALSE(fs::exists(dir / "compare2.png"));
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
}

TEST(Compare, ToolExitCodes) {
  testing::TempDir dir;
  MakeRuns(dir.path());
  const std::string columns = "compare --column own=" + (dir / "own").string() +
                              " --column general=" + (dir / "general").string() +
                              " --column transfer=" + (dir / "transfer").string();
  auto r = testing::RunTool("eval", columns + " --baseline general --title 'Vocabularies'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("| fr1_desk | 2.00 (+14.3%) | 1.75 | |"), std::string::npos) << r.output;

  r = testing::RunTool("eval", columns + " --column own=" + (dir / "general").string());
  EXPECT_EQ(r.exit_code, 64);
  EXPECT_NE(r.output.find("--column name 'own' is given twice"), std::string::npos) << r.output;
  r = testing::RunTool("eval", "compare --column " + (dir / "own").string());
  EXPECT_EQ(r.exit_code, 64);
  EXPECT_NE(r.output.find("expected NAME=DIR"), std::string::npos) << r.output;
  EXPECT_EQ(testing::RunTool("eval", "compare").exit_code, 64);
  EXPECT_EQ(testing::RunTool("eval", columns + " --baseline nope").exit_code, 64);
  // An output may not be an input or lie inside one.
  r = testing::RunTool("eval", columns + " --out " + (dir / "own").string());
  EXPECT_EQ(r.exit_code, 64) << r.output;
  r = testing::RunTool("eval", columns + " --csv " + (dir / "own" / "compare.csv").string());
  EXPECT_EQ(r.exit_code, 64) << r.output;
  EXPECT_FALSE(fs::exists(dir / "own" / "compare.csv"));

  EXPECT_EQ(testing::RunTool("eval", columns + " --column x=" + (dir / "gone").string()).exit_code,
            66);
  testing::WriteTextFile(dir / "own" / "fr1_room" / "ate.json", "[]");
  r = testing::RunTool("eval", columns);
  EXPECT_EQ(r.exit_code, 65);
  EXPECT_NE(r.output.find((dir / "own" / "fr1_room" / "ate.json").string()), std::string::npos)
      << r.output;
  testing::WriteTextFile(dir / "own" / "fr1_room" / "ate.json",
                         R"({"pairs": 5, "ate_m": {"rmse": 0.04, "mean": 0.03, "max": 0.1}})");
  r = testing::RunTool("eval", columns + " --plot " + (dir / "missing" / "c.png").string());
  EXPECT_EQ(r.exit_code, 73) << r.output;
}

TEST(Compare, HelpListsTheFlags) {
  const auto r = testing::RunTool("eval", "compare --help");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* flag : {"--column", "--baseline", "--out", "--json", "--csv", "--plot",
                           "--plot-width", "--plot-height", "--title"}) {
    EXPECT_NE(r.output.find(flag), std::string::npos) << flag;
  }
}

// Found in review (issue 36): an ate.json with a negative or infinite RMSE
// (1e999 reads as infinity) was compared and charted, and the chart's grid
// loop never ended. The reader refuses it, naming the file and the line.
TEST(Compare, NegativeOrInfiniteRmseIsBadDataNamingFileAndLine) {
  testing::TempDir dir;
  MakeRuns(dir.path());
  const fs::path ate = dir / "general" / "fr1_room" / "ate.json";
  for (const std::string value : {"-0.5", "1e999"}) {
    testing::WriteTextFile(ate, "{\n  \"pairs\": 5,\n  \"ate_m\": {\n    \"rmse\": " + value +
                                    ",\n    \"mean\": 0.03,\n    \"max\": 0.1\n  }\n}\n");
    try {
      ReadCompareTable(Columns(dir.path()));
      ADD_FAILURE() << "accepted " << value;
    } catch (const DataError& e) {
      EXPECT_EQ(std::string(e.what()),
                ate.string() + " line 4: " +
                    (value == "-0.5" ? "ate_m.rmse = -0.5; must be a finite distance >= 0 m"
                                     : "1e999 is not a finite number"));
    }
  }
  const std::string columns = "compare --column own=" + (dir / "own").string() +
                              " --column general=" + (dir / "general").string() + " --plot " +
                              (dir / "c.png").string();
  const auto r = testing::RunTool("eval", columns);
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find(ate.string() + " line 4: 1e999 is not a finite number"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(dir / "c.png"));
}

// Found in review (issue 36): one RMSE of 1e308 m (finite, but infinite in
// centimetres) made the chart's grid loop run for ever. Such a chart is a
// one-line DataError naming the cell; huge finite ones are drawn.
TEST(Compare, ChartOfAnRmseTooLargeToDrawIsADataError) {
  testing::TempDir dir;
  MakeRuns(dir.path());
  MakeRun(dir / "own" / "fr1_desk", 1e302);  // 1e300 m.
  EXPECT_EQ(RenderCompareChart(ReadCompareTable(Columns(dir.path())), {}).cols,
            CompareChartOptions{}.width_px);
  testing::WriteTextFile(dir / "own" / "fr1_desk" / "ate.json",
                         R"({"pairs": 5, "ate_m": {"rmse": 1e308, "mean": 1e307, "max": 1e308}})");
  const CompareTable table = ReadCompareTable(Columns(dir.path()));
  try {
    RenderCompareChart(table, {});
    ADD_FAILURE() << "drew an RMSE of 1e308 m";
  } catch (const DataError& e) {
    EXPECT_EQ(std::string(e.what()),
              "compare chart: the ATE RMSE of own/fr1_desk is too large to chart (its "
              "centimetres overflow a double)");
  }
}

}  // namespace
}  // namespace rrslam
