#include "common/atomic_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <csignal>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "common/errors.h"
#include "common/testing.h"

namespace rrslam {
namespace {
namespace fs = std::filesystem;

// A tool writing result.txt and stale.txt, and images/<n>.png, with run.json
// as its record.
const OutputFolderOwner kOwner = {.tool = "rrslam-test",
                                  .files = {"result.txt", "stale.txt", "run.json"},
                                  .folders = {{"images", R"(\d+\.png)"}},
                                  .record = "run.json"};

// Everything under `dir`: relative path -> content, "<folder>" or "<link>".
std::map<std::string, std::string> Snapshot(const fs::path& dir) {
  std::map<std::string, std::string> entries;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    const std::string name = fs::relative(entry.path(), dir).string();
    if (entry.is_symlink()) {
      entries[name] = "<link>";
    } else if (entry.is_directory()) {
      entries[name] = "<folder>";
    } else {
      entries[name] = ReadFileToString(entry.path());
    }
  }
  return entries;
}

// The CantCreateError message of making a folder output at `path`, or "no error".
std::string FolderOutputError(const fs::path& path, const OutputFolderOwner& owner = kOwner) {
  try {
    AtomicOutput out(path, AtomicOutput::Kind::kDirectory, owner);
  } catch (const CantCreateError& e) {
    return e.what();
  }
  return "no error";
}

// Writes a new output of kOwner at `path` (result.txt = `content`).
void WriteOwnOutput(const fs::path& path, const std::string& content) {
  AtomicOutput out(path, AtomicOutput::Kind::kDirectory, kOwner);
  testing::WriteTextFile(out.temp_path() / "result.txt", content);
  out.Commit();
}

TEST(AtomicFile, WritesAndLeavesNoTemporary) {
  testing::TempDir dir;
  WriteFileAtomically(dir / "a.txt", "hello\n");
  EXPECT_EQ(ReadFileToString(dir / "a.txt"), "hello\n");
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
}

// Issue 36: names of 245-255 bytes are legal; the temporary's suffix must
// not make them fail with "File name too long".
TEST(AtomicFile, LongestLegalNamesAreWritten) {
  testing::TempDir dir;
  for (const size_t length : {245u, 250u, 255u}) {
    const std::string name = std::string(length - 4, 'n') + ".txt";
    WriteFileAtomically(dir / name, "long\n");
    EXPECT_EQ(ReadFileToString(dir / name), "long\n") << length;
    WriteFileAtomically(dir / name, "again\n");  // Replaced, too.
    EXPECT_EQ(ReadFileToString(dir / name), "again\n") << length;
    const fs::path folder = dir / std::string(length, 'd');
    WriteOwnOutput(folder, "one");
    WriteOwnOutput(folder, "two");  // Exchanged with the old one.
    EXPECT_EQ(ReadFileToString(folder / "result.txt"), "two") << length;
  }
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
  WriteOwnOutput(dir / "out", "old");
  testing::WriteTextFile(dir / "out" / "stale.txt", "stale");
  {
    AtomicOutput out(dir / "out", AtomicOutput::Kind::kDirectory, kOwner);
    testing::WriteTextFile(out.temp_path() / "result.txt", "fresh");
    EXPECT_TRUE(fs::exists(dir / "out" / "stale.txt"));  // Untouched until commit.
    out.Commit();
  }
  EXPECT_EQ(ReadFileToString(dir / "out" / "result.txt"), "fresh");
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
        AtomicOutput out(dir / "out", AtomicOutput::Kind::kDirectory, kOwner);
        testing::WriteTextFile(out.temp_path() / "result.txt", "fresh");
        out.Commit();
        std::exit(0);  // Not reached when the hook fires.
      },
      ::testing::KilledBySignal(SIGKILL), "");
}

TEST(AtomicFileDeathTest, KillAfterExchangeLeavesTheNewFolder) {
  testing::TempDir dir;
  WriteOwnOutput(dir / "out", "old");
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
  WriteOwnOutput(dir / "out", "old");
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
  WriteOwnOutput(dir / "out", "old");
  testing::WriteTextFile(dir / "out" / "stale.txt", "stale");
  atomic_output_testing::SetForceRenameFallback(true);
  {
    AtomicOutput out(dir / "out", AtomicOutput::Kind::kDirectory, kOwner);
    testing::WriteTextFile(out.temp_path() / "result.txt", "fresh");
    out.Commit();
  }
  atomic_output_testing::SetForceRenameFallback(false);
  EXPECT_EQ(ReadFileToString(dir / "out" / "result.txt"), "fresh");
  EXPECT_FALSE(fs::exists(dir / "out" / "stale.txt"));
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
}

