// rrslam-track on bad inputs: exit codes, one-line messages naming the file,
// and no output left behind.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <regex>
#include <sstream>

#include "common/atomic_file.h"
#include "common/binary_header.h"
#include "common/settings.h"
#include "common/testing.h"
#include "stages/extract/features_file.h"
#include "stages/track/test_scene.h"
#include "stages/track/track.h"

namespace rrslam {
namespace {

namespace fs = std::filesystem;
using ::rrslam::testing::RunTool;
using ::rrslam::testing::TempDir;
using ::rrslam::testing::WriteTextFile;

// A TUM-layout sequence of `frames` frames of a blurred random texture, with
// constant depth `depth_raw` (depth units; 0 = none), 640 x 480. From frame
// `cut` on (if >= 0) the camera sees another, unrelated texture, with depth
// `depth_after_cut` when it is given (>= 0).
void WriteSequence(const fs::path& dir, int frames, uint16_t depth_raw, int cut = -1,
                   int depth_after_cut = -1) {
  fs::create_directories(dir / "rgb");
  fs::create_directories(dir / "depth");
  auto make_texture = [](uint64_t seed) {
    cv::Mat texture(480, 640, CV_8UC3);
    cv::RNG rng(seed);
    rng.fill(texture, cv::RNG::UNIFORM, 0, 255);
    cv::GaussianBlur(texture, texture, cv::Size(5, 5), 1.5);
    return texture;
  };
  const cv::Mat texture = make_texture(5), other = make_texture(6);
  const cv::Mat depth(480, 640, CV_16UC1, cv::Scalar(depth_raw));
  const cv::Mat depth_cut(480, 640, CV_16UC1,
                          cv::Scalar(depth_after_cut >= 0 ? depth_after_cut : depth_raw));
  std::ofstream rgb_list(dir / "rgb.txt"), depth_list(dir / "depth.txt");
  rgb_list << "# timestamp filename\n";
  depth_list << "# timestamp filename\n";
  for (int i = 0; i < frames; ++i) {
    const std::string name = std::to_string(i) + ".png";
    cv::imwrite((dir / "rgb" / name).string(), cut >= 0 && i >= cut ? other : texture);
    cv::imwrite((dir / "depth" / name).string(), cut >= 0 && i >= cut ? depth_cut : depth);
    rgb_list << 100 + 0.05 * i << " rgb/" << name << "\n";
    depth_list << 100 + 0.05 * i << " depth/" << name << "\n";
  }
  WriteSettings(dir / "settings.yaml", testing::TestSettings());
}

class TrackToolTest : public ::testing::Test {
 protected:
  void SetUp() override {
    WriteSequence(dir_ / "seq", 3, 10000);
    WriteTextFile(dir_ / "voc.txt", testing::HundredWordVocabularyText());
  }

  // Runs rrslam-track with the given overrides of the default arguments.
  ::rrslam::testing::CommandResult Track(const std::string& sequence, const std::string& settings,
                                         const std::string& vocab, const std::string& extra = "") {
    return RunTool("track", "--sequence " + sequence + " --settings " + settings + " --vocab " +
                                vocab + " --out " + out().string() + " -q " + extra);
  }
  fs::path out() const { return dir_ / "out"; }
  std::string Seq() const { return (dir_ / "seq").string(); }
  std::string SettingsFile() const { return (dir_ / "seq" / "settings.yaml").string(); }
  std::string Voc() const { return (dir_ / "voc.txt").string(); }

