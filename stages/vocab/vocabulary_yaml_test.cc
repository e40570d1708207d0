#include "stages/vocab/vocabulary_yaml.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cstring>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "common/atomic_file.h"
#include "common/binary_header.h"
#include "common/errors.h"
#include "common/testing.h"
#include "common/text.h"
#include "common/yaml_text.h"
#include "stages/vocab/vocab_test_util.h"
#include "stages/vocab/vocab_tool.h"

namespace rrslam {
namespace {

namespace fs = std::filesystem;
using testing::DescriptorText;

using testing::Bytes;

// A DBoW2 YAML vocabulary written by hand in the layout of DBoW2's save
// (OpenCV FileStorage's YAML): k=2, L=2, L1 scoring, TF-IDF weighting.
//   root -> {1, 2}; 1 -> {3, 4}; 2 -> {5, 6}; words: 3, 4, 5, 6.
// Nodes come in DBoW2's stack order (1, 2, 5, 6, 3, 4), not in id order.
std::string YamlNode(int id, int parent, const std::string& weight, const std::string& descriptor) {
  return "      - { nodeId:" + std::to_string(id) + ", parentId:" + std::to_string(parent) +
         ", weight:" + weight + ",\n          descriptor:\"" + descriptor + "\" }\n";
}

std::string YamlWord(int word, int node) {
  return "      - { wordId:" + std::to_string(word) + ", nodeId:" + std::to_string(node) + " }\n";
}

const std::string kHeader =
    "%YAML:1.0\n---\nvocabulary:\n   k: 2\n   L: 2\n   scoringType: 0\n   weightingType: 0\n";

std::string HandNodes() {
  return "   nodes:\n" + YamlNode(1, 0, "0.", DescriptorText(testing::Filled(1))) +
         YamlNode(2, 0, "0.", DescriptorText(testing::Filled(2))) +
         YamlNode(5, 2, "1.0000000000000000e-05", DescriptorText(testing::Filled(5))) +
         YamlNode(6, 2, "2.5000000000000000e+00", DescriptorText(testing::Filled(6))) +
         YamlNode(3, 1, "6.9314718055994529e-01", DescriptorText(testing::Filled(3))) +
         YamlNode(4, 1, "1.3862943611198906e+00", DescriptorText(testing::Filled(4)));
}

std::string HandWords() {
  return "   words:\n" + YamlWord(0, 3) + YamlWord(1, 4) + YamlWord(2, 5) + YamlWord(3, 6);
}

std::string HandYaml() { return kHeader + HandNodes() + HandWords(); }

// The same tree in DBoW2's text form (id order, weights with 6 digits).
std::string HandText() {
  auto line = [](int parent, int leaf, uint8_t fill, const std::string& weight) {
    return std::to_string(parent) + " " + std::to_string(leaf) + " " +
           DescriptorText(testing::Filled(fill)) + " " + weight + "\n";
  };
  return "2 2  0 0\n" + line(0, 0, 1, "0") + line(0, 0, 2, "0") + line(1, 1, 3, "0.693147") +
         line(1, 1, 4, "1.38629") + line(2, 1, 5, "1e-05") + line(2, 1, 6, "2.5");
}

void ExpectSameVocabulary(const VocabularyView& a, const VocabularyView& b) {
  EXPECT_EQ(a.info.k, b.info.k);
  EXPECT_EQ(a.info.levels, b.info.levels);
  EXPECT_EQ(a.info.weighting, b.info.weighting);
  EXPECT_EQ(a.info.scoring, b.info.scoring);
  ASSERT_EQ(a.info.num_nodes, b.info.num_nodes);
  EXPECT_EQ(a.info.num_words, b.info.num_words);
  for (uint64_t i = 0; i < a.info.num_nodes; ++i) {
    ASSERT_EQ(std::memcmp(a.descriptors[i].bytes, b.descriptors[i].bytes, 32), 0) << "node " << i;
    ASSERT_EQ(a.links[i], b.links[i]) << "node " << i;
    ASSERT_EQ(a.weights[i], b.weights[i]) << "node " << i;
  }
  EXPECT_EQ(VocabularyContentHash(a), VocabularyContentHash(b));
}

TEST(YamlVocabulary, ParsesHandWrittenDbow2Yaml) {
  const VocabularyData d = ParseYamlVocabulary(Bytes(HandYaml()), "hand.yml");
  EXPECT_EQ(d.info.k, 2);
  EXPECT_EQ(d.info.levels, 2);
  EXPECT_EQ(d.info.num_nodes, 7u);
  EXPECT_EQ(d.info.num_words, 4u);
  EXPECT_EQ(d.links()[0], InnerLink(1, 2));
  EXPECT_EQ(d.links()[2], InnerLink(5, 2));
  EXPECT_EQ(d.links()[3], LeafLink(0));
  EXPECT_EQ(d.links()[6], LeafLink(3));
  EXPECT_EQ(d.descriptors()[5].bytes[31], 5);
  EXPECT_EQ(d.weights()[3], 0.693147f);  // Rounded as DBoW2's text keeps it.
  EXPECT_EQ(d.weights()[6], 2.5f);
  // The same vocabulary as its DBoW2 text, and written as that text exactly.
  const VocabularyData text = ParseTextVocabulary(HandText(), "hand.txt");
  ExpectSameVocabulary(d.view(), text.view());
  EXPECT_EQ(FormatTextVocabulary(d.view(), "hand.yml"), HandText());
}

TEST(YamlVocabulary, DetectsFormatsByContent) {
  using F = VocabularyFileFormat;
  EXPECT_EQ(DetectVocabularyFileFormat(Bytes(HandYaml())), F::kDbow2Yaml);
  EXPECT_EQ(DetectVocabularyFileFormat(Bytes("\xEF\xBB\xBF" + HandYaml())), F::kDbow2Yaml);
  EXPECT_EQ(DetectVocabularyFileFormat(Bytes("\x1f\x8b\x08")), F::kDbow2Yaml);
  EXPECT_EQ(DetectVocabularyFileFormat(Bytes(HandText())), F::kDbow2Text);
  const VocabularyData d = ParseTextVocabulary(HandText(), "hand.txt");
  EXPECT_EQ(DetectVocabularyFileFormat(EncodeBinaryVocabulary(d.view())), F::kBinary);
  EXPECT_TRUE(HasYamlExtension("a/voc.yml"));
  EXPECT_TRUE(HasYamlExtension("voc.yaml"));
  EXPECT_TRUE(HasYamlExtension("voc.yml.gz"));
  EXPECT_TRUE(HasYamlExtension("voc.yaml.gz"));
  EXPECT_FALSE(HasYamlExtension("voc.txt"));
  EXPECT_FALSE(HasYamlExtension("voc.txt.gz"));
  EXPECT_FALSE(HasYamlExtension("yml"));
}

// Writes `v` as DBoW2's save does, through FileStorage itself (which
// compresses a name ending in .gz): the reader must take what OpenCV writes.
void WriteLikeDbow2(const fs::path& path, const VocabularyView& v) {
  cv::FileStorage f(path.string(), cv::FileStorage::WRITE);
  ASSERT_TRUE(f.isOpened()) << path;
  f << "vocabulary"
    << "{";
  f << "k" << v.info.k << "L" << v.info.levels;
  f << "scoringType" << static_cast<int>(v.info.scoring);
  f << "weightingType" << static_cast<int>(v.info.weighting);
  f << "nodes"
    << "[";
  std::vector<uint32_t> parents{0};
  while (!parents.empty()) {
    const uint32_t p = parents.back();
    parents.pop_back();
    for (uint32_t c = LinkIndex(v.links[p]); c < LinkIndex(v.links[p]) + LinkChildren(v.links[p]);
         ++c) {
      f << "{:"
        << "nodeId" << static_cast<int>(c) << "parentId" << static_cast<int>(p);
      f << "weight" << static_cast<double>(v.weights[c]);
      f << "descriptor" << DescriptorText(v.descriptors[c]) << "}";
      if (LinkChildren(v.links[c]) != 0) parents.push_back(c);
    }
  }
  f << "]"
    << "words"
    << "[";
  for (uint32_t i = 1; i < v.info.num_nodes; ++i) {
    if (LinkChildren(v.links[i]) == 0) {
      f << "{:"
        << "wordId" << static_cast<int>(LinkIndex(v.links[i])) << "nodeId" << static_cast<int>(i)
        << "}";
    }
  }
  f << "]"
    << "}";
}

TEST(YamlVocabulary, ReadsWhatFileStorageWritesPlainAndGzip) {
  const testing::TempDir dir;
  const VocabularyData original = testing::RandomVocabulary(5, 4, 11);
  // The text form: weights at 6 digits, as a YAML weight is read.
  const VocabularyData reference =
      ParseTextVocabulary(FormatTextVocabulary(original.view(), "r"), "r");
  for (const char* name : {"v.yml", "v.yml.gz", "v.yaml"}) {
    SCOPED_TRACE(name);
    WriteLikeDbow2(dir / name, original.view());
    VocabularyFileFormat format = VocabularyFileFormat::kBinary;
    const Vocabulary v = LoadVocabularyFile(dir / name, &format);
    EXPECT_EQ(format, VocabularyFileFormat::kDbow2Yaml);
    ExpectSameVocabulary(v.view(), reference.view());
    EXPECT_EQ(v.checksum(), Checksum64(Bytes(ReadFileToString(dir / name))));
  }
  // Compressed by OpenCV: the format is told by content, whatever the name.
  const std::string gz = ReadFileToString(dir / "v.yml.gz");
  ASSERT_EQ(static_cast<uint8_t>(gz[0]), 0x1f);
  WriteFileAtomically(dir / "gzip-without-suffix", gz);
  ExpectSameVocabulary(LoadVocabularyFile(dir / "gzip-without-suffix").view(), reference.view());
  // Vocabulary::Load (binary and text only) says how to use a YAML file.
  try {
    Vocabulary::Load(dir / "v.yml.gz");
    ADD_FAILURE() << "Vocabulary::Load accepted YAML";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("a DBoW2 YAML vocabulary; convert it first"),
              std::string::npos)
        << e.what();
  }
}

TEST(YamlVocabulary, WriterRoundTripsAndFileStorageReadsIt) {
  const testing::TempDir dir;
  const VocabularyData original = testing::RandomVocabulary(6, 4, 3);
  const VocabularyData reference =
      ParseTextVocabulary(FormatTextVocabulary(original.view(), "r"), "r");
  for (const char* name : {"w.yml", "w.yml.gz"}) {
    SCOPED_TRACE(name);
    WriteYamlVocabulary(dir / name, original.view(), "r");
    EXPECT_TRUE(testing::TemporaryLeftovers(dir).empty());
    ExpectSameVocabulary(LoadVocabularyFile(dir / name).view(), reference.view());
    // OpenCV reads it as DBoW2's load would.
    cv::FileStorage f((dir / name).string(), cv::FileStorage::READ);
    ASSERT_TRUE(f.isOpened());
    EXPECT_EQ(static_cast<int>(f["vocabulary"]["k"]), 6);
    EXPECT_EQ(f["vocabulary"]["nodes"].size(), original.info.num_nodes - 1);
    EXPECT_EQ(f["vocabulary"]["words"].size(), original.info.num_words);
  }
  // Our text (6-digit weights) -> YAML -> text is the identity.
  const std::string text = FormatTextVocabulary(reference.view(), "r");
  WriteYamlVocabulary(dir / "t.yml.gz", reference.view(), "r");
  EXPECT_EQ(FormatTextVocabulary(LoadVocabularyFile(dir / "t.yml.gz").view(), "t"), text);
}

void ExpectYamlError(const std::string& yaml, const std::string& fragment) {
  try {
    ParseYamlVocabulary(Bytes(yaml), "bad.yml");
    ADD_FAILURE() << "accepted; expected an error with: " << fragment;
  } catch (const DataError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(fragment), std::string::npos) << message;
    EXPECT_EQ(message.rfind("bad.yml: ", 0), 0u) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

// HandYaml() with the first occurrence of `from` replaced by `to`.
std::string Edited(const std::string& from, const std::string& to) {
  std::string yaml = HandYaml();
  const size_t at = yaml.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) yaml.replace(at, from.size(), to);
  return yaml;
}

TEST(YamlVocabulary, RejectsMissingKeysAndBadHeaders) {
  EXPECT_NO_THROW(ParseYamlVocabulary(Bytes(HandYaml()), "ok.yml"));
  ExpectYamlError("", "empty file");
  ExpectYamlError("%YAML:1.0\n---\nvocabulary: [ 1, {\n", "not a valid YAML file");
  // The parser's line: a node cut short in the middle of its descriptor.
  const std::string yaml = HandYaml();
  ExpectYamlError(yaml.substr(0, yaml.find("descriptor:", yaml.find("nodeId:6")) + 16),
                  "bad.yml: not a valid YAML file: line 16: ");
  ExpectYamlError("%YAML:1.0\n---\nvoc:\n   k: 2\n", "no 'vocabulary' key");
  ExpectYamlError("%YAML:1.0\n---\nvocabulary: 3\n", "'vocabulary' is not a map");
  ExpectYamlError(Edited("   k: 2\n", ""), "vocabulary: k is missing");
  ExpectYamlError(Edited("   L: 2\n", ""), "vocabulary: L is missing");
  ExpectYamlError(Edited("   scoringType: 0\n", ""), "vocabulary: scoringType is missing");
  ExpectYamlError(Edited("   weightingType: 0\n", ""), "vocabulary: weightingType is missing");
  ExpectYamlError(Edited("k: 2", "k: 2.5"), "vocabulary: k is not an integer");
  ExpectYamlError(Edited("k: 2", "k: 40"), "vocabulary: k = 40 is not in [1, 31]");
  ExpectYamlError(Edited("L: 2", "L: 0"), "vocabulary: L = 0 is not in [1, 255]");
  ExpectYamlError(Edited("scoringType: 0", "scoringType: 6"), "scoringType = 6 is not in [0, 5]");
  ExpectYamlError(Edited("weightingType: 0", "weightingType: 4"),
                  "weightingType = 4 is not in [0, 3]");
  ExpectYamlError(kHeader + HandWords(), "vocabulary: nodes is missing");
  ExpectYamlError(kHeader + "   nodes: 5\n" + HandWords(), "vocabulary: nodes is not a list");
  ExpectYamlError(kHeader + "   nodes: []\n" + HandWords(), "no node besides the root");
  ExpectYamlError(kHeader + HandNodes(), "vocabulary: words is missing");
  ExpectYamlError(kHeader + HandNodes() + "   words: 7\n", "vocabulary: words is not a list");
}

// OpenCV's YAML parser (4.6) never returns on some text that is not one map
// at column 0 (common/yaml_text.h); a DBoW2 YAML vocabulary is such a map,
// so other shapes are refused before OpenCV sees them, plain or gzip.
TEST(YamlVocabulary, RejectsShapesOpenCvWouldLoopOn) {
  ExpectYamlError("%YAML:1.0\n----=\n----\n\n", "line 2: '----=' starts with '-'");
  ExpectYamlError("%YAML:1.0\n -%\n:#:-\n\n", "line 2: ' -%' is indented");
  ExpectYamlError(HandYaml() + "---\nvocabulary: 1\n", "'---' starts with '-'");
  ExpectYamlError(HandYaml() + "...\n", "'...' ends the document");
  ExpectYamlError("%YAML:1.0\n---\n   vocabulary:\n", "is indented");
  // An empty key in a flow map: OpenCV's parser throws std::length_error
  // (found by vocab_yaml_fuzzer); a DataError like any syntax error.
  ExpectYamlError(Edited("{ nodeId:1,", "{ :odeId:1,"), "bad.yml: not a valid YAML file (");
  // Gzip-compressed: the check runs on the inflated text.
  const testing::TempDir dir;
  const VocabularyData hand = ParseYamlVocabulary(Bytes(HandYaml()), "ok.yml");
  WriteYamlVocabulary(dir / "ok.yml.gz", hand.view(), "ok");
  const std::string gz = ReadFileToString(dir / "ok.yml.gz");
  EXPECT_NO_THROW(ParseYamlVocabulary(Bytes(gz), "ok.yml.gz"));
  try {
    ParseYamlVocabulary(Bytes(gz + gz), "bad.yml.gz");  // Two gzip members: two documents.
    ADD_FAILURE() << "accepted two documents";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.yml.gz: line "), std::string::npos) << e.what();
  }
}

TEST(YamlVocabulary, RejectsBadNodesNamingTheNode) {
  // Ids.
  ExpectYamlError(Edited("nodeId:6,", "nodeId:7,"), "nodes entry 3: nodeId = 7 is not in [1, 6]");
  ExpectYamlError(Edited("nodeId:6,", "nodeId:5,"),
                  "nodes entry 3 (nodeId 5): nodeId 5 is listed twice (also entry 2)");
  ExpectYamlError(Edited("{ nodeId:6,", "{ "), "nodes entry 3: nodeId is missing");
  ExpectYamlError(Edited("nodeId:6,", "nodeId:\"6\","), "nodes entry 3: nodeId is not an integer");
  // Parents.
  ExpectYamlError(Edited("parentId:2,", "parentId:9,"),
                  "nodes entry 2 (nodeId 5): parentId = 9 is not in [0, 6]");
  ExpectYamlError(Edited("nodeId:2, parentId:0", "nodeId:2, parentId:5"),
                  "nodes entry 1 (nodeId 2): node 2 has parent 5; a parent must come before");
  // 0 -> {1, 3}, 1 -> {2}: siblings 1 and 3 are not consecutive ids.
  ExpectYamlError(kHeader + "   nodes:\n" +
                      YamlNode(1, 0, "0.", DescriptorText(testing::Filled(1))) +
                      YamlNode(3, 0, "1.", DescriptorText(testing::Filled(3))) +
                      YamlNode(2, 1, "1.", DescriptorText(testing::Filled(2))) + "   words:\n" +
                      YamlWord(0, 2) + YamlWord(1, 3),
                  "bad.yml: node 3: the children of node 0 are not consecutive: node 2 between "
                  "them has parent 1");
  ExpectYamlError(Edited("parentId:2,", "parentId:-1,"), "parentId = -1 is not in [0, 6]");
  // Siblings listed out of id order (DBoW2 lists children in id order).
  std::string swapped = kHeader + "   nodes:\n" +
                        YamlNode(2, 0, "0.", DescriptorText(testing::Filled(2))) +
                        YamlNode(1, 0, "0.", DescriptorText(testing::Filled(1)));
  ExpectYamlError(swapped + "   words:\n" + YamlWord(0, 1) + YamlWord(1, 2),
                  "nodes entry 1 (nodeId 1): children of node 0 are not listed in id order");
  // Weights.
  ExpectYamlError(Edited("weight:2.5000000000000000e+00,", ""),
                  "nodes entry 3 (nodeId 6): weight is missing");
  ExpectYamlError(Edited("2.5000000000000000e+00", ".Nan"),
                  "nodes entry 3 (nodeId 6): weight is not finite");
  ExpectYamlError(Edited("2.5000000000000000e+00", "1.0e+39"),
                  "nodes entry 3 (nodeId 6): weight 1e+39 is outside the float32 range");
  ExpectYamlError(Edited("2.5000000000000000e+00", "\"heavy\""),
                  "nodes entry 3 (nodeId 6): weight is not a number");
  // Descriptors.
  const std::string six = DescriptorText(testing::Filled(6));
  ExpectYamlError(Edited(six, six.substr(2)),
                  "nodes entry 3 (nodeId 6): descriptor has 31 bytes; an ORB descriptor has 32");
  ExpectYamlError(Edited(six, six + "6 "), "nodes entry 3 (nodeId 6): descriptor has more than 32");
  ExpectYamlError(Edited(six, "256 " + six.substr(2)),
                  "nodes entry 3 (nodeId 6): descriptor byte b0 = 256 is not in [0, 255]");
  ExpectYamlError(Edited(six, "6 x7 " + six.substr(4)),
                  "nodes entry 3 (nodeId 6): descriptor byte b1 'x7' is not a decimal number");
  ExpectYamlError(Edited(six, "6 -7 " + six.substr(4)), "descriptor byte b1 '-7'");
  ExpectYamlError(Edited("descriptor:\"" + six + "\"", "descriptor:6"),
                  "nodes entry 3 (nodeId 6): descriptor is not a string");
  ExpectYamlError(Edited(",\n          descriptor:\"" + six + "\"", ""),
                  "nodes entry 3 (nodeId 6): descriptor is missing");
  // A BRIEF vocabulary of old DBoW2 versions writes bit strings.
  ExpectYamlError(Edited(six, std::string(256, '1')),
                  "nodes entry 3 (nodeId 6): descriptor byte b0 '111");
}

TEST(YamlVocabulary, RejectsBadWords) {
  ExpectYamlError(Edited(YamlWord(3, 6), ""),
                  "vocabulary: words lists 3 words but the tree has 4 leaves");
  ExpectYamlError(Edited(YamlWord(3, 6), YamlWord(3, 2)),
                  "words entry 3 (wordId 3): node 2 is not a leaf (it has 2 children)");
  ExpectYamlError(Edited(YamlWord(3, 6), YamlWord(2, 6)),
                  "words entry 3 (wordId 2): wordId 2 is listed twice");
  // Words numbered otherwise than in node order.
  std::string swapped = Edited(YamlWord(0, 3), YamlWord(0, 4));
  swapped.replace(swapped.find(YamlWord(1, 4)), YamlWord(1, 4).size(), YamlWord(1, 3));
  ExpectYamlError(swapped,
                  "words entry 0 (wordId 0): word 0 is node 4, which is leaf 1 in node "
                  "order; rrslam numbers words in node order");
  ExpectYamlError(Edited(YamlWord(3, 6), YamlWord(4, 6)), "wordId = 4 is not in [0, 3]");
  ExpectYamlError(Edited(YamlWord(3, 6), "      - { wordId:3 }\n"),
                  "words entry 3 (wordId 3): nodeId is missing");
}

TEST(YamlVocabulary, RejectsCorruptGzipAndNonYamlNamedYml) {
  const testing::TempDir dir;
  WriteYamlVocabulary(dir / "v.yml.gz", ParseTextVocabulary(HandText(), "h").view(), "h");
  const std::string gz = ReadFileToString(dir / "v.yml.gz");
  ExpectYamlError(gz.substr(0, gz.size() / 2), "corrupt or truncated gzip data");
  std::string flipped = gz;
  flipped[gz.size() / 2] ^= 0x55;
  ExpectYamlError(flipped, "gzip");
  // A file named .yml gets the YAML reader's message whatever it holds.
  testing::WriteTextFile(dir / "text.yml", "hello\n");
  try {
    LoadVocabularyFile(dir / "text.yml");
    ADD_FAILURE() << "accepted";
  } catch (const DataError& e) {
    EXPECT_EQ(std::string(e.what()).rfind((dir / "text.yml").string() + ": ", 0), 0u) << e.what();
  }
  EXPECT_THROW(LoadVocabularyFile(dir / "missing.yml"), NoInputError);
}

// One gzip member (level 9) of `text`.
std::string GzipMember(const std::string& text) {
  z_stream z{};
  EXPECT_EQ(deflateInit2(&z, 9, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::string out(deflateBound(&z, static_cast<uLong>(text.size())), '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(text.data()));
  z.avail_in = static_cast<uInt>(text.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  EXPECT_EQ(deflate(&z, Z_FINISH), Z_STREAM_END);
  out.resize(z.total_out);
  deflateEnd(&z);
  return out;
}

// A gzip file inflating past kMaxYamlVocabularyBytes (1 GiB) is a bomb: it
// is refused while it inflates, naming the file and the cap, and nothing is
// allocated for its content (it ran out of memory). The cap is lowered to
// 256 MiB here (inflating 1 GiB of spaces takes seconds).
TEST(YamlVocabulary, RefusesGzipInflatingPastTheCap) {
  EXPECT_EQ(kMaxYamlVocabularyBytes, uint64_t{1} << 30);
  // 257 members of 1 MiB of spaces: 270 kB of file, 257 MiB of content.
  std::string bomb;
  const std::string member = GzipMember(std::string(size_t{1} << 20, ' '));
  for (int i = 0; i < 257; ++i) bomb += member;
  ASSERT_LT(bomb.size(), size_t{1} << 20);
  SetMaxYamlVocabularyBytesForTesting(uint64_t{256} << 20);
  const bool measured = testing::ResetPeakResident();
  const long before = testing::PeakResidentKb();
  ExpectYamlError(bomb,
                  "bad.yml: decompresses to more than 256 MiB, more than a DBoW2 YAML "
                  "vocabulary can be");
  if (measured) {
    EXPECT_LT(testing::PeakResidentKb() - before, 64 * 1024) << "kB";
  }
  SetMaxYamlVocabularyBytesForTesting(0);
}

// At the cap a vocabulary reads; a byte above it, plain or gzip, it is
// refused (the cap lowered through the testing hook).
TEST(YamlVocabulary, CapAppliesToPlainAndGzipText) {
  const VocabularyData hand = ParseTextVocabulary(HandText(), "h");
  const std::string text = FormatYamlVocabulary(hand.view(), "h");
  const std::string gz = GzipMember(text);
  SetMaxYamlVocabularyBytesForTesting(text.size());
  EXPECT_NO_THROW(ParseYamlVocabulary(Bytes(gz), "v.yml.gz"));
  EXPECT_NO_THROW(ParseYamlVocabulary(Bytes(text), "v.yml"));
  SetMaxYamlVocabularyBytesForTesting(text.size() - 1);
  ExpectYamlError(gz, "decompresses to more than");
  ExpectYamlError(text, std::to_string(text.size()) + " bytes of YAML, more than");
  SetMaxYamlVocabularyBytesForTesting(0);
  EXPECT_NO_THROW(ParseYamlVocabulary(Bytes(gz), "v.yml.gz"));
}

// --- The real vocabularies of ../shared/data/vocab ---------------------------

struct RealVocabulary {
  const char* name;
  int k, levels;
  uint64_t nodes, words;  // Nodes as the data README counts them (no root).
};

TEST(YamlVocabulary, RealDbow2YamlAgreesWithItsTextNodeForNode) {
  RRSLAM_REQUIRE_SHARED_DATA(data);
  for (const RealVocabulary& r : {RealVocabulary{"lema18_fr1xyz_orb_k9L4", 9, 4, 7380, 6561},
                                  RealVocabulary{"ytkn_orb_k9L3", 9, 3, 819, 729}}) {
    SCOPED_TRACE(r.name);
    const fs::path yaml = data / "vocab" / (std::string(r.name) + ".yml.gz");
    const fs::path text = data / "vocab" / (std::string(r.name) + ".txt");
    VocabularyFileFormat yaml_format, text_format;
    const Vocabulary from_yaml = LoadVocabularyFile(yaml, &yaml_format);
    const Vocabulary from_text = LoadVocabularyFile(text, &text_format);
    EXPECT_EQ(yaml_format, VocabularyFileFormat::kDbow2Yaml);
    EXPECT_EQ(text_format, VocabularyFileFormat::kDbow2Text);
    EXPECT_EQ(from_yaml.k(), r.k);
    EXPECT_EQ(from_yaml.levels(), r.levels);
    EXPECT_EQ(from_yaml.weighting(), WeightingType::kTfIdf);
    EXPECT_EQ(from_yaml.scoring(), ScoringType::kL1);
    EXPECT_EQ(from_yaml.num_nodes(), r.nodes + 1);
    EXPECT_EQ(from_yaml.num_words(), r.words);
    // Node for node: descriptors, links (so parents and word ids), weights.
    ExpectSameVocabulary(from_yaml.view(), from_text.view());
    EXPECT_EQ(VocabularyParents(from_yaml.view(), "yaml"),
              VocabularyParents(from_text.view(), "text"));
    EXPECT_EQ(from_yaml.content_hash(), from_text.content_hash());
    // Written as text, the YAML gives DBoW2's own text byte for byte.
    EXPECT_TRUE(FormatTextVocabulary(from_yaml.view(), r.name) == ReadFileToString(text));

    // Through the tool: both convert to binaries of the same tree.
    const testing::TempDir dir;
    RunVocabConvert({yaml, dir / "from_yaml.rrv"});
    RunVocabConvert({text, dir / "from_text.rrv"});
    const Vocabulary a = Vocabulary::Load(dir / "from_yaml.rrv");
    const Vocabulary b = Vocabulary::Load(dir / "from_text.rrv");
    ExpectSameVocabulary(a.view(), b.view());
    const nlohmann::json metadata = nlohmann::json::parse(a.view().metadata);
    EXPECT_EQ(metadata["source_format"], "dbow2-yaml");
    EXPECT_EQ(metadata["converted_from"], std::string(r.name) + ".yml.gz");
    const std::string info = RunVocabInfo({yaml, false});
    EXPECT_NE(info.find("format: DBoW2 YAML"), std::string::npos) << info;
    EXPECT_NE(info.find("tree: " + Hex64(from_text.content_hash())), std::string::npos) << info;
  }
}

TEST(YamlVocabulary, TruncatedRealOrbvocIsRefusedWithLineAndNode) {
  RRSLAM_REQUIRE_SHARED_DATA(data);
  const fs::path file = data / "vocab" / "ORBvoc_prefix19419_qiaozhijian.txt";
  const testing::TempDir dir;
  try {
    RunVocabConvert({file, dir / "orbvoc.rrv"});
    ADD_FAILURE() << "accepted a truncated ORBvoc.txt";
  } catch (const DataError& e) {
    // DBoW2 numbers subtrees depth first: node 2's children would come after
    // the whole subtree of node 1, which the file does not reach.
    const std::string message = e.what();
    EXPECT_EQ(message, file.string() +
                           ": line 3: node 2 is marked isLeaf = 0 but has 0 children (24 nodes "
                           "marked isLeaf = 0 have none; the last node is node 19419 on line "
                           "19420: is the file truncated?)");
  }
  EXPECT_FALSE(fs::exists(dir / "orbvoc.rrv"));
  EXPECT_TRUE(testing::TemporaryLeftovers(dir).empty());
}

// Found in review (issue 36): a vocabulary nested tens of thousands of
// levels deep overflowed the stack in OpenCV's recursive YAML parser (exit
// 139). ParseYamlText refuses it first (kMaxYamlNesting), on the inflated
// text of a .yml.gz as on plain text.
TEST(YamlVocabulary, RejectsDeepNestingPlainAndGzip) {
  const size_t n = 100000;
  std::string maps;
  for (size_t i = 0; i < n; ++i) maps += "{a: ";
  const std::string fragment =
      "line 8: YAML nested deeper than " + std::to_string(kMaxYamlNesting) + " levels";
  const std::string flow =
      kHeader + "   nodes: " + std::string(n, '[') + std::string(n, ']') + "\n";
  ExpectYamlError(flow, fragment);
  ExpectYamlError(kHeader + "   nodes: " + maps + "1" + std::string(n, '}') + "\n", fragment);
  try {
    ParseYamlVocabulary(Bytes(GzipMember(flow)), "deep.yml.gz");
    ADD_FAILURE() << "accepted";
  } catch (const DataError& e) {
    EXPECT_EQ(std::string(e.what()), "deep.yml.gz: " + fragment);
  }
}

}  // namespace
}  // namespace rrslam