// Issue 36: an existing folder is replaced only when it is empty or an
// earlier output of the same tool; anything else is refused, byte for byte
// unchanged, when the output is made and again at Commit().
TEST(AtomicFile, EmptyFolderIsReplaced) {
  testing::TempDir dir;
  fs::create_directory(dir / "out");
  fs::create_directory(dir / "plain");
  WriteOwnOutput(dir / "out", "fresh");
  EXPECT_EQ(ReadFileToString(dir / "out" / "result.txt"), "fresh");
  {  // Without an owner: an empty folder only, and no marker.
    AtomicOutput out(dir / "plain", AtomicOutput::Kind::kDirectory);
    testing::WriteTextFile(out.temp_path() / "a.txt", "a");
    out.Commit();
  }
  EXPECT_EQ(Snapshot(dir / "plain"), (std::map<std::string, std::string>{{"a.txt", "a"}}));
  EXPECT_NE(FolderOutputError(dir / "plain", {}).find("plain: is not empty (a.txt)"),
            std::string::npos);
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
}

TEST(AtomicFile, FolderWithTheMarkerOfTheSameToolIsReplaced) {
  testing::TempDir dir;
  {
    AtomicOutput out(dir / "out", AtomicOutput::Kind::kDirectory, kOwner);
    // The marker is there from the start: a committed folder always has it.
    EXPECT_EQ(ReadFileToString(out.temp_path() / ".rrslam-output"), "rrslam-test\n");
    testing::WriteTextFile(out.temp_path() / "result.txt", "first");
    fs::create_directory(out.temp_path() / "images");
    testing::WriteTextFile(out.temp_path() / "images" / "12.png", "png");
    out.Commit();
  }
  EXPECT_EQ(ReadFileToString(dir / "out" / ".rrslam-output"), "rrslam-test\n");
  WriteOwnOutput(dir / "out", "second");
  EXPECT_EQ(Snapshot(dir / "out"),
            (std::map<std::string, std::string>{{".rrslam-output", "rrslam-test\n"},
                                                {"result.txt", "second"}}));
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
}

TEST(AtomicFile, LegacyFolderWithExactlyTheToolsFilesIsReplaced) {
  testing::TempDir dir;
  // Written by a version before the marker: the tool's files, its record
  // naming it as the producer.
  fs::create_directories(dir / "out" / "images");
  testing::WriteTextFile(dir / "out" / "result.txt", "old");
  testing::WriteTextFile(dir / "out" / "stale.txt", "old");
  testing::WriteTextFile(dir / "out" / "run.json", R"({"producer": "rrslam-test 0.1"})");
  testing::WriteTextFile(dir / "out" / "images" / "0.png", "png");
  WriteOwnOutput(dir / "out", "new");
  EXPECT_EQ(Snapshot(dir / "out"),
            (std::map<std::string, std::string>{{".rrslam-output", "rrslam-test\n"},
                                                {"result.txt", "new"}}));

  // The tool's names without its record (ORB-SLAM2 writes
  // CameraTrajectory.txt and KeyFrameTrajectory.txt too), or a record of
  // another producer, are not its output.
  fs::create_directory(dir / "orb");
  testing::WriteTextFile(dir / "orb" / "result.txt", "orb");
  EXPECT_NE(FolderOutputError(dir / "orb").find("(result.txt, without run.json of rrslam-test)"),
            std::string::npos);
  testing::WriteTextFile(dir / "orb" / "run.json", R"({"producer": "rrslam-testing 2"})");
  EXPECT_NE(FolderOutputError(dir / "orb").find("(run.json of rrslam-testing 2)"),
            std::string::npos);
  testing::WriteTextFile(dir / "orb" / "run.json", "not json");
  EXPECT_NE(FolderOutputError(dir / "orb").find("(run.json of another tool)"), std::string::npos);
  EXPECT_EQ(ReadFileToString(dir / "orb" / "result.txt"), "orb");
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
}

