// A bag-of-words vocabulary of 256-bit ORB descriptors (DBoW2's model):
// a tree with branching factor k and depth L whose leaves are the words.
//
// Loaded from rrslam's binary format (memory-mapped, see vocabulary_format.h)
// or from the DBoW2 text format of ORB-SLAM2's ORBvoc.txt; the format is told
// by the file's content. DBoW2's YAML (.yml, .yml.gz) is read by
// LoadVocabularyFile (vocabulary_yaml.h), which also reads these two.
// Immutable after loading; every const method is thread-safe.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "common/orb_descriptor.h"

namespace rrslam {

using WordId = uint32_t;   // Index of a word (leaf), in [0, num_words()).
using NodeId = uint32_t;   // Index of a tree node; the root is 0.
using WordValue = double;  // Weight of a word in a BoW vector.

enum class WeightingType { kTfIdf = 0, kTf = 1, kIdf = 2, kBinary = 3 };
enum class ScoringType {
  kL1 = 0,
  kL2 = 1,
  kChiSquare = 2,
  kKL = 3,
  kBhattacharyya = 4,
  kDotProduct = 5
};

// Sparse BoW vector: (word, value) pairs sorted by word id, each word once.
// Normalized as the vocabulary's scoring requires (L1 norm 1 for L1 scoring).
struct BowVector {
  std::vector<std::pair<WordId, WordValue>> entries;
  bool empty() const { return entries.empty(); }
  size_t size() const { return entries.size(); }
};

// Feature indices grouped by their ancestor node `levels_up` levels above the
// leaves (ORB-SLAM2 uses 4): (node, sorted feature indices) pairs sorted by
// node id. Two frames' features that share a node are match candidates.
struct FeatureVector {
  std::vector<std::pair<NodeId, std::vector<uint32_t>>> entries;
  bool empty() const { return entries.empty(); }
  size_t size() const { return entries.size(); }
};

struct VocabularyData;  // vocabulary_format.h
struct VocabularyView;  // vocabulary_format.h

class Vocabulary {
 public:
  // Loads a binary (.rrv) or DBoW2 text vocabulary, told by content. Throws
  // NoInputError when missing and DataError when malformed, truncated,
  // corrupt or of an unsupported format version, or a DBoW2 YAML file (the
  // message says to convert it); errors name the file.
  static Vocabulary Load(const std::filesystem::path& path);

  // Loads a binary or text vocabulary held in memory (copied), told by
  // content; `name` stands for the file in errors and Identity().
  static Vocabulary FromBytes(std::span<const uint8_t> bytes, const std::string& name);

  // Takes ownership of arrays built in memory (`vocab build`) or parsed from
  // another format (DBoW2 YAML, vocabulary_yaml.h), after the same checks as
  // a loaded file (ValidateVocabularyLinks). checksum() is `checksum` when
  // given (the XXH3-64 of the file the arrays were parsed from), else the
  // XXH3-64 of the arrays laid out as a binary payload.
  static Vocabulary FromData(VocabularyData data, const std::string& name,
                             std::optional<uint64_t> checksum = std::nullopt);

  Vocabulary();
  ~Vocabulary();
  Vocabulary(Vocabulary&&) noexcept;
  Vocabulary& operator=(Vocabulary&&) noexcept;

  int k() const;       // Branching factor.
  int levels() const;  // Depth L (the root is level 0, leaves at most at level L).
  WeightingType weighting() const;
  ScoringType scoring() const;
  size_t num_nodes() const;  // Including the root.
  size_t num_words() const;
  bool empty() const { return num_words() == 0; }

  // "<file name> k=10 L=6 words=... tree=<content_hash() in hex>": identifies
  // the vocabulary in outputs that used it (run.json).
  std::string Identity() const;

  // True when loaded from the binary format, false for DBoW2 text or built
  // in memory.
  bool is_binary() const;
  // XXH3-64 of the binary payload, or of the whole text or YAML file.
  uint64_t checksum() const;
  // Identity of the tree itself (VocabularyContentHash): equal for the same
  // tree in either format, wherever it was trained or whatever its metadata.
  // Maps record it and refuse another vocabulary.
  uint64_t content_hash() const;
  // The node arrays (vocabulary_format.h), e.g. to write the vocabulary in
  // the other format. Valid as long as this object.
  const VocabularyView& view() const;

  // Word of one descriptor (descends the tree, nearest child by Hamming distance).
  WordId Transform(const OrbDescriptor& descriptor) const;

  // BoW vector of a set of descriptors (weights per the vocabulary's weighting,
  // normalized per its scoring) and, when `features` is non-null, the feature
  // vector grouped `levels_up` levels above the leaves.
  // As DBoW2: the group of a descriptor is the node at level L - levels_up on
  // its path from the root, or its word when the word is shallower, or the
  // root when L - levels_up <= 0. Descriptors whose word has weight 0 (with
  // idf weights: a word of no or of every training image) appear in neither
  // vector. With tf or tf-idf
  // weighting a word's value is the sum over its descriptors; with idf or
  // binary it is counted once. Vectors are L1-normalized for the l1,
  // chi-square, KL and Bhattacharyya scorings, L2-normalized for l2; with
  // dot-product scoring tf / tf-idf values are divided by the number of
  // distinct words (DBoW2's behaviour).
  void Transform(std::span<const OrbDescriptor> descriptors, BowVector* bow,
                 FeatureVector* features = nullptr, int levels_up = 4) const;

  // Similarity of two BoW vectors by the vocabulary's scoring; for L1, in [0, 1]
  // with 1 for identical vectors and 0 for disjoint ones.
  double Score(const BowVector& a, const BowVector& b) const;

 private:
  struct Impl;
  const Impl& impl() const;  // An empty vocabulary's after a move.
  std::unique_ptr<Impl> impl_;
};

}  // namespace rrslam
