#include "stages/vocab/vocab_tool.h"

#include <gtest/gtest.h>

#include <random>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/testing.h"
#include "common/worker_pool.h"
#include "stages/cluster/cluster.h"
#include "stages/extract/features_file.h"
#include "stages/vocab/vocab_test_util.h"
#include "stages/vocab/vocabulary.h"
#include "stages/vocab/vocabulary_format.h"

namespace rrslam {
namespace {

template <typename Options>
void ExpectCheckFails(const Options& o, const std::string& field) {
  std::string why;
  EXPECT_FALSE(o.Check(&why)) << field;
  EXPECT_NE(why.find(field), std::string::npos) << why;
}

TEST(VocabOptions, BuildChecks) {
  VocabBuildOptions o;
  o.tree = "t.h5";
  o.features = {"f.h5"};
  o.out = "v.rrv";
  std::string why;
  EXPECT_TRUE(o.Check(&why)) << why;
  o.out = "v.txt";
  EXPECT_TRUE(o.Check(&why)) << why;
  VocabBuildOptions bad = o;
  bad.tree.clear();
  ExpectCheckFails(bad, "tree");
  bad = o;
  bad.features.clear();
  ExpectCheckFails(bad, "features");
  bad = o;
  bad.out.clear();
  ExpectCheckFails(bad, "out");
  bad = o;
  bad.out = "v.bin";
  ExpectCheckFails(bad, "out = v.bin");
  bad = o;
  bad.weighting = "bm25";
  ExpectCheckFails(bad, "weighting = bm25");
  bad = o;
  bad.scoring = "cosine";
  ExpectCheckFails(bad, "scoring = cosine");
  bad = o;
  bad.stride = 0;
  ExpectCheckFails(bad, "stride");
  bad = o;
  bad.threads = -2;
  ExpectCheckFails(bad, "threads");
}

// Found in review (issue 36): thousands of threads hung the tool when one
// could not be started; more than kMaxThreads are a usage error (exit 64).
TEST(VocabOptions, BuildThreadsAreBounded) {
  VocabBuildOptions o;
  o.tree = "t.h5";
  o.features = {"f.h5"};
  o.out = "v.rrv";
  o.threads = kMaxThreads;
  std::string why;
  EXPECT_TRUE(o.Check(&why)) << why;
  for (int threads : {kMaxThreads + 1, 100000}) {
    o.threads = threads;
    ExpectCheckFails(o, "threads = " + std::to_string(threads) + "; must be in [0, 256]");
  }
}

TEST(VocabOptions, ConvertInfoQueryChecks) {
  VocabConvertOptions c;
  c.in = "a.txt";
  c.out = "b.rrv";
  std::string why;
  EXPECT_TRUE(c.Check(&why)) << why;
  for (const char* yaml : {"b.yml", "b.yml.gz", "b.yaml", "b.yaml.gz"}) {
    c.out = yaml;
    EXPECT_TRUE(c.Check(&why)) << yaml << ": " << why;
  }
  c.out = "b.rrv";
  VocabConvertOptions bad_c = c;
  bad_c.in.clear();
  ExpectCheckFails(bad_c, "in");
  bad_c = c;
  bad_c.out = "b.dat";
  ExpectCheckFails(bad_c, "out = b.dat");

  VocabInfoOptions i;
  ExpectCheckFails(i, "file");
  i.file = "v.rrv";
  EXPECT_TRUE(i.Check(&why)) << why;

  VocabQueryOptions q;
  q.vocab = "v.rrv";
  q.features = "f.h5";
  q.frames = {0, 3};
  EXPECT_TRUE(q.Check(&why)) << why;
  VocabQueryOptions bad_q = q;
  bad_q.vocab.clear();
  ExpectCheckFails(bad_q, "vocab");
  bad_q = q;
  bad_q.features.clear();
  ExpectCheckFails(bad_q, "features");
  bad_q = q;
  bad_q.frames.clear();
  ExpectCheckFails(bad_q, "frames");
  bad_q = q;
  bad_q.frames = {-1};
  ExpectCheckFails(bad_q, "frame -1");
  bad_q = q;
  bad_q.levels_up = -1;
  ExpectCheckFails(bad_q, "levels_up");
}

// Frames of descriptors drawn around a few random "scene" descriptors, so
// that nearby frames share words.
void WriteSceneFeatures(const std::filesystem::path& path, int frames, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<OrbDescriptor> scene(600);
  for (auto& d : scene) d = testing::RandomOrbDescriptor(rng);
  FeaturesFile f;
  for (int i = 0; i < frames; ++i) {
    std::vector<OrbDescriptor> d;
    for (int j = 0; j < 120; ++j) {
      OrbDescriptor x = scene[(i * 20 + j) % scene.size()];
      for (int flip = 0; flip < 5; ++flip) {
        const int bit = static_cast<int>(rng() % 256);
        x.SetBit(bit, !x.Bit(bit));
      }
      d.push_back(x);
    }
    std::vector<Keypoint> kps(d.size());
    f.AddFrame(FrameRecord{100.0 + i, 100.0 + i, "rgb/" + std::to_string(i) + ".png", "d"}, kps, d);
  }
  WriteFeaturesFile(path, f, "rrslam-test 0", {});
}

class VocabCommandsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    WriteSceneFeatures(dir_ / "f.h5", 12, 1);
    ClusterOptions c;
    c.features = {dir_ / "f.h5"};
    c.out = dir_ / "tree.h5";
    c.k = 6;
    c.levels = 3;
    RunCluster(c);
  }
  VocabBuildOptions Build(const std::string& out) {
    VocabBuildOptions b;
    b.tree = dir_ / "tree.h5";
    b.features = {dir_ / "f.h5"};
    b.out = dir_ / out;
    return b;
  }
  testing::TempDir dir_;
};

