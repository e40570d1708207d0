#include "stages/vocab/vocabulary_format.h"

#include <sys/mman.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <thread>
#include <utility>

#include "common/atomic_file.h"
#include "common/binary_header.h"
#include "common/errors.h"
#include "common/formats.h"

namespace rrslam {
namespace {

std::string NodeText(uint64_t node) { return "node " + std::to_string(node); }

// DBoW2's header ranges (TemplatedVocabulary::loadFromTextFile).
constexpr int kTextMaxK = 20;
constexpr int kTextMaxLevels = 10;

}  // namespace

// ---------------------------------------------------------------------------
// Names

const char* WeightingName(WeightingType w) {
  switch (w) {
    case WeightingType::kTfIdf:
      return "tf-idf";
    case WeightingType::kTf:
      return "tf";
    case WeightingType::kIdf:
      return "idf";
    case WeightingType::kBinary:
      return "binary";
  }
  return "unknown";
}

const char* ScoringName(ScoringType s) {
  switch (s) {
    case ScoringType::kL1:
      return "l1";
    case ScoringType::kL2:
      return "l2";
    case ScoringType::kChiSquare:
      return "chi-square";
    case ScoringType::kKL:
      return "kl";
    case ScoringType::kBhattacharyya:
      return "bhattacharyya";
    case ScoringType::kDotProduct:
      return "dot-product";
  }
  return "unknown";
}

bool ParseWeighting(std::string_view name, WeightingType* w) {
  for (int i = 0; i <= 3; ++i) {
    if (name == WeightingName(static_cast<WeightingType>(i))) {
      *w = static_cast<WeightingType>(i);
      return true;
    }
  }
  return false;
}

bool ParseScoring(std::string_view name, ScoringType* s) {
  for (int i = 0; i <= 5; ++i) {
    if (name == ScoringName(static_cast<ScoringType>(i))) {
      *s = static_cast<ScoringType>(i);
      return true;
    }
  }
  return false;
}

// ---------------------------------------------------------------------------
// File formats

const char* VocabularyFileFormatName(VocabularyFileFormat format) {
  switch (format) {
    case VocabularyFileFormat::kBinary:
      return "binary";
    case VocabularyFileFormat::kDbow2Text:
      return "DBoW2 text";
    case VocabularyFileFormat::kDbow2Yaml:
      return "DBoW2 YAML";
  }
  return "unknown";
}

VocabularyFileFormat DetectVocabularyFileFormat(std::span<const uint8_t> bytes) {
  if (HasMagic(bytes, kVocabularyFormat)) return VocabularyFileFormat::kBinary;
  // Neither the binary format nor DBoW2 text (digits first) starts with
  // either of these.
  if (bytes.size() >= 2 && bytes[0] == 0x1f && bytes[1] == 0x8b) {
    return VocabularyFileFormat::kDbow2Yaml;
  }
  std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);
  if (text.starts_with("%YAML")) return VocabularyFileFormat::kDbow2Yaml;
  return VocabularyFileFormat::kDbow2Text;
}

// ---------------------------------------------------------------------------
// Owned arrays

LargeBuffer::LargeBuffer(size_t bytes) : size_(bytes) {
  if (bytes == 0) return;
  void* p = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE,
                   MAP_PRIVATE | MAP_ANONYMOUS | MAP_POPULATE, -1, 0);
  if (p == MAP_FAILED) throw std::bad_alloc();
  data_ = static_cast<uint8_t*>(p);
}

LargeBuffer::~LargeBuffer() {
  if (data_ != nullptr) ::munmap(data_, size_);
}

LargeBuffer::LargeBuffer(LargeBuffer&& other) noexcept : data_(other.data_), size_(other.size_) {
  other.data_ = nullptr;
  other.size_ = 0;
}

LargeBuffer& LargeBuffer::operator=(LargeBuffer&& other) noexcept {
  if (this != &other) {
    if (data_ != nullptr) ::munmap(data_, size_);
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
  }
  return *this;
}

void VocabularyData::Allocate(uint64_t num_nodes) {
  if (num_nodes > kMaxVocabularyNodes) {
    throw DataError(std::to_string(num_nodes) + " nodes, more than the supported " +
                    std::to_string(kMaxVocabularyNodes));
  }
  block_ = LargeBuffer(40 * num_nodes);
  nodes_ = num_nodes;
  info.num_nodes = num_nodes;
}

// ---------------------------------------------------------------------------
// Tree structure

