#include "stages/extract/features_file.h"

#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <random>
#include <thread>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/testing.h"

namespace rrslam {
namespace {

FeaturesFile MakeFeatures(int frames, int per_frame, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0, 640);
  FeaturesFile features;
  features.settings_yaml = "%YAML:1.0\nCamera.fx: 500\n";
  for (int f = 0; f < frames; ++f) {
    std::vector<Keypoint> kps(per_frame + f);
    std::vector<OrbDescriptor> descs(kps.size());
    for (size_t i = 0; i < kps.size(); ++i) {
      kps[i].pixel = {u(rng), u(rng)};
      kps[i].undistorted = {u(rng), u(rng)};
      kps[i].angle_deg = u(rng) / 2;
      kps[i].octave = static_cast<uint8_t>(i % 8);
      kps[i].response = u(rng);
      kps[i].depth = u(rng) / 100;
      for (auto& b : descs[i].bytes) b = static_cast<uint8_t>(rng());
    }
    FrameRecord record{1000.0 + f / 30.0, 1000.01 + f / 30.0, "rgb/" + std::to_string(f) + ".png",
                       "depth/" + std::to_string(f) + ".png"};
    record.rgb_checksum = (uint64_t{rng()} << 32) | rng();
    record.depth_checksum = (uint64_t{rng()} << 32) | rng();
    features.AddFrame(record, kps, descs);
  }
  return features;
}

TEST(FeaturesFile, RoundTrip) {
  testing::TempDir dir;
  const FeaturesFile written = MakeFeatures(5, 20, 1);
  WriteFeaturesFile(dir / "f.h5", written, "rrslam-test 0", {{"stride", 1}});
  const FeaturesFile read = ReadFeaturesFile(dir / "f.h5");
  EXPECT_EQ(read.format.format, "rrslam.features");
  EXPECT_EQ(read.format.major, 1);
  EXPECT_EQ(read.format.producer, "rrslam-test 0");
  EXPECT_EQ(read.format.options["stride"], 1);
  EXPECT_EQ(read.settings_yaml, written.settings_yaml);
  ASSERT_EQ(read.num_frames(), 5u);
  ASSERT_EQ(read.keypoints.size(), written.keypoints.size());
  for (size_t f = 0; f < 5; ++f) {
    EXPECT_EQ(read.frames[f].rgb_path, written.frames[f].rgb_path);
    EXPECT_EQ(read.frames[f].depth_timestamp, written.frames[f].depth_timestamp);
    EXPECT_EQ(read.frames[f].rgb_checksum, written.frames[f].rgb_checksum);
    EXPECT_EQ(read.frames[f].depth_checksum, written.frames[f].depth_checksum);
    EXPECT_EQ(read.FrameKeypoints(f).size(), written.FrameKeypoints(f).size());
  }
  for (size_t i = 0; i < read.keypoints.size(); ++i) {
    EXPECT_EQ(read.keypoints[i].pixel, written.keypoints[i].pixel);
    EXPECT_EQ(read.keypoints[i].undistorted, written.keypoints[i].undistorted);
    EXPECT_EQ(read.keypoints[i].angle_deg, written.keypoints[i].angle_deg);
    EXPECT_EQ(read.keypoints[i].octave, written.keypoints[i].octave);
    EXPECT_EQ(read.keypoints[i].depth, written.keypoints[i].depth);
    EXPECT_EQ(read.descriptors[i], written.descriptors[i]);
  }
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
}

// A file of format 1.0 (before the images' checksums) still reads, with
// checksums 0; a 1.1 file without them is refused.
TEST(FeaturesFile, ReadsFormat10WithoutChecksums) {
  testing::TempDir dir;
  WriteFeaturesFile(dir / "f.h5", MakeFeatures(3, 5, 7), "p", {});
  {
    H5::H5File file((dir / "f.h5").string(), H5F_ACC_RDWR);
    H5::Group frames = file.openGroup("frames");
    frames.unlink("rgb_checksum");
    frames.unlink("depth_checksum");
  }
  EXPECT_THROW(ReadFeaturesFile(dir / "f.h5"), DataError);
  {
    H5::H5File file((dir / "f.h5").string(), H5F_ACC_RDWR);
    file.removeAttr("format_minor");
    WriteH5ScalarAttribute(file, "format_minor", 0, H5::PredType::STD_U16LE);
  }
  const FeaturesFile read = ReadFeaturesFile(dir / "f.h5");
  EXPECT_EQ(read.format.minor, 0);
  ASSERT_EQ(read.num_frames(), 3u);
  for (const FrameRecord& r : read.frames) {
    EXPECT_EQ(r.rgb_checksum, 0u);
    EXPECT_EQ(r.depth_checksum, 0u);
  }
}

TEST(FeaturesFile, SameContentGivesSameBytes) {
  // No modification times anywhere in the file (groups included): writing the
  // same features more than a second later gives a byte-identical file.
  testing::TempDir dir;
  const FeaturesFile features = MakeFeatures(3, 10, 2);
  WriteFeaturesFile(dir / "a.h5", features, "p", {});
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));
  WriteFeaturesFile(dir / "b.h5", features, "p", {});
  EXPECT_EQ(ReadFileToString(dir / "a.h5"), ReadFileToString(dir / "b.h5"));
}

