#include "common/path_check.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <string>
#include <utility>

#include "common/dataset.h"
#include "common/errors.h"
#include "common/settings.h"
#include "common/testing.h"

namespace rrslam {
namespace {
namespace fs = std::filesystem;

// The NoInputError message of `fn`, or "no error".
template <typename Fn>
std::string NoInputMessage(Fn&& fn) {
  return testing::ErrorMessage<NoInputError>(std::forward<Fn>(fn));
}

TEST(PathCheck, NamesWhatIsThere) {
  testing::TempDir dir;
  testing::WriteTextFile(dir / "file.txt", "x");
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  fs::create_symlink(dir / "gone", dir / "dangling");
  const fs::path too_long = dir / std::string(300, 'n');
  EXPECT_EQ(WhyNotAFile(dir / "file.txt"), "");
  EXPECT_EQ(WhyNotAFolder(dir.path()), "");
  EXPECT_EQ(WhyNotAFile(dir / "missing"), "does not exist");
  EXPECT_EQ(WhyNotAFile(dir.path()), "is a folder");
  EXPECT_EQ(WhyNotAFolder(dir / "file.txt"), "is a regular file");
  EXPECT_EQ(WhyNotAFile(dir / "fifo"), "is a FIFO");
  EXPECT_EQ(WhyNotAFile("/dev/zero"), "is a character device");
  EXPECT_EQ(WhyNotAFile(dir / "dangling"), "is a broken symbolic link");
  EXPECT_EQ(WhyNotAFolder(too_long), "has a name longer than the system allows");
  EXPECT_EQ(WhyNotAFile(dir / "file.txt" / "x"), "cannot be reached: Not a directory");
}

// Issue 36's misleading messages: each input is named for what it is.
TEST(PathCheck, ReadersSayWhatTheInputIs) {
  testing::TempDir dir;
  EXPECT_EQ(NoInputMessage([] { (void)ReadSettings("/dev/zero"); }),
            "/dev/zero: is a character device, not a settings file");
  EXPECT_EQ(NoInputMessage([&] { (void)ReadSettings(dir / "s.yaml"); }),
            (dir / "s.yaml").string() + ": no such settings file");
  const fs::path too_long = dir / std::string(300, 's');
  EXPECT_EQ(
      NoInputMessage([&] { (void)RgbdSequence::Open(too_long); }),
      too_long.string() + ": has a name longer than the system allows, not a sequence folder");
  // A FIFO listed as an image.
  const fs::path seq = dir / "seq";
  fs::create_directories(seq / "rgb");
  testing::WriteTextFile(seq / "rgb.txt", "1.0 rgb/1.png\n");
  testing::WriteTextFile(seq / "depth.txt", "1.0 rgb/2.png\n");
  testing::WriteTextFile(seq / "rgb" / "2.png", "x");
  ASSERT_EQ(::mkfifo((seq / "rgb" / "1.png").c_str(), 0600), 0);
  try {
    (void)RgbdSequence::Open(seq);
    FAIL();
  } catch (const DataError& e) {
    EXPECT_EQ(std::string(e.what()), (seq / "rgb" / "1.png").string() + ": listed image is a FIFO");
  }
}

}  // namespace
}  // namespace rrslam