namespace {

constexpr uint32_t kLeafFlagBit = uint32_t{1} << 31;

// Builds links in place: while reading the parents, links[p] holds the
// (first child, count) of node p so far; then leaves get their word ids.
// When `leaf_flags_in_parents`, bit 31 of parents[i] is the isLeaf flag of a
// DBoW2 text line, checked against the tree. `line_offset` > 0 adds the text
// line of a node to messages (node i is on line i + 1 of a text file).
void BuildLinks(std::span<const uint32_t> parents, bool leaf_flags_in_parents, VocabularyInfo* info,
                std::span<uint32_t> links, const std::string& source, int line_offset) {
  auto where = [&](uint64_t node) {
    std::string s = source + ": ";
    if (line_offset > 0) s += "line " + std::to_string(node + line_offset) + ": ";
    return s + NodeText(node);
  };
  const uint64_t n = parents.size();
  if (n < 2) throw DataError(source + ": the vocabulary has no node besides the root");
  if (n > kMaxVocabularyNodes) {
    throw DataError(source + ": " + std::to_string(n) + " nodes, more than the supported " +
                    std::to_string(kMaxVocabularyNodes));
  }
  if (links.size() != n) throw std::invalid_argument("BuildLinks: links size");
  if (info->k < 1 || info->k > kMaxVocabularyK) {
    throw DataError(source + ": k = " + std::to_string(info->k) + " is not in [1, " +
                    std::to_string(kMaxVocabularyK) + "]");
  }
  const uint32_t k = static_cast<uint32_t>(info->k);
  std::fill(links.begin(), links.end(), 0u);
  for (uint64_t i = 1; i < n; ++i) {
    const uint32_t p = parents[i] & ~kLeafFlagBit;
    if (p >= i) {
      throw DataError(where(i) + " has parent " + std::to_string(p) +
                      "; a parent must come before its children");
    }
    const uint32_t link = links[p];
    if (link == 0) {
      links[p] = InnerLink(static_cast<uint32_t>(i), 1);
      continue;
    }
    const uint32_t first = LinkIndex(link), count = LinkChildren(link);
    if (first + count != i) {
      // first + count < i: the node where the next sibling should be.
      const uint32_t gap = first + count;
      throw DataError(where(i) + ": the children of node " + std::to_string(p) +
                      " are not consecutive: node " + std::to_string(gap) +
                      " between them has parent " + std::to_string(parents[gap] & ~kLeafFlagBit) +
                      " (DBoW2 numbers siblings consecutively)");
    }
    if (count + 1 > k) {
      throw DataError(where(i) + ": node " + std::to_string(p) +
                      " has more than k = " + std::to_string(k) + " children");
    }
    links[p] = InnerLink(first, count + 1);
  }
  // Inner nodes (isLeaf = 0) without children: a file cut short loses the
  // children of every inner node whose subtree it had not reached, and
  // DBoW2 numbers subtrees depth first, so a truncated ORBvoc.txt shows
  // many such nodes; the message counts them.
  auto childless_inner_nodes = [&] {
    uint64_t count = 0;
    for (uint64_t j = 1; j < n; ++j) {
      count += (parents[j] & kLeafFlagBit) == 0 && LinkChildren(links[j]) == 0;
    }
    return count;
  };
  uint32_t words = 0;
  for (uint64_t i = 0; i < n; ++i) {
    const uint32_t children = LinkChildren(links[i]);
    if (leaf_flags_in_parents && i > 0 && ((parents[i] & kLeafFlagBit) != 0) != (children == 0)) {
      const bool marked_leaf = (parents[i] & kLeafFlagBit) != 0;
      std::string message = where(i) + " is marked isLeaf = " + std::to_string(marked_leaf) +
                            " but has " + std::to_string(children) + " children";
      if (!marked_leaf) {
        message += " (" + std::to_string(childless_inner_nodes()) +
                   " nodes marked isLeaf = 0 have none; the last node is " + NodeText(n - 1);
        if (line_offset > 0) message += " on line " + std::to_string(n - 1 + line_offset);
        message += ": is the file truncated?)";
      }
      throw DataError(message);
    }
    if (children == 0) {
      if (i == 0) throw DataError(source + ": the root has no children");
      links[i] = LeafLink(words++);
    }
  }
  info->num_nodes = n;
  info->num_words = words;
}

}  // namespace

void LinksFromParents(std::span<const uint32_t> parents, VocabularyInfo* info,
                      std::span<uint32_t> links, const std::string& source) {
  BuildLinks(parents, false, info, links, source, 0);
}

