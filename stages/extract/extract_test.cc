#include "stages/extract/extract.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/json_text.h"
#include "common/settings.h"
#include "common/testing.h"
#include "stages/extract/orb_extractor.h"
#include "stages/extract/test_images.h"

namespace rrslam {
namespace {
namespace fs = std::filesystem;

constexpr int kWidth = 320;
constexpr int kHeight = 240;

// Depth of the tiny sequences: 1 m at the left edge, growing by 2 mm per column.
double DepthAt(int u) { return 1.0 + 0.002 * u; }

Settings TinySettings() {
  Settings s;
  s.fx = s.fy = 300;
  s.cx = 160;
  s.cy = 120;
  s.distortion = {0.1, -0.05, 0.001, -0.002, 0.0};
  s.width = kWidth;
  s.height = kHeight;
  s.depth_map_factor = 5000;
  s.orb.n_features = 400;
  return s;
}

cv::Mat DepthImage(int width, int height) {
  cv::Mat depth(height, width, CV_16UC1);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      depth.at<uint16_t>(v, u) = static_cast<uint16_t>(std::lround(5000 * DepthAt(u)));
    }
  }
  return depth;
}

// A TUM-layout sequence of `frames` textured frames with a settings file.
struct TinySequence {
  explicit TinySequence(int frames) {
    fs::create_directories(dir.path() / "rgb");
    fs::create_directories(dir.path() / "depth");
    std::string rgb_list = "# color images\n# timestamp filename\n";
    std::string depth_list = "# depth maps\n# timestamp filename\n";
    for (int i = 0; i < frames; ++i) {
      const double t = 100.0 + i / 30.0;
      const std::string name = std::to_string(i) + ".png";
      cv::Mat gray = testing::MakeTexturedImage(kWidth, kHeight, 1000 + i);
      cv::Mat colour;
      cv::cvtColor(gray, colour, cv::COLOR_GRAY2BGR);
      cv::imwrite((dir.path() / "rgb" / name).string(), colour);
      cv::imwrite((dir.path() / "depth" / name).string(), DepthImage(kWidth, kHeight));
      char line[128];
      std::snprintf(line, sizeof(line), "%.6f rgb/%s\n", t, name.c_str());
      rgb_list += line;
      std::snprintf(line, sizeof(line), "%.6f depth/%s\n", t + 0.005, name.c_str());
      depth_list += line;
    }
    testing::WriteTextFile(dir.path() / "rgb.txt", rgb_list);
    testing::WriteTextFile(dir.path() / "depth.txt", depth_list);
    WriteSettings(settings_path(), TinySettings());
  }
  fs::path path() const { return dir.path(); }
  fs::path settings_path() const { return dir.path() / "settings.yaml"; }
  fs::path rgb(int i) const { return dir.path() / "rgb" / (std::to_string(i) + ".png"); }
  fs::path depth(int i) const { return dir.path() / "depth" / (std::to_string(i) + ".png"); }

  ExtractOptions Options(const fs::path& out) const {
    ExtractOptions options;
    options.sequence = path();
    options.settings = settings_path();
    options.out = out;
    return options;
  }

  testing::TempDir dir;
};

// Runs `fn`, expects an exception of type E, returns its message.
template <typename E>
std::string MessageOf(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const E& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "unexpected exception: " << e.what();
    return {};
  }
  ADD_FAILURE() << "no exception";
  return {};
}

bool Contains(const std::string& text, const fs::path& path) {
  return text.find(path.string()) != std::string::npos;
}

