#include "stages/cluster/vocab_tree.h"

#include <gtest/gtest.h>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/testing.h"
#include "stages/extract/features_file.h"

namespace rrslam {
namespace {

// Root with two children; the first has two leaf children.
//   0 -> {1, 2}, 1 -> {3, 4}
VocabTree SmallTree() {
  VocabTree t;
  t.k = 2;
  t.levels = 2;
  t.parent = {-1, 0, 0, 1, 1};
  t.level = {0, 1, 1, 2, 2};
  t.count = {5, 3, 2, 2, 1};
  t.centre.resize(5);
  for (int i = 0; i < 5; ++i) t.centre[i].bytes[i] = static_cast<uint8_t>(10 * i + 1);
  return t;
}

TEST(VocabTree, WriteReadRoundTrip) {
  testing::TempDir dir;
  const VocabTree t = SmallTree();
  WriteVocabTree(dir / "tree.h5", t, "rrslam-test 0", {{"k", 2}});
  H5FormatInfo info;
  const VocabTree r = ReadVocabTree(dir / "tree.h5", &info);
  EXPECT_EQ(info.format, "rrslam.vocab_tree");
  EXPECT_EQ(info.major, 1);
  EXPECT_EQ(info.producer, "rrslam-test 0");
  EXPECT_EQ(info.options["k"], 2);
  EXPECT_EQ(r.k, 2);
  EXPECT_EQ(r.levels, 2);
  EXPECT_EQ(r.parent, t.parent);
  EXPECT_EQ(r.level, t.level);
  EXPECT_EQ(r.count, t.count);
  EXPECT_TRUE(r.centre == t.centre);
  EXPECT_EQ(r.NumLeaves(), 3u);
  const auto ranges = r.ChildRanges();
  EXPECT_EQ(ranges[0], std::make_pair(1u, 2u));
  EXPECT_EQ(ranges[1], std::make_pair(3u, 2u));
  EXPECT_EQ(ranges[2].second, 0u);
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
}

void ExpectInvalid(const VocabTree& t, const std::string& fragment) {
  try {
    ValidateVocabTree(t, "t.h5");
    ADD_FAILURE() << "accepted a tree that should fail with: " << fragment;
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("t.h5"), std::string::npos) << e.what();
  }
}

TEST(VocabTree, ValidationRejectsBrokenTrees) {
  EXPECT_NO_THROW(ValidateVocabTree(SmallTree(), "t.h5"));
  VocabTree t = SmallTree();
  t.parent[3] = 4;
  ExpectInvalid(t, "parents must precede");
  t = SmallTree();
  t.level[3] = 1;
  ExpectInvalid(t, "has level");
  t = SmallTree();
  t.levels = 1;
  ExpectInvalid(t, "has level");
  t = SmallTree();
  t.k = 1;
  ExpectInvalid(t, "more than k");
  t = SmallTree();
  t.count[4] = 2;
  ExpectInvalid(t, "children hold");
  t = SmallTree();
  t.count.pop_back();
  ExpectInvalid(t, "differ in length");
  t = SmallTree();
  t.parent[0] = 0;
  ExpectInvalid(t, "root");
  // Siblings of node 0 split by a child of node 1: 0 -> {1, 3}, 1 -> {2}.
  t = SmallTree();
  t.parent = {-1, 0, 1, 0, 1};
  t.level = {0, 1, 2, 1, 2};
  t.count = {5, 3, 2, 2, 1};
  ExpectInvalid(t, "not contiguous");
}

TEST(VocabTree, ReadRejectsOtherFormatsAndMissingFiles) {
  testing::TempDir dir;
  FeaturesFile f;
  WriteFeaturesFile(dir / "f.h5", f, "p", {});
  EXPECT_THROW(ReadVocabTree(dir / "f.h5"), DataError);
  EXPECT_THROW(ReadVocabTree(dir / "missing.h5"), NoInputError);
  testing::WriteTextFile(dir / "text.h5", "not hdf5");
  EXPECT_THROW(ReadVocabTree(dir / "text.h5"), DataError);
}

TEST(VocabTree, ReadsFromMemoryAsFromDisk) {
  testing::TempDir dir;
  WriteVocabTree(dir / "tree.h5", SmallTree(), "rrslam-test 0", {{"k", 2}});
  const std::string text = ReadFileToString(dir / "tree.h5");
  const std::vector<uint8_t> bytes(text.begin(), text.end());
  H5FormatInfo info;
  const VocabTree tree = ReadVocabTreeImage(bytes, "mem.h5", &info);
  EXPECT_EQ(tree.parent, SmallTree().parent);
  EXPECT_EQ(tree.count, SmallTree().count);
  EXPECT_EQ(info.producer, "rrslam-test 0");
  try {
    ReadVocabTreeImage(std::vector<uint8_t>(bytes.begin(), bytes.end() - 200), "mem.h5");
    FAIL() << "a truncated image was read";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("mem.h5"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rrslam
