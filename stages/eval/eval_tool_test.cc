// Runs the rrslam-eval executable: exit codes, stdout, written files.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "common/atomic_file.h"
#include "common/geometry.h"
#include "common/json_text.h"
#include "common/testing.h"
#include "common/text.h"
#include "common/trajectory.h"

namespace rrslam {
namespace {

namespace fs = std::filesystem;
using testing::RunTool;

Trajectory MakeGroundTruth(int n) {
  Trajectory gt;
  for (int i = 0; i < n; ++i) {
    const double s = i / 30.0;
    StampedPose pose;
    pose.timestamp = 1000 + s;
    pose.T_world_cam.translation = Eigen::Vector3d(std::cos(s), 0.5 * std::sin(2 * s), 0.1 * s);
    pose.T_world_cam.rotation = ExpSO3(Eigen::Vector3d(0.2 * s, 0.1, -0.3 * s));
    gt.push_back(pose);
  }
  return gt;
}

Trajectory Moved(Trajectory trajectory, double time_shift = 0) {
  const Rigid3d T(ExpSO3(Eigen::Vector3d(0.3, -1.2, 0.4)), Eigen::Vector3d(2, 1, -3));
  for (StampedPose& pose : trajectory) {
    pose.T_world_cam = T * pose.T_world_cam;
    pose.timestamp += time_shift;
  }
  return trajectory;
}

using testing::Quote;

// stdout only (stderr dropped), for JSON.
testing::CommandResult RunStdout(const std::string& args) {
  return testing::RunCommand("( " + Quote(testing::BinDir() / "rrslam-eval") + " " + args +
                             " 2>/dev/null )");
}

class EvalTool : public ::testing::Test {
 protected:
  void SetUp() override {
    gt_ = dir_ / "groundtruth.txt";
    est_ = dir_ / "CameraTrajectory.txt";
    WriteTumTrajectory(gt_, MakeGroundTruth(150));
    WriteTumTrajectory(est_, Moved(MakeGroundTruth(150), 0.004));
  }
  std::string Inputs() const { return "--gt " + Quote(gt_) + " --est " + Quote(est_); }

