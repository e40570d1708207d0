#include "stages/vocab/vocabulary_yaml.h"

#include <zlib.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <functional>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "common/atomic_file.h"
#include "common/binary_header.h"
#include "common/errors.h"
#include "common/yaml_text.h"

namespace rrslam {
namespace {

uint64_t max_yaml_bytes = kMaxYamlVocabularyBytes;  // SetMaxYamlVocabularyBytesForTesting.

// "1 GiB", "64 MiB", else bytes.
std::string SizeText(uint64_t bytes) {
  if (bytes > 0 && bytes % (uint64_t{1} << 30) == 0) return std::to_string(bytes >> 30) + " GiB";
  if (bytes > 0 && bytes % (uint64_t{1} << 20) == 0) return std::to_string(bytes >> 20) + " MiB";
  return std::to_string(bytes) + " bytes";
}

bool IsGzip(std::span<const uint8_t> bytes) {
  return bytes.size() >= 2 && bytes[0] == 0x1f && bytes[1] == 0x8b;
}

// Inflates a gzip file (all members, as gzip -d reads them) through a
// 256 KiB buffer, handing each piece to `sink` (may be null), and returns the
// size of the content. Throws DataError once the content passes
// max_yaml_bytes, having allocated nothing for it.
uint64_t InflateGzip(std::span<const uint8_t> bytes, const std::string& source,
                     const std::function<void(const char*, size_t)>& sink) {
  z_stream z{};
  // 16 + MAX_WBITS: a gzip wrapper, not zlib's.
  if (inflateInit2(&z, 16 + MAX_WBITS) != Z_OK) {
    throw std::runtime_error("zlib: inflateInit2 failed");
  }
  std::vector<char> buffer(size_t{1} << 18);
  uint64_t produced = 0;
  const uint8_t* in = bytes.data();
  size_t left = bytes.size();
  int status = Z_OK;
  while (true) {
    // zlib counts in uInt (32 bits): feed at most 1 GiB at a time.
    const size_t in_chunk = std::min<size_t>(left, size_t{1} << 30);
    z.next_in = const_cast<Bytef*>(in);
    z.avail_in = static_cast<uInt>(in_chunk);
    z.next_out = reinterpret_cast<Bytef*>(buffer.data());
    z.avail_out = static_cast<uInt>(buffer.size());
    status = inflate(&z, Z_NO_FLUSH);
    in += in_chunk - z.avail_in;
    left -= in_chunk - z.avail_in;
    const size_t out = buffer.size() - z.avail_out;
    produced += out;
    if (produced > max_yaml_bytes) {
      inflateEnd(&z);
      throw DataError(source + ": decompresses to more than " + SizeText(max_yaml_bytes) +
                      ", more than a DBoW2 YAML vocabulary can be (a gzip bomb?)");
    }
    if (sink && out > 0) sink(buffer.data(), out);
    if (status == Z_STREAM_END) {
      // Concatenated members, as gzip allows; trailing zero padding ends it.
      while (left > 0 && *in == 0) {
        ++in;
        --left;
      }
      if (left == 0) break;
      inflateReset(&z);
      continue;
    }
    if (status == Z_BUF_ERROR && left == 0) break;  // Truncated: no progress without input.
    if (status != Z_OK && status != Z_BUF_ERROR) break;
  }
  const std::string zlib_message = z.msg != nullptr ? z.msg : "";
  inflateEnd(&z);
  if (status != Z_STREAM_END) {
    throw DataError(source + ": corrupt or truncated gzip data" +
                    (zlib_message.empty() ? std::string() : " (" + zlib_message + ")") + " after " +
                    std::to_string(produced) + " bytes of YAML");
  }
  return produced;
}

// The content of a gzip file. Inflated twice: once to measure it (refusing
// a bomb before anything is allocated for it), then into a string of exactly
// that size (no doubling, so a vocabulary near the cap needs no more than
// its size).
std::string Gunzip(std::span<const uint8_t> bytes, const std::string& source) {
  const uint64_t size = InflateGzip(bytes, source, nullptr);
  std::string out;
  out.reserve(size);
  InflateGzip(bytes, source, [&](const char* data, size_t n) { out.append(data, n); });
  return out;
}

std::string Gzip(std::string_view text, const std::filesystem::path& path) {
  z_stream z{};
  // Level 6 (gzip's default); 16 + MAX_WBITS: a gzip wrapper.
  if (deflateInit2(&z, 6, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
    throw CantCreateError(path.string() + ": zlib deflateInit2 failed");
  }
  std::string out(deflateBound(&z, static_cast<uLong>(text.size())), '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(text.data()));
  z.avail_in = static_cast<uInt>(text.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  const int status = deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  if (status != Z_STREAM_END) throw CantCreateError(path.string() + ": zlib deflate failed");
  return out;
}

// Reads the keys of a DBoW2 YAML vocabulary, throwing DataError with the
// file name and, for nodes and words, the entry and the id at fault.
class YamlReader {
 public:
  explicit YamlReader(const std::string& source) : source_(source) {}

  [[noreturn]] void Fail(const std::string& what) const { throw DataError(source_ + ": " + what); }

  // An integer key of `map`, in [min, max]; `where` names the map in errors.
  int64_t Int(const cv::FileNode& map, const char* key, int64_t min, int64_t max,
              const std::string& where) const {
    const cv::FileNode node = map[key];
    if (node.empty() || node.isNone()) Fail(where + ": " + key + " is missing");
    if (!node.isInt()) Fail(where + ": " + key + " is not an integer");
    const int64_t value = static_cast<int>(node);
    if (value < min || value > max) {
      Fail(where + ": " + key + " = " + std::to_string(value) + " is not in [" +
           std::to_string(min) + ", " + std::to_string(max) + "]");
    }
    return value;
  }

  // The weight as DBoW2's text form of the same vocabulary holds it: the
  // double rounded to 6 significant digits (a stream's default), then to
  // float32. Rounding the double straight to float32 would differ from the
  // text in the 6th digit where the double lies near a rounding tie
  // (0.82768748532 -> 0.827687 in text, but float32 0.8276875019 -> 0.827688),
  // and the YAML and text forms would then be two trees (VocabularyContentHash).
  float Weight(const cv::FileNode& map, const std::string& where) const {
    const cv::FileNode node = map["weight"];
    if (node.empty() || node.isNone()) Fail(where + ": weight is missing");
    if (!node.isReal() && !node.isInt()) Fail(where + ": weight is not a number");
    const double value = static_cast<double>(node);
    if (!std::isfinite(value)) Fail(where + ": weight is not finite");
    char text[32];
    const auto printed =
        std::to_chars(text, text + sizeof(text), value, std::chars_format::general, 6);
    float weight = 0;
    const auto parsed = std::from_chars(text, printed.ptr, weight, std::chars_format::general);
    if (parsed.ec != std::errc() || !std::isfinite(weight)) {
      Fail(where + ": weight " + std::string(text, printed.ptr) + " is outside the float32 range");
    }
    return weight;
  }

  // FORB::toString's text: 32 decimal bytes separated by blanks (DBoW2 ends
  // it with a space). DBoW2's fromString reads whatever numbers it finds
  // and leaves missing bytes as they were; we require exactly 32.
  OrbDescriptor Descriptor(const cv::FileNode& map, const std::string& where) const {
    const cv::FileNode node = map["descriptor"];
    if (node.empty() || node.isNone()) Fail(where + ": descriptor is missing");
    if (!node.isString()) {
      Fail(where + ": descriptor is not a string (DBoW2 writes ORB descriptors as \"b0 b1 ... " +
           "b31 \")");
    }
    const std::string text = node.string();
    OrbDescriptor d;
    const char* p = text.data();
    const char* const end = p + text.size();
    auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
    int count = 0;
    while (true) {
      while (p < end && blank(*p)) ++p;
      if (p == end) break;
      unsigned value = 0;
      const auto r = std::from_chars(p, end, value);
      if (r.ec != std::errc() || (r.ptr < end && !blank(*r.ptr)) || *p == '+') {
        const char* token_end = std::find_if(p, end, blank);
        Fail(where + ": descriptor byte b" + std::to_string(count) + " '" +
             std::string(p, token_end) + "' is not a decimal number in [0, 255]");
      }
      if (value > 255) {
        Fail(where + ": descriptor byte b" + std::to_string(count) + " = " + std::to_string(value) +
             " is not in [0, 255]");
      }
      if (count == 32) {
        Fail(where + ": descriptor has more than 32 bytes (an ORB descriptor has 32)");
      }
      d.bytes[count++] = static_cast<uint8_t>(value);
      p = r.ptr;
    }
    if (count != 32) {
      Fail(where + ": descriptor has " + std::to_string(count) +
           " bytes; an ORB descriptor has 32 (is this a vocabulary of another descriptor?)");
    }
    return d;
  }

 private:
  const std::string& source_;
};

std::string NodeEntry(size_t entry, int64_t node_id) {
  return "nodes entry " + std::to_string(entry) + " (nodeId " + std::to_string(node_id) + ")";
}

// The vocabulary of a parsed YAML file.
VocabularyData ReadYamlTree(const cv::FileStorage& fs, const std::string& source) {
  const YamlReader read(source);
  const cv::FileNode voc = fs["vocabulary"];
  if (voc.empty() || voc.isNone()) {
    read.Fail("no 'vocabulary' key (DBoW2's save writes the tree under it)");
  }
  if (!voc.isMap()) read.Fail("'vocabulary' is not a map");
  VocabularyData out;
  out.info.k = static_cast<int>(read.Int(voc, "k", 1, kMaxVocabularyK, "vocabulary"));
  out.info.levels = static_cast<int>(read.Int(voc, "L", 1, 255, "vocabulary"));
  out.info.scoring = static_cast<ScoringType>(read.Int(voc, "scoringType", 0, 5, "vocabulary"));
  out.info.weighting =
      static_cast<WeightingType>(read.Int(voc, "weightingType", 0, 3, "vocabulary"));

  const cv::FileNode nodes = voc["nodes"];
  if (nodes.empty() || nodes.isNone()) read.Fail("vocabulary: nodes is missing");
  if (!nodes.isSeq()) read.Fail("vocabulary: nodes is not a list");
  const uint64_t n = uint64_t{nodes.size()} + 1;  // The root is not listed.
  if (n < 2) read.Fail("the vocabulary has no node besides the root");
  if (n > kMaxVocabularyNodes) {
    read.Fail(std::to_string(n) + " nodes, more than the supported " +
              std::to_string(kMaxVocabularyNodes));
  }
  out.Allocate(n);
  const int64_t max_id = static_cast<int64_t>(n - 1);
  std::vector<uint32_t> parents(n, 0);
  // Entry (1-based) where each id was seen, 0 = not yet; and per parent the
  // last child listed, to check siblings come in id order as DBoW2 lists them.
  std::vector<uint32_t> seen_at(n, 0);
  std::vector<uint32_t> last_child(n, 0);
  OrbDescriptor* descriptors = out.descriptors().data();
  float* weights = out.weights().data();
  descriptors[0] = OrbDescriptor{};
  weights[0] = 0;
  // Iterators, not nodes[i]: FileNode::operator[](int) steps an iterator
  // from the start of the list, which makes DBoW2's own loader quadratic in
  // the node count (0.55 s against 5 ms to visit the 7380 nodes of the real
  // k = 9, L = 4 vocabulary in ../shared/data).
  size_t entry = 0;
  for (auto it = nodes.begin(); it != nodes.end(); ++it, ++entry) {
    const cv::FileNode node = *it;
    const std::string list_entry = "nodes entry " + std::to_string(entry);
    if (!node.isMap())
      read.Fail(list_entry + " is not a map of nodeId, parentId, weight, descriptor");
    const int64_t id = read.Int(node, "nodeId", 1, max_id, list_entry);
    const std::string where = NodeEntry(entry, id);
    if (seen_at[id] != 0) {
      read.Fail(where + ": nodeId " + std::to_string(id) + " is listed twice (also entry " +
                std::to_string(seen_at[id] - 1) + ")");
    }
    seen_at[id] = static_cast<uint32_t>(entry + 1);
    const int64_t parent = read.Int(node, "parentId", 0, max_id, where);
    if (parent >= id) {
      read.Fail(where + ": node " + std::to_string(id) + " has parent " + std::to_string(parent) +
                "; a parent must come before its children");
    }
    if (last_child[parent] > id) {
      read.Fail(where + ": children of node " + std::to_string(parent) +
                " are not listed in id order (node " + std::to_string(id) + " after node " +
                std::to_string(last_child[parent]) + ")");
    }
    last_child[parent] = static_cast<uint32_t>(id);
    parents[id] = static_cast<uint32_t>(parent);
    weights[id] = read.Weight(node, where);
    descriptors[id] = read.Descriptor(node, where);
  }
  // N - 1 entries with distinct ids in [1, N - 1]: every node is listed.
  LinksFromParents(parents, &out.info, out.links(), source);

  const cv::FileNode words = voc["words"];
  if (words.empty() || words.isNone()) read.Fail("vocabulary: words is missing");
  if (!words.isSeq()) read.Fail("vocabulary: words is not a list");
  if (words.size() != out.info.num_words) {
    read.Fail("vocabulary: words lists " + std::to_string(words.size()) +
              " words but the tree has " + std::to_string(out.info.num_words) + " leaves");
  }
  const auto links = out.links();
  const int64_t max_word = static_cast<int64_t>(out.info.num_words) - 1;
  std::vector<uint8_t> word_seen(out.info.num_words, 0);
  entry = 0;
  for (auto it = words.begin(); it != words.end(); ++it, ++entry) {
    const cv::FileNode word = *it;
    const std::string list_entry = "words entry " + std::to_string(entry);
    if (!word.isMap()) read.Fail(list_entry + " is not a map of wordId, nodeId");
    const int64_t word_id = read.Int(word, "wordId", 0, max_word, list_entry);
    const std::string where = list_entry + " (wordId " + std::to_string(word_id) + ")";
    const int64_t node_id = read.Int(word, "nodeId", 1, max_id, where);
    const uint32_t link = links[node_id];
    if (LinkChildren(link) != 0) {
      read.Fail(where + ": node " + std::to_string(node_id) + " is not a leaf (it has " +
                std::to_string(LinkChildren(link)) + " children)");
    }
    if (word_seen[word_id])
      read.Fail(where + ": wordId " + std::to_string(word_id) + " is listed twice");
    word_seen[word_id] = 1;
    if (LinkIndex(link) != word_id) {
      read.Fail(where + ": word " + std::to_string(word_id) + " is node " +
                std::to_string(node_id) + ", which is leaf " + std::to_string(LinkIndex(link)) +
                " in node order; rrslam numbers words in node order, as DBoW2 does when it "
                "creates a vocabulary or reads its text form");
    }
  }
  ValidateVocabularyLinks(out.view(), source);
  return out;
}

}  // namespace

VocabularyData ParseYamlVocabulary(std::span<const uint8_t> bytes, const std::string& source) {
  if (bytes.empty()) throw DataError(source + ": empty file, not a vocabulary");
  if (!IsGzip(bytes) && bytes.size() > max_yaml_bytes) {
    throw DataError(source + ": " + std::to_string(bytes.size()) + " bytes of YAML, more than " +
                    SizeText(max_yaml_bytes) + ", more than a DBoW2 YAML vocabulary can be");
  }
  std::string text = IsGzip(bytes)
                         ? Gunzip(bytes, source)
                         : std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  cv::FileStorage fs = ParseYamlText(
      text, source,
      "a DBoW2 YAML vocabulary is one YAML document holding the map 'vocabulary' at column 0");
  std::string().swap(text);  // FileStorage holds its own parsed tree.
  try {
    return ReadYamlTree(fs, source);
  } catch (const cv::Exception& e) {
    // Not expected (every node's type is checked before it is read); a
    // DataError all the same, as the input is at fault.
    throw DataError(source + ": unreadable YAML: " + YamlSyntaxError(e));
  }
}

// ---------------------------------------------------------------------------
// Writer

std::string FormatYamlVocabulary(const VocabularyView& v, const std::string& source) {
  VocabularyParents(v, source);  // Checks that `v` is a tree; the links give the children.
  const uint64_t n = v.info.num_nodes;
  cv::FileStorage fs(
      ".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  // The keys and their order of DBoW2's TemplatedVocabulary::save.
  fs << "vocabulary"
     << "{";
  fs << "k" << v.info.k;
  fs << "L" << v.info.levels;
  fs << "scoringType" << static_cast<int>(v.info.scoring);
  fs << "weightingType" << static_cast<int>(v.info.weighting);
  fs << "nodes"
     << "[";
  // DBoW2's order: a stack of inner nodes, the root first; each popped node
  // lists its children in order and pushes the inner ones.
  std::vector<uint32_t> stack{0};
  std::string descriptor;
  while (!stack.empty()) {
    const uint32_t parent = stack.back();
    stack.pop_back();
    const uint32_t first = LinkIndex(v.links[parent]);
    const uint32_t count = LinkChildren(v.links[parent]);
    for (uint32_t child = first; child < first + count; ++child) {
      descriptor.clear();
      for (uint8_t b : v.descriptors[child].bytes) {
        descriptor += std::to_string(b);
        descriptor += ' ';
      }
      fs << "{:";
      fs << "nodeId" << static_cast<int>(child);
      fs << "parentId" << static_cast<int>(parent);
      fs << "weight" << static_cast<double>(v.weights[child]);
      fs << "descriptor" << descriptor;
      fs << "}";
      if (LinkChildren(v.links[child]) != 0) stack.push_back(child);
    }
  }
  fs << "]";
  fs << "words"
     << "[";
  for (uint64_t i = 1; i < n; ++i) {
    if (LinkChildren(v.links[i]) != 0) continue;
    fs << "{:";
    fs << "wordId" << static_cast<int>(LinkIndex(v.links[i]));
    fs << "nodeId" << static_cast<int>(i);
    fs << "}";
  }
  fs << "]";
  fs << "}";
  return fs.releaseAndGetString();
}

void SetMaxYamlVocabularyBytesForTesting(uint64_t bytes) {
  max_yaml_bytes = bytes == 0 ? kMaxYamlVocabularyBytes : bytes;
}

bool HasYamlExtension(const std::filesystem::path& path) {
  std::filesystem::path name = path.filename();
  if (name.extension() == ".gz") name = name.stem();
  const std::string ext = name.extension().string();
  return ext == ".yml" || ext == ".yaml";
}

void WriteYamlVocabulary(const std::filesystem::path& path, const VocabularyView& v,
                         const std::string& source) {
  const std::string text = FormatYamlVocabulary(v, source);
  if (path.extension() == ".gz") {
    WriteFileAtomically(path, Gzip(text, path));
  } else {
    WriteFileAtomically(path, text);
  }
}

// ---------------------------------------------------------------------------
// Loader of every format

Vocabulary LoadVocabularyFile(const std::filesystem::path& path, VocabularyFileFormat* format) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    throw NoInputError(path.string() + ": vocabulary file not found");
  }
  VocabularyFileFormat detected;
  {
    const MappedFile file(path);
    detected = DetectVocabularyFileFormat(file.bytes());
    // A .yml file that does not start as YAML gets a YAML error, not "line 1
    // is not a DBoW2 text header".
    if (detected == VocabularyFileFormat::kDbow2Text && HasYamlExtension(path)) {
      detected = VocabularyFileFormat::kDbow2Yaml;
    }
    if (detected == VocabularyFileFormat::kDbow2Yaml) {
      if (format != nullptr) *format = detected;
      VocabularyData data = ParseYamlVocabulary(file.bytes(), path.string());
      return Vocabulary::FromData(std::move(data), path.filename().string(),
                                  Checksum64(file.bytes()));
    }
  }
  if (format != nullptr) *format = detected;
  return Vocabulary::Load(path);
}

}  // namespace rrslam
