// The seed corpora of the features file fuzz target (features_fuzzer.cc),
// made here by code (no real data):
//   fuzz/corpus/     file descriptions for h5_image_builder.h (a few bytes:
//                    frame and keypoint counts; the rest kept well-formed)
//   fuzz/corpus_h5/  small rrslam.features files, for RRSLAM_FUZZ_H5_RAW=1
// The test writes them and checks that each reads back: the files, from disk
// and from their bytes in memory, and the file each description builds (a
// schema change in features_file.h that features_schema.h misses fails
// here). With RRSLAM_WRITE_FUZZ_SEEDS=<dir> they go to <dir>/corpus and
// <dir>/corpus_h5 (to regenerate the committed seeds, see `make fuzz-seeds`:
//   RRSLAM_WRITE_FUZZ_SEEDS=stages/extract/fuzz build/tests/extract_features_seeds
// ), otherwise to a temporary folder.
#include <H5Cpp.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "common/atomic_file.h"
#include "common/fuzz/h5_image_builder.h"
#include "common/testing.h"
#include "stages/extract/features_file.h"
#include "stages/extract/fuzz/features_schema.h"

namespace rrslam {
namespace {

// `frames` frames of `per_frame` + f keypoints with values from a fixed
// pattern (no random engine: the bytes depend only on the code).
FeaturesFile SeedFeatures(int frames, int per_frame) {
  FeaturesFile features;
  features.settings_yaml =
      "%YAML:1.0\nCamera.fx: 500\nCamera.fy: 500\nCamera.cx: 320\nCamera.cy: 240\n";
  for (int f = 0; f < frames; ++f) {
    std::vector<Keypoint> kps(per_frame + f);
    std::vector<OrbDescriptor> descs(kps.size());
    for (size_t i = 0; i < kps.size(); ++i) {
      const float x = static_cast<float>(37 * i + 11 * f);
      kps[i].pixel = {x, 2 * x + 1};
      kps[i].undistorted = {x + 0.5f, 2 * x + 1.25f};
      kps[i].angle_deg = static_cast<float>((45 * i) % 360);
      kps[i].octave = static_cast<uint8_t>(i % 8);
      kps[i].response = 10.0f + static_cast<float>(i);
      kps[i].depth = i % 3 == 0 ? 0.0f : 1.5f + 0.25f * static_cast<float>(i);
      for (int b = 0; b < 32; ++b) descs[i].bytes[b] = static_cast<uint8_t>(i * 31 + b * 7 + f);
    }
    const std::string name = std::to_string(1000 + f);
    features.AddFrame(
        {1000.0 + f / 30.0, 1000.004 + f / 30.0, "rgb/" + name + ".png", "depth/" + name + ".png"},
        kps, descs);
  }
  return features;
}

using testing::Bytes;

TEST(FeaturesSeeds, WriteAndRead) {
  H5::Exception::dontPrint();
  testing::TempDir temp;
  const std::filesystem::path dir = testing::FuzzSeedFolder(temp);
  std::filesystem::create_directories(dir / "corpus");
  std::filesystem::create_directories(dir / "corpus_h5");

  // Descriptions: frame count, then keypoints per frame.
  struct Seed {
    const char* name;
    std::string bytes;
    size_t frames, keypoints;
  };
  const Seed seeds[] = {{"empty", "", 0, 0},
                        {"three_frames", std::string("\x03\x02\x00\x05", 4), 3, 7},
                        {"four_frames", "\x04\x01\x02\x03\x04", 4, 10}};
  for (const Seed& seed : seeds) {
    testing::WriteTextFile(dir / "corpus" / seed.name, seed.bytes);
    const std::string bytes = ReadFileToString(dir / "corpus" / seed.name);
    const std::vector<uint8_t> image = fuzz::BuildH5Image(Bytes(bytes), fuzz::FeaturesObjects);
    const FeaturesFile read = ReadFeaturesFileImage(image, seed.name);
    EXPECT_EQ(read.num_frames(), seed.frames) << seed.name;
    EXPECT_EQ(read.keypoints.size(), seed.keypoints) << seed.name;
    EXPECT_EQ(ReadFeatureDescriptorsImage(image, seed.name, 2).size(),
              seed.frames > 0 ? read.FrameKeypoints(0).size() +
                                    (seed.frames > 2 ? read.FrameKeypoints(2).size() : 0)
                              : 0)
        << seed.name;
  }

  WriteFeaturesFile(dir / "corpus_h5" / "small.h5", SeedFeatures(3, 2), "rrslam-extract seed",
                    {{"seed", 1}});
  WriteFeaturesFile(dir / "corpus_h5" / "empty.h5", FeaturesFile{}, "rrslam-extract seed", {});
  for (const char* name : {"small.h5", "empty.h5"}) {
    const FeaturesFile read = ReadFeaturesFile(dir / "corpus_h5" / name);
    const std::string bytes = ReadFileToString(dir / "corpus_h5" / name);
    const FeaturesFile image = ReadFeaturesFileImage(Bytes(bytes), name);
    EXPECT_EQ(image.keypoints.size(), read.keypoints.size()) << name;
    EXPECT_EQ(image.num_frames(), read.num_frames()) << name;
    EXPECT_LE(bytes.size(), 16384u) << name << ": a seed should stay small";
  }
  EXPECT_EQ(ReadFeaturesFile(dir / "corpus_h5" / "small.h5").keypoints.size(), 9u);
}

}  // namespace
}  // namespace rrslam