  testing::TempDir dir_;
  fs::path gt_, est_;
};

TEST_F(EvalTool, AtePrintsTheTumReport) {
  const auto r = RunTool("eval", "ate " + Inputs());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("compared_pose_pairs 150 pairs"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("absolute_translational_error.rmse 0.000000 m"), std::string::npos);
}

TEST_F(EvalTool, AteJsonOnStdout) {
  const auto r = RunStdout("ate --json " + Inputs() + " --max-diff 0.01 --offset 0");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto json = nlohmann::json::parse(r.output);
  EXPECT_EQ(json["command"], "ate");
  EXPECT_EQ(json["pairs"], 150);
  EXPECT_LT(json["ate_m"]["rmse"].get<double>(), 1e-6);
  EXPECT_DOUBLE_EQ(json["options"]["max_difference_s"].get<double>(), 0.01);
  EXPECT_EQ(json["producer"].get<std::string>().rfind("rrslam-eval ", 0), 0u);
}

TEST_F(EvalTool, AteWritesPlotAssociationsAndAlignedEstimate) {
  const fs::path png = dir_ / "ate.png", pairs = dir_ / "pairs.txt", aligned = dir_ / "aligned.txt";
  const auto r = RunTool("eval", "ate " + Inputs() + " --plot " + Quote(png) +
                                     " --plot-width 640 --plot-height 480 --plot-axes xy" +
                                     " --save-associations " + Quote(pairs) + " --save-aligned " +
                                     Quote(aligned));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const cv::Mat image = cv::imread(png.string(), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(image.cols, 640);
  EXPECT_EQ(image.rows, 480);
  EXPECT_EQ(image.channels(), 3);
  // The aligned estimate is the ground truth again; files carry a '#' header.
  const Trajectory back = ReadTumTrajectory(aligned);
  const Trajectory gt = ReadTumTrajectory(gt_);
  ASSERT_EQ(back.size(), gt.size());
  for (size_t i = 0; i < gt.size(); ++i) {
    EXPECT_NEAR((back[i].T_world_cam.translation - gt[i].T_world_cam.translation).norm(), 0, 1e-6);
  }
  const std::string text = ReadFileToString(pairs);
  EXPECT_EQ(text.rfind("# rrslam-eval ", 0), 0u);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 150 + 2);
}

TEST_F(EvalTool, OutWritesTheReportToAFileInsteadOfStdout) {
  const auto ate = RunStdout("ate --json " + Inputs() + " --out " + Quote(dir_ / "ate.json"));
  ASSERT_EQ(ate.exit_code, 0) << ate.output;
  EXPECT_EQ(ate.output, "");
  const auto json = nlohmann::json::parse(ReadFileToString(dir_ / "ate.json"));
  EXPECT_EQ(json["pairs"], 150);
  const auto rpe =
      RunStdout("rpe " + Inputs() + " --delta 1 --delta-unit f --out " + Quote(dir_ / "rpe.txt"));
  ASSERT_EQ(rpe.exit_code, 0) << rpe.output;
  EXPECT_EQ(rpe.output, "");
  EXPECT_NE(ReadFileToString(dir_ / "rpe.txt").find("compared_pose_pairs"), std::string::npos);
  // The report may not overwrite an input.
  EXPECT_EQ(RunTool("eval", "ate " + Inputs() + " --out " + Quote(est_)).exit_code, 64);
}

// A folder name in Latin-1 (legal on Linux, not UTF-8): the JSON report, the
// plot's metadata and the file headers record the paths (common/json_text.h)
// instead of failing with nlohmann's type_error 316 (exit 70).
TEST_F(EvalTool, PathsThatAreNotUtf8RoundTripThroughTheReports) {
  const fs::path dir = dir_ / "caf\xe9";
  fs::create_directories(dir);
  const fs::path gt = dir / "gt.txt", est = dir / "est.txt", report = dir / "ate.json";
  fs::copy_file(gt_, gt);
  fs::copy_file(est_, est);
  const std::string inputs = "--gt " + Quote(gt) + " --est " + Quote(est);
  const auto ate = RunTool("eval", "ate --json " + inputs + " --out " + Quote(report) + " --plot " +
                                       Quote(dir / "ate.png") + " --save-associations " +
                                       Quote(dir / "pairs.txt"));
  ASSERT_EQ(ate.exit_code, 0) << ate.output;
  const auto json = nlohmann::json::parse(ReadFileToString(report));
  EXPECT_EQ(json["pairs"], 150);
  EXPECT_EQ(PathFromJson(json["gt"].get<std::string>()), gt);
  EXPECT_EQ(PathFromJson(json["est"].get<std::string>()), est);
  const auto rpe = RunTool("eval", "rpe --json " + inputs + " --delta 1 --delta-unit f --out " +
                                       Quote(dir / "rpe.json") + " --save-pairs " +
                                       Quote(dir / "rpe_pairs.txt"));
  ASSERT_EQ(rpe.exit_code, 0) << rpe.output;
  EXPECT_EQ(
      PathFromJson(
          nlohmann::json::parse(ReadFileToString(dir / "rpe.json"))["est"].get<std::string>()),
      est);
}

TEST_F(EvalTool, RpeTextAndJson) {
  auto r = RunTool("eval", "rpe " + Inputs() + " --delta 1 --delta-unit f");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("compared_pose_pairs 148 pairs"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("rotational_error.rmse 0.000000 deg"), std::string::npos) << r.output;
  r = RunStdout("rpe --json " + Inputs() + " --delta 0.5 --delta-unit s --error-form paper");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto json = nlohmann::json::parse(r.output);
  EXPECT_EQ(json["command"], "rpe");
  EXPECT_EQ(json["options"]["delta_unit"], "s");
  EXPECT_EQ(json["options"]["error_form"], "paper");
  EXPECT_EQ(json["pairs"], 150 - 1 - 15);
  EXPECT_LT(json["translational_error_m"]["max"].get<double>(), 1e-6);
  // A delta longer than the sequence computes nothing: 75, one line naming
  // the files, no report (issue 36).
  for (const char* delta : {"--delta 1000 --delta-unit s", "--delta 150 --delta-unit f"}) {
    r = RunTool("eval", "rpe " + Inputs() + " " + delta + " --out " + Quote(dir_ / "no.txt"));
    EXPECT_EQ(r.exit_code, 75) << r.output;
    EXPECT_NE(r.output.find("leaves no pose pair"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(est_.string()), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir_ / "no.txt"));
  }
}

TEST_F(EvalTool, MissingInputIs66) {
  const auto r = RunTool("eval", "ate --gt " + Quote(dir_ / "nope.txt") + " --est " + Quote(est_));
  EXPECT_EQ(r.exit_code, 66) << r.output;
  EXPECT_NE(r.output.find("nope.txt"), std::string::npos);
}

TEST_F(EvalTool, MalformedLineIs65NamingFileAndLine) {
  testing::WriteTextFile(est_, "# header\n1000.0 1 2 3 0 0 0 1\n1000.1 1 2 x 0 0 0 1\n");
  const auto r = RunTool("eval", "ate " + Inputs());
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find("CameraTrajectory.txt line 3"), std::string::npos) << r.output;
}

TEST_F(EvalTool, NoMatchingStampsIs65) {
  for (const std::string command : {"ate", "rpe"}) {
    for (const std::string offset : {"50", "-50"}) {
      const auto r = RunTool("eval", command + " " + Inputs() + " --offset " + offset);
      EXPECT_EQ(r.exit_code, 65) << r.output;
      EXPECT_NE(r.output.find("no stamps matched"), std::string::npos) << r.output;
      EXPECT_NE(r.output.find("max_difference"), std::string::npos) << r.output;
    }
  }
}

TEST_F(EvalTool, FewerThanThreeAtePairsIs65) {
  WriteTumTrajectory(est_, Moved(Trajectory(MakeGroundTruth(2))));
  const auto r = RunTool("eval", "ate " + Inputs());
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find("at least 3"), std::string::npos) << r.output;
}