namespace {

// A weight as the DBoW2 text format keeps it: six significant digits
// (mantissa in [100000, 999999] and the decimal exponent of its first digit;
// 0 for zero, negative values negated), so that a tree converted from binary
// to text and back has the same identity. Fast path: scale by a power of
// ten and round; near a rounding tie (where the scaled value's rounding error
// could decide) it asks std::to_chars, which rounds the exact value as the
// text writer does.
struct SixDigits {
  int64_t mantissa = 0;
  int32_t exponent = 0;
  int32_t zero = 0;  // Hashed too: no uninitialized padding.
};

SixDigits SixDigitsSlow(double value) {
  char buffer[40];
  const auto r =
      std::to_chars(buffer, buffer + sizeof(buffer), value, std::chars_format::scientific, 5);
  // "d.ddddde[+-]xx"
  SixDigits out;
  const char* p = buffer;
  for (; p < r.ptr && *p != 'e'; ++p) {
    if (*p >= '0' && *p <= '9') out.mantissa = out.mantissa * 10 + (*p - '0');
  }
  int exponent = 0;
  std::from_chars(p + 1 + (p[1] == '+'), r.ptr, exponent);
  out.exponent = exponent;
  return out;
}

SixDigits ToSixDigits(float weight) {
  double value = std::abs(static_cast<double>(weight));
  SixDigits out;
  if (value == 0 || !std::isfinite(value)) return out;
  // Decimal exponent of the first digit, from the binary one (log10(2) =
  // 0.30103) corrected against exact powers of ten; and 10^(5 - exponent)
  // from a table (std::log10 and std::pow made this 60 ns per weight, 35 ms
  // for a 540k-word vocabulary at every load).
  static const std::array<double, 61> kPow10 = [] {
    std::array<double, 61> p{};
    for (int i = 0; i < 61; ++i) p[i] = std::pow(10.0, i - 30);
    return p;
  }();
  auto pow10 = [](int e) { return e >= -30 && e <= 30 ? kPow10[e + 30] : std::pow(10.0, e); };
  int binary_exponent = 0;
  std::frexp(value, &binary_exponent);
  int exponent = static_cast<int>(std::floor((binary_exponent - 1) * 0.30102999566398120));
  while (value >= pow10(exponent + 1)) ++exponent;
  while (value < pow10(exponent)) --exponent;
  const double scaled = value * pow10(5 - exponent);
  const double whole = std::floor(scaled);
  const double fraction = scaled - whole;
  if (std::abs(fraction - 0.5) < 1e-6 || whole < 100000 || whole > 999999) {
    out = SixDigitsSlow(value);
  } else {
    out.mantissa = static_cast<int64_t>(whole) + (fraction > 0.5 ? 1 : 0);
    out.exponent = exponent;
    if (out.mantissa == 1000000) {
      out.mantissa = 100000;
      ++out.exponent;
    }
  }
  if (weight < 0) out.mantissa = -out.mantissa;
  return out;
}

}  // namespace

uint64_t VocabularyContentHash(const VocabularyView& v) {
  const uint64_t n = v.info.num_nodes;
  // The root's weight is not in the DBoW2 text format: left out (zero).
  // Hashed in blocks through a small buffer (a whole array of them is ~10 MB
  // of fresh pages, ~20 ms of page faults on a VM).
  constexpr uint64_t kBlock = 4096;
  std::vector<SixDigits> block(kBlock);
  std::vector<uint64_t> block_hashes;
  for (uint64_t begin = 0; begin < n; begin += kBlock) {
    const uint64_t end = std::min(n, begin + kBlock);
    for (uint64_t i = begin; i < end; ++i) {
      block[i - begin] = i == 0 ? SixDigits{} : ToSixDigits(v.weights[i]);
    }
    block_hashes.push_back(Checksum64(
        {reinterpret_cast<const uint8_t*>(block.data()), sizeof(SixDigits) * (end - begin)}));
  }
  static_assert(sizeof(SixDigits) == 16);
  const uint64_t fields[9] = {static_cast<uint64_t>(v.info.k),
                              static_cast<uint64_t>(v.info.levels),
                              static_cast<uint64_t>(v.info.weighting),
                              static_cast<uint64_t>(v.info.scoring),
                              n,
                              v.info.num_words,
                              Checksum64({reinterpret_cast<const uint8_t*>(v.descriptors), 32 * n}),
                              Checksum64({reinterpret_cast<const uint8_t*>(v.links), 4 * n}),
                              Checksum64({reinterpret_cast<const uint8_t*>(block_hashes.data()),
                                          sizeof(uint64_t) * block_hashes.size()})};
  return Checksum64({reinterpret_cast<const uint8_t*>(fields), sizeof(fields)});
}

void ValidateVocabularyLinks(const VocabularyView& v, const std::string& source) {
  const uint64_t n = v.info.num_nodes;
  if (n < 2 || n > kMaxVocabularyNodes) {
    throw DataError(source + ": node count " + std::to_string(n) + " is not in [2, " +
                    std::to_string(kMaxVocabularyNodes) + "]");
  }
  const uint32_t k = static_cast<uint32_t>(v.info.k);
  uint32_t next_word = 0;
  bool weights_finite = true;
  for (uint64_t i = 0; i < n; ++i) {
    const uint32_t link = v.links[i];
    const uint32_t c = LinkChildren(link);
    const uint32_t index = LinkIndex(link);
    if (c == 0) {
      if (i == 0) throw DataError(source + ": corrupt vocabulary: the root has no children");
      if (index != next_word) {
        throw DataError(source + ": corrupt vocabulary: " + NodeText(i) + " has word id " +
                        std::to_string(index) + ", expected " + std::to_string(next_word) +
                        " (words are numbered in node order)");
      }
      ++next_word;
    } else if (c > k || index <= i || uint64_t{index} + c > n) {
      throw DataError(source + ": corrupt vocabulary: " + NodeText(i) + " links to " +
                      std::to_string(c) + " children at " + std::to_string(index) +
                      ", out of range (children must lie in (" + std::to_string(i) + ", " +
                      std::to_string(n) + "), at most k = " + std::to_string(k) + ")");
    }
    weights_finite &= std::isfinite(v.weights[i]);
  }
  if (next_word != v.info.num_words) {
    throw DataError(source + ": corrupt vocabulary: " + std::to_string(next_word) +
                    " leaves but the header says " + std::to_string(v.info.num_words) + " words");
  }
  if (!weights_finite) throw DataError(source + ": corrupt vocabulary: a weight is not finite");
}