  TempDir dir_;
};

TEST_F(TrackToolTest, BadOptionsAreUsageErrors) {
  EXPECT_EQ(Track(Seq(), SettingsFile(), Voc(), "--mode fast").exit_code, 64);
  EXPECT_EQ(Track(Seq(), SettingsFile(), Voc(), "--max-frames 1").exit_code, 64);
  EXPECT_EQ(Track(Seq(), SettingsFile(), Voc(), "--first-frame -1").exit_code, 64);
  EXPECT_EQ(Track(Seq(), SettingsFile(), Voc(), "--localization-only").exit_code, 64);
  EXPECT_EQ(Track(Seq(), SettingsFile(), Voc(), "--changed-point-ratio 1.5").exit_code, 64);
  EXPECT_EQ(Track(Seq(), SettingsFile(), Voc(), "--changed-point-views -2").exit_code, 64);
  EXPECT_EQ(Track(Seq(), SettingsFile(), Voc(), "--restore-point-found -1").exit_code, 64);
  EXPECT_EQ(RunTool("track", "--sequence " + Seq()).exit_code, 64);  // Missing flags.
  EXPECT_FALSE(fs::exists(out()));
  const auto help = RunTool("track", "--help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.output.find("--mode TEXT=batch"), std::string::npos) << help.output;
  EXPECT_NE(help.output.find("75"), std::string::npos);
}

TEST_F(TrackToolTest, MissingInputsExit66) {
  EXPECT_EQ(Track((dir_ / "nowhere").string(), SettingsFile(), Voc()).exit_code, 66);
  EXPECT_EQ(Track(Seq(), (dir_ / "none.yaml").string(), Voc()).exit_code, 66);
  const auto r = Track(Seq(), SettingsFile(), (dir_ / "none.rrv").string());
  EXPECT_EQ(r.exit_code, 66);
  EXPECT_NE(r.output.find("none.rrv"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out()));
}

TEST_F(TrackToolTest, SettingsWithoutIntrinsicsExit65) {
  WriteTextFile(dir_ / "bad.yaml", "%YAML:1.0\nCamera.fx: 500.0\nCamera.fy: 500.0\n");
  const auto r = Track(Seq(), (dir_ / "bad.yaml").string(), Voc());
  EXPECT_EQ(r.exit_code, 65);
  EXPECT_NE(r.output.find("Camera.cx"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out()));
}

TEST_F(TrackToolTest, EmptyOrTooShortSequencesExit65) {
  WriteSequence(dir_ / "one", 1, 10000);
  const auto r = Track((dir_ / "one").string(), SettingsFile(), Voc());
  EXPECT_EQ(r.exit_code, 65);
  EXPECT_NE(r.output.find("at least 2"), std::string::npos) << r.output;
  fs::create_directories(dir_ / "empty");
  WriteTextFile(dir_ / "empty" / "rgb.txt", "# nothing\n");
  WriteTextFile(dir_ / "empty" / "depth.txt", "# nothing\n");
  EXPECT_EQ(Track((dir_ / "empty").string(), SettingsFile(), Voc()).exit_code, 65);
  EXPECT_FALSE(fs::exists(out()));
}

TEST_F(TrackToolTest, VocabularyOfAnotherDescriptorExit65) {
  // A DBoW2 text vocabulary of 64-float (SURF) descriptors is not an ORB one.
  std::string surf = "2 1  0 0\n";
  for (int n = 0; n < 2; ++n) {
    surf += "0 1 ";
    for (int i = 0; i < 64; ++i) surf += "0.125 ";
    surf += " 1\n";
  }
  WriteTextFile(dir_ / "surf.txt", surf);
  const auto r = Track(Seq(), SettingsFile(), (dir_ / "surf.txt").string());
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find("surf.txt"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out()));
}

TEST_F(TrackToolTest, AllZeroDepthCannotInitializeExit75) {
  WriteSequence(dir_ / "nodepth", 3, 0);
  const auto r = Track((dir_ / "nodepth").string(), SettingsFile(), Voc());
  EXPECT_EQ(r.exit_code, 75) << r.output;
  EXPECT_NE(r.output.find("never initialized"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out()));
  EXPECT_EQ(testing::TemporaryLeftovers(dir_), std::vector<std::string>{});
}

// ORB-SLAM2's reset: lost with at most 5 keyframes in the map, the map is
// discarded and the next frame initializes a new one. Frames 0-1 see one
// texture, frames 2-5 another: frame 2 is lost, frame 3 starts a new map.
TEST_F(TrackToolTest, LostSoonAfterInitializationResetsTheMap) {
  WriteSequence(dir_ / "cut", 6, 10000, 2);
  const auto r = Track((dir_ / "cut").string(), SettingsFile(), Voc());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json run = nlohmann::json::parse(ReadFileToString(out() / "run.json"));
  EXPECT_EQ(run.at("counts").at("resets").get<int>(), 1);
  // Frames 0-1 were tracked on the discarded map: lost, as frame 2.
  EXPECT_EQ(run.at("counts").at("tracked").get<int>(), 3);
  EXPECT_EQ(run.at("counts").at("lost").get<int>(), 3);
  EXPECT_EQ(run.at("counts").at("keyframes").get<int>(), 1);
}

TEST_F(TrackToolTest, LoopClosingIsOnByDefaultAndCanBeTurnedOff) {
  const auto help = RunTool("track", "--help");
  EXPECT_NE(help.output.find("--no-loop-closing "), std::string::npos) << help.output;
  ASSERT_EQ(Track(Seq(), SettingsFile(), Voc()).exit_code, 0);
  nlohmann::json run = nlohmann::json::parse(ReadFileToString(out() / "run.json"));
  EXPECT_TRUE(run.at("options").at("loop_closing").get<bool>());
  EXPECT_TRUE(run.at("loop_closing").at("enabled").get<bool>());
  EXPECT_EQ(run.at("counts").at("loop_closures").get<int>(), 0);
  EXPECT_TRUE(run.at("loop_closing").at("loops").empty());
  ASSERT_EQ(Track(Seq(), SettingsFile(), Voc(), "--no-loop-closing").exit_code, 0);
  run = nlohmann::json::parse(ReadFileToString(out() / "run.json"));
  EXPECT_FALSE(run.at("options").at("loop_closing").get<bool>());
  EXPECT_FALSE(run.at("loop_closing").at("enabled").get<bool>());
  EXPECT_EQ(run.at("loop_closing").at("keyframes_checked").get<int>(), 0);
}

TEST_F(TrackToolTest, FailureKeepsAnExistingOutputFolder) {
  // An output of an older rrslam-track (no .rrslam-output marker): its
  // files, with run.json naming the tool.
  fs::create_directories(out());
  WriteTextFile(out() / "CameraTrajectory.txt", "previous\n");
  WriteTextFile(out() / "run.json", "{\"producer\": \"rrslam-track 0.1\"}\n");
  WriteSequence(dir_ / "nodepth", 3, 0);
  EXPECT_EQ(Track((dir_ / "nodepth").string(), SettingsFile(), Voc()).exit_code, 75);
  std::ifstream in(out() / "CameraTrajectory.txt");
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "previous");
}

// Issue 36: --out is replaced only when it is empty or an earlier output of
// rrslam-track; a folder holding anything else is refused before tracking.
TEST_F(TrackToolTest, OutputFolderWithOtherFilesIsRefusedAndKept) {
  fs::create_directories(out() / "older");
  WriteTextFile(out() / "notes.txt", "my notes\n");
  WriteTextFile(out() / "older" / "run.json", "{}\n");
  auto r = Track(Seq(), SettingsFile(), Voc());
  EXPECT_EQ(r.exit_code, 73) << r.output;
  EXPECT_NE(r.output.find(out().string() + ": holds files rrslam-track did not write (notes.txt)"),
            std::string::npos)
      << r.output;
  EXPECT_EQ(ReadFileToString(out() / "notes.txt"), "my notes\n");
  EXPECT_EQ(ReadFileToString(out() / "older" / "run.json"), "{}\n");
  EXPECT_FALSE(fs::exists(out() / "run.json"));
  EXPECT_EQ(testing::TemporaryLeftovers(dir_), std::vector<std::string>{});

  // Emptied, it is replaced; a rerun replaces the run's own output.
  fs::remove(out() / "notes.txt");
  fs::remove_all(out() / "older");
  ASSERT_EQ(Track(Seq(), SettingsFile(), Voc()).exit_code, 0);
  r = Track(Seq(), SettingsFile(), Voc());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(out() / "run.json"));
}