TEST_F(EvalTool, BadOptionsAre64) {
  for (const std::string args :
       {"rpe --delta 0", "rpe --delta -1", "rpe --delta 1.5 --delta-unit f", "rpe --delta-unit m",
        "rpe --delta abc", "ate --max-diff 0", "ate --scale -2", "ate --plot-axes xw",
        "ate --plot-width 10 --plot x.png"}) {
    const auto r = RunTool("eval", args + " " + Inputs());
    EXPECT_EQ(r.exit_code, 64) << args << "\n" << r.output;
  }
  EXPECT_EQ(RunTool("eval", "").exit_code, 64);  // A command is required.
  EXPECT_EQ(RunTool("eval", "ate --gt " + Quote(gt_)).exit_code, 64);
  // An output over an input is refused before anything is written.
  const auto r = RunTool("eval", "ate " + Inputs() + " --save-aligned " + Quote(est_));
  EXPECT_EQ(r.exit_code, 64) << r.output;
  EXPECT_EQ(ReadTumTrajectory(est_).size(), 150u);
}

TEST_F(EvalTool, UnwritablePlotIs73AndWritesNothing) {
  const fs::path pairs = dir_ / "pairs.txt";
  const auto r = RunTool("eval", "ate " + Inputs() + " --save-associations " + Quote(pairs) +
                                     " --plot " + Quote(dir_ / "no" / "such" / "dir" / "ate.png"));
  EXPECT_EQ(r.exit_code, 73) << r.output;
  EXPECT_FALSE(fs::exists(pairs));
  EXPECT_EQ(testing::TemporaryLeftovers(dir_), std::vector<std::string>{});
  // An existing output is not destroyed by a failing run.
  testing::WriteTextFile(pairs, "keep me\n");
  EXPECT_EQ(RunTool("eval", "ate " + Inputs() + " --save-associations " + Quote(pairs) +
                                " --plot " + Quote(dir_ / "no" / "ate.png"))
                .exit_code,
            73);
  EXPECT_EQ(ReadFileToString(pairs), "keep me\n");
}

