// The seed corpora of the vocabulary tree fuzz target (vocab_tree_fuzzer.cc),
// made here by code (no real data):
//   fuzz/corpus/     file descriptions for h5_image_builder.h (a few bytes:
//                    k, L and the splits; the rest kept well-formed)
//   fuzz/corpus_h5/  small rrslam.vocab_tree files, for RRSLAM_FUZZ_H5_RAW=1
// The test writes them and checks that each reads back: the files, from disk
// and from their bytes in memory, and the file each description builds (a
// schema change in vocab_tree.h that vocab_tree_schema.h misses fails here).
// With RRSLAM_WRITE_FUZZ_SEEDS=<dir> they go to <dir>/corpus and
// <dir>/corpus_h5 (to regenerate the committed seeds, see `make fuzz-seeds`:
//   RRSLAM_WRITE_FUZZ_SEEDS=stages/cluster/fuzz build/tests/cluster_vocab_tree_seeds
// ), otherwise to a temporary folder.
#include <H5Cpp.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "common/atomic_file.h"
#include "common/fuzz/h5_image_builder.h"
#include "common/testing.h"
#include "stages/cluster/fuzz/vocab_tree_schema.h"
#include "stages/cluster/vocab_tree.h"

namespace rrslam {
namespace {

// A complete tree of branching `k` and depth `levels` with `leaf_count`
// descriptors in every leaf, nodes numbered depth-first as rrslam-cluster
// numbers them.
VocabTree SeedTree(int k, int levels, uint64_t leaf_count) {
  VocabTree t;
  t.k = k;
  t.levels = levels;
  // Depth-first: a node's children get consecutive ids when it is split.
  t.parent = {-1};
  t.level = {0};
  std::vector<size_t> stack = {0};
  while (!stack.empty()) {
    const size_t node = stack.back();
    stack.pop_back();
    if (t.level[node] == levels) continue;
    const size_t first = t.parent.size();
    for (int c = 0; c < k; ++c) {
      t.parent.push_back(static_cast<int32_t>(node));
      t.level.push_back(static_cast<uint8_t>(t.level[node] + 1));
    }
    for (int c = k - 1; c >= 0; --c) stack.push_back(first + static_cast<size_t>(c));
  }
  const size_t n = t.parent.size();
  t.centre.resize(n);
  t.count.assign(n, 0);
  for (size_t i = 1; i < n; ++i) {
    for (int b = 0; b < 32; ++b) t.centre[i].bytes[b] = static_cast<uint8_t>(i * 29 + b);
  }
  for (size_t i = n; i-- > 1;) {
    if (t.count[i] == 0) t.count[i] = leaf_count;  // A leaf (children come later).
    t.count[static_cast<size_t>(t.parent[i])] += t.count[i];
  }
  return t;
}

TEST(VocabTreeSeeds, WriteAndRead) {
  H5::Exception::dontPrint();
  testing::TempDir temp;
  const std::filesystem::path dir = testing::FuzzSeedFolder(temp);
  std::filesystem::create_directories(dir / "corpus");
  std::filesystem::create_directories(dir / "corpus_h5");

  // Descriptions: k - 1, L - 1, then the splits in depth-first order (and the
  // leaves' descriptor counts).
  struct Seed {
    const char* name;
    std::string bytes;
    size_t nodes;
  };
  const Seed seeds[] = {
      {"root_and_leaf", "", 2},
      {"k3_l2", std::string("\x02\x01\x02\x03\x00\x02", 6), 9},
      {"k4_l3", std::string("\x03\x02\x03\x02\x01\x04\x00\x01\x03\x02\x01", 11), 0}};
  for (const Seed& seed : seeds) {
    testing::WriteTextFile(dir / "corpus" / seed.name, seed.bytes);
    const std::string bytes = ReadFileToString(dir / "corpus" / seed.name);
    const std::vector<uint8_t> image =
        fuzz::BuildH5Image(testing::Bytes(bytes), fuzz::VocabTreeObjects);
    const VocabTree tree = ReadVocabTreeImage(image, seed.name);
    if (seed.nodes > 0) {
      EXPECT_EQ(tree.num_nodes(), seed.nodes) << seed.name;
    }
    EXPECT_GE(tree.NumLeaves(), 1u) << seed.name;
  }

  WriteVocabTree(dir / "corpus_h5" / "k2_l2.h5", SeedTree(2, 2, 3), "rrslam-cluster seed",
                 {{"k", 2}});
  WriteVocabTree(dir / "corpus_h5" / "k3_l3.h5", SeedTree(3, 3, 2), "rrslam-cluster seed",
                 {{"k", 3}});
  for (const char* name : {"k2_l2.h5", "k3_l3.h5"}) {
    const VocabTree read = ReadVocabTree(dir / "corpus_h5" / name);
    const std::string bytes = ReadFileToString(dir / "corpus_h5" / name);
    const VocabTree image = ReadVocabTreeImage(testing::Bytes(bytes), name);
    EXPECT_EQ(image.parent, read.parent) << name;
    EXPECT_EQ(image.count, read.count) << name;
    EXPECT_LE(bytes.size(), 16384u) << name << ": a seed should stay small";
  }
  EXPECT_EQ(ReadVocabTree(dir / "corpus_h5" / "k2_l2.h5").num_nodes(), 7u);
  EXPECT_EQ(ReadVocabTree(dir / "corpus_h5" / "k3_l3.h5").NumLeaves(), 27u);
}

}  // namespace
}  // namespace rrslam
