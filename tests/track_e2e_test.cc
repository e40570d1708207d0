// End to end: rrslam-synth renders a short room loop; a vocabulary is trained
// on it (rrslam-extract -> rrslam-cluster -> rrslam-vocab build); rrslam-track
// tracks it in batch mode (twice, from images, and once from the features
// file) and in realtime mode; rrslam-eval ate scores the trajectories. The
// same for a short fast hand-held shake (motion blur, jerky rotation), and a
// kidnapped camera that must relocalize.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "common/atomic_file.h"
#include "common/dataset.h"
#include "common/image_io.h"
#include "common/testing.h"
#include "common/text.h"
#include "common/trajectory.h"
#include "tests/room_pipeline.h"

namespace rrslam {
namespace {

namespace fs = std::filesystem;

using testing::Quote;

constexpr int kFrames = 120;

// ATE RMSE (metres) of a trajectory against the ground truth, which must
// pair `frames` poses.
double AteRmseAgainst(const fs::path& groundtruth, const fs::path& trajectory, int frames) {
  const auto r = testing::RunTool(
      "eval", "ate --json --gt " + Quote(groundtruth) + " --est " + Quote(trajectory));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  const size_t brace = r.output.find('{');
  if (brace == std::string::npos) return 1e9;
  const nlohmann::json j =
      nlohmann::json::parse(r.output.substr(brace, r.output.rfind('}') - brace + 1));
  EXPECT_EQ(j.at("pairs").get<int>(), frames);
  return j.at("ate_m").at("rmse").get<double>();
}

class TrackPipelineTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir();
    testing::PrepareRoomSequence(
        dir_->path(), "--trajectory loop --frames " + std::to_string(kFrames) + " --seed 3");
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static fs::path path(const std::string& name) { return dir_->path() / name; }
  static fs::path seq() { return path("room"); }
  static fs::path settings() { return seq() / "settings.yaml"; }
  static fs::path features() { return path("room.h5"); }
  static fs::path vocab() { return path("room.rrv"); }

  static testing::CommandResult Track(const fs::path& out, const std::string& extra = "") {
    return testing::RunTool("track", "--quiet --sequence " + Quote(seq()) + " --settings " +
                                         Quote(settings()) + " --vocab " + Quote(vocab()) +
                                         " --out " + Quote(out) + " " + extra);
  }
  static double AteRmse(const fs::path& trajectory) {
    return AteRmseAgainst(seq() / "groundtruth.txt", trajectory, kFrames);
  }

