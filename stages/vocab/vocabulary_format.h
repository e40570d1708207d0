// The two on-disk forms of a bag-of-words vocabulary: rrslam's binary format
// (rrslam.vocabulary, magic "RRSLVOCB", loaded by memory mapping) and the
// DBoW2 text format of ORB-SLAM2's ORBvoc.txt. docs/vocab.md describes both
// byte by byte.
//
// Both list the same nodes in the same order: DBoW2's node ids, the root
// first, children of a node consecutive and after their parent. A node is a
// 256-bit descriptor, a weight and a link:
//   link = (number of children << 27) | first child id   for an inner node
//   link = word id                                        for a leaf (0 children)
// Words are the leaves numbered in node order (as DBoW2 numbers them when it
// reads a text file), so a word's id never needs a table.
//
// Weights are stored as float32. A weight written by DBoW2 (6 significant
// digits) converts text -> binary -> text unchanged; a weight with more digits
// is rounded to the nearest float32 and written back with 6 digits, as DBoW2
// itself would write it. Weights outside the float32 range (or not finite)
// are rejected.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/orb_descriptor.h"
#include "stages/vocab/vocabulary.h"

namespace rrslam {

// --- Node links -------------------------------------------------------------
inline constexpr int kLinkCountShift = 27;
inline constexpr uint32_t kLinkIndexMask = (uint32_t{1} << kLinkCountShift) - 1;
inline constexpr uint32_t kMaxVocabularyNodes = uint32_t{1} << kLinkCountShift;
inline constexpr int kMaxVocabularyK = 31;  // Children per node the link can hold.

inline uint32_t InnerLink(uint32_t first_child, uint32_t num_children) {
  return (num_children << kLinkCountShift) | first_child;
}
inline uint32_t LeafLink(uint32_t word) { return word; }
inline uint32_t LinkChildren(uint32_t link) { return link >> kLinkCountShift; }
inline uint32_t LinkIndex(uint32_t link) { return link & kLinkIndexMask; }

// --- Names ------------------------------------------------------------------
// "tf-idf", "tf", "idf", "binary"; "l1", "l2", "chi-square", "kl",
// "bhattacharyya", "dot-product". Parse* return false for unknown names.
const char* WeightingName(WeightingType w);
const char* ScoringName(ScoringType s);
bool ParseWeighting(std::string_view name, WeightingType* w);
bool ParseScoring(std::string_view name, ScoringType* s);

// --- File formats ----------------------------------------------------------
// The three forms a vocabulary file takes; DBoW2 YAML is read by
// vocabulary_yaml.h.
enum class VocabularyFileFormat { kBinary, kDbow2Text, kDbow2Yaml };
// "binary", "DBoW2 text", "DBoW2 YAML".
const char* VocabularyFileFormatName(VocabularyFileFormat format);
// Told by the first bytes: the magic RRSLVOCB is binary; the gzip magic
// (1f 8b: FileStorage's .yml.gz) or "%YAML" (after an optional UTF-8 byte
// order mark) is YAML; anything else is taken for DBoW2 text.
VocabularyFileFormat DetectVocabularyFileFormat(std::span<const uint8_t> bytes);

// --- In-memory forms ---------------------------------------------------------
struct VocabularyInfo {
  int k = 0;       // Branching factor.
  int levels = 0;  // Depth L.
  WeightingType weighting = WeightingType::kTfIdf;
  ScoringType scoring = ScoringType::kL1;
  uint64_t num_nodes = 0;  // Including the root.
  uint64_t num_words = 0;
};

// Read-only arrays of a vocabulary (num_nodes entries each), wherever they
// live: a mapped binary file or a VocabularyData.
struct VocabularyView {
  VocabularyInfo info;
  const OrbDescriptor* descriptors = nullptr;
  const uint32_t* links = nullptr;
  const float* weights = nullptr;
  std::string_view metadata;  // JSON: producer and options; may be empty.
};

// Zero-filled memory for large arrays, mapped and pre-faulted in one system
// call: first-touch page faults cost up to ~15 us each on virtual machines,
// 0.2 s for the arrays of an ORBvoc-sized vocabulary. Move-only.
class LargeBuffer {
 public:
  LargeBuffer() = default;
  explicit LargeBuffer(size_t bytes);  // Throws std::bad_alloc.
  ~LargeBuffer();
  LargeBuffer(LargeBuffer&& other) noexcept;
  LargeBuffer& operator=(LargeBuffer&& other) noexcept;
  LargeBuffer(const LargeBuffer&) = delete;
  LargeBuffer& operator=(const LargeBuffer&) = delete;
  uint8_t* data() const { return data_; }  // Page-aligned.
  size_t size() const { return size_; }

