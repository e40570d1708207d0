// End to end: `make vocab` (extract -> cluster -> vocab build -> convert) on a
// sequence rendered by rrslam-synth, then `rrslam-vocab query` on its frames.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "common/atomic_file.h"
#include "common/testing.h"
#include "common/text.h"

namespace rrslam {
namespace {

namespace fs = std::filesystem;

using testing::Quote;
using testing::SourceDir;

constexpr int kFrames = 48;

class VocabPipelineTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir();
    fs::create_directories(data());
    const auto r = testing::RunTool("synth", "--quiet --out " + Quote(data() / "room") +
                                                 " --trajectory loop --frames " +
                                                 std::to_string(kFrames) + " --seed 5");
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static fs::path data() { return dir_->path() / "data"; }
  static fs::path out() { return dir_->path() / "pipeline"; }

  // `make vocab` (or another goal of pipelines/vocab.mk, as eval.mk and the
  // benchmarks make them) with the test's executables (no build step) and data
  // root. The outer make's job server is not inherited (MAKEFLAGS unset).
  static testing::CommandResult MakeVocab(const std::string& dataset, const std::string& extra = "",
                                          const std::string& goal = "vocab") {
    return testing::RunCommand(
        "env -u MAKEFLAGS -u MFLAGS -u MAKELEVEL make --no-print-directory -C " +
        Quote(SourceDir()) + " " + goal + " DATASET=" + dataset + " DATA_ROOT=" + Quote(data()) +
        " PIPELINE_ROOT=" + Quote(out()) + " BIN=" + Quote(fs::absolute(testing::BinDir())) +
        " SKIP_BUILD=1 VOCAB_K=10 VOCAB_L=4 " + extra);
  }