TEST(ExtractOptions, CheckNamesEachViolatedConstraint) {
  ExtractOptions options;
  options.sequence = "seq";
  options.settings = "settings.yaml";
  options.out = "features.h5";
  std::string why;
  EXPECT_TRUE(options.Check(&why)) << why;

  auto fails = [&](const std::function<void(ExtractOptions*)>& change, const std::string& name) {
    ExtractOptions bad = options;
    change(&bad);
    std::string reason;
    EXPECT_FALSE(bad.Check(&reason)) << name;
    EXPECT_NE(reason.find(name), std::string::npos) << reason;
  };
  fails([](ExtractOptions* o) { o->sequence.clear(); }, "--sequence");
  fails([](ExtractOptions* o) { o->settings.clear(); }, "--settings");
  fails([](ExtractOptions* o) { o->out.clear(); }, "--out");
  fails([](ExtractOptions* o) { o->stride = 0; }, "--stride");
  fails([](ExtractOptions* o) { o->first = -1; }, "--first");
  fails([](ExtractOptions* o) { o->max_frames = -2; }, "--max-frames");
  fails([](ExtractOptions* o) { o->threads = -1; }, "--threads");
  fails([](ExtractOptions* o) { o->threads = 257; }, "--threads");
  EXPECT_FALSE(ExtractOptions{}.Check(nullptr));  // Paths are required.

  // Recorded options leave out the thread count (it does not change the output).
  const nlohmann::json json = options.ToJson();
  EXPECT_EQ(json["stride"], 1);
  EXPECT_EQ(json["sequence"], "seq");
  EXPECT_FALSE(json.contains("threads"));
}

TEST(ExtractOptions, SelectFrames) {
  ExtractOptions o;
  EXPECT_EQ(SelectFrames(4, o), (std::vector<size_t>{0, 1, 2, 3}));
  o.first = 2;
  o.stride = 3;
  EXPECT_EQ(SelectFrames(10, o), (std::vector<size_t>{2, 5, 8}));
  o.max_frames = 2;
  EXPECT_EQ(SelectFrames(10, o), (std::vector<size_t>{2, 5}));
  o.first = 10;
  EXPECT_TRUE(SelectFrames(10, o).empty());
}

TEST(RunExtract, WritesFeaturesOfEveryFrame) {
  const TinySequence seq(3);
  testing::TempDir out_dir;
  const fs::path out = out_dir / "features.h5";
  RunExtract(seq.Options(out));
  ASSERT_TRUE(fs::exists(out));
  EXPECT_EQ(testing::TemporaryLeftovers(out_dir), std::vector<std::string>{});

  const FeaturesFile f = ReadFeaturesFile(out);
  EXPECT_EQ(f.format.format, "rrslam.features");
  EXPECT_EQ(f.format.major, 1);
  EXPECT_EQ(f.format.producer.rfind("rrslam-extract ", 0), 0u) << f.format.producer;
  EXPECT_EQ(f.format.options["sequence"], seq.path().string());
  EXPECT_EQ(f.format.options["stride"], 1);
  EXPECT_EQ(f.format.options["orb"]["n_features"], 400);
  EXPECT_EQ(f.format.options["orb"]["n_levels"], 8);
  EXPECT_EQ(f.format.options["orb"]["ini_th_fast"], 20);
  EXPECT_EQ(f.settings_yaml, ReadFileToString(seq.settings_path()));

  ASSERT_EQ(f.num_frames(), 3u);
  const Settings settings = TinySettings();
  const PinholeCamera camera = settings.Camera();
  OrbExtractor reference(settings.orb);
  for (size_t i = 0; i < 3; ++i) {
    const FrameRecord& r = f.frames[i];
    EXPECT_NEAR(r.rgb_timestamp, 100.0 + i / 30.0, 1e-6);  // rgb.txt has 6 decimals.
    EXPECT_NEAR(r.depth_timestamp, 100.005 + i / 30.0, 1e-6);
    EXPECT_EQ(fs::path(r.rgb_path), seq.rgb(static_cast<int>(i)));
    EXPECT_EQ(fs::path(r.depth_path), seq.depth(static_cast<int>(i)));

    // The same keypoints and descriptors as the extractor on the grey image.
    cv::Mat gray;
    cv::cvtColor(cv::imread(seq.rgb(static_cast<int>(i)).string()), gray, cv::COLOR_BGR2GRAY);
    std::vector<Keypoint> keypoints;
    std::vector<OrbDescriptor> descriptors;
    reference.Extract(gray, &keypoints, &descriptors);
    const auto frame_keypoints = f.FrameKeypoints(i);
    const auto frame_descriptors = f.FrameDescriptors(i);
    ASSERT_EQ(frame_keypoints.size(), keypoints.size());
    EXPECT_GE(frame_keypoints.size(), 360u);  // About n_features on a textured frame.
    for (size_t k = 0; k < keypoints.size(); ++k) {
      const Keypoint& kp = frame_keypoints[k];
      ASSERT_EQ(kp.pixel, keypoints[k].pixel);
      ASSERT_EQ(kp.octave, keypoints[k].octave);
      ASSERT_EQ(kp.angle_deg, keypoints[k].angle_deg);
      ASSERT_EQ(frame_descriptors[k], descriptors[k]);
      // Undistorted with the settings' camera; depth from the depth image.
      const Eigen::Vector2d ideal = camera.UndistortPixel(kp.pixel.cast<double>());
      EXPECT_NEAR(kp.undistorted.x(), ideal.x(), 1e-3);
      EXPECT_NEAR(kp.undistorted.y(), ideal.y(), 1e-3);
      const int u = static_cast<int>(std::lround(kp.pixel.x()));
      EXPECT_NEAR(kp.depth, std::lround(5000 * DepthAt(u)) / 5000.0, 1e-6);
    }
  }
}