 private:
  uint8_t* data_ = nullptr;
  size_t size_ = 0;
};

// A vocabulary owning its arrays (text parser, `vocab build`): one block laid
// out as the binary payload (descriptors, links, weights). Move-only.
struct VocabularyData {
  VocabularyInfo info;
  std::string metadata;

  // Allocates zeroed arrays for `num_nodes` nodes and sets info.num_nodes.
  void Allocate(uint64_t num_nodes);
  std::span<OrbDescriptor> descriptors() { return {Descriptors(), nodes_}; }
  std::span<const OrbDescriptor> descriptors() const { return {Descriptors(), nodes_}; }
  std::span<uint32_t> links() { return {Links(), nodes_}; }
  std::span<const uint32_t> links() const { return {Links(), nodes_}; }
  std::span<float> weights() { return {Weights(), nodes_}; }
  std::span<const float> weights() const { return {Weights(), nodes_}; }
  VocabularyView view() const { return {info, Descriptors(), Links(), Weights(), metadata}; }

 private:
  OrbDescriptor* Descriptors() const { return reinterpret_cast<OrbDescriptor*>(block_.data()); }
  uint32_t* Links() const { return reinterpret_cast<uint32_t*>(block_.data() + 32 * nodes_); }
  float* Weights() const { return reinterpret_cast<float*>(block_.data() + 36 * nodes_); }
  LargeBuffer block_;
  uint64_t nodes_ = 0;
};

// Builds the links of a tree given by parent ids in DBoW2 order (parents[0]
// is ignored: the root) into `links` and checks it: parent id < node id,
// siblings contiguous, at most info->k children. Sets info->num_nodes and
// info->num_words. Throws DataError naming `source`.
void LinksFromParents(std::span<const uint32_t> parents, VocabularyInfo* info,
                      std::span<uint32_t> links, const std::string& source);

// Checks every index a descent can follow: for inner nodes first child > node
// id, first child + count <= num_nodes, count <= k; leaves carry the word ids
// 0, 1, ... in node order; num_words matches; weights are finite. After this
// check, descending from the root always ends at a leaf without leaving the
// arrays. Throws DataError naming `source`.
void ValidateVocabularyLinks(const VocabularyView& v, const std::string& source);

// Parent id of every node (root: 0), derived from the links; checks that
// every node but the root has exactly one parent. Throws DataError.
std::vector<uint32_t> VocabularyParents(const VocabularyView& v, const std::string& source);

// Hash of the tree's content: XXH3-64 over k, L, weighting, scoring, the
// node and word counts and the XXH3-64 of each array (descriptors, links,
// and the weights, but the root's, to the six significant digits the DBoW2
// text format keeps). Not of the metadata: a tree converted between text and binary
// either way, or trained with the same data in another folder, hashes the
// same.
uint64_t VocabularyContentHash(const VocabularyView& v);

// Leaf node reached by a descriptor: from the root, the nearest child by
// Hamming distance (the first one on ties), until a node without children.
uint32_t DescendToLeaf(const VocabularyView& v, const OrbDescriptor& d);

// --- Binary format (rrslam.vocabulary) -----------------------------------------
// Header: the common header of binary_header.h, then these fields at offset 40:
//    40 uint32 k                   72 uint64 descriptors_offset
//    44 uint32 levels              80 uint64 links_offset
//    48 uint32 weighting           88 uint64 weights_offset
//    52 uint32 scoring             96 uint64 metadata_offset
//    56 uint64 num_nodes          104 uint64 metadata_size
//    64 uint64 num_words          112 uint64 tree_hash (1.1; 0 in 1.0)
//                                 120 uint8[8] reserved (0)
// Offsets are relative to the payload, which starts at header_size = 128.
// tree_hash is VocabularyContentHash, stored by the writer (a 1.0 file's is
// computed at load): the identity costs no pass over the weights, and the
// header checksum covers it.
// Payload: descriptors (N x 32 bytes), links (N x uint32), weights (N x
// float32), metadata (JSON, UTF-8).
inline constexpr uint32_t kVocabularyHeaderSize = 128;

struct BinaryVocabularyHeader {
  VocabularyInfo info;
  uint16_t major = 0;
  uint16_t minor = 0;
  uint64_t file_size = 0;
  uint64_t payload_checksum = 0;
  uint64_t descriptors_offset = 0, links_offset = 0, weights_offset = 0;
  uint64_t metadata_offset = 0, metadata_size = 0;
  uint64_t tree_hash = 0;  // Stored VocabularyContentHash (1.1); 0: none (1.0).
};

// The tree's identity of a binary file: the stored hash, else (1.0 files)
// VocabularyContentHash(v).
uint64_t TreeHashOf(const VocabularyView& v, const BinaryVocabularyHeader& header);

// The whole binary file for `v`.
std::vector<uint8_t> EncodeBinaryVocabulary(const VocabularyView& v);
// Writes `v` to `path` atomically. Throws CantCreateError.
void WriteBinaryVocabulary(const std::filesystem::path& path, const VocabularyView& v);

// Parses and checks the header and its fields (not the payload checksum, not
// the links). Throws DataError naming `source`.
BinaryVocabularyHeader ParseBinaryVocabularyHeader(std::span<const uint8_t> file,
                                                   const std::string& source);

// Parses a whole binary file: header, payload checksum, array bounds and
// alignment, and ValidateVocabularyLinks. The view points into `file`, which
// must be 32-byte aligned and outlive it. Throws DataError naming `source`.
VocabularyView ParseBinaryVocabulary(std::span<const uint8_t> file, const std::string& source,
                                     BinaryVocabularyHeader* header = nullptr);

// --- DBoW2 text format -------------------------------------------------------
// Line 1: "k L  scoring weighting" (DBoW2 writes two spaces before scoring).
// Then one line per node after the root, in id order:
//   "parent isLeaf b0 b1 ... b31  weight"
// where each byte is followed by one space and the weight is preceded by one
// more (DBoW2's FORB::toString ends with a space), the weight printed as
// C++ streams print a double by default (%g, 6 significant digits), and
// every line, the last one included, ends with '\n'.

// The text of `v`, exactly as DBoW2's saveToTextFile writes it. Throws
// DataError when the vocabulary cannot be written as DBoW2 text (k > 20,
// L > 10, or not a tree).
std::string FormatTextVocabulary(const VocabularyView& v, const std::string& source);
// Writes FormatTextVocabulary(v) to `path` atomically.
void WriteTextVocabulary(const std::filesystem::path& path, const VocabularyView& v,
                         const std::string& source);

// Parses a DBoW2 text vocabulary with up to `threads` threads. Accepts what
// DBoW2's loader accepts from a well-formed file: any spaces, tabs or '\r'
// between fields, a final newline or none, blank lines at the very end.
// Rejects everything else with the line number: missing or extra fields,
// bytes outside [0, 255], isLeaf not 0/1 or inconsistent with the tree,
// parents after their children, non-contiguous siblings, weights that are
// not finite float32 values. Throws DataError naming `source`.
VocabularyData ParseTextVocabulary(std::string_view text, const std::string& source,
                                   int threads = 2);

}  // namespace rrslam