TEST_F(EvalTool, AteCorrectScalePrintsTheEstimatedScale) {
  const auto r = RunTool("eval", "ate --correct-scale " + Inputs());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("estimated_scale 1.000000"), std::string::npos) << r.output;
  const auto both = RunTool("eval", "ate --correct-scale --scale 2 " + Inputs());
  EXPECT_EQ(both.exit_code, 64) << both.output;
  EXPECT_NE(both.output.find("correct_scale"), std::string::npos) << both.output;
}

// The lines of a file that are not '#' comments.
std::string DataLines(const fs::path& path) {
  std::istringstream lines(ReadFileToString(path));
  std::string line, out;
  while (std::getline(lines, line)) {
    if (!line.empty() && line[0] != '#') out += line + "\n";
  }
  return out;
}

TEST_F(EvalTool, AteAlignWithTheEstimateItselfIsPlainAte) {
  // A noisy estimate, so that the alignment and the errors are not trivial.
  Trajectory est = ReadTumTrajectory(est_);
  for (size_t i = 0; i < est.size(); ++i) {
    est[i].T_world_cam.translation +=
        0.01 * Eigen::Vector3d(std::sin(7.0 * i), std::cos(3.0 * i), std::sin(5.0 * i + 1));
  }
  WriteTumTrajectory(est_, est);
  for (const std::string flags : {"", " --correct-scale"}) {
    const std::string plain_dir = (dir_ / "plain").string() + (flags.empty() ? "" : "_cs");
    const std::string with_dir = (dir_ / "with").string() + (flags.empty() ? "" : "_cs");
    fs::create_directories(plain_dir);
    fs::create_directories(with_dir);
    auto outputs = [&](const std::string& dir) {
      return " --save-associations " + Quote(fs::path(dir) / "pairs.txt") + " --save-aligned " +
             Quote(fs::path(dir) / "aligned.txt");
    };
    const auto plain = RunStdout("ate --json " + Inputs() + flags + outputs(plain_dir));
    const auto with = RunStdout("ate --json " + Inputs() + flags + " --align-with " + Quote(est_) +
                                outputs(with_dir));
    ASSERT_EQ(plain.exit_code, 0) << plain.output;
    ASSERT_EQ(with.exit_code, 0) << with.output;
    auto json = nlohmann::json::parse(with.output);
    EXPECT_EQ(json["alignment"]["source"], est_.string());
    EXPECT_EQ(json["alignment"]["pairs"], 150);
    json.erase("alignment");
    const auto plain_json = nlohmann::json::parse(plain.output);
    EXPECT_FALSE(plain_json.contains("alignment"));
    EXPECT_EQ(json.dump(), plain_json.dump());  // Numbers at full precision.
    EXPECT_GT(plain_json["ate_m"]["rmse"].get<double>(), 0.005);
    for (const char* file : {"pairs.txt", "aligned.txt"}) {
      EXPECT_EQ(DataLines(fs::path(with_dir) / file), DataLines(fs::path(plain_dir) / file))
          << file;
    }
  }
}

