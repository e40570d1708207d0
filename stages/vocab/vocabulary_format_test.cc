#include "stages/vocab/vocabulary_format.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>

#include "common/atomic_file.h"
#include "common/binary_header.h"
#include "common/errors.h"
#include "common/formats.h"
#include "common/testing.h"
#include "stages/vocab/vocab_test_util.h"

namespace rrslam {
namespace {

using testing::DescriptorText;

// A DBoW2 text vocabulary written by hand in the exact layout of DBoW2's
// saveToTextFile: k=2, L=2, L1 scoring (0), TF-IDF weighting (0).
//   root -> {1, 2}; 1 -> {3, 4}; words: 2 (w0), 3 (w1), 4 (w2).
const char kHandText[] =
    "2 2  0 0\n"
    "0 0 255 0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30  "
    "0\n"
    "0 1 0 255 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 99  1.38629\n"
    "1 1 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7 7  0.693147\n"
    "1 1 100 200 100 200 100 200 100 200 100 200 100 200 100 200 100 200 100 200 100 200 "
    "100 200 100 200 100 200 100 200 100 200 100 200  1e-05\n";

TEST(TextVocabulary, ParsesHandWrittenDbow2File) {
  const VocabularyData d = ParseTextVocabulary(kHandText, "hand.txt");
  EXPECT_EQ(d.info.k, 2);
  EXPECT_EQ(d.info.levels, 2);
  EXPECT_EQ(d.info.scoring, ScoringType::kL1);
  EXPECT_EQ(d.info.weighting, WeightingType::kTfIdf);
  EXPECT_EQ(d.info.num_nodes, 5u);
  EXPECT_EQ(d.info.num_words, 3u);
  const auto links = d.links();
  EXPECT_EQ(links[0], InnerLink(1, 2));
  EXPECT_EQ(links[1], InnerLink(3, 2));
  EXPECT_EQ(links[2], LeafLink(0));  // Words numbered in file order.
  EXPECT_EQ(links[3], LeafLink(1));
  EXPECT_EQ(links[4], LeafLink(2));
  EXPECT_EQ(d.descriptors()[1].bytes[0], 255);
  EXPECT_EQ(d.descriptors()[1].bytes[31], 30);
  EXPECT_EQ(d.descriptors()[2].bytes[1], 255);
  EXPECT_EQ(d.descriptors()[2].bytes[31], 99);
  EXPECT_EQ(d.descriptors()[4].bytes[1], 200);
  EXPECT_EQ(d.weights()[1], 0.0f);
  EXPECT_EQ(d.weights()[2], 1.38629f);
  EXPECT_EQ(d.weights()[3], 0.693147f);
  EXPECT_EQ(d.weights()[4], 1e-05f);
  // Written back byte for byte, double space before scoring and weight included.
  EXPECT_EQ(FormatTextVocabulary(d.view(), "hand.txt"), kHandText);
}

TEST(TextVocabulary, AcceptsWhitespaceVariants) {
  const VocabularyData reference = ParseTextVocabulary(kHandText, "hand.txt");
  std::string crlf, tabs;
  for (char c : std::string(kHandText)) {
    if (c == '\n') crlf += '\r';
    crlf += c;
    tabs += c == ' ' ? '\t' : c;
  }
  std::string no_final_newline = kHandText;
  no_final_newline.pop_back();
  const std::string trailing_blank_lines = std::string(kHandText) + "\n  \n\n";
  std::string plus_weight = kHandText;
  plus_weight.replace(plus_weight.find("1.38629"), 7, "+1.38629");
  for (const std::string& text :
       {crlf, tabs, no_final_newline, trailing_blank_lines, plus_weight}) {
    const VocabularyData d = ParseTextVocabulary(text, "variant.txt");
    EXPECT_EQ(FormatTextVocabulary(d.view(), "v"), kHandText);
  }
}

void ExpectTextError(const std::string& text, const std::string& fragment) {
  try {
    ParseTextVocabulary(text, "bad.txt");
    ADD_FAILURE() << "accepted; expected an error with: " << fragment;
  } catch (const DataError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(fragment), std::string::npos) << message;
    EXPECT_EQ(message.rfind("bad.txt: ", 0), 0u) << message;
  }
}

std::string Line(const std::string& parent, const std::string& leaf, const std::string& weight,
                 const std::string& descriptor = DescriptorText(OrbDescriptor{})) {
  return parent + " " + leaf + " " + descriptor + " " + weight + "\n";
}

TEST(TextVocabulary, RejectsMalformedFilesWithLineNumbers) {
  const std::string header = "2 2  0 0\n";
  const std::string ok = header + Line("0", "1", "1") + Line("0", "1", "2");
  EXPECT_NO_THROW(ParseTextVocabulary(ok, "ok.txt"));
  ExpectTextError("", "line 1 is not a DBoW2 text header");
  ExpectTextError("RRSLVOCX\n", "line 1 is not a DBoW2 text header");
  ExpectTextError("2 2 0\n", "line 1 is not a DBoW2 text header");
  ExpectTextError("2 2 0 0 9\n", "line 1 is not a DBoW2 text header");
  ExpectTextError("21 2 0 0\n" + Line("0", "1", "1"), "out of DBoW2's ranges");
  ExpectTextError("2 11 0 0\n" + Line("0", "1", "1"), "out of DBoW2's ranges");
  ExpectTextError("2 2 6 0\n" + Line("0", "1", "1"), "out of DBoW2's ranges");
  ExpectTextError("2 2 0 4\n" + Line("0", "1", "1"), "out of DBoW2's ranges");
  // A large number gets the range message too, not "not a header".
  ExpectTextError("1000000 6 0 0\n" + Line("0", "1", "1"), "k = 1000000, L = 6");
  ExpectTextError("0 6 0 0\n" + Line("0", "1", "1"), "k = 0, L = 6");
  ExpectTextError(header, "no node besides the root");
  ExpectTextError(header + "\n\n", "no node besides the root");
  ExpectTextError(header + Line("0", "1", "1") + "\n" + Line("0", "1", "2"), "line 3: empty line");
  ExpectTextError(header + Line("0", "1", ""), "line 2: expected a weight");
  ExpectTextError(header + Line("0", "1", "1 5"), "line 2: unexpected text after the weight");
  ExpectTextError(header + Line("0", "2", "1"), "line 2: expected isLeaf");
  ExpectTextError(header + Line("x", "1", "1"), "line 2: expected a parent");
  ExpectTextError(header + Line("0", "1", "1", "1 2 3"), "line 2: expected descriptor byte b4");
  std::string big = DescriptorText(OrbDescriptor{});
  big.replace(0, 1, "256");
  ExpectTextError(header + Line("0", "1", "1", big), "line 2: expected descriptor byte b0");
  ExpectTextError(header + Line("0", "1", "nan"), "line 2: weight is not finite");
  ExpectTextError(header + Line("0", "1", "inf"), "line 2: weight is not finite");
  ExpectTextError(header + Line("0", "1", "1e39"), "outside the float32 range");
  ExpectTextError(header + Line("0", "1", "1x"), "line 2: expected a weight");
  // Tree structure.
  ExpectTextError(header + Line("1", "1", "1"), "line 2: node 1 has parent 1");
  ExpectTextError(header + Line("0", "0", "0") + Line("2", "1", "1"),
                  "line 3: node 2 has parent 2");
  ExpectTextError(header + Line("0", "1", "1") + Line("0", "1", "1") + Line("0", "1", "1"),
                  "line 4: node 3: node 0 has more than k = 2 children");
  ExpectTextError(header + Line("0", "0", "1") + Line("0", "1", "1"),
                  "line 2: node 1 is marked isLeaf = 0 but has 0 children");
  ExpectTextError(header + Line("0", "1", "0") + Line("1", "1", "1"),
                  "line 2: node 1 is marked isLeaf = 1 but has 1 children");
  // 0 -> {1, 3}, 1 -> {2}: siblings 1 and 3 are not consecutive.
  ExpectTextError(header + Line("0", "0", "0") + Line("1", "1", "1") + Line("0", "1", "1"),
                  "the children of node 0 are not consecutive");
}

TEST(TextVocabulary, WeightPolicy) {
  // More than 6 significant digits: rounded to float32, written with 6 digits.
  const std::string header = "2 2  0 0\n";
  const VocabularyData d = ParseTextVocabulary(
      header + Line("0", "1", "0.12345678912") + Line("0", "1", "2.5e-07"), "w");
  EXPECT_EQ(d.weights()[1], 0.12345678912f);
  EXPECT_EQ(FormatTextVocabulary(d.view(), "w"),
            header + Line("0", "1", "0.123457") + Line("0", "1", "2.5e-07"));
}

TEST(TextVocabulary, OwnTextRoundTripsByteForByte) {
  const VocabularyData random = testing::RandomVocabulary(10, 5, 3);
  const std::string text = FormatTextVocabulary(random.view(), "r");
  const VocabularyData parsed = ParseTextVocabulary(text, "r.txt");
  EXPECT_EQ(FormatTextVocabulary(parsed.view(), "r"), text);
  // Through the binary format.
  const std::vector<uint8_t> binary = EncodeBinaryVocabulary(parsed.view());
  std::vector<OrbDescriptor> aligned(binary.size() / 32 + 1);
  std::memcpy(static_cast<void*>(aligned.data()), binary.data(), binary.size());
  const VocabularyView view = ParseBinaryVocabulary(
      {reinterpret_cast<const uint8_t*>(aligned.data()), binary.size()}, "r.rrv");
  EXPECT_EQ(FormatTextVocabulary(view, "r"), text);
}

TEST(TextVocabulary, ParallelParseEqualsSerial) {
  // Large enough (> 4 MB of text) to be cut into several parts.
  const VocabularyData random = testing::RandomVocabulary(10, 6, 8, 1.0, 80000);
  const std::string text = FormatTextVocabulary(random.view(), "r");
  ASSERT_GT(text.size(), size_t{8} << 20);  // At least 2 parts of 4 MB.
  const VocabularyData serial = ParseTextVocabulary(text, "r", 1);
  for (int threads : {2, 3, 4}) {
    const VocabularyData parallel = ParseTextVocabulary(text, "r", threads);
    ASSERT_EQ(parallel.info.num_nodes, serial.info.num_nodes);
    EXPECT_EQ(0, std::memcmp(parallel.view().descriptors, serial.view().descriptors,
                             40 * serial.info.num_nodes));
  }
  // A malformed line deep in the second half is reported with its line number.
  std::string broken = text;
  size_t pos = broken.size() * 3 / 4;
  pos = broken.find('\n', pos) + 1;
  const size_t line = static_cast<size_t>(std::count(text.begin(), text.begin() + pos, '\n')) + 1;
  broken.insert(pos, "oops ");
  ExpectTextError(broken, "line " + std::to_string(line) + ": expected a parent");
}

// --- Binary format ---------------------------------------------------------

struct AlignedFile {
  std::vector<OrbDescriptor> storage;
  size_t size = 0;
  explicit AlignedFile(const std::vector<uint8_t>& bytes)
      : storage(bytes.size() / 32 + 1), size(bytes.size()) {
    // An empty vector's data() may be null, which memcpy may not be passed
    // even for 0 bytes (UBSan: nonnull-attribute).
    if (!bytes.empty()) std::memcpy(static_cast<void*>(storage.data()), bytes.data(), bytes.size());
  }
  std::span<const uint8_t> span() const {
    return {reinterpret_cast<const uint8_t*>(storage.data()), size};
  }
};

void ExpectBinaryError(const std::vector<uint8_t>& bytes, const std::string& fragment) {
  const AlignedFile file(bytes);
  try {
    ParseBinaryVocabulary(file.span(), "v.rrv");
    ADD_FAILURE() << "accepted; expected an error with: " << fragment;
  } catch (const DataError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(fragment), std::string::npos) << message;
    EXPECT_EQ(message.rfind("v.rrv: ", 0), 0u) << message;
  }
}