std::vector<uint32_t> VocabularyParents(const VocabularyView& v, const std::string& source) {
  const uint64_t n = v.info.num_nodes;
  constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();
  std::vector<uint32_t> parents(n, kNone);
  if (n == 0) return parents;
  parents[0] = 0;
  for (uint64_t i = 0; i < n; ++i) {
    const uint32_t c = LinkChildren(v.links[i]);
    const uint64_t first = LinkIndex(v.links[i]);
    if (c == 0) continue;
    if (first + c > n) throw DataError(source + ": " + NodeText(i) + ": children out of range");
    for (uint64_t j = first; j < first + c; ++j) {
      if (parents[j] != kNone) {
        throw DataError(source + ": not a tree: " + NodeText(j) + " has two parents");
      }
      parents[j] = static_cast<uint32_t>(i);
    }
  }
  for (uint64_t j = 1; j < n; ++j) {
    if (parents[j] == kNone)
      throw DataError(source + ": not a tree: " + NodeText(j) + " has no parent");
  }
  return parents;
}

uint32_t DescendToLeaf(const VocabularyView& v, const OrbDescriptor& d) {
  uint32_t node = 0;
  while (true) {
    const uint32_t link = v.links[node];
    const uint32_t c = LinkChildren(link);
    if (c == 0) return node;
    const uint32_t first = LinkIndex(link);
    uint32_t best = first;
    int best_d = HammingDistance(d, v.descriptors[first]);
    for (uint32_t j = first + 1; j < first + c; ++j) {
      const int dist = HammingDistance(d, v.descriptors[j]);
      if (dist < best_d) {
        best_d = dist;
        best = j;
      }
    }
    node = best;
  }
}

// ---------------------------------------------------------------------------
// Binary format

namespace {
constexpr size_t kFieldsSize = kVocabularyHeaderSize - kBaseHeaderSize;  // 88
}

std::vector<uint8_t> EncodeBinaryVocabulary(const VocabularyView& v) {
  const uint64_t n = v.info.num_nodes;
  const uint64_t descriptors_offset = 0;
  const uint64_t links_offset = descriptors_offset + 32 * n;
  const uint64_t weights_offset = links_offset + 4 * n;
  const uint64_t metadata_offset = weights_offset + 4 * n;
  const uint64_t payload_size = metadata_offset + v.metadata.size();

  std::vector<uint8_t> file(kVocabularyHeaderSize + payload_size);
  uint8_t* payload = file.data() + kVocabularyHeaderSize;
  std::memcpy(payload + descriptors_offset, v.descriptors, 32 * n);
  std::memcpy(payload + links_offset, v.links, 4 * n);
  std::memcpy(payload + weights_offset, v.weights, 4 * n);
  if (!v.metadata.empty())
    std::memcpy(payload + metadata_offset, v.metadata.data(), v.metadata.size());

  uint8_t fields[kFieldsSize] = {};
  StoreLittleEndian<uint32_t>(fields + 0, static_cast<uint32_t>(v.info.k));
  StoreLittleEndian<uint32_t>(fields + 4, static_cast<uint32_t>(v.info.levels));
  StoreLittleEndian<uint32_t>(fields + 8, static_cast<uint32_t>(v.info.weighting));
  StoreLittleEndian<uint32_t>(fields + 12, static_cast<uint32_t>(v.info.scoring));
  StoreLittleEndian<uint64_t>(fields + 16, n);
  StoreLittleEndian<uint64_t>(fields + 24, v.info.num_words);
  StoreLittleEndian<uint64_t>(fields + 32, descriptors_offset);
  StoreLittleEndian<uint64_t>(fields + 40, links_offset);
  StoreLittleEndian<uint64_t>(fields + 48, weights_offset);
  StoreLittleEndian<uint64_t>(fields + 56, metadata_offset);
  StoreLittleEndian<uint64_t>(fields + 64, v.metadata.size());
  StoreLittleEndian<uint64_t>(fields + 72, VocabularyContentHash(v));
  const std::vector<uint8_t> header =
      BuildBinaryHeader(kVocabularyFormat, fields, std::span<const uint8_t>(payload, payload_size));
  if (header.size() != kVocabularyHeaderSize) {
    throw std::logic_error("vocabulary header size " + std::to_string(header.size()));
  }
  std::memcpy(file.data(), header.data(), header.size());
  return file;
}

