// End to end: scripts/regenerate-vocab.sh, the cron job that republishes a
// vocabulary when the images of its sequence change, on a tiny sequence
// rendered by rrslam-synth: two runs at once (one rebuilds, the other finds
// the lock taken and exits 75, or waits with --wait), a run with nothing
// changed (no rebuild), a run after an image changed (rebuild, the previous
// vocabulary kept), one after an image was only touched (rebuild, nothing
// republished), and the documented exit codes of bad calls.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "common/atomic_file.h"
#include "common/testing.h"
#include "common/text.h"

namespace rrslam {
namespace {

namespace fs = std::filesystem;

using testing::Quote;
using testing::SourceDir;

// Occurrences of `needle` in `text`.
int Count(const std::string& text, const std::string& needle) {
  int n = 0;
  for (size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1)) ++n;
  return n;
}

class RegenerateVocabTest : public ::testing::Test {
 protected:
  // One sequence for the suite: 8 small frames with coarse textures render
  // in about a second, and a vocabulary is built from them in about two.
  static void SetUpTestSuite() {
    suite_dir_ = new testing::TempDir();
    fs::create_directories(data());
    const auto r = testing::RunTool("synth", "--quiet --out " + Quote(data() / "room") +
                                                 " --trajectory loop --frames 8 --width 320 "
                                                 "--height 240 --texel-size 0.01 --seed 3");
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  static void TearDownTestSuite() {
    delete suite_dir_;
    suite_dir_ = nullptr;
  }
  static fs::path data() { return suite_dir_->path() / "data"; }
  // Published files, logs and the pipeline's work, per test.
  fs::path publish() const { return dir_.path() / "published"; }
  fs::path logs() const { return publish() / "logs"; }

  // The script's command line (executables of this build, no build step; a
  // small vocabulary). The outer make's job server is not inherited.
  std::string Command(const std::string& extra = "") const {
    return "env -u MAKEFLAGS -u MFLAGS -u MAKELEVEL " +
           Quote(SourceDir() / "scripts" / "regenerate-vocab.sh") + " --data-root " +
           Quote(data()) + " --publish-dir " + Quote(publish()) + " --bin " +
           Quote(fs::absolute(testing::BinDir())) + " " + extra +
           " room VOCAB_K=6 VOCAB_L=3 VOCAB_THREADS=1";
  }

  // Every dated log, concatenated (a run near midnight writes two).
  std::string Logs() const {
    std::string all;
    const std::regex name("regenerate-vocab-[0-9]{4}-[0-9]{2}-[0-9]{2}\\.log");
    if (!fs::exists(logs())) return all;
    for (const auto& entry : fs::directory_iterator(logs())) {
      EXPECT_TRUE(std::regex_match(entry.path().filename().string(), name)) << entry.path();
      all += ReadFileToString(entry.path());
    }
    return all;
  }

  // The images rgb.txt lists, relative to the sequence.
  static std::vector<std::string> ListedImages() {
    std::vector<std::string> images;
    std::istringstream list(ReadFileToString(data() / "room" / "rgb.txt"));
    std::string line;
    while (std::getline(list, line)) {
      std::istringstream fields(line);
      std::string timestamp, image;
      if (line.empty() || line[0] == '#' || !(fields >> timestamp >> image)) continue;
      images.push_back(image);
    }
    return images;
  }

  static testing::TempDir* suite_dir_;
  testing::TempDir dir_;
};

testing::TempDir* RegenerateVocabTest::suite_dir_ = nullptr;

TEST_F(RegenerateVocabTest, OneRebuildAtATimeOnlyWhenImagesChange) {
  const fs::path published = publish() / "room.rrv";
  const fs::path previous = publish() / "room.previous.rrv";

  // Two runs at once: the lock is taken before anything slow, and a rebuild
  // takes seconds, so the second finds it held.
  const std::string cmd = Command();
  const auto both = testing::RunCommand("(" + cmd + "; echo \"exit-a $?\") & (" + cmd +
                                        "; echo \"exit-b $?\") & wait");
  const bool a_built = both.output.find("exit-a 0") != std::string::npos;
  const bool b_built = both.output.find("exit-b 0") != std::string::npos;
  EXPECT_NE(a_built, b_built) << both.output << Logs();
  EXPECT_NE(both.output.find(a_built ? "exit-b 75" : "exit-a 75"), std::string::npos)
      << both.output << Logs();
  std::string log = Logs();
  EXPECT_EQ(Count(log, "room: rebuilding"), 1) << log;
  EXPECT_EQ(Count(log, "another run holds"), 1) << log;
  EXPECT_EQ(Count(log, "room: published"), 1) << log;
  ASSERT_TRUE(fs::exists(published)) << log;
  EXPECT_FALSE(fs::exists(previous));
  EXPECT_TRUE(fs::exists(publish() / "room.fingerprint"));
  EXPECT_TRUE(testing::TemporaryLeftovers(publish()).empty());
  const auto info = testing::RunTool("vocab", "info " + Quote(published));
  ASSERT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("k: 6"), std::string::npos) << info.output;
  const std::string first = ReadFileToString(published);
  const auto first_time = fs::last_write_time(published);