// Re-seals a modified file: recomputes the payload and header checksums, so
// that only the check under test can reject it.
std::vector<uint8_t> Reseal(const std::vector<uint8_t>& bytes, uint16_t major = 1,
                            uint16_t minor = kVocabularyFormat.minor) {
  FormatSpec spec = kVocabularyFormat;
  spec.major = major;
  spec.minor = minor;
  const std::span<const uint8_t> all(bytes);
  const std::vector<uint8_t> header =
      BuildBinaryHeader(spec, all.subspan(kBaseHeaderSize, kVocabularyHeaderSize - kBaseHeaderSize),
                        all.subspan(kVocabularyHeaderSize));
  std::vector<uint8_t> out = header;
  out.insert(out.end(), bytes.begin() + kVocabularyHeaderSize, bytes.end());
  return out;
}

template <typename T>
void Put(std::vector<uint8_t>* bytes, size_t offset, T value) {
  std::memcpy(bytes->data() + offset, &value, sizeof(T));
}

class BinaryVocabularyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    data_ = testing::RandomVocabulary(4, 3, 5);
    data_.metadata = R"({"producer":"test"})";
    bytes_ = EncodeBinaryVocabulary(data_.view());
  }
  size_t n() const { return data_.info.num_nodes; }
  size_t LinksAt() const { return kVocabularyHeaderSize + 32 * n(); }
  VocabularyData data_;
  std::vector<uint8_t> bytes_;
};

