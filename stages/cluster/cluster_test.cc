#include "stages/cluster/cluster.h"

#include <gtest/gtest.h>

#include <random>

#include "common/errors.h"
#include "common/testing.h"
#include "common/worker_pool.h"
#include "stages/extract/features_file.h"

namespace rrslam {
namespace {

ClusterOptions ValidOptions() {
  ClusterOptions o;
  o.features = {"a.h5"};
  o.out = "tree.h5";
  return o;
}

void ExpectCheckFails(const ClusterOptions& o, const std::string& field) {
  std::string why;
  EXPECT_FALSE(o.Check(&why)) << field;
  EXPECT_NE(why.find(field), std::string::npos) << why;
}

TEST(ClusterOptions, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(ValidOptions().Check(&why)) << why;
}

TEST(ClusterOptions, EachConstraintFails) {
  ClusterOptions o = ValidOptions();
  o.features.clear();
  ExpectCheckFails(o, "features");
  o = ValidOptions();
  o.out.clear();
  ExpectCheckFails(o, "out");
  for (int k : {1, 21}) {
    o = ValidOptions();
    o.k = k;
    ExpectCheckFails(o, "k = ");
  }
  for (int levels : {0, 11}) {
    o = ValidOptions();
    o.levels = levels;
    ExpectCheckFails(o, "levels");
  }
  o = ValidOptions();
  o.threads = -1;
  ExpectCheckFails(o, "threads");
  o = ValidOptions();
  o.stride = 0;
  ExpectCheckFails(o, "stride");
  o = ValidOptions();
  o.max_iterations = 0;
  ExpectCheckFails(o, "max_iterations");
}

// Found in review (issue 36): `--threads 100000` hung (the pool waited for
// ever once a thread could not be started); more threads than kMaxThreads
// are now a usage error (exit 64) before any is started.
TEST(ClusterOptions, ThreadsAreBounded) {
  ClusterOptions o = ValidOptions();
  std::string why;
  for (int threads : {0, 1, kMaxThreads}) {
    o.threads = threads;
    EXPECT_TRUE(o.Check(&why)) << threads << ": " << why;
  }
  for (int threads : {kMaxThreads + 1, 1000, 100000}) {
    o.threads = threads;
    EXPECT_FALSE(o.Check(&why)) << threads;
    EXPECT_EQ(why,
              "threads = " + std::to_string(threads) + "; must be in [0, 256] (0 = all cores)");
  }
}

// `frames` frames of `per_frame` random descriptors.
void WriteRandomFeatures(const std::filesystem::path& path, int frames, int per_frame,
                         uint64_t seed) {
  std::mt19937_64 rng(seed);
  FeaturesFile f;
  for (int i = 0; i < frames; ++i) {
    std::vector<Keypoint> kps(per_frame);
    std::vector<OrbDescriptor> d(per_frame);
    for (auto& x : d) {
      for (auto& b : x.bytes) b = static_cast<uint8_t>(rng());
    }
    f.AddFrame(FrameRecord{1.0 * i, 1.0 * i, "rgb", "depth"}, kps, d);
  }
  WriteFeaturesFile(path, f, "rrslam-test 0", {});
}

TEST(RunCluster, WritesTreeWithOptions) {
  testing::TempDir dir;
  WriteRandomFeatures(dir / "a.h5", 6, 100, 1);
  WriteRandomFeatures(dir / "b.h5", 4, 50, 2);
  ClusterOptions o;
  o.features = {dir / "a.h5", dir / "b.h5"};
  o.out = dir / "tree.h5";
  o.k = 4;
  o.levels = 3;
  o.seed = 9;
  o.stride = 2;
  const VocabTree written = RunCluster(o);
  H5FormatInfo info;
  const VocabTree tree = ReadVocabTree(o.out, &info);
  EXPECT_EQ(tree.k, 4);
  EXPECT_EQ(tree.levels, 3);
  // Frames 0, 2, 4 of a and 0, 2 of b.
  EXPECT_EQ(tree.count[0], 3u * 100 + 2u * 50);
  EXPECT_EQ(tree.parent, written.parent);
  EXPECT_EQ(info.options["k"], 4);
  EXPECT_EQ(info.options["seed"], 9);
  EXPECT_EQ(info.options["stride"], 2);
  EXPECT_EQ(info.options["features"].size(), 2u);
  EXPECT_EQ(info.producer.rfind("rrslam-cluster ", 0), 0u);

  // A random subset of fixed size.
  o.max_descriptors = 123;
  o.out = dir / "sub.h5";
  EXPECT_EQ(RunCluster(o).count[0], 123u);
}

TEST(RunCluster, BadInputsLeaveNoOutput) {
  testing::TempDir dir;
  ClusterOptions o;
  o.features = {dir / "missing.h5"};
  o.out = dir / "tree.h5";
  EXPECT_THROW(RunCluster(o), NoInputError);
  EXPECT_FALSE(std::filesystem::exists(o.out));

  WriteRandomFeatures(dir / "empty.h5", 2, 0, 1);
  o.features = {dir / "empty.h5"};
  EXPECT_THROW(RunCluster(o), AlgorithmError);
  EXPECT_FALSE(std::filesystem::exists(o.out));

  WriteRandomFeatures(dir / "a.h5", 2, 30, 1);
  o.features = {dir / "a.h5"};
  o.out = dir / "no_such_folder" / "tree.h5";
  EXPECT_THROW(RunCluster(o), CantCreateError);

  o.out = dir / "tree.h5";
  o.k = 50;
  EXPECT_THROW(RunCluster(o), UsageError);
}

}  // namespace
}  // namespace rrslam