// A sequence folder named in Latin-1 (legal on Linux, not UTF-8): the
// features file records the options (JSON) with the path quoted
// (common/json_text.h) instead of failing with nlohmann's type_error 316.
TEST(RunExtract, SequenceFolderThatIsNotUtf8) {
  const TinySequence seq(2);
  testing::TempDir out_dir;
  const fs::path latin1 = out_dir / "caf\xe9";
  fs::create_directory_symlink(seq.path(), latin1);
  ExtractOptions options = seq.Options(out_dir / "features.h5");
  options.sequence = latin1;
  RunExtract(options);
  const FeaturesFile f = ReadFeaturesFile(out_dir / "features.h5");
  EXPECT_EQ(PathFromJson(f.format.options["sequence"].get<std::string>()), latin1);
  EXPECT_EQ(f.num_frames(), 2u);
}

TEST(RunExtract, SameContentForAnyThreadCount) {
  const TinySequence seq(5);
  testing::TempDir out_dir;
  std::vector<std::string> bytes;
  for (int threads : {1, 2, 3}) {
    ExtractOptions options = seq.Options(out_dir / std::to_string(threads));
    options.threads = threads;
    RunExtract(options);
    bytes.push_back(ReadFileToString(options.out));
  }
  // Same options apart from threads, which is not recorded: identical files.
  EXPECT_EQ(bytes[0], bytes[1]);
  EXPECT_EQ(bytes[0], bytes[2]);
  const FeaturesFile f = ReadFeaturesFile(out_dir / "1");
  EXPECT_EQ(f.num_frames(), 5u);
}

TEST(RunExtract, FrameSelectionAndAssociations) {
  const TinySequence seq(6);
  testing::TempDir out_dir;
  ExtractOptions options = seq.Options(out_dir / "f.h5");
  options.first = 1;
  options.stride = 2;
  options.max_frames = 2;
  RunExtract(options);
  const FeaturesFile f = ReadFeaturesFile(options.out);
  ASSERT_EQ(f.num_frames(), 2u);
  EXPECT_EQ(fs::path(f.frames[0].rgb_path), seq.rgb(1));
  EXPECT_EQ(fs::path(f.frames[1].rgb_path), seq.rgb(3));
  EXPECT_EQ(f.format.options["first"], 1);
  EXPECT_EQ(f.format.options["stride"], 2);
  EXPECT_EQ(f.format.options["max_frames"], 2);

  // An associations file pairs frames explicitly (here rgb 4 with depth 0).
  testing::WriteTextFile(seq.path() / "pairs.txt",
                         "# rgb_ts rgb depth_ts depth\n200.0 rgb/4.png 200.01 depth/0.png\n");
  ExtractOptions paired = seq.Options(out_dir / "paired.h5");
  paired.associations = "pairs.txt";
  RunExtract(paired);
  const FeaturesFile p = ReadFeaturesFile(paired.out);
  ASSERT_EQ(p.num_frames(), 1u);
  EXPECT_EQ(fs::path(p.frames[0].rgb_path), seq.rgb(4));
  EXPECT_EQ(fs::path(p.frames[0].depth_path), seq.depth(0));
  EXPECT_DOUBLE_EQ(p.frames[0].rgb_timestamp, 200.0);
  EXPECT_EQ(p.format.options["associations"], "pairs.txt");
}