TEST_F(BinaryVocabularyTest, RoundTrip) {
  EXPECT_EQ(bytes_.size(), kVocabularyHeaderSize + 40 * n() + data_.metadata.size());
  const AlignedFile file(bytes_);
  BinaryVocabularyHeader h;
  const VocabularyView v = ParseBinaryVocabulary(file.span(), "v.rrv", &h);
  EXPECT_EQ(h.major, 1);
  EXPECT_EQ(h.minor, 1);
  EXPECT_EQ(h.tree_hash, VocabularyContentHash(v));
  EXPECT_NE(h.tree_hash, 0u);
  EXPECT_EQ(v.info.k, 4);
  EXPECT_EQ(v.info.levels, 3);
  EXPECT_EQ(v.info.num_nodes, n());
  EXPECT_EQ(v.info.num_words, data_.info.num_words);
  EXPECT_EQ(v.metadata, data_.metadata);
  EXPECT_EQ(0, std::memcmp(v.descriptors, data_.view().descriptors, 32 * n()));
  EXPECT_EQ(0, std::memcmp(v.links, data_.view().links, 4 * n()));
  EXPECT_EQ(0, std::memcmp(v.weights, data_.view().weights, 4 * n()));
  EXPECT_EQ(EncodeBinaryVocabulary(v), bytes_);
  // File written atomically.
  testing::TempDir dir;
  WriteBinaryVocabulary(dir / "v.rrv", v);
  const std::string written = ReadFileToString(dir / "v.rrv");
  EXPECT_EQ(written, std::string(bytes_.begin(), bytes_.end()));
}

