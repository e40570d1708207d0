#include "common/atomic_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>

#include "common/errors.h"
#include "common/testing.h"

namespace rrslam {
namespace {
namespace fs = std::filesystem;

TEST(AtomicFile, WritesAndLeavesNoTemporary) {
  testing::TempDir dir;
  WriteFileAtomically(dir / "a.txt", "hello\n");
  EXPECT_EQ(ReadFileToString(dir / "a.txt"), "hello\n");
  EXPECT_FALSE(fs::exists(dir / "a.txt.tmp"));
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
  EXPECT_FALSE(fs::exists(dir / "a.txt.tmp"));
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
  EXPECT_FALSE(fs::exists(dir / "out.tmp"));
  EXPECT_FALSE(fs::exists(dir / "out.old.tmp"));
}

TEST(AtomicFile, UncommittedDirectoryIsRemoved) {
  testing::TempDir dir;
  {
    AtomicOutput out(dir / "out", AtomicOutput::Kind::kDirectory);
    testing::WriteTextFile(out.temp_path() / "partial.txt", "x");
  }
  EXPECT_FALSE(fs::exists(dir / "out"));
  EXPECT_FALSE(fs::exists(dir / "out.tmp"));
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
