#include "stages/vocab/vocab_build.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/errors.h"
#include "stages/vocab/vocab_test_util.h"

namespace rrslam {
namespace {

using testing::Filled;

// Root with four leaf words A, B, C, D (k = 4, L = 1).
VocabTree FourWordTree() {
  VocabTree t;
  t.k = 4;
  t.levels = 1;
  t.parent = {-1, 0, 0, 0, 0};
  t.level = {0, 1, 1, 1, 1};
  t.count = {10, 4, 3, 2, 1};
  t.centre = {OrbDescriptor{}, Filled(0x00), Filled(0xff), Filled(0x0f), Filled(0x3c)};
  return t;
}

// The toy corpus: 4 images over words A, B, C; D occurs in none.
//   image 0: A A B   image 1: B   image 2: C B   image 3: A
struct Corpus {
  std::vector<std::vector<OrbDescriptor>> images{{Filled(0x00), Filled(0x00), Filled(0xff)},
                                                 {Filled(0xff)},
                                                 {Filled(0x0f), Filled(0xff)},
                                                 {Filled(0x00)}};
  std::vector<std::span<const OrbDescriptor>> Spans() const {
    return {images.begin(), images.end()};
  }
};

TEST(VocabBuild, WordsAreTheLeavesInNodeOrder) {
  const VocabularyData d =
      VocabularyFromTree(FourWordTree(), WeightingType::kTfIdf, ScoringType::kL1, "tree.h5");
  EXPECT_EQ(d.info.num_nodes, 5u);
  EXPECT_EQ(d.info.num_words, 4u);
  EXPECT_EQ(d.links()[0], InnerLink(1, 4));
  for (uint32_t i = 1; i <= 4; ++i) EXPECT_EQ(d.links()[i], LeafLink(i - 1));
  EXPECT_EQ(d.descriptors()[2], Filled(0xff));
  VocabTree broken = FourWordTree();
  broken.count[0] = 3;
  EXPECT_THROW(VocabularyFromTree(broken, WeightingType::kTfIdf, ScoringType::kL1, "t"), DataError);
}

TEST(VocabBuild, IdfOnHandComputedCorpus) {
  const Corpus corpus;
  for (WeightingType w : {WeightingType::kTfIdf, WeightingType::kIdf}) {
    VocabularyData d = VocabularyFromTree(FourWordTree(), w, ScoringType::kL1, "t");
    SetWordWeights(corpus.Spans(), 1, &d);
    // N = 4 images; A in 2, B in 3, C in 1, D in none.
    EXPECT_FLOAT_EQ(d.weights()[1], static_cast<float>(std::log(4.0 / 2.0)));
    EXPECT_FLOAT_EQ(d.weights()[2], static_cast<float>(std::log(4.0 / 3.0)));
    EXPECT_FLOAT_EQ(d.weights()[3], static_cast<float>(std::log(4.0 / 1.0)));
    EXPECT_EQ(d.weights()[4], 0.0f);
    EXPECT_EQ(d.weights()[0], 0.0f);
  }
  for (WeightingType w : {WeightingType::kTf, WeightingType::kBinary}) {
    VocabularyData d = VocabularyFromTree(FourWordTree(), w, ScoringType::kL1, "t");
    SetWordWeights(corpus.Spans(), 1, &d);
    for (int i = 1; i <= 4; ++i) EXPECT_EQ(d.weights()[i], 1.0f);
    EXPECT_EQ(d.weights()[0], 0.0f);
  }
}

TEST(VocabBuild, TfIdfBowOfToyImage) {
  const Corpus corpus;
  VocabularyData d =
      VocabularyFromTree(FourWordTree(), WeightingType::kTfIdf, ScoringType::kL1, "t");
  SetWordWeights(corpus.Spans(), 2, &d);
  const Vocabulary voc = Vocabulary::FromData(std::move(d), "toy");
  BowVector bow;
  voc.Transform(corpus.images[0], &bow);
  // tf-idf of image 0: A = 2 ln 2, B = ln(4/3); L1-normalized.
  const double a = 2 * static_cast<double>(static_cast<float>(std::log(2.0)));
  const double b = static_cast<double>(static_cast<float>(std::log(4.0 / 3.0)));
  ASSERT_EQ(bow.size(), 2u);
  EXPECT_EQ(bow.entries[0].first, 0u);
  EXPECT_EQ(bow.entries[1].first, 1u);
  EXPECT_NEAR(bow.entries[0].second, a / (a + b), 1e-12);
  EXPECT_NEAR(bow.entries[1].second, b / (a + b), 1e-12);
  EXPECT_NEAR(bow.entries[0].second, 0.828144, 1e-6);  // By hand: 1.386294 / 1.673976.
  // Image 3 (A only) and image 1 (B only) share no word.
  BowVector b1, b3;
  voc.Transform(corpus.images[1], &b1);
  voc.Transform(corpus.images[3], &b3);
  EXPECT_NEAR(voc.Score(b1, b3), 0.0, 1e-12);
  EXPECT_NEAR(voc.Score(bow, bow), 1.0, 1e-12);
}

TEST(VocabBuild, WeightsDoNotDependOnThreads) {
  const VocabularyData tree_like = testing::RandomVocabulary(8, 4, 3);
  std::mt19937_64 rng(6);
  std::vector<std::vector<OrbDescriptor>> images(57);
  for (auto& image : images) {
    image.resize(40 + rng() % 50);
    for (auto& x : image) x = testing::RandomOrbDescriptor(rng);
  }
  const std::vector<std::span<const OrbDescriptor>> spans(images.begin(), images.end());
  std::vector<std::vector<float>> results;
  for (int threads : {1, 2, 5}) {
    VocabularyData d = testing::RandomVocabulary(8, 4, 3);
    SetWordWeights(spans, threads, &d);
    results.emplace_back(d.weights().begin(), d.weights().end());
  }
  EXPECT_EQ(results[0], results[1]);
  EXPECT_EQ(results[0], results[2]);
  size_t nonzero = 0;
  for (float w : results[0]) nonzero += w > 0;
  EXPECT_GT(nonzero, 10u);
  EXPECT_EQ(tree_like.info.num_nodes, results[0].size());
}

}  // namespace
}  // namespace rrslam