TEST_F(VocabCommandsTest, BuildConvertInfoQuery) {
  RunVocabBuild(Build("v.rrv"));
  const Vocabulary v = Vocabulary::Load(dir_ / "v.rrv");
  EXPECT_TRUE(v.is_binary());
  EXPECT_EQ(v.k(), 6);
  EXPECT_EQ(v.levels(), 3);
  const nlohmann::json metadata = nlohmann::json::parse(v.view().metadata);
  EXPECT_EQ(metadata["producer"].get<std::string>().rfind("rrslam-vocab ", 0), 0u);
  EXPECT_EQ(metadata["options"]["weighting"], "tf-idf");
  EXPECT_EQ(metadata["training_images"], 12);
  EXPECT_EQ(metadata["tree"]["options"]["k"], 6);

  // Text straight from build equals the converted binary.
  RunVocabBuild(Build("direct.txt"));
  RunVocabConvert({dir_ / "v.rrv", dir_ / "v.txt"});
  EXPECT_EQ(ReadFileToString(dir_ / "direct.txt"), ReadFileToString(dir_ / "v.txt"));
  // text -> binary -> text, byte for byte.
  RunVocabConvert({dir_ / "v.txt", dir_ / "back.rrv"});
  RunVocabConvert({dir_ / "back.rrv", dir_ / "back.txt"});
  EXPECT_EQ(ReadFileToString(dir_ / "v.txt"), ReadFileToString(dir_ / "back.txt"));
  const Vocabulary back = Vocabulary::Load(dir_ / "back.rrv");
  EXPECT_EQ(nlohmann::json::parse(back.view().metadata)["converted_from"], "v.txt");
  // binary -> DBoW2 YAML (gzip) -> text, and YAML -> binary: the same tree.
  RunVocabConvert({dir_ / "v.rrv", dir_ / "v.yml.gz"});
  RunVocabConvert({dir_ / "v.yml.gz", dir_ / "yaml.txt"});
  EXPECT_EQ(ReadFileToString(dir_ / "v.txt"), ReadFileToString(dir_ / "yaml.txt"));
  RunVocabConvert({dir_ / "v.yml.gz", dir_ / "yaml.rrv"});
  const Vocabulary from_yaml = Vocabulary::Load(dir_ / "yaml.rrv");
  EXPECT_EQ(from_yaml.content_hash(), v.content_hash());
  EXPECT_EQ(nlohmann::json::parse(from_yaml.view().metadata)["source_format"], "dbow2-yaml");

  const std::string info = RunVocabInfo({dir_ / "v.rrv", false});
  for (const char* line : {"format: rrslam.vocabulary 1.1 (binary)", "k: 6", "levels: 3",
                           "weighting: tf-idf", "scoring: l1", "checksum: ok", "structure: ok"}) {
    EXPECT_NE(info.find(line), std::string::npos) << line << "\n" << info;
  }
  EXPECT_NE(info.find("words: " + std::to_string(v.num_words())), std::string::npos);
  const nlohmann::json info_json = nlohmann::json::parse(RunVocabInfo({dir_ / "v.txt", true}));
  EXPECT_EQ(info_json["format"], "DBoW2 text");
  EXPECT_EQ(info_json["nodes"], v.num_nodes());

  VocabQueryOptions q;
  q.vocab = dir_ / "v.rrv";
  q.features = dir_ / "f.h5";
  q.frames = {5};
  q.all = true;
  q.json = true;
  q.out = dir_ / "query.json";
  RunVocabQuery(q);
  const nlohmann::json result = nlohmann::json::parse(ReadFileToString(q.out));
  ASSERT_EQ(result["scores"].size(), 12u);
  EXPECT_NEAR(result["scores"][5]["score"].get<double>(), 1.0, 1e-9);
  for (const auto& s : result["scores"]) EXPECT_LE(s["score"].get<double>(), 1.0 + 1e-9);
  // Frame 5 shares scene descriptors with its neighbours, not with far frames.
  EXPECT_GT(result["scores"][4]["score"].get<double>(),
            result["scores"][11]["score"].get<double>());
  EXPECT_EQ(result["frames"][0]["frame"], 5);
  EXPECT_EQ(result["frames"][0]["features"], 120);

  q.frames = {20};
  EXPECT_THROW(RunVocabQuery(q), UsageError);
}

