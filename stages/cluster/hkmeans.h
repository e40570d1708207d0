// Hierarchical k-means over 256-bit ORB descriptors: the vocabulary tree of
// Nister and Stewenius (CVPR 2006) as DBoW2 builds it (written anew).
//
// Every node is split by k-means with Hamming distance: k-means++ seeding,
// then alternating nearest-centre assignment and per-bit majority centres
// until no assignment changes (or a cap on iterations is hit). As in DBoW2:
//   - a node at level < L with more than k descriptors is split by k-means;
//   - a node with 2..k descriptors gets one child per descriptor (the trivial
//     clustering), so its descriptors become leaves;
//   - a node with one descriptor, or at level L, is a leaf.
// Differences from DBoW2, on purpose: k-means++ samples with probability
// proportional to D(x)^2 (the original algorithm; DBoW2 uses D(x)); a cluster
// that loses all its descriptors keeps its centre while iterating and is
// dropped at the end (DBoW2 would compute the mean of an empty set); every
// node has its own random stream derived from (seed, path from the root), so
// subtrees are split in parallel and the tree is identical for any number of
// threads.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "common/orb_descriptor.h"
#include "common/progress.h"
#include "stages/cluster/vocab_tree.h"

namespace rrslam {

struct HkmeansParams {
  int k = 10;                // Branching factor (children per node), in [2, 20].
  int levels = 6;            // Depth L of the tree (leaves at level <= L), in [1, 10].
  uint64_t seed = 0;         // Seed of every random choice; same seed, same tree.
  int threads = 0;           // Worker threads; 0 = all hardware threads.
  int max_iterations = 100;  // Cap on k-means assignment rounds per node (>= 1).
};

// Per-bit majority of `descriptors`: bit i is set when at least half of them
// have it (ties give 1, as DBoW2's FORB::meanValue). Zeros for an empty set.
OrbDescriptor MajorityCentre(std::span<const OrbDescriptor> descriptors);

// k-means++ seeding: indices into `descriptors` of up to k distinct seeds; the
// first uniformly at random, each next one with probability proportional to
// the squared Hamming distance to the nearest seed so far. Fewer than k when
// the set holds fewer distinct descriptors. Deterministic for a given seed.
std::vector<uint32_t> KMeansPlusPlusSeeds(std::span<const OrbDescriptor> descriptors, int k,
                                          uint64_t seed);

struct BinaryKMeansResult {
  std::vector<OrbDescriptor> centres;  // Non-empty clusters only.
  std::vector<uint32_t> assignment;    // Cluster of each input descriptor.
  int iterations = 0;                  // Assignment rounds after seeding.
  bool converged = false;              // False when max_iterations stopped it.
};

// One k-means clustering (one node's split) of more than k descriptors.
// Each descriptor is assigned to its nearest centre (the first one on ties).
BinaryKMeansResult BinaryKMeans(std::span<const OrbDescriptor> descriptors, int k, uint64_t seed,
                                int max_iterations);

// Builds the whole tree (nodes in DBoW2 order, see vocab_tree.h) from the
// training descriptors, which it reorders in place. `progress`, if given,
// advances by the number of descriptors that reach a leaf. Throws
// AlgorithmError when there is no descriptor or the tree would exceed
// kMaxTreeNodes.
inline constexpr size_t kMaxTreeNodes = size_t{1} << 27;
VocabTree BuildVocabTree(std::vector<OrbDescriptor>& descriptors, const HkmeansParams& params,
                         ProgressBar* progress = nullptr);

}  // namespace rrslam