// Every bad input: the right error, naming the file, and no output left
// behind (an existing output file keeps its content).
class RunExtractBadInput : public ::testing::Test {
 protected:
  void SetUp() override { testing::WriteTextFile(out_, "previous content"); }
  void ExpectOutputUntouched() {
    EXPECT_EQ(ReadFileToString(out_), "previous content");
    EXPECT_EQ(testing::TemporaryLeftovers(out_dir_), std::vector<std::string>{});
  }
  testing::TempDir out_dir_;
  fs::path out_ = out_dir_ / "features.h5";
};

TEST_F(RunExtractBadInput, MissingListedImage) {
  const TinySequence seq(3);
  fs::remove(seq.rgb(1));
  const std::string message = MessageOf<DataError>([&] { RunExtract(seq.Options(out_)); });
  EXPECT_TRUE(Contains(message, seq.rgb(1))) << message;
  ExpectOutputUntouched();
}

TEST_F(RunExtractBadInput, DepthNot16Bit) {
  const TinySequence seq(3);
  cv::imwrite(seq.depth(2).string(), cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(9)));
  const std::string message = MessageOf<DataError>([&] { RunExtract(seq.Options(out_)); });
  EXPECT_TRUE(Contains(message, seq.depth(2))) << message;
  EXPECT_NE(message.find("16-bit"), std::string::npos) << message;
  ExpectOutputUntouched();
}

TEST_F(RunExtractBadInput, DepthAndColourSizesDiffer) {
  const TinySequence seq(3);
  cv::imwrite(seq.depth(0).string(), DepthImage(kWidth / 2, kHeight / 2));
  const std::string message = MessageOf<DataError>([&] { RunExtract(seq.Options(out_)); });
  EXPECT_TRUE(Contains(message, seq.depth(0))) << message;
  ExpectOutputUntouched();
}

TEST_F(RunExtractBadInput, ImageSizeDiffersFromSettings) {
  const TinySequence seq(3);
  Settings wrong = TinySettings();
  wrong.width = 640;
  wrong.height = 480;
  WriteSettings(seq.settings_path(), wrong);
  const std::string message = MessageOf<DataError>([&] { RunExtract(seq.Options(out_)); });
  EXPECT_TRUE(Contains(message, seq.rgb(0))) << message;
  EXPECT_NE(message.find("640x480"), std::string::npos) << message;
  ExpectOutputUntouched();
}

