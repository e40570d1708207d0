// The `cluster` stage: hierarchical k-means of the ORB descriptors of one or
// more features files into a vocabulary tree (vocab_tree.h).
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "stages/cluster/vocab_tree.h"

namespace CLI {
class App;
}

namespace rrslam {

struct ClusterOptions {
  // Features files written by rrslam-extract (at least one); their
  // descriptors are pooled in the order given.
  std::vector<std::filesystem::path> features;
  // Output tree file (HDF5, rrslam.vocab_tree).
  std::filesystem::path out;
  // Branching factor k: clusters per node, in [2, 20] (DBoW2's text format
  // allows at most 20).
  int k = 10;
  // Depth L of the tree: leaves at level <= L, in [1, 10].
  int levels = 6;
  // Seed of every random choice; the same inputs and seed give the same tree.
  uint64_t seed = 0;
  // Worker threads; 0 = all hardware threads; in [0, kMaxThreads = 256]
  // (common/worker_pool.h). Does not change the tree.
  int threads = 0;
  // Use descriptors of every `stride`-th frame only (>= 1).
  int stride = 1;
  // When > 0 and more descriptors are read, a seeded uniform random subset
  // of this many is clustered (keeps memory and time bounded). 0 = all.
  uint64_t max_descriptors = 0;
  // Cap on k-means assignment rounds per node (>= 1); DBoW2 has none, but
  // binary majority centres can oscillate between ties.
  int max_iterations = 100;

  // True when every field is valid; otherwise `why` names the violated constraint.
  bool Check(std::string* why) const;
  nlohmann::json ToJson() const;
};

// Binds every option to a flag of `app`.
void BindClusterOptions(CLI::App& app, ClusterOptions* options);

// Reads the descriptors, builds the tree, writes `options.out` atomically.
// Throws UsageError for invalid options, NoInputError / DataError for bad
// inputs, AlgorithmError when there is no descriptor, CantCreateError when
// the output cannot be written. Returns the tree written.
VocabTree RunCluster(const ClusterOptions& options);

}  // namespace rrslam