void WriteBinaryVocabulary(const std::filesystem::path& path, const VocabularyView& v) {
  const std::vector<uint8_t> bytes = EncodeBinaryVocabulary(v);
  WriteFileAtomically(path,
                      std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

namespace {

BinaryVocabularyHeader ParseHeaderImpl(std::span<const uint8_t> file, const std::string& source,
                                       BinaryHeaderView* base_out) {
  const BinaryHeaderView base = ParseBinaryHeader(file, kVocabularyFormat, source);
  *base_out = base;
  if (base.fields.size() < kFieldsSize) {
    throw DataError(source + ": corrupt header: " + std::to_string(base.fields.size()) +
                    " bytes of vocabulary fields, expected at least " +
                    std::to_string(kFieldsSize));
  }
  const uint8_t* f = base.fields.data();
  BinaryVocabularyHeader h;
  h.major = base.major;
  h.minor = base.minor;
  h.file_size = file.size();
  h.payload_checksum = base.payload_checksum;
  const uint32_t k = LoadLittleEndian<uint32_t>(f + 0);
  const uint32_t levels = LoadLittleEndian<uint32_t>(f + 4);
  const uint32_t weighting = LoadLittleEndian<uint32_t>(f + 8);
  const uint32_t scoring = LoadLittleEndian<uint32_t>(f + 12);
  h.info.num_nodes = LoadLittleEndian<uint64_t>(f + 16);
  h.info.num_words = LoadLittleEndian<uint64_t>(f + 24);
  h.descriptors_offset = LoadLittleEndian<uint64_t>(f + 32);
  h.links_offset = LoadLittleEndian<uint64_t>(f + 40);
  h.weights_offset = LoadLittleEndian<uint64_t>(f + 48);
  h.metadata_offset = LoadLittleEndian<uint64_t>(f + 56);
  h.metadata_size = LoadLittleEndian<uint64_t>(f + 64);
  if (base.minor >= 1) h.tree_hash = LoadLittleEndian<uint64_t>(f + 72);
  auto fail = [&](const std::string& what) {
    throw DataError(source + ": corrupt header: " + what);
  };
  if (k < 1 || k > static_cast<uint32_t>(kMaxVocabularyK)) fail("k = " + std::to_string(k));
  if (levels < 1 || levels > 255) fail("levels = " + std::to_string(levels));
  if (weighting > 3) fail("weighting = " + std::to_string(weighting));
  if (scoring > 5) fail("scoring = " + std::to_string(scoring));
  const uint64_t n = h.info.num_nodes;
  if (n < 2 || n > kMaxVocabularyNodes) fail("node count " + std::to_string(n));
  if (h.info.num_words < 1 || h.info.num_words >= n) {
    fail("word count " + std::to_string(h.info.num_words) + " for " + std::to_string(n) + " nodes");
  }
  h.info.k = static_cast<int>(k);
  h.info.levels = static_cast<int>(levels);
  h.info.weighting = static_cast<WeightingType>(weighting);
  h.info.scoring = static_cast<ScoringType>(scoring);
  const uint64_t payload_size = base.payload.size();
  auto check_array = [&](const char* name, uint64_t offset, uint64_t bytes, uint64_t alignment) {
    if (offset % alignment != 0)
      fail(std::string(name) + " offset is not " + std::to_string(alignment) + "-byte aligned");
    if (offset > payload_size || bytes > payload_size - offset) {
      fail(std::string(name) + " [" + std::to_string(offset) + ", +" + std::to_string(bytes) +
           ") exceed the payload of " + std::to_string(payload_size) + " bytes");
    }
  };
  if ((file.size() - payload_size) % 32 != 0) fail("header size is not a multiple of 32");
  check_array("descriptors", h.descriptors_offset, 32 * n, 32);
  check_array("links", h.links_offset, 4 * n, 4);
  check_array("weights", h.weights_offset, 4 * n, 4);
  check_array("metadata", h.metadata_offset, h.metadata_size, 1);
  return h;
}

}  // namespace

uint64_t TreeHashOf(const VocabularyView& v, const BinaryVocabularyHeader& header) {
  return header.tree_hash != 0 ? header.tree_hash : VocabularyContentHash(v);
}

BinaryVocabularyHeader ParseBinaryVocabularyHeader(std::span<const uint8_t> file,
                                                   const std::string& source) {
  BinaryHeaderView base;
  return ParseHeaderImpl(file, source, &base);
}

VocabularyView ParseBinaryVocabulary(std::span<const uint8_t> file, const std::string& source,
                                     BinaryVocabularyHeader* header_out) {
  BinaryHeaderView base;
  const BinaryVocabularyHeader h = ParseHeaderImpl(file, source, &base);
  VerifyPayloadChecksum(base, source);
  const uint8_t* payload = base.payload.data();
  if (reinterpret_cast<uintptr_t>(payload + h.descriptors_offset) % alignof(OrbDescriptor) != 0) {
    throw DataError(source + ": descriptors are not 32-byte aligned in memory");
  }
  VocabularyView v;
  v.info = h.info;
  v.descriptors = reinterpret_cast<const OrbDescriptor*>(payload + h.descriptors_offset);
  v.links = reinterpret_cast<const uint32_t*>(payload + h.links_offset);
  v.weights = reinterpret_cast<const float*>(payload + h.weights_offset);
  v.metadata =
      std::string_view(reinterpret_cast<const char*>(payload + h.metadata_offset), h.metadata_size);
  ValidateVocabularyLinks(v, source);
  if (header_out != nullptr) *header_out = h;
  return v;
}

// ---------------------------------------------------------------------------
// DBoW2 text format: writer

namespace {

struct ByteTexts {
  char text[256][4];
  uint8_t length[256];
  constexpr ByteTexts() : text(), length() {
    for (int v = 0; v < 256; ++v) {
      int len = 0;
      if (v >= 100) text[v][len++] = static_cast<char>('0' + v / 100);
      if (v >= 10) text[v][len++] = static_cast<char>('0' + (v / 10) % 10);
      text[v][len++] = static_cast<char>('0' + v % 10);
      text[v][len++] = ' ';
      length[v] = static_cast<uint8_t>(len);
    }
  }
};
constexpr ByteTexts kByteTexts;

std::string TextHeaderLine(const VocabularyInfo& info) {
  // DBoW2: f << m_k << " " << m_L << " " << " " << m_scoring << " " << m_weighting << endl;
  return std::to_string(info.k) + " " + std::to_string(info.levels) + "  " +
         std::to_string(static_cast<int>(info.scoring)) + " " +
         std::to_string(static_cast<int>(info.weighting)) + "\n";
}

// Lines of nodes [begin, end).
std::string FormatNodeLines(const VocabularyView& v, const std::vector<uint32_t>& parents,
                            uint64_t begin, uint64_t end) {
  std::string out;
  out.resize((end - begin) * 176);
  char* p = out.data();
  for (uint64_t i = begin; i < end; ++i) {
    p = std::to_chars(p, p + 16, parents[i]).ptr;
    *p++ = ' ';
    *p++ = LinkChildren(v.links[i]) == 0 ? '1' : '0';
    *p++ = ' ';
    for (int b = 0; b < 32; ++b) {
      const uint8_t byte = v.descriptors[i].bytes[b];
      std::memcpy(p, kByteTexts.text[byte], 4);
      p += kByteTexts.length[byte];
    }
    *p++ = ' ';
    // A C++ stream's default for a double: %g with 6 significant digits.
    p = std::to_chars(p, p + 32, static_cast<double>(v.weights[i]), std::chars_format::general, 6)
            .ptr;
    *p++ = '\n';
  }
  out.resize(static_cast<size_t>(p - out.data()));
  return out;
}

std::vector<std::string> FormatTextChunks(const VocabularyView& v, const std::string& source) {
  if (v.info.k > kTextMaxK || v.info.levels > kTextMaxLevels) {
    throw DataError(source + ": k = " + std::to_string(v.info.k) +
                    ", L = " + std::to_string(v.info.levels) +
                    " cannot be written as DBoW2 text (k <= 20, L <= 10)");
  }
  const std::vector<uint32_t> parents = VocabularyParents(v, source);
  const uint64_t n = v.info.num_nodes;
  const int threads = n > 100000 ? 2 : 1;
  std::vector<std::string> chunks(threads + 1);
  chunks[0] = TextHeaderLine(v.info);
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    const uint64_t begin = 1 + (n - 1) * t / threads;
    const uint64_t end = 1 + (n - 1) * (t + 1) / threads;
    auto job = [&, t, begin, end] { chunks[t + 1] = FormatNodeLines(v, parents, begin, end); };
    if (t + 1 < threads) {
      workers.emplace_back(job);
    } else {
      job();
    }
  }
  for (auto& w : workers) w.join();
  return chunks;
}

}  // namespace

std::string FormatTextVocabulary(const VocabularyView& v, const std::string& source) {
  std::vector<std::string> chunks = FormatTextChunks(v, source);
  size_t total = 0;
  for (const auto& c : chunks) total += c.size();
  std::string out;
  out.reserve(total);
  for (const auto& c : chunks) out += c;
  return out;
}

void WriteTextVocabulary(const std::filesystem::path& path, const VocabularyView& v,
                         const std::string& source) {
  const std::vector<std::string> chunks = FormatTextChunks(v, source);
  AtomicOutput out(path);
  {
    std::ofstream file(out.temp_path(), std::ios::binary);
    for (const auto& c : chunks) file.write(c.data(), static_cast<std::streamsize>(c.size()));
    file.flush();
    if (!file) throw CantCreateError(path.string() + ": write failed");
  }
  out.Commit();
}

// ---------------------------------------------------------------------------
// DBoW2 text format: parser

namespace {

inline bool IsBlank(char c) { return c == ' ' || c == '\t' || c == '\r'; }
inline bool IsDigit(char c) { return static_cast<unsigned>(c - '0') <= 9; }

// Cursor over one line (without its '\n').
struct Cursor {
  const char* p;
  const char* end;

  void SkipBlanks() {
    while (p < end && IsBlank(*p)) ++p;
  }
  // A decimal integer in [0, max] followed by a blank or the end of the line.
  bool Uint(uint64_t max, uint64_t* out) {
    SkipBlanks();
    if (p == end || !IsDigit(*p)) return false;
    uint64_t v = 0;
    while (p < end && IsDigit(*p)) {
      v = v * 10 + static_cast<uint64_t>(*p - '0');
      if (v > max) return false;
      ++p;
    }
    if (p < end && !IsBlank(*p)) return false;
    *out = v;
    return true;
  }
  // A descriptor byte, [0, 255]. Fast path for DBoW2's layout (one space,
  // 1 to 3 digits, a space), without data-dependent branches: the number of
  // digits of random bytes is unpredictable. `limit` is the end of the whole
  // text: the fast path reads 8 bytes, possibly past the line.
  bool Byte(const char* limit, uint8_t* out) {
    if (limit - p >= 8) {
      uint64_t x;
      std::memcpy(&x, p, 8);
      const uint32_t d0 = static_cast<uint32_t>((x >> 8) & 0xff) - '0';
      const uint32_t d1 = static_cast<uint32_t>((x >> 16) & 0xff) - '0';
      const uint32_t d2 = static_cast<uint32_t>((x >> 24) & 0xff) - '0';
      // All-ones masks: the 2nd digit exists; the 2nd and 3rd exist.
      const uint32_t m1 = 0u - static_cast<uint32_t>(d1 < 10);
      const uint32_t m2 = m1 & (0u - static_cast<uint32_t>(d2 < 10));
      uint32_t value = d0;
      value = (value & ~m1) | ((10 * value + d1) & m1);
      value = (value & ~m2) | ((10 * value + d2) & m2);
      const uint32_t digits = 1 + (m1 & 1) + (m2 & 1);
      const uint32_t after = static_cast<uint32_t>(x >> (8 * (digits + 1))) & 0xff;
      const bool ok = ((x & 0xff) == ' ') & (d0 < 10) & (after == ' ') & (value <= 255);
      if (ok) {
        *out = static_cast<uint8_t>(value);
        p += digits + 1;
        return true;
      }
    }
    uint64_t v = 0;
    if (!Uint(255, &v)) return false;
    *out = static_cast<uint8_t>(v);
    return true;
  }
  bool AtEnd() {
    SkipBlanks();
    return p == end;
  }
};

struct ParseError {
  uint64_t line = std::numeric_limits<uint64_t>::max();  // 1-based text line.
  std::string message;
};

// Parses the node lines in [begin, end) (whole lines), the first of which is
// node `first_node`, into parents (bit 31: isLeaf), descriptors and weights.
// Stops at the first error.
void ParseNodeLines(const char* begin, const char* end, const char* text_end, uint64_t first_node,
                    uint32_t* parents, OrbDescriptor* descriptors, float* weights,
                    ParseError* error) {
  uint64_t node = first_node;
  const char* line = begin;
  while (line < end) {
    const char* nl =
        static_cast<const char*>(std::memchr(line, '\n', static_cast<size_t>(end - line)));
    const char* line_end = nl != nullptr ? nl : end;
    Cursor c{line, line_end};
    auto fail = [&](const std::string& what) {
      error->line = node + 1;
      error->message = what;
    };
    uint64_t parent = 0, leaf = 0;
    if (c.AtEnd()) return fail("empty line");
    c.p = line;
    if (!c.Uint(kMaxVocabularyNodes - 1, &parent)) return fail("expected a parent node id");
    if (!c.Uint(1, &leaf)) return fail("expected isLeaf (0 or 1)");
    OrbDescriptor& d = descriptors[node];
    for (int b = 0; b < 32; ++b) {
      if (!c.Byte(text_end, &d.bytes[b])) {
        return fail("expected descriptor byte b" + std::to_string(b) + " in [0, 255]");
      }
    }
    c.SkipBlanks();
    if (c.p < c.end && *c.p == '+' && c.p + 1 < c.end && c.p[1] != '-') ++c.p;
    float weight = 0;
    const auto r = std::from_chars(c.p, c.end, weight, std::chars_format::general);
    if (r.ec == std::errc::result_out_of_range) {
      return fail("weight " + std::string(c.p, r.ptr) + " is outside the float32 range");
    }
    if (r.ec != std::errc() || (r.ptr < c.end && !IsBlank(*r.ptr))) {
      return fail("expected a weight");
    }
    if (!std::isfinite(weight)) return fail("weight is not finite");
    c.p = r.ptr;
    if (!c.AtEnd()) return fail("unexpected text after the weight (a node line has 35 fields)");
    parents[node] = static_cast<uint32_t>(parent) | (leaf != 0 ? kLeafFlagBit : 0);
    weights[node] = weight;
    ++node;
    line = line_end + 1;
  }
}

size_t CountNewlines(const char* begin, const char* end) {
  size_t count = 0;
  for (const char* p = begin; p < end; ++count, ++p) {
    p = static_cast<const char*>(std::memchr(p, '\n', static_cast<size_t>(end - p)));
    if (p == nullptr) break;
  }
  return count;
}

}  // namespace

VocabularyData ParseTextVocabulary(std::string_view text, const std::string& source, int threads) {
  const char* const data = text.data();
  const char* const end = data + text.size();
  // Line 1: k L scoring weighting.
  const char* nl = static_cast<const char*>(std::memchr(data, '\n', text.size()));
  const char* header_end = nl != nullptr ? nl : end;
  Cursor h{data, header_end};
  uint64_t k = 0, levels = 0, scoring = 0, weighting = 0;
  // Any unsigned number parses here, so that a large one gets the range
  // message below (k = 1000000 as k = 0), not "not a header".
  constexpr uint64_t kAnyUint32 = 0xffffffffu;
  if (!h.Uint(kAnyUint32, &k) || !h.Uint(kAnyUint32, &levels) || !h.Uint(kAnyUint32, &scoring) ||
      !h.Uint(kAnyUint32, &weighting) || !h.AtEnd()) {
    throw DataError(source + ": not a vocabulary: no " + std::string(kVocabularyFormat.magic, 8) +
                    " magic, and line 1 is not a DBoW2 text header 'k L scoring weighting'");
  }
  if (k < 1 || k > kTextMaxK || levels < 1 || levels > kTextMaxLevels || scoring > 5 ||
      weighting > 3) {
    throw DataError(source + ": line 1: k = " + std::to_string(k) +
                    ", L = " + std::to_string(levels) + ", scoring = " + std::to_string(scoring) +
                    ", weighting = " + std::to_string(weighting) +
                    " out of DBoW2's ranges (k in [1, 20], L in [1, 10], scoring in [0, 5], "
                    "weighting in [0, 3])");
  }
  VocabularyData out;
  out.info.k = static_cast<int>(k);
  out.info.levels = static_cast<int>(levels);
  out.info.scoring = static_cast<ScoringType>(scoring);
  out.info.weighting = static_cast<WeightingType>(weighting);

  // Node lines: everything after line 1 up to the last non-blank character.
  const char* body = nl != nullptr ? nl + 1 : end;
  const char* body_end = end;
  while (body_end > body && (IsBlank(body_end[-1]) || body_end[-1] == '\n')) --body_end;
  if (body == body_end) throw DataError(source + ": the vocabulary has no node besides the root");

  // Cut the body into whole-line parts, count the lines of each in parallel,
  // then parse each part into its rows of the arrays.
  const size_t size = static_cast<size_t>(body_end - body);
  const int parts = std::clamp(static_cast<int>(size >> 22) + 1, 1, std::max(1, threads));
  std::vector<const char*> bounds(parts + 1);
  bounds[0] = body;
  bounds[parts] = body_end;
  for (int t = 1; t < parts; ++t) {
    const char* guess = std::max(bounds[t - 1], body + size * t / parts);
    const char* cut =
        static_cast<const char*>(std::memchr(guess, '\n', static_cast<size_t>(body_end - guess)));
    bounds[t] = cut != nullptr ? cut + 1 : body_end;
  }
  auto run_parallel = [&](const std::function<void(int)>& fn) {
    std::vector<std::thread> workers;
    for (int t = 1; t < parts; ++t) workers.emplace_back(fn, t);
    fn(0);
    for (auto& w : workers) w.join();
  };
  std::vector<size_t> lines(parts, 0);
  run_parallel([&](int t) {
    // A part ends after a '\n' or at body_end, where the last line has none.
    if (bounds[t] < bounds[t + 1]) {
      lines[t] = CountNewlines(bounds[t], bounds[t + 1]) + (bounds[t + 1][-1] != '\n');
    }
  });
  std::vector<uint64_t> first_node(parts, 1);
  for (int t = 1; t < parts; ++t) first_node[t] = first_node[t - 1] + lines[t - 1];
  const uint64_t n = first_node[parts - 1] + lines[parts - 1];
  if (n > kMaxVocabularyNodes) {
    throw DataError(source + ": " + std::to_string(n) + " nodes, more than the supported " +
                    std::to_string(kMaxVocabularyNodes));
  }
  out.Allocate(n);
  LargeBuffer parents_block(4 * n);
  uint32_t* const parents = reinterpret_cast<uint32_t*>(parents_block.data());
  OrbDescriptor* descriptors = out.descriptors().data();
  float* weights = out.weights().data();
  descriptors[0] = OrbDescriptor{};  // The root has no descriptor in DBoW2.
  weights[0] = 0;
  parents[0] = 0;
  std::vector<ParseError> errors(parts);
  run_parallel([&](int t) {
    ParseNodeLines(bounds[t], bounds[t + 1], end, first_node[t], parents, descriptors, weights,
                   &errors[t]);
  });
  const auto first_error =
      std::min_element(errors.begin(), errors.end(),
                       [](const ParseError& a, const ParseError& b) { return a.line < b.line; });
  if (first_error->line != std::numeric_limits<uint64_t>::max()) {
    throw DataError(source + ": line " + std::to_string(first_error->line) + ": " +
                    first_error->message);
  }
  BuildLinks({parents, n}, true, &out.info, out.links(), source, 1);
  return out;
}

}  // namespace rrslam
