// The vocabulary tree written by `rrslam-cluster` and read by `rrslam-vocab
// build` (format rrslam.vocab_tree 1.0, HDF5).
//
// The tree of a hierarchical k-means over ORB descriptors: the root (node 0,
// level 0) holds every training descriptor; each node's children split its
// descriptors into at most k clusters; leaves sit at level <= L and become the
// words of a vocabulary. Nodes are numbered as DBoW2 numbers them: children of
// a node get consecutive ids when the node is split, and nodes are split in
// depth-first pre-order, so a DBoW2 text vocabulary of this tree lists the
// nodes in this order (parent id < child id, siblings contiguous).
//
// Schema (N nodes including the root):
//   root attributes   format, format_major, format_minor, producer, options
//                     (h5io.h), and the scalars k, levels, num_descriptors
//   /nodes/parent     (N)    int32   parent id; -1 for the root
//   /nodes/level      (N)    uint8   depth: 0 for the root, in [1, L] otherwise
//   /nodes/centre     (N,32) uint8   cluster centre (per-bit majority of the
//                                    node's descriptors; zeros for the root)
//   /nodes/count      (N)    uint64  training descriptors in the node's cluster
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "common/h5io.h"
#include "common/orb_descriptor.h"

namespace rrslam {

struct VocabTree {
  int k = 0;                          // Branching factor: no node has more than k children.
  int levels = 0;                     // Depth L: no node is deeper than L.
  std::vector<int32_t> parent;        // Parent id per node; -1 for the root.
  std::vector<uint8_t> level;         // Depth per node.
  std::vector<OrbDescriptor> centre;  // Cluster centre per node.
  std::vector<uint64_t> count;        // Training descriptors per node.

  size_t num_nodes() const { return parent.size(); }
  // Children of every node as (first child id, count); count 0 for leaves.
  // Valid only for trees whose siblings are contiguous (see ValidateVocabTree).
  std::vector<std::pair<uint32_t, uint32_t>> ChildRanges() const;
  size_t NumLeaves() const;
};

// Checks the invariants listed above (array sizes, root, parent id < child id,
// levels, contiguous siblings, at most k children, counts that add up).
// Throws DataError naming `source`.
void ValidateVocabTree(const VocabTree& tree, const std::string& source);

// Writes `tree` atomically with root attributes from `producer` and `options`.
// Throws CantCreateError.
void WriteVocabTree(const std::filesystem::path& path, const VocabTree& tree,
                    const std::string& producer, const nlohmann::json& options);

// Reads and validates a tree file. Throws NoInputError when missing and
// DataError when it is not a rrslam.vocab_tree file of a supported major
// version or breaks an invariant. `info` receives the root attributes.
VocabTree ReadVocabTree(const std::filesystem::path& path, H5FormatInfo* info = nullptr);

// The same from the bytes of a tree file held in memory (an HDF5 file image,
// see OpenH5FileImage; used by the fuzz target). `name` stands for the file in
// messages. Throws DataError as ReadVocabTree.
VocabTree ReadVocabTreeImage(std::span<const uint8_t> bytes, const std::string& name,
                             H5FormatInfo* info = nullptr);

}  // namespace rrslam
