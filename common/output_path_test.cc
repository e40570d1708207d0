#include "common/output_path.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include "common/testing.h"

namespace rrslam {
namespace {

TEST(OutputPath, RefusesAnOutputThatIsContainsOrLiesInsideAnInput) {
  testing::TempDir dir;
  std::filesystem::create_directories(dir / "seq" / "rgb");
  testing::WriteTextFile(dir / "map.rrm", "x");
  std::string why;
  const std::vector<NamedPath> inputs = {{"--map", dir / "map.rrm"}, {"--sequence", dir / "seq"}};
  EXPECT_TRUE(CheckOutputNotInput({"--out", dir / "out.ply"}, inputs, &why)) << why;
  EXPECT_TRUE(CheckOutputNotInput({"--out", dir / "seq-model.ply"}, inputs, &why)) << why;
  EXPECT_TRUE(CheckOutputNotInput({"--out", {}}, inputs, &why));

  EXPECT_FALSE(CheckOutputNotInput({"--out", dir / "map.rrm"}, inputs, &why));
  EXPECT_EQ(why,
            "--out " + (dir / "map.rrm").string() + " is the --map input; it would be overwritten");
  // Another spelling of the same file.
  EXPECT_FALSE(CheckOutputNotInput({"--out", dir / "seq" / ".." / "map.rrm"}, inputs, &why));
  EXPECT_NE(why.find("is the --map input"), std::string::npos);
  // A hard link to it.
  ASSERT_EQ(::link((dir / "map.rrm").c_str(), (dir / "link.rrm").c_str()), 0);
  EXPECT_FALSE(CheckOutputNotInput({"--out", dir / "link.rrm"}, inputs, &why));
  // A symbolic link to the sequence folder, and a file inside it.
  std::filesystem::create_directory_symlink(dir / "seq", dir / "alias");
  EXPECT_FALSE(CheckOutputNotInput({"--out", dir / "alias"}, inputs, &why));
  EXPECT_NE(why.find("is the --sequence input"), std::string::npos);
  EXPECT_FALSE(CheckOutputNotInput({"--out", dir / "alias" / "model.ply"}, inputs, &why));
  EXPECT_NE(why.find("lies inside the --sequence input"), std::string::npos);
  EXPECT_FALSE(CheckOutputNotInput({"--out", dir / "seq/"}, inputs, &why));
  // A folder that contains an input.
  EXPECT_FALSE(CheckOutputNotInput({"--out", dir.path()}, inputs, &why));
  EXPECT_NE(why.find("contains the --map input"), std::string::npos);
}

TEST(OutputPath, OutputsDifferFromEachOther) {
  testing::TempDir dir;
  testing::WriteTextFile(dir / "in.txt", "x");
  std::string why;
  EXPECT_TRUE(CheckOutputs({{"--out", dir / "a"}, {"--plot", dir / "b.png"}, {"--x", {}}},
                           {{"--est", dir / "in.txt"}}, &why))
      << why;
  EXPECT_FALSE(CheckOutputs({{"--out", dir / "a"}, {"--plot", dir / "." / "a"}}, {}, &why));
  EXPECT_EQ(why, "--out and --plot name the same file " + (dir / "a").string());
  EXPECT_FALSE(CheckOutputs({{"--out", dir / "a"}, {"--plot", dir / "in.txt"}},
                            {{"--est", dir / "in.txt"}}, &why));
  EXPECT_NE(why.find("--plot " + (dir / "in.txt").string() + " is the --est input"),
            std::string::npos);
}

}  // namespace
}  // namespace rrslam
