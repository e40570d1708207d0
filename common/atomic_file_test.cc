#include "common/atomic_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <csignal>
#include <fstream>
#include <string>
#include <vector>

#include "common/errors.h"
#include "common/testing.h"

namespace rrslam {
namespace {
namespace fs = std::filesystem;

TEST(AtomicFile, WritesAndLeavesNoTemporary) {
  testing::TempDir dir;
  WriteFileAtomically(dir / "a.txt", "hello\n");
  EXPECT_EQ(ReadFileToString(dir / "a.txt"), "hello\n");
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
}

TEST(AtomicFile, ReplacesExistingFileOnlyOnCommit) {
  testing::TempDir dir;
  WriteFileAtomically(dir / "a.txt", "old");
  {
    AtomicOutput out(dir / "a.txt");
    testing::WriteTextFile(out.temp_path(), "new, not committed");
    // Destroyed without Commit(), as when an exception unwinds.
  }
  EXPECT_EQ(ReadFileToString(dir / "a.txt"), "old");
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
  {
    AtomicOutput out(dir / "a.txt");
    testing::WriteTextFile(out.temp_path(), "new");
    out.Commit();
  }
  EXPECT_EQ(ReadFileToString(dir / "a.txt"), "new");
}

TEST(AtomicFile, MissingOrReadOnlyFolderIsCantCreate) {
  testing::TempDir dir;
  EXPECT_THROW(WriteFileAtomically(dir / "missing" / "a.txt", "x"), CantCreateError);
  EXPECT_THROW(AtomicOutput(dir.path()), CantCreateError);  // A folder, not a file.
  if (::geteuid() != 0) {                                   // root ignores permissions
    fs::create_directory(dir / "ro");
    fs::permissions(dir / "ro", fs::perms::owner_read | fs::perms::owner_exec);
    EXPECT_THROW(WriteFileAtomically(dir / "ro" / "a.txt", "x"), CantCreateError);
  }
}

TEST(AtomicFile, DirectoryOutputReplacesWholeFolder) {
  testing::TempDir dir;
  fs::create_directory(dir / "out");
  testing::WriteTextFile(dir / "out" / "stale.txt", "stale");
  {
    AtomicOutput out(dir / "out", AtomicOutput::Kind::kDirectory);
    testing::WriteTextFile(out.temp_path() / "result.txt", "fresh");
    EXPECT_TRUE(fs::exists(dir / "out" / "stale.txt"));  // Untouched until commit.
    out.Commit();
  }
  EXPECT_TRUE(fs::exists(dir / "out" / "result.txt"));
  EXPECT_FALSE(fs::exists(dir / "out" / "stale.txt"));
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
}

TEST(AtomicFile, TemporaryNamesAreUniqueAndUsersTmpFilesAreKept) {
  testing::TempDir dir;
  // A user's own files under the names older versions used are never touched.
  fs::create_directory(dir / "out.tmp");
  testing::WriteTextFile(dir / "out.tmp" / "mine.txt", "keep");
  testing::WriteTextFile(dir / "a.txt.tmp", "keep too");
  {
    AtomicOutput first(dir / "out", AtomicOutput::Kind::kDirectory);
    AtomicOutput second(dir / "out", AtomicOutput::Kind::kDirectory);
    EXPECT_NE(first.temp_path(), second.temp_path());
    EXPECT_EQ(first.temp_path().parent_path(), dir.path());
    EXPECT_EQ(first.temp_path().extension(), ".tmp");
    testing::WriteTextFile(first.temp_path() / "result.txt", "fresh");
    first.Commit();
  }  // `second` is abandoned: only its own temporary goes.
  {
    AtomicOutput file(dir / "a.txt");
    EXPECT_TRUE(fs::is_regular_file(file.temp_path()));  // Reserved, empty.
    testing::WriteTextFile(file.temp_path(), "new");
    file.Commit();
  }
  EXPECT_EQ(ReadFileToString(dir / "out.tmp" / "mine.txt"), "keep");
  EXPECT_EQ(ReadFileToString(dir / "a.txt.tmp"), "keep too");
  EXPECT_EQ(ReadFileToString(dir / "a.txt"), "new");
  EXPECT_TRUE(fs::exists(dir / "out" / "result.txt"));
  EXPECT_EQ(testing::TemporaryLeftovers(dir), (std::vector<std::string>{"a.txt.tmp", "out.tmp"}));
}

// The process is killed (SIGKILL) at `step` of a folder replacement, in a
// forked child (gtest death test); returns the parent's view afterwards.
void KillDuringFolderReplacement(const fs::path& dir, const char* step, bool fallback) {
  static std::string kill_step;
  kill_step = step;
  EXPECT_EXIT(
      {
        atomic_output_testing::SetForceRenameFallback(fallback);
        atomic_output_testing::SetCommitHook([](std::string_view at) {
          if (at == kill_step) std::raise(SIGKILL);
        });
        AtomicOutput out(dir / "out", AtomicOutput::Kind::kDirectory);
        testing::WriteTextFile(out.temp_path() / "result.txt", "fresh");
        out.Commit();
        std::exit(0);  // Not reached when the hook fires.
      },
      ::testing::KilledBySignal(SIGKILL), "");
}

TEST(AtomicFileDeathTest, KillAfterExchangeLeavesTheNewFolder) {
  testing::TempDir dir;
  fs::create_directory(dir / "out");
  testing::WriteTextFile(dir / "out" / "stale.txt", "stale");
  KillDuringFolderReplacement(dir.path(), "exchanged", /*fallback=*/false);
  // One step replaced the folder: the final name holds the complete new one,
  // the old one waits under the killed run's temporary name.
  EXPECT_EQ(ReadFileToString(dir / "out" / "result.txt"), "fresh");
  EXPECT_FALSE(fs::exists(dir / "out" / "stale.txt"));
  const std::vector<std::string> left = testing::TemporaryLeftovers(dir);
  ASSERT_EQ(left.size(), 1u);
  EXPECT_EQ(ReadFileToString(dir / left[0] / "stale.txt"), "stale");
}

TEST(AtomicFileDeathTest, KillInTheRenameFallbackKeepsTheOldFolder) {
  testing::TempDir dir;
  fs::create_directory(dir / "out");
  testing::WriteTextFile(dir / "out" / "stale.txt", "stale");
  KillDuringFolderReplacement(dir.path(), "moved-aside", /*fallback=*/true);
  // The documented weakness of the fallback: between its two renames the
  // final name is empty; nothing is lost, the old folder is `.old.tmp`.
  EXPECT_FALSE(fs::exists(dir / "out"));
  const std::vector<std::string> left = testing::TemporaryLeftovers(dir);
  ASSERT_EQ(left.size(), 2u);
  const fs::path old_folder = left[0].ends_with(".old.tmp") ? left[0] : left[1];
  EXPECT_EQ(ReadFileToString(dir / old_folder / "stale.txt"), "stale");
}

TEST(AtomicFile, RenameFallbackReplacesTheFolder) {
  testing::TempDir dir;
  fs::create_directory(dir / "out");
  testing::WriteTextFile(dir / "out" / "stale.txt", "stale");
  atomic_output_testing::SetForceRenameFallback(true);
  {
    AtomicOutput out(dir / "out", AtomicOutput::Kind::kDirectory);
    testing::WriteTextFile(out.temp_path() / "result.txt", "fresh");
    out.Commit();
  }
  atomic_output_testing::SetForceRenameFallback(false);
  EXPECT_EQ(ReadFileToString(dir / "out" / "result.txt"), "fresh");
  EXPECT_FALSE(fs::exists(dir / "out" / "stale.txt"));
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
}

TEST(AtomicFile, UncommittedDirectoryIsRemoved) {
  testing::TempDir dir;
  {
    AtomicOutput out(dir / "out", AtomicOutput::Kind::kDirectory);
    testing::WriteTextFile(out.temp_path() / "partial.txt", "x");
  }
  EXPECT_FALSE(fs::exists(dir / "out"));
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
}

TEST(AtomicFile, RefusesDevicesFifosAndFileParents) {
  testing::TempDir dir;
  const auto message = [](const fs::path& path) {
    try {
      AtomicOutput out(path);
    } catch (const CantCreateError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("/dev/null").find("/dev/null: is not a regular file"), std::string::npos);
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  EXPECT_NE(message(dir / "fifo").find("is not a regular file"), std::string::npos);
  EXPECT_TRUE(fs::is_fifo(dir / "fifo"));  // Untouched.
  testing::WriteTextFile(dir / "afile", "x");
  EXPECT_NE(message(dir / "afile" / "trk").find("afile is a file, not a folder"),
            std::string::npos);
  EXPECT_NE(message(dir / "none" / "trk").find("none does not exist"), std::string::npos);
}

TEST(AtomicFile, ReadMissingFileIsNoInput) {
  testing::TempDir dir;
  EXPECT_THROW(ReadFileToString(dir / "absent"), NoInputError);
  EXPECT_THROW(ReadFileToString(dir.path()), NoInputError);
}

}  // namespace
}  // namespace rrslam