TEST_F(TrackToolTest, FeaturesFileMustMatchSequenceAndSettings) {
  // Three frames of the sequence with a few keypoints each.
  auto write_features = [&](const fs::path& path, const std::string& settings_yaml,
                            const std::string& first_rgb) {
    FeaturesFile features;
    features.settings_yaml = settings_yaml;
    std::mt19937 rng(1);
    for (int i = 0; i < 3; ++i) {
      FrameRecord record;
      record.rgb_timestamp = 100 + 0.05 * i;
      record.depth_timestamp = record.rgb_timestamp;
      record.rgb_path =
          i == 0 ? first_rgb : (dir_ / "seq" / "rgb" / (std::to_string(i) + ".png")).string();
      record.depth_path = (dir_ / "seq" / "depth" / (std::to_string(i) + ".png")).string();
      if (fs::exists(record.rgb_path)) record.rgb_checksum = FileChecksum64(record.rgb_path);
      record.depth_checksum = FileChecksum64(record.depth_path);
      std::vector<Keypoint> kps(10);
      std::vector<OrbDescriptor> ds(10);
      for (auto& d : ds) d = testing::RandomDescriptor(rng);
      features.AddFrame(record, kps, ds);
    }
    WriteFeaturesFile(path, features, "test", nlohmann::json::object());
  };
  const std::string yaml = FormatSettings(testing::TestSettings());
  const std::string rgb0 = (dir_ / "seq" / "rgb" / "0.png").string();

  write_features(dir_ / "other_frames.h5", yaml, (dir_ / "seq" / "rgb" / "7.png").string());
  auto r = Track(Seq(), SettingsFile(), Voc(), "--features " + (dir_ / "other_frames.h5").string());
  EXPECT_EQ(r.exit_code, 65);
  EXPECT_NE(r.output.find("is not a frame of sequence"), std::string::npos) << r.output;

  Settings other = testing::TestSettings();
  other.fx = 520;
  write_features(dir_ / "other_settings.h5", FormatSettings(other), rgb0);
  r = Track(Seq(), SettingsFile(), Voc(), "--features " + (dir_ / "other_settings.h5").string());
  EXPECT_EQ(r.exit_code, 65);
  EXPECT_NE(r.output.find("Camera.fx"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out()));
  // The extractor's own settings too (issue 36: nFeatures 999 was accepted).
  other = testing::TestSettings();
  other.orb.n_features -= 1;
  write_features(dir_ / "other_orb.h5", FormatSettings(other), rgb0);
  r = Track(Seq(), SettingsFile(), Voc(), "--features " + (dir_ / "other_orb.h5").string());
  EXPECT_EQ(r.exit_code, 65);
  EXPECT_NE(r.output.find("extracted with ORBextractor.nFeatures = " +
                          std::to_string(other.orb.n_features) + " but"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(out()));

  // Matching frames and settings are accepted (tracking then fails to
  // initialize: ten keypoints without depth).
  write_features(dir_ / "good.h5", yaml, rgb0);
  r = Track(Seq(), SettingsFile(), Voc(), "--features " + (dir_ / "good.h5").string());
  EXPECT_EQ(r.exit_code, 75) << r.output;
}

// The features of another sequence whose files have the same names and
// timestamps (every synthetic sequence's) were tracked without a word:
// extract records the images' checksums and track compares them.
TEST_F(TrackToolTest, FeaturesOfAnotherSequenceWithTheSameFileNames) {
  WriteSequence(dir_ / "a", 4, 10000);
  WriteSequence(dir_ / "b", 4, 10000, 0);  // Other colour images, the same depth.
  WriteSequence(dir_ / "c", 4, 12000);     // The same colour images, other depth.
  const fs::path features = dir_ / "a.h5";
  ASSERT_EQ(RunTool("extract", "-q --sequence " + (dir_ / "a").string() + " --settings " +
                                   (dir_ / "a" / "settings.yaml").string() + " --out " +
                                   features.string())
                .exit_code,
            0);
  for (const auto& [seq, file] : {std::pair{"b", "rgb"}, std::pair{"c", "depth"}}) {
    const fs::path dir = dir_ / seq;
    const auto r = Track(dir.string(), (dir / "settings.yaml").string(), Voc(),
                         "--features " + features.string());
    EXPECT_EQ(r.exit_code, 65) << r.output;
    EXPECT_NE(
        r.output.find(features.string() + ": frame 0 was extracted from other image bytes than " +
                      (dir / file / "0.png").string()),
        std::string::npos)
        << r.output;
    EXPECT_FALSE(fs::exists(out()));
  }
  const auto r = Track((dir_ / "a").string(), (dir_ / "a" / "settings.yaml").string(), Voc(),
                       "--features " + features.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

// --first-frame with --features tracks the features of the frames it names:
// the features of frame k were those of the file's k-th frame counted from
// --first-frame (frame 0's on a cold start at frame N), so a cold start on a
// map from cached features got the first frame's pose. The sequence shows
// another texture without depth from frame 6 on; starting there, the
// features run must
// fail as the images run does: those frames have no depth.
TEST_F(TrackToolTest, FirstFrameWithFeaturesUsesThatFramesFeatures) {
  WriteSequence(dir_ / "cut", 12, 10000, 6, 0);
  const std::string seq = (dir_ / "cut").string();
  const std::string settings = (dir_ / "cut" / "settings.yaml").string();
  const fs::path features = dir_ / "cut.h5";
  ASSERT_EQ(RunTool("extract", "-q --sequence " + seq + " --settings " + settings + " --out " +
                                   features.string())
                .exit_code,
            0);
  EXPECT_EQ(Track(seq, settings, Voc(), "--first-frame 6").exit_code, 75);
  const auto r = Track(seq, settings, Voc(), "--first-frame 6 --features " + features.string());
  EXPECT_EQ(r.exit_code, 75) << r.output;
  EXPECT_NE(r.output.find("tracking never initialized"), std::string::npos) << r.output;
}

// Issue 36: folder names in Latin-1 (legal on Linux, not UTF-8) made run.json
// and the saved map's metadata fail with nlohmann's type_error 316 (exit 70).
// They are written quoted (common/json_text.h) and the run succeeds; the map
// saved there loads again and `rrslam-mapstore info --json` shows it.
TEST_F(TrackToolTest, FolderNamesThatAreNotUtf8) {
  const fs::path dir = dir_ / "caf\xe9";
  WriteSequence(dir / "seq", 3, 10000);
  const std::string common = "--sequence " + testing::Quote(dir / "seq") + " --settings " +
                             testing::Quote(dir / "seq" / "settings.yaml") + " --vocab " +
                             testing::Quote(dir_ / "voc.txt") + " -q";
  auto r = RunTool("track", common + " --out " + testing::Quote(dir / "out") + " --save-map " +
                                testing::Quote(dir / "m.rrm"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string run_json = ReadFileToString(dir / "out" / "run.json");
  EXPECT_TRUE(nlohmann::json::parse(run_json, nullptr, false).is_object());
  EXPECT_NE(run_json.find("caf\\\\351"), std::string::npos) << run_json;
  r = RunTool("track", common + " --out " + testing::Quote(dir / "out2") + " --load-map " +
                           testing::Quote(dir / "m.rrm"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  r = RunTool("mapstore", "info --json " + testing::Quote(dir / "m.rrm") + " 2>/dev/null");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(nlohmann::json::parse(r.output)["metadata"].is_object()) << r.output;
}

// Issue 36: images larger than the settings' Camera.width x Camera.height
// were tracked with the wrong calibration; they are refused from the image
// header (exit 65, naming the file and both sizes).
TEST_F(TrackToolTest, ImagesLargerThanTheSettingsExit65) {
  Settings small = testing::TestSettings();
  small.width = 320;
  small.height = 240;
  WriteSettings(dir_ / "small.yaml", small);
  const auto r = Track(Seq(), (dir_ / "small.yaml").string(), Voc());
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find("0.png: image is 640x480, larger than 320x240 (Camera.width x "
                          "Camera.height of " +
                          (dir_ / "small.yaml").string() + ")"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(out()));
}

// Found in review (issue 36): `--mode realtime --pace` slept through a
// 1000 s gap in the timestamps. A gap longer than --max-pace-gap (1 s by
// default) is now paced as that long, and a warning at start names the
// largest gap and where it is.
TEST_F(TrackToolTest, PaceCapsLongGapsBetweenTimestamps) {
  WriteSequence(dir_ / "gap", 3, 10000);
  for (const char* list : {"rgb", "depth"}) {
    const std::string folder = list;
    WriteTextFile(dir_ / "gap" / (folder + ".txt"), "# timestamp filename\n100 " + folder +
                                                        "/0.png\n100.05 " + folder +
                                                        "/1.png\n1100.05 " + folder + "/2.png\n");
  }
  const auto start = std::chrono::steady_clock::now();
  const auto r = Track((dir_ / "gap").string(), SettingsFile(), Voc(), "--mode realtime --pace");
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_LT(seconds, 30);
  EXPECT_NE(r.output.find("the timestamps jump 1000.000 s from frame 1 (100.050000) to frame 2 "
                          "(1100.050000); gaps longer than --max-pace-gap = 1 s are paced as 1 s"),
            std::string::npos)
      << r.output;
  const nlohmann::json run = nlohmann::json::parse(ReadFileToString(out() / "run.json"));
  EXPECT_EQ(run.at("options").at("max_pace_gap").get<double>(), 1.0);
  EXPECT_EQ(run.at("counts").at("frames").get<int>(), 3);
  for (const std::string bad : {"0", "-1", "inf", "nan"}) {
    const auto b = Track(Seq(), SettingsFile(), Voc(), "--max-pace-gap " + bad);
    EXPECT_EQ(b.exit_code, 64) << bad << ": " << b.output;
  }
  const auto help = RunTool("track", "--help");
  EXPECT_NE(help.output.find("--max-pace-gap FLOAT=1"), std::string::npos) << help.output;
}

// Issue 33: each option has one default, the options struct's; --help shows
// that one (a default given to the binding instead would differ here).
TEST(TrackHelp, DefaultsAreTheOptionsStructs) {
  const auto r = RunTool("track", "--help");
  ASSERT_EQ(r.exit_code, 0);
  const nlohmann::json defaults = TrackOptions{}.ToJson();
  // "--close-tracked INT=300", "--relocalization TEXT:{bow,bow+direct,direct}=bow+direct".
  const std::regex option(R"(^\s+--([a-z-]+) [A-Z]+(?::\{[^}]*\})?=(\S+))");
  std::istringstream lines(r.output);
  std::string line;
  int compared = 0;
  while (std::getline(lines, line)) {
    std::smatch m;
    if (!std::regex_search(line, m, option)) continue;
    std::string key = m[1].str();
    std::replace(key.begin(), key.end(), '-', '_');
    if (!defaults.contains(key)) continue;
    const nlohmann::json& value = defaults[key];
    if (value.is_number()) {
      EXPECT_DOUBLE_EQ(std::stod(m[2].str()), value.get<double>()) << line;
    } else {
      EXPECT_EQ(m[2].str(), value.get<std::string>()) << line;
    }
    ++compared;
  }
  EXPECT_GE(compared, 10) << r.output;
  // Switches state their default in words.
  EXPECT_TRUE(defaults["ba_depth_fallback"].get<bool>());
  EXPECT_NE(r.output.find("disagrees as (u, v) (default: on)"), std::string::npos);
  EXPECT_FALSE(defaults["refine_map"].get<bool>());
  EXPECT_NE(r.output.find("written (default: off;"), std::string::npos);
  // The nested modules' defaults are the tool's.
  EXPECT_EQ(defaults["close_tracked"], TrackerOptions{}.close_tracked);
  EXPECT_EQ(defaults["changed_point_views"], LocalMapperOptions{}.changed_point_min_views);
  EXPECT_EQ(defaults["restore_point_found"], LocalMapperOptions{}.restore_point_min_found);
  EXPECT_EQ(defaults["relocalization"], ToString(TrackerOptions{}.relocalization.method));
  EXPECT_EQ(defaults["relocalization_covisible"], TrackerOptions{}.relocalization.bow_covisible);
  EXPECT_NE(r.output.find("--relocalization TEXT:{bow,bow+direct,direct}=bow+direct"),
            std::string::npos);
}

}  // namespace
}  // namespace rrslam