  static testing::TempDir* dir_;
};

testing::TempDir* VocabPipelineTest::dir_ = nullptr;

TEST_F(VocabPipelineTest, TrainsQueriesAndRerunsNothing) {
  ASSERT_TRUE(fs::exists(SourceDir() / "pipelines" / "vocab.mk")) << SourceDir();
  const auto first = MakeVocab("room");
  ASSERT_EQ(first.exit_code, 0) << first.output;
  const fs::path room = out() / "room";
  for (const char* f : {"features.h5", "tree.h5", "voc.rrv", "voc.txt"}) {
    EXPECT_TRUE(fs::exists(room / f)) << f;
  }
  for (const auto& entry : fs::directory_iterator(room)) {
    EXPECT_NE(entry.path().extension(), ".tmp") << entry.path();
  }

  // A rerun finds every step up to date.
  const auto before = fs::last_write_time(room / "voc.rrv");
  const auto again = MakeVocab("room");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_EQ(again.output.find("rrslam-extract"), std::string::npos) << again.output;
  EXPECT_EQ(again.output.find("rrslam-cluster"), std::string::npos) << again.output;
  EXPECT_EQ(fs::last_write_time(room / "voc.rrv"), before);
  // A changed build option redoes only the vocabulary, not extraction or clustering.
  const auto features_time = fs::last_write_time(room / "features.h5");
  const auto rebuilt = MakeVocab("room", "VOCAB_WEIGHTING=idf");
  ASSERT_EQ(rebuilt.exit_code, 0) << rebuilt.output;
  EXPECT_NE(rebuilt.output.find("rrslam-vocab build"), std::string::npos) << rebuilt.output;
  EXPECT_EQ(rebuilt.output.find("rrslam-cluster"), std::string::npos) << rebuilt.output;
  EXPECT_EQ(fs::last_write_time(room / "features.h5"), features_time);
  ASSERT_EQ(MakeVocab("room").exit_code, 0);  // Back to tf-idf.

  // The binary file is sound and the text converts back to the same vocabulary.
  const auto info = testing::RunTool("vocab", "info --json " + Quote(room / "voc.rrv"));
  ASSERT_EQ(info.exit_code, 0) << info.output;
  const nlohmann::json header = nlohmann::json::parse(info.output);
  EXPECT_EQ(header["k"], 10);
  EXPECT_EQ(header["levels"], 4);
  EXPECT_EQ(header["weighting"], "tf-idf");
  EXPECT_EQ(header["checksum"].get<std::string>().rfind("ok", 0), 0u);
  EXPECT_GT(header["words"].get<int>(), 1000);
  ASSERT_EQ(testing::RunTool("vocab", "--quiet convert " + Quote(room / "voc.txt") + " " +
                                          Quote(dir_->path() / "back.rrv"))
                .exit_code,
            0);
  ASSERT_EQ(testing::RunTool("vocab", "--quiet convert " + Quote(dir_->path() / "back.rrv") + " " +
                                          Quote(dir_->path() / "back.txt"))
                .exit_code,
            0);
  EXPECT_EQ(ReadFileToString(room / "voc.txt"), ReadFileToString(dir_->path() / "back.txt"));

  // Each query frame scores highest against itself, then against its
  // neighbours on the loop; frames on the far side of the room score lower.
  for (int frame : {12, 24, 36}) {
    const auto q = testing::RunTool(
        "vocab", "query --json --all --vocab " + Quote(room / "voc.rrv") + " --features " +
                     Quote(room / "features.h5") + " --frame " + std::to_string(frame));
    ASSERT_EQ(q.exit_code, 0) << q.output;
    const nlohmann::json result = nlohmann::json::parse(q.output.substr(q.output.find('{')));
    const auto& scores = result["scores"];
    ASSERT_EQ(scores.size(), static_cast<size_t>(kFrames));
    std::vector<std::pair<double, int>> ranked;
    for (const auto& s : scores) ranked.emplace_back(s["score"].get<double>(), s["b"].get<int>());
    std::sort(ranked.rbegin(), ranked.rend());
    EXPECT_EQ(ranked[0].second, frame);
    EXPECT_NEAR(ranked[0].first, 1.0, 1e-9);
    auto loop_distance = [&](int j) {
      const int d = std::abs(j - frame);
      return std::min(d, kFrames - d);
    };
    EXPECT_LE(loop_distance(ranked[1].second), 2) << "best other frame " << ranked[1].second;
    double near = 0, far = 0, min_near = 1;
    int num_near = 0, num_far = 0;
    for (const auto& [score, j] : ranked) {
      if (j == frame) continue;
      if (loop_distance(j) <= 2) {
        near += score;
        min_near = std::min(min_near, score);
        ++num_near;
      } else if (loop_distance(j) >= kFrames / 4) {
        far += score;
        ++num_far;
      }
    }
    ASSERT_EQ(num_near, 4);
    EXPECT_GT(near / num_near, 1.5 * far / num_far) << "frame " << frame;
    EXPECT_GT(min_near, far / num_far) << "frame " << frame;
  }
}

TEST_F(VocabPipelineTest, UnknownDatasetFailsWithoutOutput) {
  const auto r = MakeVocab("no_such_sequence");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("no sequence 'no_such_sequence'"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out() / "no_such_sequence"));
}

// A sequence without settings (no settings.yaml, no TUM camera in its name,
// no SETTINGS=): `make vocab` stops before running anything, and a file goal
// of the pipeline (as eval-all asks for) fails with the same message.
TEST_F(VocabPipelineTest, SequenceWithoutSettingsFailsWithoutOutput) {
  const fs::path seq = data() / "plain";
  fs::create_directories(seq);
  fs::copy_file(data() / "room" / "rgb.txt", seq / "rgb.txt");
  fs::copy_file(data() / "room" / "depth.txt", seq / "depth.txt");
  for (const std::string& goal : {std::string("vocab"), Quote(out() / "plain" / "voc.rrv")}) {
    const auto r = MakeVocab("plain", "", goal);
    EXPECT_NE(r.exit_code, 0) << goal;
    EXPECT_NE(r.output.find("no settings for 'plain'"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(out() / "plain" / "features.h5")) << goal;
  }
}

}  // namespace
}  // namespace rrslam
