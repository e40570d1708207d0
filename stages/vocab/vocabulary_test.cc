#include "stages/vocab/vocabulary.h"

#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <map>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/testing.h"
#include "common/text.h"
#include "stages/vocab/vocab_test_util.h"
#include "stages/vocab/vocabulary_format.h"

namespace rrslam {
namespace {

using testing::Filled;

OrbDescriptor WithByte(OrbDescriptor d, int index, uint8_t value) {
  d.bytes[index] = value;
  return d;
}

// k = 3, L = 2:  root -> {1, 2, 3};  1 -> {4, 5};  2 is a leaf at level 1;
// 3 -> {6, 7}.  Words in node order: 2 = w0, 4 = w1, 5 = w2, 6 = w3, 7 = w4.
// Word weights: w0 0.5, w1 1, w2 2, w3 0 (stopped), w4 4.
struct Toy {
  OrbDescriptor d[8];
  Toy() {
    d[1] = Filled(0x00);
    d[2] = Filled(0xff);
    d[3] = Filled(0xf0);
    d[4] = WithByte(Filled(0x00), 31, 0x01);  // 1 bit from node 1.
    d[5] = WithByte(Filled(0x00), 31, 0x0e);  // 3 bits from node 1.
    d[6] = WithByte(Filled(0xf0), 0, 0xf1);   // 1 bit from node 3.
    d[7] = WithByte(Filled(0xf0), 0, 0xf7);   // 3 bits from node 3.
  }
  Vocabulary Make(WeightingType weighting = WeightingType::kTfIdf,
                  ScoringType scoring = ScoringType::kL1) const {
    const std::vector<uint32_t> parents{0, 0, 0, 0, 1, 1, 3, 3};
    const std::vector<float> weights{0, 0, 0.5f, 0, 1, 2, 0, 4};
    return Vocabulary::FromData(
        testing::MakeVocabulary(3, 2, parents, {d, d + 8}, weights, weighting, scoring), "toy");
  }
  // Image A: two descriptors of word w2, one of w1, one of w0, one of the
  // stopped word w3.
  std::vector<OrbDescriptor> ImageA() const { return {d[5], d[5], d[4], d[2], d[6]}; }
};

std::map<WordId, double> AsMap(const BowVector& v) {
  std::map<WordId, double> m;
  for (const auto& [w, x] : v.entries) m[w] = x;
  return m;
}

TEST(Vocabulary, TransformsSingleDescriptors) {
  const Toy toy;
  const Vocabulary voc = toy.Make();
  EXPECT_EQ(voc.num_nodes(), 8u);
  EXPECT_EQ(voc.num_words(), 5u);
  EXPECT_EQ(voc.Transform(toy.d[2]), 0u);
  EXPECT_EQ(voc.Transform(toy.d[4]), 1u);
  EXPECT_EQ(voc.Transform(toy.d[5]), 2u);
  EXPECT_EQ(voc.Transform(toy.d[6]), 3u);
  EXPECT_EQ(voc.Transform(toy.d[7]), 4u);
  EXPECT_EQ(voc.Transform(WithByte(toy.d[7], 5, 0xf1)), 4u);
}

TEST(Vocabulary, TfIdfL1BowVector) {
  const Toy toy;
  BowVector bow;
  toy.Make().Transform(toy.ImageA(), &bow);
  // Raw tf-idf sums: w0 0.5, w1 1, w2 2 + 2 = 4 (w3 is stopped); L1 norm 5.5.
  ASSERT_EQ(bow.size(), 3u);
  const auto m = AsMap(bow);
  EXPECT_NEAR(m.at(0), 0.5 / 5.5, 1e-12);
  EXPECT_NEAR(m.at(1), 1.0 / 5.5, 1e-12);
  EXPECT_NEAR(m.at(2), 4.0 / 5.5, 1e-12);
  EXPECT_TRUE(std::is_sorted(bow.entries.begin(), bow.entries.end()));
}

TEST(Vocabulary, WeightingsAndNormalizations) {
  const Toy toy;
  BowVector bow;
  // idf: each word counted once; L1 norm 3.5.
  toy.Make(WeightingType::kIdf).Transform(toy.ImageA(), &bow);
  EXPECT_NEAR(AsMap(bow).at(2), 2.0 / 3.5, 1e-12);
  // L2 scoring normalizes by the L2 norm sqrt(0.25 + 1 + 16).
  toy.Make(WeightingType::kTfIdf, ScoringType::kL2).Transform(toy.ImageA(), &bow);
  EXPECT_NEAR(AsMap(bow).at(2), 4.0 / std::sqrt(17.25), 1e-12);
  // Dot product does not normalize; DBoW2 divides tf values by the number of
  // distinct words.
  toy.Make(WeightingType::kTfIdf, ScoringType::kDotProduct).Transform(toy.ImageA(), &bow);
  EXPECT_NEAR(AsMap(bow).at(2), 4.0 / 3.0, 1e-12);
  toy.Make(WeightingType::kIdf, ScoringType::kDotProduct).Transform(toy.ImageA(), &bow);
  EXPECT_NEAR(AsMap(bow).at(2), 2.0, 1e-12);
}

TEST(Vocabulary, FeatureVectorGroupsAsDbow2) {
  const Toy toy;
  const Vocabulary voc = toy.Make();
  BowVector bow;
  FeatureVector fv;
  using Groups = std::vector<std::pair<NodeId, std::vector<uint32_t>>>;
  // levels_up 1: level 1 nodes; the stopped descriptor (index 4) is left out.
  voc.Transform(toy.ImageA(), &bow, &fv, 1);
  EXPECT_EQ(fv.entries, (Groups{{1, {0, 1, 2}}, {2, {3}}}));
  // levels_up 0: the words' nodes; word w0 (node 2) is a level-1 leaf.
  voc.Transform(toy.ImageA(), &bow, &fv, 0);
  EXPECT_EQ(fv.entries, (Groups{{2, {3}}, {4, {2}}, {5, {0, 1}}}));
  // levels_up >= L: everything under the root.
  for (int up : {2, 4}) {
    voc.Transform(toy.ImageA(), &bow, &fv, up);
    EXPECT_EQ(fv.entries, (Groups{{0, {0, 1, 2, 3}}}));
  }
  // Empty input.
  voc.Transform({}, &bow, &fv);
  EXPECT_TRUE(bow.empty());
  EXPECT_TRUE(fv.empty());
}

BowVector Bow(std::initializer_list<std::pair<WordId, WordValue>> entries) {
  BowVector v;
  v.entries.assign(entries.begin(), entries.end());
  return v;
}

TEST(Vocabulary, L1ScoreOnHandComputedVectors) {
  const Vocabulary voc = Toy().Make();
  const BowVector v = Bow({{1, 0.5}, {2, 0.5}});
  const BowVector w = Bow({{2, 0.5}, {3, 0.5}});
  const BowVector x = Bow({{4, 0.25}, {7, 0.75}});
  // 1 - 1/2 (|0.5 - 0| + |0.5 - 0.5| + |0 - 0.5|) = 0.5.
  EXPECT_NEAR(voc.Score(v, w), 0.5, 1e-12);
  EXPECT_NEAR(voc.Score(w, v), 0.5, 1e-12);
  EXPECT_NEAR(voc.Score(v, v), 1.0, 1e-12);
  EXPECT_NEAR(voc.Score(v, x), 0.0, 1e-12);
  EXPECT_NEAR(voc.Score(Bow({{1, 0.2}, {5, 0.8}}), Bow({{1, 0.6}, {5, 0.4}})), 0.6, 1e-12);
  // Identical images score 1 through Transform too.
  const Toy toy;
  BowVector a, b;
  voc.Transform(toy.ImageA(), &a);
  voc.Transform(toy.ImageA(), &b);
  EXPECT_NEAR(voc.Score(a, b), 1.0, 1e-12);
}

TEST(Vocabulary, OtherScorings) {
  const Toy toy;
  const double h = std::sqrt(0.5);
  const BowVector v1 = Bow({{1, 0.5}, {2, 0.5}}), w1 = Bow({{2, 0.5}, {3, 0.5}});
  EXPECT_NEAR(toy.Make(WeightingType::kTfIdf, ScoringType::kL2)
                  .Score(Bow({{1, h}, {2, h}}), Bow({{2, h}, {3, h}})),
              1.0 - std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(toy.Make(WeightingType::kTfIdf, ScoringType::kL2).Score(v1, v1), 1 - std::sqrt(0.5),
              1e-12);
  EXPECT_NEAR(toy.Make(WeightingType::kTfIdf, ScoringType::kChiSquare).Score(v1, w1), 0.5, 1e-12);
  EXPECT_NEAR(toy.Make(WeightingType::kTfIdf, ScoringType::kChiSquare).Score(v1, v1), 1.0, 1e-12);
  EXPECT_NEAR(toy.Make(WeightingType::kTfIdf, ScoringType::kBhattacharyya).Score(v1, w1), 0.5,
              1e-12);
  EXPECT_NEAR(toy.Make(WeightingType::kTfIdf, ScoringType::kDotProduct).Score(v1, w1), 0.25, 1e-12);
  const Vocabulary kl = toy.Make(WeightingType::kTfIdf, ScoringType::kKL);
  EXPECT_NEAR(kl.Score(v1, v1), 0.0, 1e-12);
  EXPECT_NEAR(kl.Score(v1, w1), 0.5 * (std::log(0.5) - std::log(DBL_EPSILON)), 1e-9);
}

TEST(Vocabulary, BatchedTransformMatchesSingleDescents) {
  const VocabularyData data = testing::RandomVocabulary(10, 6, 21, 0.85, 100000);
  const std::vector<uint32_t> parents = VocabularyParents(data.view(), "r");
  std::vector<int> level(parents.size(), 0);
  for (size_t i = 1; i < parents.size(); ++i) level[i] = level[parents[i]] + 1;
  const Vocabulary voc =
      Vocabulary::FromData(testing::RandomVocabulary(10, 6, 21, 0.85, 100000), "r");
  std::mt19937_64 rng(4);
  std::vector<OrbDescriptor> q(1003);
  for (auto& d : q) d = testing::RandomOrbDescriptor(rng);
  const int levels_up = 2;
  BowVector bow;
  FeatureVector fv;
  voc.Transform(q, &bow, &fv, levels_up);
  std::map<WordId, double> expected_bow;
  std::map<NodeId, std::vector<uint32_t>> expected_fv;
  double sum = 0;
  for (uint32_t i = 0; i < q.size(); ++i) {
    const uint32_t leaf = DescendToLeaf(data.view(), q[i]);
    EXPECT_EQ(voc.Transform(q[i]), LinkIndex(data.links()[leaf]));
    const double w = data.weights()[leaf];
    expected_bow[LinkIndex(data.links()[leaf])] += w;
    sum += w;
    uint32_t group = leaf;
    while (level[group] > 6 - levels_up) group = parents[group];
    expected_fv[group].push_back(i);
  }
  ASSERT_EQ(bow.size(), expected_bow.size());
  for (const auto& [word, value] : bow.entries) EXPECT_NEAR(value, expected_bow[word] / sum, 1e-12);
  ASSERT_EQ(fv.size(), expected_fv.size());
  for (const auto& [node, indices] : fv.entries) EXPECT_EQ(indices, expected_fv[node]);
}

TEST(Vocabulary, LoadsBothFormatsFromFilesAndMemory) {
  testing::TempDir dir;
  VocabularyData data = testing::RandomVocabulary(6, 4, 2);
  data.metadata = "{}";
  WriteBinaryVocabulary(dir / "v.rrv", data.view());
  WriteTextVocabulary(dir / "v.txt", data.view(), "v");
  const Vocabulary binary = Vocabulary::Load(dir / "v.rrv");
  const Vocabulary text = Vocabulary::Load(dir / "v.txt");
  EXPECT_TRUE(binary.is_binary());
  EXPECT_FALSE(text.is_binary());
  for (const Vocabulary* v : {&binary, &text}) {
    EXPECT_EQ(v->k(), 6);
    EXPECT_EQ(v->levels(), 4);
    EXPECT_EQ(v->weighting(), WeightingType::kTfIdf);
    EXPECT_EQ(v->scoring(), ScoringType::kL1);
    EXPECT_EQ(v->num_nodes(), data.info.num_nodes);
    EXPECT_EQ(v->num_words(), data.info.num_words);
    // Descriptors and links exactly; weights to the 6 digits of the text.
    EXPECT_EQ(0, std::memcmp(v->view().descriptors, data.view().descriptors, 36 * v->num_nodes()));
    for (size_t i = 0; i < v->num_nodes(); ++i) {
      EXPECT_NEAR(v->view().weights[i], data.weights()[i], 1e-5 * data.weights()[i]);
    }
  }
  EXPECT_EQ(binary.Identity(), "v.rrv k=6 L=4 words=" + std::to_string(data.info.num_words) +
                                   " tree=" + Hex64(binary.content_hash()));
  // From memory, at any alignment of the source bytes.
  const std::string bytes = ReadFileToString(dir / "v.rrv");
  std::vector<uint8_t> shifted(bytes.size() + 1);
  std::memcpy(shifted.data() + 1, bytes.data(), bytes.size());
  const Vocabulary from_memory =
      Vocabulary::FromBytes({shifted.data() + 1, bytes.size()}, "memory");
  EXPECT_EQ(from_memory.checksum(), binary.checksum());
  // A moved-from vocabulary is empty.
  Vocabulary moved = Vocabulary::Load(dir / "v.txt");
  const Vocabulary taken = std::move(moved);
  EXPECT_EQ(taken.num_words(), data.info.num_words);
  EXPECT_TRUE(moved.empty());  // NOLINT(bugprone-use-after-move)
}

// The tree's identity does not depend on the file: its name, its format
// (text converted to binary) or its metadata (training paths). Another tree,
// or the same tree with one weight changed, has another identity.
TEST(Vocabulary, ContentHashIdentifiesTheTreeNotTheFile) {
  testing::TempDir dir;
  VocabularyData data = testing::RandomVocabulary(6, 4, 2);
  data.metadata = R"({"training": "/data/a"})";
  WriteTextVocabulary(dir / "a.txt", data.view(), "a");
  const Vocabulary text = Vocabulary::Load(dir / "a.txt");
  VocabularyView converted = text.view();
  converted.metadata = R"({"training": "/elsewhere/b", "converted_from": "a.txt"})";
  WriteBinaryVocabulary(dir / "b.rrv", converted);
  const Vocabulary binary = Vocabulary::Load(dir / "b.rrv");
  EXPECT_NE(text.checksum(), binary.checksum());
  EXPECT_EQ(text.content_hash(), binary.content_hash());
  EXPECT_EQ(text.content_hash(), VocabularyContentHash(text.view()));

  // The other way: a binary tree with full-precision weights, converted to
  // text (six significant digits) and read back.
  VocabularyData precise = testing::RandomVocabulary(6, 4, 5);
  for (size_t i = 0; i < precise.info.num_nodes; ++i) {
    precise.weights()[i] = 0.1234567f + 1e-3f * static_cast<float>(i) / 7.0f;
  }
  WriteBinaryVocabulary(dir / "c.rrv", precise.view());
  const Vocabulary precise_binary = Vocabulary::Load(dir / "c.rrv");
  WriteTextVocabulary(dir / "c.txt", precise_binary.view(), "c");
  const Vocabulary precise_text = Vocabulary::Load(dir / "c.txt");
  EXPECT_NE(precise_text.view().weights[5], precise_binary.view().weights[5]);  // Rounded.
  EXPECT_EQ(precise_text.content_hash(), precise_binary.content_hash());

  const Vocabulary other = Vocabulary::FromData(testing::RandomVocabulary(6, 4, 3), "other");
  EXPECT_NE(other.content_hash(), text.content_hash());
  VocabularyData changed = testing::RandomVocabulary(6, 4, 2);
  VocabularyData same = testing::RandomVocabulary(6, 4, 2);
  changed.weights()[changed.info.num_nodes - 1] += 0.001f;  // Within the six digits.
  EXPECT_NE(Vocabulary::FromData(std::move(changed), "c").content_hash(),
            Vocabulary::FromData(std::move(same), "s").content_hash());
}

// A binary vocabulary padded far beyond the size its header gives (256 MB,
// sparse) is refused from its header, before the mapping that pre-faults
// every page reads it all.
TEST(Vocabulary, PaddedBinaryFileIsRefusedBeforeItsPagesAreRead) {
  testing::TempDir dir;
  WriteBinaryVocabulary(dir / "v.rrv", testing::RandomVocabulary(6, 2, 3).view());
  std::filesystem::resize_file(dir / "v.rrv", uint64_t{256} << 20);
  if (!testing::ResetPeakResident()) GTEST_SKIP() << "cannot reset the peak resident size";
  const long before = testing::PeakResidentKb();
  try {
    Vocabulary::Load(dir / "v.rrv");
    ADD_FAILURE() << "no error";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("v.rrv: truncated or padded"), std::string::npos)
        << e.what();
  }
  EXPECT_LT(testing::PeakResidentKb() - before, 64 * 1024) << "kB read into memory";
}

TEST(Vocabulary, LoadErrorsNameTheFile) {
  testing::TempDir dir;
  EXPECT_THROW(Vocabulary::Load(dir / "missing.rrv"), NoInputError);
  testing::WriteTextFile(dir / "empty.txt", "");
  testing::WriteTextFile(dir / "junk.bin", std::string("\x01\x02\x03garbage", 10));
  for (const char* name : {"empty.txt", "junk.bin"}) {
    try {
      Vocabulary::Load(dir / name);
      ADD_FAILURE() << name;
    } catch (const DataError& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace rrslam