  static testing::TempDir* dir_;
};
testing::TempDir* TrackPipelineTest::dir_ = nullptr;

TEST_F(TrackPipelineTest, BatchModeIsAccurateAndBitIdentical) {
  const auto first = Track(path("batch1"));
  ASSERT_EQ(first.exit_code, 0) << first.output;
  const auto second = Track(path("batch2"));
  ASSERT_EQ(second.exit_code, 0) << second.output;

  const std::string trajectory = ReadFileToString(path("batch1") / "CameraTrajectory.txt");
  EXPECT_EQ(trajectory, ReadFileToString(path("batch2") / "CameraTrajectory.txt"));
  EXPECT_EQ(ReadFileToString(path("batch1") / "KeyFrameTrajectory.txt"),
            ReadFileToString(path("batch2") / "KeyFrameTrajectory.txt"));

  // Every frame tracked, in TUM format, and accurate.
  EXPECT_EQ(std::count(trajectory.begin(), trajectory.end(), '\n'), kFrames);
  EXPECT_LT(AteRmse(path("batch1") / "CameraTrajectory.txt"), 0.02);

  const nlohmann::json run = nlohmann::json::parse(ReadFileToString(path("batch1") / "run.json"));
  EXPECT_EQ(run.at("counts").at("frames").get<int>(), kFrames);
  EXPECT_EQ(run.at("counts").at("tracked").get<int>(), kFrames);
  EXPECT_EQ(run.at("counts").at("lost").get<int>(), 0);
  EXPECT_GT(run.at("counts").at("keyframes").get<int>(), 1);
  EXPECT_GT(run.at("counts").at("map_points").get<int>(), 100);
  EXPECT_TRUE(run.at("lost_timestamps").empty());
  EXPECT_NE(run.at("vocabulary").get<std::string>().find("room.rrv"), std::string::npos);
  EXPECT_EQ(run.at("options").at("mode").get<std::string>(), "batch");
  EXPECT_EQ(run.at("producer").get<std::string>().rfind("rrslam-track ", 0), 0u);
  EXPECT_EQ(run.at("timings").at("tracking").at("count").get<int>(), kFrames);
  EXPECT_GT(run.at("timings").at("tracking").at("median_ms").get<double>(), 0.0);
  EXPECT_GT(run.at("timings").at("local_mapping").at("count").get<int>(), 0);
  const std::string keyframes = ReadFileToString(path("batch1") / "KeyFrameTrajectory.txt");
  EXPECT_EQ(std::count(keyframes.begin(), keyframes.end(), '\n'),
            run.at("counts").at("keyframes").get<int>());
}

TEST_F(TrackPipelineTest, FeaturesFileGivesTheSameTrajectoryAsImages) {
  ASSERT_EQ(Track(path("images")).exit_code, 0);
  const auto r = Track(path("cached"), "--features " + Quote(features()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(ReadFileToString(path("images") / "CameraTrajectory.txt"),
            ReadFileToString(path("cached") / "CameraTrajectory.txt"));
}

TEST_F(TrackPipelineTest, RealtimeModeTracksEveryFrame) {
  const auto r = Track(path("realtime"), "--mode realtime");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json run = nlohmann::json::parse(ReadFileToString(path("realtime") / "run.json"));
  EXPECT_EQ(run.at("counts").at("tracked").get<int>(), kFrames);
  EXPECT_LT(AteRmse(path("realtime") / "CameraTrajectory.txt"), 0.02);
}

TEST_F(TrackPipelineTest, MaxFramesTracksAPrefix) {
  const auto r = Track(path("prefix"), "--max-frames 30");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string prefix = ReadFileToString(path("prefix") / "CameraTrajectory.txt");
  EXPECT_EQ(std::count(prefix.begin(), prefix.end(), '\n'), 30);
}

// Fast hand-held rotation with motion blur (rrslam-synth --trajectory shake,
// 2 to 4 degrees per frame): every frame tracked, ATE under 2 cm.
TEST_F(TrackPipelineTest, TracksAFastShakeWithMotionBlur) {
  constexpr int kShakeFrames = 60;
  testing::TempDir shake;
  testing::PrepareRoomSequence(
      shake.path(), "--trajectory shake --frames " + std::to_string(kShakeFrames) + " --seed 2");
  const fs::path seq = shake.path() / "room", out = shake.path() / "track";
  const auto r = testing::RunTool(
      "track", "--quiet --sequence " + Quote(seq) + " --settings " + Quote(seq / "settings.yaml") +
                   " --vocab " + Quote(shake.path() / "room.rrv") + " --out " + Quote(out));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json run = nlohmann::json::parse(ReadFileToString(out / "run.json"));
  EXPECT_EQ(run.at("counts").at("tracked").get<int>(), kShakeFrames);
  EXPECT_LT(AteRmseAgainst(seq / "groundtruth.txt", out / "CameraTrajectory.txt", kShakeFrames),
            0.02);
}

// A kidnapped camera: frames 0-79 of the loop, three black frames (the lens
// covered), then frames 20-59 again with later timestamps. The black frames
// are lost; the first frame after them is relocalized in the map, and every
// other frame gets a pose in the first part's world frame.
TEST_F(TrackPipelineTest, KidnappedCameraIsRelocalized) {
  const RgbdSequence room = RgbdSequence::Open(seq());
  const Trajectory gt = ReadTumTrajectory(seq() / "groundtruth.txt");
  ASSERT_EQ(room.size(), static_cast<size_t>(kFrames));
  const fs::path kid = path("kidnapped");
  fs::create_directories(kid / "rgb");
  fs::create_directories(kid / "depth");
  std::ofstream rgb_list(kid / "rgb.txt"), depth_list(kid / "depth.txt");
  Trajectory kid_gt;
  std::vector<int> order;
  for (int i = 0; i < 80; ++i) order.push_back(i);
  for (int i = 0; i < 3; ++i) order.push_back(-1);
  for (int i = 20; i < 60; ++i) order.push_back(i);
  for (size_t k = 0; k < order.size(); ++k) {
    const double t = 1000 + k / 30.0;
    const std::string name = std::to_string(k) + ".png";
    const int i = order[k];
    const RgbdFrameRef& f = room.frame(i < 0 ? 0 : i);
    if (i < 0) {
      WritePng(kid / "rgb" / name, cv::Mat::zeros(240, 320, CV_8UC3));
    } else {
      fs::copy_file(f.rgb_path, kid / "rgb" / name);
      kid_gt.push_back({t, gt[i].T_world_cam});
    }
    fs::copy_file(f.depth_path, kid / "depth" / name);
    rgb_list << std::fixed << t << " rgb/" << name << "\n";
    depth_list << std::fixed << t << " depth/" << name << "\n";
  }
  rgb_list.close();
  depth_list.close();
  testing::WriteTextFile(kid / "groundtruth.txt", FormatTumTrajectory(kid_gt));

  const fs::path out = path("kidnapped-track");
  const auto r = testing::RunTool("track", "--quiet --sequence " + Quote(kid) + " --settings " +
                                               Quote(settings()) + " --vocab " + Quote(vocab()) +
                                               " --out " + Quote(out));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json run = nlohmann::json::parse(ReadFileToString(out / "run.json"));
  EXPECT_EQ(run.at("counts").at("lost").get<int>(), 3);  // The black frames only.
  EXPECT_EQ(run.at("counts").at("relocalizations").get<int>(), 1);
  EXPECT_GE(run.at("timings").at("relocalization").at("count").get<int>(), 1);
  EXPECT_LT(AteRmseAgainst(kid / "groundtruth.txt", out / "CameraTrajectory.txt", 120), 0.02);
}

}  // namespace
}  // namespace rrslam
