#include "stages/cluster/hkmeans.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <map>
#include <random>
#include <set>

#include "common/errors.h"

namespace rrslam {
namespace {

OrbDescriptor RandomDescriptor(std::mt19937_64& rng) {
  OrbDescriptor d;
  for (auto& b : d.bytes) b = static_cast<uint8_t>(rng());
  return d;
}

// `clusters` random centres, each with `per_cluster` members that differ from
// it in at most `max_flips` random bits. Returns the members; `truth` gets the
// cluster of each member and `centres` the centres.
std::vector<OrbDescriptor> ClusteredDescriptors(int clusters, int per_cluster, int max_flips,
                                                uint64_t seed, std::vector<int>* truth,
                                                std::vector<OrbDescriptor>* centres) {
  std::mt19937_64 rng(seed);
  centres->clear();
  for (int c = 0; c < clusters; ++c) centres->push_back(RandomDescriptor(rng));
  std::vector<OrbDescriptor> out;
  truth->clear();
  for (int i = 0; i < per_cluster; ++i) {
    for (int c = 0; c < clusters; ++c) {
      OrbDescriptor d = (*centres)[c];
      const int flips = static_cast<int>(rng() % (max_flips + 1));
      for (int f = 0; f < flips; ++f) {
        const int bit = static_cast<int>(rng() % 256);
        d.SetBit(bit, !d.Bit(bit));
      }
      out.push_back(d);
      truth->push_back(c);
    }
  }
  return out;
}

TEST(MajorityCentre, HandComputed) {
  OrbDescriptor a, b, c;
  a.bytes[0] = 0b0000'0111;
  b.bytes[0] = 0b0000'0011;
  c.bytes[0] = 0b0000'0001;
  a.bytes[31] = 0x80;
  // Bit 0: 3 of 3, bit 1: 2 of 3, bit 2: 1 of 3, bit 255: 1 of 3.
  const OrbDescriptor m = MajorityCentre(std::vector<OrbDescriptor>{a, b, c});
  EXPECT_EQ(m.bytes[0], 0b0000'0011);
  EXPECT_EQ(m.bytes[31], 0);
  // A tie (1 of 2) sets the bit, as DBoW2's FORB::meanValue does.
  const OrbDescriptor tie = MajorityCentre(std::vector<OrbDescriptor>{a, c});
  EXPECT_EQ(tie.bytes[0], 0b0000'0111);
  EXPECT_EQ(tie.bytes[31], 0x80);
  EXPECT_EQ(MajorityCentre(std::vector<OrbDescriptor>{b}), b);
  EXPECT_EQ(MajorityCentre({}), OrbDescriptor{});
}

TEST(MajorityCentre, MatchesNaiveCountOnManyDescriptors) {
  // More than 255 descriptors exercises the lane flushes of the bit counter.
  std::mt19937_64 rng(7);
  for (int n : {1, 2, 254, 255, 256, 511, 1000, 4097}) {
    std::vector<OrbDescriptor> d(n);
    for (auto& x : d) {
      x = RandomDescriptor(rng);
      x.bytes[3] |= 0x10;  // Bit 28 always set.
      x.bytes[4] &= 0xfe;  // Bit 32 never set.
    }
    OrbDescriptor expected;
    for (int bit = 0; bit < 256; ++bit) {
      int count = 0;
      for (const auto& x : d) count += x.Bit(bit);
      expected.SetBit(bit, 2 * count >= n);
    }
    const OrbDescriptor m = MajorityCentre(d);
    EXPECT_EQ(m, expected) << "n = " << n;
    EXPECT_TRUE(m.Bit(28));
    EXPECT_FALSE(m.Bit(32));
  }
}

TEST(KMeansPlusPlus, SeedsFallInDistinctClusters) {
  std::vector<int> truth;
  std::vector<OrbDescriptor> centres;
  const auto d = ClusteredDescriptors(8, 100, 3, 11, &truth, &centres);
  const auto seeds = KMeansPlusPlusSeeds(d, 8, 5);
  ASSERT_EQ(seeds.size(), 8u);
  std::set<int> clusters;
  for (uint32_t s : seeds) clusters.insert(truth[s]);
  EXPECT_EQ(clusters.size(), 8u);
  EXPECT_EQ(KMeansPlusPlusSeeds(d, 8, 5), seeds);  // Deterministic.
  EXPECT_NE(KMeansPlusPlusSeeds(d, 8, 6), seeds);  // Seed matters.
}

TEST(KMeansPlusPlus, StopsAtTheNumberOfDistinctDescriptors) {
  std::mt19937_64 rng(3);
  const OrbDescriptor a = RandomDescriptor(rng), b = RandomDescriptor(rng);
  std::vector<OrbDescriptor> d(50, a);
  d.insert(d.end(), 30, b);
  const auto seeds = KMeansPlusPlusSeeds(d, 10, 1);
  ASSERT_EQ(seeds.size(), 2u);
  EXPECT_NE(d[seeds[0]], d[seeds[1]]);
}

TEST(BinaryKMeans, RecoversSyntheticClusters) {
  std::vector<int> truth;
  std::vector<OrbDescriptor> centres;
  const auto d = ClusteredDescriptors(10, 150, 6, 21, &truth, &centres);
  const BinaryKMeansResult r = BinaryKMeans(d, 10, 99, 100);
  EXPECT_TRUE(r.converged);
  ASSERT_EQ(r.centres.size(), 10u);
  // Every true cluster maps to exactly one found cluster and vice versa.
  std::map<int, std::set<uint32_t>> found_of_true;
  std::map<uint32_t, std::set<int>> true_of_found;
  for (size_t i = 0; i < d.size(); ++i) {
    found_of_true[truth[i]].insert(r.assignment[i]);
    true_of_found[r.assignment[i]].insert(truth[i]);
  }
  for (const auto& [t, f] : found_of_true) EXPECT_EQ(f.size(), 1u) << "true cluster " << t;
  for (const auto& [f, t] : true_of_found) EXPECT_EQ(t.size(), 1u) << "found cluster " << f;
  // With at most 6 of 256 bits flipped, the per-bit majority is the true centre.
  for (const auto& [t, f] : found_of_true) EXPECT_EQ(r.centres[*f.begin()], centres[t]);
}

TEST(BinaryKMeans, AssignmentIsNearestCentre) {
  std::mt19937_64 rng(5);
  std::vector<OrbDescriptor> d(3000);
  for (auto& x : d) x = RandomDescriptor(rng);
  const BinaryKMeansResult r = BinaryKMeans(d, 7, 3, 100);
  ASSERT_GE(r.centres.size(), 2u);
  for (size_t i = 0; i < d.size(); ++i) {
    int best = 0;
    for (size_t c = 1; c < r.centres.size(); ++c) {
      if (HammingDistance(d[i], r.centres[c]) < HammingDistance(d[i], r.centres[best])) {
        best = static_cast<int>(c);
      }
    }
    EXPECT_EQ(r.assignment[i], static_cast<uint32_t>(best));
  }
  if (r.converged) {
    // At convergence each centre is the majority of its cluster.
    for (size_t c = 0; c < r.centres.size(); ++c) {
      std::vector<OrbDescriptor> members;
      for (size_t i = 0; i < d.size(); ++i) {
        if (r.assignment[i] == c) members.push_back(d[i]);
      }
      EXPECT_EQ(MajorityCentre(members), r.centres[c]);
    }
  }
}

// Descends from the root to a leaf by the nearest child (first on ties).
uint32_t DescendTree(const VocabTree& tree,
                     const std::vector<std::pair<uint32_t, uint32_t>>& children,
                     const OrbDescriptor& d) {
  uint32_t node = 0;
  while (children[node].second > 0) {
    uint32_t best = children[node].first;
    for (uint32_t c = best + 1; c < children[node].first + children[node].second; ++c) {
      if (HammingDistance(d, tree.centre[c]) < HammingDistance(d, tree.centre[best])) best = c;
    }
    node = best;
  }
  return node;
}

std::vector<OrbDescriptor> TreeTrainingSet(size_t n, uint64_t seed) {
  // A mixture: clustered descriptors plus uniform noise.
  std::vector<int> truth;
  std::vector<OrbDescriptor> centres;
  auto d = ClusteredDescriptors(40, static_cast<int>(n / 80), 40, seed, &truth, &centres);
  std::mt19937_64 rng(seed + 1);
  while (d.size() < n) d.push_back(RandomDescriptor(rng));
  return d;
}

TEST(BuildVocabTree, StructureFollowsDbow2Rules) {
  std::vector<OrbDescriptor> d = TreeTrainingSet(6000, 2);
  const std::vector<OrbDescriptor> original = d;
  HkmeansParams p;
  p.k = 5;
  p.levels = 4;
  p.seed = 17;
  p.threads = 1;
  const VocabTree tree = BuildVocabTree(d, p);
  ValidateVocabTree(tree, "tree");
  EXPECT_EQ(tree.count[0], original.size());
  const auto children = tree.ChildRanges();
  // DBoW2 numbering: children get consecutive ids when their parent is
  // visited in depth-first pre-order.
  uint32_t next = 1;
  std::function<void(uint32_t)> visit = [&](uint32_t node) {
    if (children[node].second == 0) return;
    EXPECT_EQ(children[node].first, next) << "node " << node;
    next += children[node].second;
    for (uint32_t c = 0; c < children[node].second; ++c) visit(children[node].first + c);
  };
  visit(0);
  EXPECT_EQ(next, tree.num_nodes());
  for (size_t i = 1; i < tree.num_nodes(); ++i) {
    const bool leaf = children[i].second == 0;
    if (tree.level[i] == p.levels || tree.count[i] == 1) {
      EXPECT_TRUE(leaf) << "node " << i;
    }
    if (!leaf && tree.count[i] <= static_cast<uint64_t>(p.k)) {
      // Trivial split: one leaf per descriptor.
      EXPECT_EQ(children[i].second, tree.count[i]);
      for (uint32_t c = 0; c < children[i].second; ++c) {
        EXPECT_EQ(tree.count[children[i].first + c], 1u);
        EXPECT_EQ(children[children[i].first + c].second, 0u);
      }
    }
  }
  // Centres are consistent with the clustering: every training descriptor
  // descends to a leaf, and each leaf receives exactly its count.
  std::vector<uint64_t> arrived(tree.num_nodes(), 0);
  for (const auto& x : original) ++arrived[DescendTree(tree, children, x)];
  for (size_t i = 1; i < tree.num_nodes(); ++i) {
    if (children[i].second == 0) {
      EXPECT_EQ(arrived[i], tree.count[i]) << "leaf " << i;
    }
  }
}

void ExpectSameTree(const VocabTree& a, const VocabTree& b) {
  ASSERT_EQ(a.num_nodes(), b.num_nodes());
  EXPECT_EQ(a.parent, b.parent);
  EXPECT_EQ(a.level, b.level);
  EXPECT_EQ(a.count, b.count);
  EXPECT_TRUE(a.centre == b.centre);
}

TEST(BuildVocabTree, SameTreeForOneAndTwoThreads) {
  // Large enough that the root and the first level are split by all threads
  // together and the rest as parallel subtrees.
  const std::vector<OrbDescriptor> d = TreeTrainingSet(70000, 4);
  HkmeansParams p;
  p.k = 10;
  p.levels = 4;
  p.seed = 42;
  std::vector<VocabTree> trees;
  for (int threads : {1, 2, 3}) {
    std::vector<OrbDescriptor> copy = d;
    p.threads = threads;
    trees.push_back(BuildVocabTree(copy, p));
  }
  ExpectSameTree(trees[0], trees[1]);
  ExpectSameTree(trees[0], trees[2]);
  EXPECT_GT(trees[0].num_nodes(), 1000u);

  std::vector<OrbDescriptor> copy = d;
  p.seed = 43;
  p.threads = 2;
  const VocabTree other = BuildVocabTree(copy, p);
  EXPECT_FALSE(other.num_nodes() == trees[0].num_nodes() && other.centre == trees[0].centre);
}

TEST(BuildVocabTree, TinyInputs) {
  std::mt19937_64 rng(1);
  HkmeansParams p;
  p.k = 10;
  p.levels = 3;
  // One descriptor: the root still gets a child, the single word.
  std::vector<OrbDescriptor> one{RandomDescriptor(rng)};
  const VocabTree t1 = BuildVocabTree(one, p);
  ASSERT_EQ(t1.num_nodes(), 2u);
  EXPECT_EQ(t1.centre[1], one[0]);
  // Identical descriptors collapse to one chain down to level L.
  std::vector<OrbDescriptor> same(50, one[0]);
  const VocabTree t2 = BuildVocabTree(same, p);
  ASSERT_EQ(t2.num_nodes(), 4u);
  EXPECT_EQ(t2.level[3], 3);
  EXPECT_EQ(t2.count[3], 50u);
  std::vector<OrbDescriptor> none;
  EXPECT_THROW(BuildVocabTree(none, p), AlgorithmError);
}

}  // namespace
}  // namespace rrslam