TEST(FeaturesFile, DescriptorsWithStride) {
  testing::TempDir dir;
  const FeaturesFile features = MakeFeatures(4, 3, 3);
  WriteFeaturesFile(dir / "f.h5", features, "p", {});
  const auto all = ReadFeatureDescriptors(dir / "f.h5");
  EXPECT_EQ(all.size(), features.descriptors.size());
  const auto every_2nd = ReadFeatureDescriptors(dir / "f.h5", 2);
  EXPECT_EQ(every_2nd.size(),
            features.FrameDescriptors(0).size() + features.FrameDescriptors(2).size());
  EXPECT_EQ(every_2nd.back(), features.FrameDescriptors(2).back());
}

TEST(FeaturesFile, RejectsMissingWrongAndTruncatedFiles) {
  testing::TempDir dir;
  EXPECT_THROW(ReadFeaturesFile(dir / "absent.h5"), NoInputError);
  testing::WriteTextFile(dir / "text.h5", "not hdf5");
  EXPECT_THROW(ReadFeaturesFile(dir / "text.h5"), DataError);
  WriteFeaturesFile(dir / "f.h5", MakeFeatures(2, 50, 4), "p", {});
  const std::string bytes = ReadFileToString(dir / "f.h5");
  testing::WriteTextFile(dir / "cut.h5", bytes.substr(0, bytes.size() / 2));
  EXPECT_THROW(ReadFeaturesFile(dir / "cut.h5"), DataError);
}

TEST(FeaturesFile, RejectsOtherFormatAndFutureMajor) {
  testing::TempDir dir;
  {
    H5::H5File file = CreateH5File(dir / "other.h5");
    WriteFormatAttributes(file, kVocabTreeFormat, "p", {});
  }
  EXPECT_THROW(ReadFeaturesFile(dir / "other.h5"), DataError);
  {
    H5::H5File file = CreateH5File(dir / "future.h5");
    FormatSpec future = kFeaturesFormat;
    future.major = 99;
    WriteFormatAttributes(file, future, "p", {});
  }
  try {
    ReadFeaturesFile(dir / "future.h5");
    FAIL() << "future major accepted";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("version 99"), std::string::npos) << e.what();
  }
}

TEST(FeaturesFile, WriteToMissingFolderFailsWithoutOutput) {
  testing::TempDir dir;
  EXPECT_THROW(WriteFeaturesFile(dir / "no" / "f.h5", MakeFeatures(1, 1, 5), "p", {}),
               CantCreateError);
  EXPECT_FALSE(std::filesystem::exists(dir / "no"));
}

TEST(FeaturesFile, ReadsFromMemoryAsFromDisk) {
  testing::TempDir dir;
  const FeaturesFile written = MakeFeatures(3, 20, 6);
  WriteFeaturesFile(dir / "f.h5", written, "p", {{"k", 1}});
  const std::string text = ReadFileToString(dir / "f.h5");
  const std::vector<uint8_t> bytes(text.begin(), text.end());
  const FeaturesFile from_disk = ReadFeaturesFile(dir / "f.h5");
  const FeaturesFile from_memory = ReadFeaturesFileImage(bytes, "mem.h5");
  ASSERT_EQ(from_memory.num_frames(), from_disk.num_frames());
  EXPECT_EQ(from_memory.descriptors, from_disk.descriptors);
  EXPECT_EQ(from_memory.frames.back().rgb_path, written.frames.back().rgb_path);
  EXPECT_EQ(from_memory.settings_yaml, written.settings_yaml);
  EXPECT_EQ(from_memory.format.options["k"], 1);
  EXPECT_EQ(ReadFeatureDescriptorsImage(bytes, "mem.h5", 2),
            ReadFeatureDescriptors(dir / "f.h5", 2));
  try {
    ReadFeaturesFileImage(std::vector<uint8_t>(bytes.begin(), bytes.begin() + 100), "mem.h5");
    FAIL() << "a truncated image was read";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("mem.h5"), std::string::npos) << e.what();
  }
}

// Found by stages/extract/fuzz/features_fuzzer.cc: a damaged file whose
// "frames" or "keypoints" is a dataset, not a group, made libhdf5's
// exception escape the reader (exit 70 instead of 65).
TEST(FeaturesFile, ObjectsOfTheWrongKindAreDataErrors) {
  testing::TempDir dir;
  for (const char* name : {"frames", "keypoints"}) {
    const std::filesystem::path path = dir / (std::string(name) + ".h5");
    {
      H5::H5File file = CreateH5File(path);
      WriteFormatAttributes(file, kFeaturesFormat, "p", {});
      H5::Group root = file.openGroup("/");
      H5::Group frames =
          CreateH5Group(root, std::string(name) == "frames" ? "keypoints" : "frames");
      const std::vector<uint64_t> one = {0};
      WriteH5Array<uint64_t>(frames, "keypoint_offset", one, {1});
      WriteH5Array<uint64_t>(root, name, one, {1});
    }
    try {
      ReadFeaturesFile(path);
      FAIL() << name << " as a dataset was read";
    } catch (const DataError& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("missing group ") + name), std::string::npos)
          << e.what();
    }
    EXPECT_THROW(ReadFeatureDescriptors(path), DataError) << name;
  }
}

}  // namespace
}  // namespace rrslam