// `png` with the width and height of its IHDR chunk replaced (CRC updated):
// a few kB declaring a huge image.
std::string WithDeclaredSize(std::string png, uint32_t width, uint32_t height) {
  for (int i = 0; i < 4; ++i) {
    png[16 + i] = static_cast<char>(width >> (24 - 8 * i));
    png[20 + i] = static_cast<char>(height >> (24 - 8 * i));
  }
  uint32_t crc = 0xFFFFFFFFu;  // CRC-32 of the chunk type and data.
  for (size_t k = 12; k < 29; ++k) {
    crc ^= static_cast<unsigned char>(png[k]);
    for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  crc = ~crc;
  for (int i = 0; i < 4; ++i) png[29 + i] = static_cast<char>(crc >> (24 - 8 * i));
  return png;
}

// A PNG declaring 65535 x 65535 pixels (34 GB decoded) is refused from its
// header, naming the file and both sizes (exit 65); so is one merely larger
// than the settings' Camera.width x Camera.height.
TEST_F(RunExtractBadInput, ImageDeclaringAHugeSizeIsRefusedFromItsHeader) {
  const TinySequence seq(3);
  const std::string png = ReadFileToString(seq.rgb(1));
  testing::WriteTextFile(seq.rgb(1), WithDeclaredSize(png, 65535, 65535));
  std::string message = MessageOf<DataError>([&] { RunExtract(seq.Options(out_)); });
  EXPECT_EQ(message, seq.rgb(1).string() + ": image is 65535x65535, larger than 320x240 " +
                         "(Camera.width x Camera.height of " + seq.settings_path().string() + ")");
  ExpectOutputUntouched();
  testing::WriteTextFile(seq.rgb(1), WithDeclaredSize(png, kWidth + 1, kHeight));
  message = MessageOf<DataError>([&] { RunExtract(seq.Options(out_)); });
  EXPECT_NE(message.find(": image is 321x240, larger than 320x240"), std::string::npos) << message;
  const auto r =
      testing::RunTool("extract", "--sequence " + testing::Quote(seq.path()) + " --settings " +
                                      testing::Quote(seq.settings_path()) + " --out " +
                                      testing::Quote(out_) + " -q");
  EXPECT_EQ(r.exit_code, 65) << r.output;
  EXPECT_NE(r.output.find("321x240"), std::string::npos) << r.output;
  ExpectOutputUntouched();
}

TEST_F(RunExtractBadInput, CorruptImage) {
  const TinySequence seq(3);
  testing::WriteTextFile(seq.rgb(2), "not a PNG");
  const std::string message = MessageOf<DataError>([&] { RunExtract(seq.Options(out_)); });
  EXPECT_TRUE(Contains(message, seq.rgb(2))) << message;
  ExpectOutputUntouched();
}

TEST_F(RunExtractBadInput, FirstOfSeveralBadFramesIsReported) {
  // Frames 1 and 3 are bad; with any number of threads the error names frame 1.
  const TinySequence seq(5);
  testing::WriteTextFile(seq.rgb(1), "broken");
  testing::WriteTextFile(seq.rgb(3), "broken");
  for (int threads : {1, 2, 4}) {
    ExtractOptions options = seq.Options(out_);
    options.threads = threads;
    const std::string message = MessageOf<DataError>([&] { RunExtract(options); });
    EXPECT_TRUE(Contains(message, seq.rgb(1))) << message;
  }
  ExpectOutputUntouched();
}

TEST_F(RunExtractBadInput, MissingOrEmptySequenceFolder) {
  const TinySequence seq(1);
  ExtractOptions options = seq.Options(out_);
  options.sequence = seq.path() / "absent";
  std::string message = MessageOf<NoInputError>([&] { RunExtract(options); });
  EXPECT_TRUE(Contains(message, options.sequence)) << message;
  options.sequence = seq.path() / "empty";
  fs::create_directories(options.sequence);
  message = MessageOf<NoInputError>([&] { RunExtract(options); });
  EXPECT_TRUE(Contains(message, options.sequence)) << message;
  ExpectOutputUntouched();
}

TEST_F(RunExtractBadInput, MissingOrIncompleteSettings) {
  const TinySequence seq(1);
  ExtractOptions options = seq.Options(out_);
  options.settings = seq.path() / "absent.yaml";
  std::string message = MessageOf<NoInputError>([&] { RunExtract(options); });
  EXPECT_TRUE(Contains(message, options.settings)) << message;
  options.settings = seq.path() / "incomplete.yaml";
  testing::WriteTextFile(options.settings, "%YAML:1.0\nCamera.fx: 500\n");
  message = MessageOf<DataError>([&] { RunExtract(options); });
  EXPECT_TRUE(Contains(message, options.settings)) << message;
  ExpectOutputUntouched();
}

TEST_F(RunExtractBadInput, UnwritableOutputAndBadSelection) {
  const TinySequence seq(2);
  ExtractOptions options = seq.Options(out_dir_ / "no" / "such" / "folder" / "f.h5");
  std::string message = MessageOf<CantCreateError>([&] { RunExtract(options); });
  EXPECT_NE(message.find("f.h5"), std::string::npos) << message;
  options = seq.Options(out_dir_.path());  // A folder, not a file.
  MessageOf<CantCreateError>([&] { RunExtract(options); });

  options = seq.Options(out_);
  options.first = 2;  // Past the last of 2 frames.
  message = MessageOf<UsageError>([&] { RunExtract(options); });
  EXPECT_TRUE(Contains(message, seq.path())) << message;
  options.first = 0;
  options.stride = 0;
  MessageOf<UsageError>([&] { RunExtract(options); });
  ExpectOutputUntouched();
}

}  // namespace
}  // namespace rrslam