TEST_F(EvalTool, AteAlignWithReportsTheOffsetOfALocalizationRun) {
  // Mapping run A: all 150 poses in the map frame. Localization run B: the
  // last 60, 10 cm off in the map frame.
  const Trajectory a = Moved(MakeGroundTruth(150), 0.004);
  Trajectory b(a.begin() + 90, a.end());
  for (StampedPose& pose : b) pose.T_world_cam.translation += Eigen::Vector3d(0, 0.06, 0.08);
  const fs::path a_path = dir_ / "mapping.txt";
  WriteTumTrajectory(a_path, a);
  WriteTumTrajectory(est_, b);

  auto r = RunStdout("ate --json " + Inputs());  // Aligned by itself B looks perfect.
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_LT(nlohmann::json::parse(r.output)["ate_m"]["max"].get<double>(), 1e-6);

  const fs::path pairs = dir_ / "pairs.txt";
  r = RunStdout("ate --json " + Inputs() + " --align-with " + Quote(a_path) +
                " --save-associations " + Quote(pairs));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto json = nlohmann::json::parse(r.output);
  EXPECT_EQ(json["pairs"], 60);
  EXPECT_EQ(json["est_poses"], 60);
  EXPECT_EQ(json["alignment"]["source"], a_path.string());
  EXPECT_EQ(json["alignment"]["pairs"], 150);
  // TUM files carry 9 significant decimals; 1e-6 leaves room for that.
  for (const char* stat : {"rmse", "mean", "median", "min", "max"}) {
    EXPECT_NEAR(json["ate_m"][stat].get<double>(), 0.1, 1e-6) << stat;
  }
  // The pairs are B's, aligned as A; the header records the option.
  const std::string pairs_text = ReadFileToString(pairs);
  EXPECT_EQ(std::count(pairs_text.begin(), pairs_text.end(), '\n'), 60 + 2);
  EXPECT_NE(pairs_text.find("\"align_with\""), std::string::npos);

  const auto text = RunTool("eval", "ate " + Inputs() + " --align-with " + Quote(a_path));
  ASSERT_EQ(text.exit_code, 0) << text.output;
  EXPECT_NE(text.output.find("compared_pose_pairs 60 pairs\n"), std::string::npos) << text.output;
  EXPECT_NE(text.output.find("absolute_translational_error.rmse 0.100000 m\n"), std::string::npos)
      << text.output;
  EXPECT_NE(text.output.find("alignment_source " + a_path.string() + "\n"), std::string::npos)
      << text.output;
  EXPECT_NE(text.output.find("alignment_pose_pairs 150 pairs\n"), std::string::npos) << text.output;
}

TEST_F(EvalTool, AteAlignWithErrors) {
  // A missing file is 66 and named.
  auto r = RunTool("eval", "ate " + Inputs() + " --align-with " + Quote(dir_ / "no_map.txt"));
  EXPECT_EQ(r.exit_code, 66) << r.output;
  EXPECT_NE(r.output.find("no_map.txt"), std::string::npos) << r.output;
  // Fewer than 3 pairs with the ground truth is 65, naming the flag and the file.
  const fs::path two = dir_ / "two.txt";
  WriteTumTrajectory(two, Moved(MakeGroundTruth(2)));
  r = RunTool("eval", "ate " + Inputs() + " --align-with " + Quote(two));
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find("--align-with"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("two.txt"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("at least 3"), std::string::npos) << r.output;
  // No stamps of it near the ground truth's: 65.
  r = RunTool("eval", "ate " + Inputs() + " --align-with " + Quote(two) + " --offset 50");
  EXPECT_EQ(r.exit_code, 65) << r.output;
  // Under that alignment the estimate needs only one pair, but not none.
  WriteTumTrajectory(est_, Moved(MakeGroundTruth(1)));
  const fs::path map = dir_ / "map.txt";
  WriteTumTrajectory(map, Moved(MakeGroundTruth(150)));
  r = RunTool("eval", "ate " + Inputs() + " --align-with " + Quote(map));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("compared_pose_pairs 1 pairs"), std::string::npos) << r.output;
  Trajectory late = Moved(MakeGroundTruth(5));
  for (StampedPose& pose : late) pose.timestamp += 100;
  WriteTumTrajectory(est_, late);
  r = RunTool("eval", "ate " + Inputs() + " --align-with " + Quote(map));
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find("no stamps matched"), std::string::npos) << r.output;
  // An output may not overwrite it.
  r = RunTool("eval",
              "ate " + Inputs() + " --align-with " + Quote(map) + " --save-aligned " + Quote(map));
  EXPECT_EQ(r.exit_code, 64) << r.output;
  EXPECT_NE(r.output.find("--align-with"), std::string::npos) << r.output;
  EXPECT_EQ(ReadTumTrajectory(map).size(), 150u);
}