TEST(AtomicFile, FolderWithForeignEntriesIsRefusedAndKept) {
  struct Case {
    const char* what;
    void (*make)(const fs::path& out);
    std::string entry;  // As the message names it.
  };
  const std::vector<Case> cases = {
      {"a foreign file",
       [](const fs::path& out) { testing::WriteTextFile(out / "notes.txt", "my notes"); },
       "notes.txt"},
      {"a foreign sub-folder",
       [](const fs::path& out) {
         fs::create_directory(out / "older");
         testing::WriteTextFile(out / "older" / "result.txt", "keep");
       },
       "older"},
      {"the marker of another tool",
       [](const fs::path& out) {
         testing::WriteTextFile(out / ".rrslam-output", "rrslam-other\n");
       },
       ".rrslam-output of rrslam-other"},
      {"a foreign file in the tool's sub-folder",
       [](const fs::path& out) { testing::WriteTextFile(out / "images" / "cat.jpg", "cat"); },
       "images/cat.jpg"},
      {"a folder under the name of the tool's file",
       [](const fs::path& out) { fs::create_directory(out / "stale.txt"); }, "stale.txt"},
      {"a symbolic link under the name of the tool's file",
       [](const fs::path& out) { fs::create_symlink("/etc/hostname", out / "stale.txt"); },
       "stale.txt"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    testing::TempDir dir;
    const fs::path out = dir / "runs";
    {  // An earlier output of the tool, then the foreign entry.
      AtomicOutput first(out, AtomicOutput::Kind::kDirectory, kOwner);
      testing::WriteTextFile(first.temp_path() / "result.txt", "earlier");
      fs::create_directory(first.temp_path() / "images");
      testing::WriteTextFile(first.temp_path() / "images" / "1.png", "png");
      first.Commit();
    }
    c.make(out);
    const auto before = Snapshot(out);
    const std::string message = FolderOutputError(out);
    EXPECT_EQ(message, out.string() + ": holds files rrslam-test did not write (" + c.entry +
                           "); give an empty or new folder, or one an earlier rrslam-test run "
                           "wrote");
    EXPECT_EQ(message.find('\n'), std::string::npos);
    EXPECT_EQ(Snapshot(out), before);
    EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
  }
}

TEST(AtomicFile, CommitChecksTheFolderAgain) {
  for (const bool fallback : {false, true}) {
    SCOPED_TRACE(fallback ? "rename fallback" : "exchange");
    atomic_output_testing::SetForceRenameFallback(fallback);
    testing::TempDir dir;
    fs::create_directory(dir / "empty");
    WriteOwnOutput(dir / "own", "earlier");
    for (const char* name : {"empty", "own"}) {
      AtomicOutput out(dir / name, AtomicOutput::Kind::kDirectory, kOwner);
      testing::WriteTextFile(out.temp_path() / "result.txt", "new");
      // Someone puts a file there while the tool works.
      testing::WriteTextFile(dir / name / "notes.txt", "my notes");
      const auto before = Snapshot(dir / name);
      try {
        out.Commit();
        ADD_FAILURE() << name << ": committed over notes.txt";
      } catch (const CantCreateError& e) {
        EXPECT_NE(std::string(e.what()).find((dir / name).string() +
                                             ": holds files rrslam-test did not write (notes.txt)"),
                  std::string::npos)
            << e.what();
      }
      EXPECT_EQ(Snapshot(dir / name), before) << name;
    }
    atomic_output_testing::SetForceRenameFallback(false);
    EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
  }
}

// A file that gets into the old folder after Commit()'s check (here: at the
// "exchanged" step) is not deleted: the old folder stays under its .tmp name.
TEST(AtomicFile, FileAddedAfterTheCheckIsKept) {
  testing::TempDir dir;
  WriteOwnOutput(dir / "out", "earlier");
  static fs::path old_folder;
  {
    AtomicOutput out(dir / "out", AtomicOutput::Kind::kDirectory, kOwner);
    old_folder = out.temp_path();  // Holds the old folder after the exchange.
    testing::WriteTextFile(out.temp_path() / "result.txt", "new");
    atomic_output_testing::SetCommitHook([](std::string_view step) {
      if (step == "exchanged") testing::WriteTextFile(old_folder / "notes.txt", "my notes");
    });
    out.Commit();
    atomic_output_testing::SetCommitHook(nullptr);
  }
  EXPECT_EQ(ReadFileToString(dir / "out" / "result.txt"), "new");
  EXPECT_EQ(ReadFileToString(old_folder / "notes.txt"), "my notes");
}

TEST(AtomicFile, SymbolicLinkOrWorkingFolderIsRefused) {
  testing::TempDir dir;
  WriteOwnOutput(dir / "own", "earlier");
  fs::create_directory_symlink(dir / "own", dir / "link");
  EXPECT_NE(FolderOutputError(dir / "link").find("link: is a symbolic link"), std::string::npos);
  EXPECT_TRUE(fs::is_symlink(dir / "link"));
  EXPECT_EQ(ReadFileToString(dir / "own" / "result.txt"), "earlier");

  // The working folder, or a folder holding it, even when it is the tool's own
  // or empty: the run would leave the user's shell in a deleted folder.
  fs::create_directories(dir / "empty");
  const fs::path cwd = fs::current_path();
  for (const char* inside : {"own", "empty"}) {
    fs::current_path(dir / inside);
    for (const fs::path& path : {fs::path("."), fs::path("./"), fs::path("../") / inside,
                                 dir / inside, fs::path(".."), dir.path()}) {
      EXPECT_NE(FolderOutputError(path).find(": is the current folder or holds it"),
                std::string::npos)
          << path;
    }
    fs::current_path(cwd);
  }
  EXPECT_EQ(ReadFileToString(dir / "own" / "result.txt"), "earlier");
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
  // A device never ends (issue 36: `--gt /dev/zero` read for ever).
  try {
    ReadFileToString("/dev/zero");
    FAIL();
  } catch (const NoInputError& e) {
    EXPECT_STREQ(e.what(), "/dev/zero: is a character device, expected a file");
  }
  // A pipe is read to its end.
  ASSERT_EQ(::mkfifo((dir / "pipe").c_str(), 0600), 0);
  std::thread writer([&] { std::ofstream(dir / "pipe") << "through a pipe\n"; });
  EXPECT_EQ(ReadFileToString(dir / "pipe"), "through a pipe\n");
  writer.join();
}

}  // namespace
}  // namespace rrslam