TEST_F(BinaryVocabularyTest, RejectsTruncatedFiles) {
  for (size_t size : {size_t{0}, size_t{7}, size_t{8}, size_t{39}, size_t{40}, size_t{100},
                      size_t{kVocabularyHeaderSize}, size_t{kVocabularyHeaderSize + 1}, LinksAt(),
                      bytes_.size() / 2, bytes_.size() - 1}) {
    std::vector<uint8_t> truncated(bytes_.begin(), bytes_.begin() + static_cast<long>(size));
    const AlignedFile file(truncated);
    EXPECT_THROW(ParseBinaryVocabulary(file.span(), "v.rrv"), DataError) << "size " << size;
  }
  std::vector<uint8_t> half(bytes_.begin(), bytes_.begin() + static_cast<long>(bytes_.size() / 2));
  ExpectBinaryError(half, "truncated");
  std::vector<uint8_t> padded = bytes_;
  padded.push_back(0);
  ExpectBinaryError(padded, "truncated or padded");
}

TEST_F(BinaryVocabularyTest, RejectsBadMagic) {
  std::vector<uint8_t> bad = bytes_;
  bad[7] = 'X';
  ExpectBinaryError(bad, "bad magic");
}

TEST_F(BinaryVocabularyTest, RejectsFutureMajorAcceptsNewerMinor) {
  ExpectBinaryError(Reseal(bytes_, 2, 0), "version 2.0 is not supported");
  const std::vector<uint8_t> newer = Reseal(bytes_, 1, 7);
  const AlignedFile file(newer);
  BinaryVocabularyHeader h;
  EXPECT_NO_THROW(ParseBinaryVocabulary(file.span(), "v.rrv", &h));
  EXPECT_EQ(h.minor, 7);
}

// A 1.0 file has no stored tree hash (its bytes 112-119 were reserved): the
// identity is computed from the arrays, and it is the one 1.1 stores.
TEST_F(BinaryVocabularyTest, VersionOneZeroFilesGetTheTreeHashComputed) {
  std::vector<uint8_t> old = bytes_;
  Put<uint64_t>(&old, 112, 0);
  old = Reseal(old, 1, 0);
  const AlignedFile file(old);
  BinaryVocabularyHeader h;
  const VocabularyView v = ParseBinaryVocabulary(file.span(), "v.rrv", &h);
  EXPECT_EQ(h.minor, 0);
  EXPECT_EQ(h.tree_hash, 0u);
  EXPECT_EQ(TreeHashOf(v, h), VocabularyContentHash(data_.view()));
  // A stored hash is covered by the header checksum: changed, it is refused.
  std::vector<uint8_t> tampered = bytes_;
  Put<uint64_t>(&tampered, 112, 12345);
  ExpectBinaryError(tampered, "header checksum mismatch");
}

TEST_F(BinaryVocabularyTest, RejectsBadChecksums) {
  std::vector<uint8_t> payload_flip = bytes_;
  payload_flip[kVocabularyHeaderSize + 40] ^= 1;
  ExpectBinaryError(payload_flip, "checksum mismatch");
  std::vector<uint8_t> header_flip = bytes_;
  header_flip[kBaseHeaderSize + 1] ^= 1;  // k, without resealing.
  ExpectBinaryError(header_flip, "header checksum mismatch");
}