TEST_F(EvalTool, HelpListsFlagsWithDefaults) {
  const auto r = RunTool("eval", "ate --help");
  EXPECT_EQ(r.exit_code, 0);
  for (const char* text :
       {"--max-diff", "0.02", "--offset", "--scale", "--plot", "--json", "--save-associations",
        "--save-aligned", "--plot-axes", "--correct-scale", "--align-with"}) {
    EXPECT_NE(r.output.find(text), std::string::npos) << text;
  }
  const auto rpe = RunTool("eval", "rpe --help");
  for (const char* text : {"--delta", "--delta-unit", "--error-form", "--max-diff"}) {
    EXPECT_NE(rpe.output.find(text), std::string::npos) << text;
  }
}

// Real TUM data: fr1_desk ground truth (2335 poses at 100 Hz).
TEST(EvalToolSharedData, Fr1DeskGroundTruthAgainstItself) {
  RRSLAM_REQUIRE_SHARED_DATA(data_dir);
  const fs::path gt_path = data_dir / "tum" / "fr1_desk" / "groundtruth.txt";
  if (!fs::exists(gt_path)) GTEST_SKIP() << gt_path << " absent";
  testing::TempDir dir;
  const Trajectory gt = ReadTumTrajectory(gt_path);
  ASSERT_EQ(gt.size(), 2335u);

  // The whole ground truth, rigidly moved: every stamp pairs, ATE ~0.
  WriteTumTrajectory(dir / "moved.txt", Moved(gt));
  auto r = RunStdout("ate --json --gt " + Quote(gt_path) + " --est " + Quote(dir / "moved.txt"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto json = nlohmann::json::parse(r.output);
  EXPECT_EQ(json["pairs"], 2335);
  EXPECT_LT(json["ate_m"]["rmse"].get<double>(), 1e-6);
  EXPECT_LT(json["ate_m"]["max"].get<double>(), 1e-6);

  // The 9 RGB frames of rgb.txt with the poses of the ground-truth stamps
  // nearest to them, found by hand in groundtruth.txt (|difference| in ms).
  const std::vector<std::pair<double, double>> frames = {
      {1305031453.359684, 1305031453.3595},  // 0.184
      {1305031453.391690, 1305031453.3894},  // 2.290
      {1305031453.423683, 1305031453.4195},  // 4.183
      {1305031453.459685, 1305031453.4595},  // 0.185
      {1305031453.491698, 1305031453.4895},  // 2.198
      {1305031453.523684, 1305031453.5195},  // 4.184
      {1305031453.559753, 1305031453.5595},  // 0.253
      {1305031453.591640, 1305031453.5899},  // 1.740
      {1305031453.627706, 1305031453.6295},  // 1.794
  };
  Trajectory est;
  for (const auto& [rgb_stamp, gt_stamp] : frames) {
    const auto it = std::find_if(gt.begin(), gt.end(),
                                 [&](const StampedPose& p) { return p.timestamp == gt_stamp; });
    ASSERT_NE(it, gt.end()) << gt_stamp;
    est.push_back({rgb_stamp, it->T_world_cam});
  }
  WriteTumTrajectory(dir / "rgb_poses.txt", Moved(est));
  const fs::path pairs = dir / "pairs.txt";
  r = RunStdout("ate --json --gt " + Quote(gt_path) + " --est " + Quote(dir / "rgb_poses.txt") +
                " --save-associations " + Quote(pairs));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  json = nlohmann::json::parse(r.output);
  EXPECT_EQ(json["pairs"], 9);
  EXPECT_LT(json["ate_m"]["rmse"].get<double>(), 1e-6);
  std::istringstream lines(ReadFileToString(pairs));
  std::string line;
  size_t k = 0;
  while (std::getline(lines, line)) {
    if (line.empty() || line[0] == '#') continue;
    ASSERT_LT(k, frames.size());
    EXPECT_NEAR(std::stod(line), frames[k].second, 1e-6) << k;  // The gt stamp column.
    ++k;
  }
  EXPECT_EQ(k, frames.size());

  // Within 2 ms only the frames at 0.184, 0.185, 0.253, 1.740 and 1.794 ms pair.
  r = RunStdout("ate --json --max-diff 0.002 --gt " + Quote(gt_path) + " --est " +
                Quote(dir / "rgb_poses.txt"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(nlohmann::json::parse(r.output)["pairs"], 5);
}

}  // namespace
}  // namespace rrslam