  // Nothing changed: no rebuild, the published file untouched.
  const auto again = testing::RunCommand(cmd);
  EXPECT_EQ(again.exit_code, 0) << again.output;
  EXPECT_TRUE(again.output.empty()) << again.output;  // Quiet for cron.
  log = Logs();
  EXPECT_EQ(Count(log, "room: rebuilding"), 1) << log;
  EXPECT_EQ(Count(log, "room: up to date"), 1) << log;
  EXPECT_EQ(fs::last_write_time(published), first_time);
  EXPECT_FALSE(fs::exists(previous));

  // An image changes (its list does not, so make alone would not notice):
  // rebuilt, and the vocabulary it replaces is kept.
  const std::vector<std::string> images = ListedImages();
  ASSERT_GE(images.size(), 6u);
  fs::copy_file(data() / "room" / images[5], data() / "room" / images[0],
                fs::copy_options::overwrite_existing);
  const auto changed = testing::RunCommand(cmd);
  EXPECT_EQ(changed.exit_code, 0) << changed.output;
  log = Logs();
  EXPECT_EQ(Count(log, "room: rebuilding"), 2) << log;
  EXPECT_EQ(Count(log, "room: images of"), 2) << log;
  ASSERT_TRUE(fs::exists(previous)) << log;
  EXPECT_EQ(ReadFileToString(previous), first);
  EXPECT_NE(ReadFileToString(published), first);
  EXPECT_EQ(testing::RunTool("vocab", "info " + Quote(published)).exit_code, 0);
  EXPECT_TRUE(testing::TemporaryLeftovers(publish()).empty());

  // An image touched, not changed: rebuilt (the fingerprint holds times, not
  // contents), but the same vocabulary is not published again, so the
  // previous one stays the one before.
  const std::string second = ReadFileToString(published);
  fs::last_write_time(data() / "room" / images[1], fs::file_time_type::clock::now());
  const auto touched = testing::RunCommand(cmd);
  EXPECT_EQ(touched.exit_code, 0) << touched.output;
  log = Logs();
  EXPECT_EQ(Count(log, "room: rebuilding"), 3) << log;
  EXPECT_EQ(Count(log, "byte for byte: left as it is"), 1) << log;
  EXPECT_EQ(ReadFileToString(published), second);
  EXPECT_EQ(ReadFileToString(previous), first);
}

TEST_F(RegenerateVocabTest, WaitsForTheLockWhenAskedAndReportsBadCalls) {
  const fs::path script = SourceDir() / "scripts" / "regenerate-vocab.sh";
  const auto help = testing::RunCommand(Quote(script) + " --help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.output.find("Exit codes:"), std::string::npos) << help.output;
  EXPECT_NE(help.output.find("75  another run holds the lock"), std::string::npos);
  EXPECT_EQ(testing::RunCommand(Quote(script) + " --no-such-option room").exit_code, 64);
  EXPECT_EQ(testing::RunCommand(Quote(script)).exit_code, 64);
  EXPECT_EQ(testing::RunCommand(Quote(script) + " ../room").exit_code, 64);
  const auto missing = testing::RunCommand(
      Quote(script) + " --data-root " + Quote(data()) + " --publish-dir " + Quote(publish()) +
      " --bin " + Quote(fs::absolute(testing::BinDir())) + " no_such_sequence");
  EXPECT_EQ(missing.exit_code, 66) << missing.output;
  EXPECT_NE(missing.output.find("no_such_sequence: no sequence"), std::string::npos)
      << missing.output;

  // Held lock, with --wait: the second run waits, then finds the vocabulary
  // the first one published up to date.
  const std::string cmd = Command("--wait 120");
  const auto both = testing::RunCommand("(" + cmd + "; echo \"exit-a $?\") & (" + cmd +
                                        "; echo \"exit-b $?\") & wait");
  EXPECT_NE(both.output.find("exit-a 0"), std::string::npos) << both.output;
  EXPECT_NE(both.output.find("exit-b 0"), std::string::npos) << both.output;
  const std::string log = Logs();
  EXPECT_EQ(Count(log, "room: rebuilding"), 1) << log;
  EXPECT_EQ(Count(log, "room: up to date"), 1) << log;
  EXPECT_EQ(Count(log, "another run holds"), 0) << log;
}

}  // namespace
}  // namespace rrslam