TEST_F(VocabCommandsTest, FailuresLeaveNoOutput) {
  VocabBuildOptions b = Build("v.rrv");
  b.tree = dir_ / "missing.h5";
  EXPECT_THROW(RunVocabBuild(b), NoInputError);
  EXPECT_FALSE(std::filesystem::exists(b.out));
  b = Build("v.rrv");
  b.features = {dir_ / "tree.h5"};  // Not a features file.
  EXPECT_THROW(RunVocabBuild(b), DataError);
  EXPECT_FALSE(std::filesystem::exists(b.out));

  RunVocabBuild(Build("v.rrv"));
  std::string bytes = ReadFileToString(dir_ / "v.rrv");
  bytes[bytes.size() / 2] ^= 0x40;
  WriteFileAtomically(dir_ / "bad.rrv", bytes);
  EXPECT_THROW(RunVocabConvert({dir_ / "bad.rrv", dir_ / "bad.txt"}), DataError);
  EXPECT_FALSE(std::filesystem::exists(dir_ / "bad.txt"));
  // info reports the mismatch, then fails.
  EXPECT_THROW(RunVocabInfo({dir_ / "bad.rrv", false}), DataError);
  EXPECT_THROW(RunVocabInfo({dir_ / "missing.rrv", false}), NoInputError);
  // An existing output survives a failed conversion.
  testing::WriteTextFile(dir_ / "keep.txt", "previous");
  EXPECT_THROW(RunVocabConvert({dir_ / "bad.rrv", dir_ / "keep.txt"}), DataError);
  EXPECT_EQ(ReadFileToString(dir_ / "keep.txt"), "previous");
}

}  // namespace
}  // namespace rrslam