TEST_F(BinaryVocabularyTest, RejectsChildIndexOutOfRange) {
  // Checksums recomputed after corrupting, so the bounds check itself is tested.
  std::vector<uint8_t> bad = bytes_;
  Put<uint32_t>(&bad, LinksAt(), InnerLink(static_cast<uint32_t>(n()) - 1, 2));
  ExpectBinaryError(Reseal(bad),
                    "node 0 links to 2 children at " + std::to_string(n() - 1) + ", out of range");
  bad = bytes_;
  Put<uint32_t>(&bad, LinksAt(), InnerLink(0, 1));  // A cycle: the root as its own child.
  ExpectBinaryError(Reseal(bad), "out of range");
  bad = bytes_;
  Put<uint32_t>(&bad, LinksAt(), InnerLink(1, 5));  // More than k = 4 children.
  ExpectBinaryError(Reseal(bad), "out of range");
  // A leaf with the wrong word id.
  bad = bytes_;
  size_t leaf = 1;
  while (LinkChildren(data_.links()[leaf]) != 0) ++leaf;
  Put<uint32_t>(&bad, LinksAt() + 4 * leaf, LeafLink(12345));
  ExpectBinaryError(Reseal(bad), "word id 12345");
}

TEST_F(BinaryVocabularyTest, RejectsBadHeaderFields) {
  auto field = [&](size_t offset, auto value) {
    std::vector<uint8_t> bad = bytes_;
    Put(&bad, kBaseHeaderSize + offset, value);
    return Reseal(bad);
  };
  ExpectBinaryError(field(0, uint32_t{0}), "k = 0");
  ExpectBinaryError(field(8, uint32_t{4}), "weighting = 4");
  ExpectBinaryError(field(12, uint32_t{6}), "scoring = 6");
  ExpectBinaryError(field(16, uint64_t{1} << 40), "node count");
  ExpectBinaryError(field(16, uint64_t{2 * n()}), "exceed the payload");
  ExpectBinaryError(field(24, uint64_t{n()}), "word count");
  ExpectBinaryError(field(24, uint64_t{data_.info.num_words - 1}), "leaves but the header says");
  ExpectBinaryError(field(40, uint64_t{bytes_.size() / 4 * 4 + 4}), "links [");
  ExpectBinaryError(field(32, uint64_t{16}), "not 32-byte aligned");
  ExpectBinaryError(field(64, uint64_t{1000}), "metadata [");
}

TEST(VocabularyLinks, ParentsAndDescent) {
  const VocabularyData d = testing::RandomVocabulary(5, 4, 9);
  const std::vector<uint32_t> parents = VocabularyParents(d.view(), "d");
  VocabularyInfo info = d.info;
  VocabularyData rebuilt;
  rebuilt.Allocate(parents.size());
  LinksFromParents(parents, &info, rebuilt.links(), "d");
  EXPECT_TRUE(std::equal(d.links().begin(), d.links().end(), rebuilt.links().begin()));
  EXPECT_EQ(info.num_words, d.info.num_words);
  // Any descriptor descends to a leaf.
  std::mt19937_64 rng(1);
  for (int i = 0; i < 100; ++i) {
    const uint32_t leaf = DescendToLeaf(d.view(), testing::RandomOrbDescriptor(rng));
    EXPECT_EQ(LinkChildren(d.links()[leaf]), 0u);
  }
  // Every parent lists its children.
  for (size_t i = 1; i < d.info.num_nodes; ++i) {
    const uint32_t link = d.links()[parents[i]];
    EXPECT_GE(i, LinkIndex(link));
    EXPECT_LT(i, LinkIndex(link) + LinkChildren(link));
  }
}

TEST(VocabularyNames, RoundTrip) {
  for (int i = 0; i <= 3; ++i) {
    WeightingType w;
    ASSERT_TRUE(ParseWeighting(WeightingName(static_cast<WeightingType>(i)), &w));
    EXPECT_EQ(static_cast<int>(w), i);
  }
  for (int i = 0; i <= 5; ++i) {
    ScoringType s;
    ASSERT_TRUE(ParseScoring(ScoringName(static_cast<ScoringType>(i)), &s));
    EXPECT_EQ(static_cast<int>(s), i);
  }
  WeightingType w;
  ScoringType s;
  EXPECT_FALSE(ParseWeighting("tfidf", &w));
  EXPECT_FALSE(ParseScoring("L1", &s));
}

}  // namespace
}  // namespace rrslam
