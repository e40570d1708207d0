// End-to-end: rrslam-synth renders a small sequence, rrslam-extract turns it
// into a features file; both run as executables. Also real TUM frames (when
// the shared data is present) and the documented exit codes on bad input.
#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "common/atomic_file.h"
#include "common/formats.h"
#include "common/h5io.h"
#include "common/testing.h"
#include "common/text.h"

namespace rrslam {
namespace {
namespace fs = std::filesystem;

using testing::Quote;

struct FeaturesSummary {
  H5FormatInfo info;
  std::string settings;
  std::vector<uint64_t> offsets;
  std::vector<uint8_t> octaves;
  std::vector<float> pixels, undistorted, depths;
};

FeaturesSummary ReadSummary(const fs::path& path) {
  FeaturesSummary s;
  H5::H5File file = OpenH5File(path, kFeaturesFormat, &s.info);
  s.settings = ReadH5StringAttribute(file, "settings", path.string());
  const H5::Group frames = file.openGroup("frames");
  s.offsets = ReadH5Array<uint64_t>(frames, "keypoint_offset", path.string());
  const H5::Group keypoints = file.openGroup("keypoints");
  s.octaves = ReadH5Array<uint8_t>(keypoints, "octave", path.string());
  s.pixels = ReadH5Array<float>(keypoints, "pixel", path.string());
  s.undistorted = ReadH5Array<float>(keypoints, "undistorted", path.string());
  s.depths = ReadH5Array<float>(keypoints, "depth", path.string());
  return s;
}

// Checks what every features file of a textured sequence must hold.
void ExpectFeaturesFile(const FeaturesSummary& s, size_t frames, const fs::path& settings_path) {
  EXPECT_EQ(s.info.format, "rrslam.features");
  EXPECT_EQ(s.info.major, kFeaturesFormat.major);
  EXPECT_EQ(s.info.producer.rfind("rrslam-extract ", 0), 0u) << s.info.producer;
  EXPECT_EQ(s.info.options["orb"]["n_features"], 1000);
  EXPECT_EQ(s.info.options["orb"]["n_levels"], 8);
  EXPECT_EQ(s.settings, ReadFileToString(settings_path));
  ASSERT_EQ(s.offsets.size(), frames + 1);
  EXPECT_EQ(s.offsets.front(), 0u);
  for (size_t f = 0; f < frames; ++f) {
    const uint64_t count = s.offsets[f + 1] - s.offsets[f];
    EXPECT_GE(count, 950u) << "frame " << f;
    EXPECT_LE(count, 1000u) << "frame " << f;
  }
  ASSERT_EQ(s.octaves.size(), s.offsets.back());
  std::vector<int> per_level(8, 0);
  for (uint8_t o : s.octaves) ++per_level.at(o);
  for (int l = 0; l < 8; ++l) EXPECT_GT(per_level[l], 0) << "level " << l;
}

class ExtractE2E : public ::testing::Test {
 protected:
  testing::TempDir dir_;
};

TEST_F(ExtractE2E, SynthThenExtract) {
  const fs::path seq = dir_ / "seq";
  testing::CommandResult r = testing::RunTool(
      "synth", "--out " + Quote(seq) + " --trajectory loop --frames 6 --seed 7 -q");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const fs::path settings = seq / "settings.yaml";
  ASSERT_TRUE(fs::exists(settings));

  const fs::path out = dir_ / "features.h5";
  r = testing::RunTool("extract", "--sequence " + Quote(seq) + " --settings " + Quote(settings) +
                                      " --out " + Quote(out) + " -q");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(r.output.empty()) << "--quiet run printed: " << r.output;
  EXPECT_EQ(testing::TemporaryLeftovers(dir_), std::vector<std::string>{});
  const FeaturesSummary s = ReadSummary(out);
  ExpectFeaturesFile(s, 6, settings);
  EXPECT_EQ(s.info.options["sequence"], seq.string());
  // The synthetic depth covers the whole room: nearly every keypoint has one,
  // within the room's size.
  size_t with_depth = 0;
  for (float d : s.depths) {
    if (d > 0) ++with_depth;
    EXPECT_LT(d, 20.0f);
  }
  EXPECT_GE(with_depth, 0.9 * s.depths.size());

  // Same inputs, another thread count: the same bytes.
  const fs::path again = dir_ / "again.h5";
  r = testing::RunTool("extract", "--sequence " + Quote(seq) + " --settings " + Quote(settings) +
                                      " --out " + Quote(again) + " --threads 1 -q");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(ReadFileToString(out), ReadFileToString(again));

  // Frame selection.
  const fs::path some = dir_ / "some.h5";
  r = testing::RunTool("extract", "--sequence " + Quote(seq) + " --settings " + Quote(settings) +
                                      " --out " + Quote(some) +
                                      " --first 1 --stride 2 --max-frames 2 -q");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const FeaturesSummary selected = ReadSummary(some);
  EXPECT_EQ(selected.offsets.size(), 3u);
  EXPECT_EQ(selected.info.options["first"], 1);
  EXPECT_EQ(selected.info.options["stride"], 2);
  // Frames 1 and 3 of the full run: the same keypoints.
  EXPECT_EQ(selected.offsets[1] - selected.offsets[0], s.offsets[2] - s.offsets[1]);
  EXPECT_EQ(selected.offsets[2] - selected.offsets[1], s.offsets[4] - s.offsets[3]);
}

TEST_F(ExtractE2E, TumDeskWithDistortion) {
  RRSLAM_REQUIRE_SHARED_DATA(data);
  const fs::path seq = data / "tum" / "fr1_desk";
  const fs::path settings = data / "settings" / "tum1.yaml";
  const fs::path out = dir_ / "desk.h5";
  const testing::CommandResult r =
      testing::RunTool("extract", "--sequence " + Quote(seq) + " --settings " + Quote(settings) +
                                      " --out " + Quote(out) + " -q");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const FeaturesSummary s = ReadSummary(out);
  ExpectFeaturesFile(s, 9, settings);
  // tum1 has strong radial distortion: undistorted pixels differ from pixels,
  // most by more than a pixel away from the image centre.
  size_t moved = 0;
  for (size_t i = 0; i < s.pixels.size(); i += 2) {
    const double dx = s.undistorted[i] - s.pixels[i], dy = s.undistorted[i + 1] - s.pixels[i + 1];
    if (dx * dx + dy * dy > 1.0) ++moved;
  }
  EXPECT_GE(moved, s.pixels.size() / 2 / 2);
  size_t with_depth = 0;
  for (float d : s.depths) with_depth += d > 0 ? 1 : 0;
  EXPECT_GE(with_depth, s.depths.size() / 2);  // Kinect depth has holes, not that many.
}

TEST_F(ExtractE2E, BadInputGivesDocumentedExitCodesAndNoOutput) {
  testing::CommandResult r = testing::RunTool("extract", "--help");
  EXPECT_EQ(r.exit_code, 0);
  for (const char* text : {"--sequence", "--settings", "--out", "--stride", "--first",
                           "--max-frames", "--associations", "--threads", "64", "65", "66", "73"}) {
    EXPECT_NE(r.output.find(text), std::string::npos) << "--help lacks " << text;
  }

  // A small valid sequence to break in different ways.
  const fs::path seq = dir_ / "seq";
  fs::create_directories(seq / "rgb");
  fs::create_directories(seq / "depth");
  cv::Mat rgb(120, 160, CV_8UC3);
  cv::randu(rgb, 0, 255);
  cv::imwrite((seq / "rgb" / "0.png").string(), rgb);
  cv::imwrite((seq / "depth" / "0.png").string(), cv::Mat(120, 160, CV_16UC1, cv::Scalar(5000)));
  testing::WriteTextFile(seq / "rgb.txt", "1.0 rgb/0.png\n");
  testing::WriteTextFile(seq / "depth.txt", "1.0 depth/0.png\n");
  testing::WriteTextFile(
      seq / "settings.yaml",
      "%YAML:1.0\nCamera.fx: 200\nCamera.fy: 200\nCamera.cx: 80\nCamera.cy: 60\n");
  const fs::path settings = seq / "settings.yaml";
  const fs::path out = dir_ / "out.h5";
  auto run = [&](const std::string& args) { return testing::RunTool("extract", args + " -q"); };
  const std::string good = "--sequence " + Quote(seq) + " --settings " + Quote(settings);

  r = run(good + " --out " + Quote(out));
  ASSERT_EQ(r.exit_code, 0) << r.output;  // The valid sequence works.
  fs::remove(out);

  r = run("--sequence " + Quote(dir_ / "absent") + " --settings " + Quote(settings) + " --out " +
          Quote(out));
  EXPECT_EQ(r.exit_code, 66) << r.output;
  EXPECT_NE(r.output.find("absent"), std::string::npos) << r.output;

  r = run(good + " --out " + Quote(out) + " --stride 0");
  EXPECT_EQ(r.exit_code, 64) << r.output;
  r = run(good);  // --out missing.
  EXPECT_EQ(r.exit_code, 64) << r.output;

  r = run(good + " --out " + Quote(dir_ / "no" / "folder" / "out.h5"));
  EXPECT_EQ(r.exit_code, 73) << r.output;

  r = run("--sequence " + Quote(seq) + " --settings " + Quote(seq / "rgb.txt") + " --out " +
          Quote(out));
  EXPECT_EQ(r.exit_code, 65) << r.output;  // Not a settings file.

  cv::imwrite((seq / "depth" / "0.png").string(), cv::Mat(120, 160, CV_8UC1, cv::Scalar(50)));
  r = run(good + " --out " + Quote(out));
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find((seq / "depth" / "0.png").string()), std::string::npos) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1)
      << "one-line error: " << r.output;

  EXPECT_FALSE(fs::exists(out));
  EXPECT_EQ(testing::TemporaryLeftovers(dir_), std::vector<std::string>{});
}

}  // namespace
}  // namespace rrslam
