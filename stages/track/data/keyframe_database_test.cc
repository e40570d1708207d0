#include "stages/track/data/keyframe_database.h"

#include <gtest/gtest.h>

#include <random>

#include "stages/track/test_scene.h"

namespace rrslam {
namespace {

using testing::HundredWordVocabulary;
using testing::MakeGridKeyFrame;
using testing::MakeObservedPoint;
using testing::TestSensor;

// An L1-normalized BoW vector with equal weights on `words`.
BowVector Bow(const std::vector<WordId>& words) {
  BowVector bow;
  for (WordId w : words) bow.entries.emplace_back(w, 1.0 / words.size());
  return bow;
}

std::vector<WordId> Range(WordId first, WordId last) {
  std::vector<WordId> out;
  for (WordId w = first; w <= last; ++w) out.push_back(w);
  return out;
}

class KeyFrameDatabaseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_EQ(vocabulary_.num_words(), 100u);
    auto words_b = Range(1, 18);
    words_b.push_back(50);
    words_b.push_back(51);
    auto words_d = Range(1, 10);
    for (WordId w = 60; w <= 69; ++w) words_d.push_back(w);
    const std::vector<std::vector<WordId>> words = {Range(1, 20), words_b, Range(60, 79), words_d};
    for (const auto& w : words) {
      KeyFrame* kf = MakeGridKeyFrame(&map_, sensor_, 40, Rigid3d::Identity(), rng_);
      kf->SetBow(Bow(w), {});
      database_.Add(kf);
      keyframes_.push_back(kf);
    }
  }

  std::mt19937 rng_{3};
  SensorModel sensor_ = TestSensor();
  Vocabulary vocabulary_ = HundredWordVocabulary();
  Map map_;
  KeyFrameDatabase database_{vocabulary_};
  std::vector<KeyFrame*> keyframes_;  // A, B, C, D
};

TEST_F(KeyFrameDatabaseTest, IndexesKeyFramesByWordInIdOrder) {
  EXPECT_EQ(database_.KeyFramesWithWord(1),
            (std::vector<KeyFrame*>{keyframes_[0], keyframes_[1], keyframes_[3]}));
  EXPECT_EQ(database_.KeyFramesWithWord(70), (std::vector<KeyFrame*>{keyframes_[2]}));
  EXPECT_TRUE(database_.KeyFramesWithWord(99).empty());
  database_.Erase(keyframes_[1]);
  EXPECT_EQ(database_.KeyFramesWithWord(1), (std::vector<KeyFrame*>{keyframes_[0], keyframes_[3]}));
  EXPECT_TRUE(database_.KeyFramesWithWord(50).empty());
}

// Indexing at once (a loaded map), in any order, gives the index that
// adding one keyframe at a time gives; adding twice changes nothing.
TEST_F(KeyFrameDatabaseTest, AddAllEqualsAddingOneAtATime) {
  KeyFrameDatabase all(vocabulary_);
  all.AddAll({keyframes_[3], keyframes_[1], keyframes_[0], keyframes_[2]});
  database_.Add(keyframes_[2]);
  for (WordId word = 0; word < 100; ++word) {
    EXPECT_EQ(all.KeyFramesWithWord(word), database_.KeyFramesWithWord(word)) << word;
  }
  const BowVector query = Bow(Range(1, 20));
  EXPECT_EQ(all.DetectRelocalizationCandidates(query),
            database_.DetectRelocalizationCandidates(query));
}

TEST_F(KeyFrameDatabaseTest, RelocalizationCandidatesShareMostWordsAndScoreWell) {
  // A shares 20 words with the query, B 18, D 10, C none: only A and B share
  // more than 80% of the most; scores 1.0 and 0.9, both above 75% of the best.
  const BowVector query = Bow(Range(1, 20));
  EXPECT_NEAR(vocabulary_.Score(query, keyframes_[1]->bow()), 0.9, 1e-9);
  EXPECT_EQ(database_.DetectRelocalizationCandidates(query),
            (std::vector<KeyFrame*>{keyframes_[0], keyframes_[1]}));
  // Nothing in common: no candidate.
  EXPECT_TRUE(database_.DetectRelocalizationCandidates(Bow({95, 96})).empty());
}

TEST_F(KeyFrameDatabaseTest, CovisibleCandidatesAreGroupedUnderTheirBest) {
  // A and B covisible (20 shared points): one group, represented by A.
  for (uint32_t i = 0; i < 20; ++i)
    MakeObservedPoint(&map_, {keyframes_[0], keyframes_[1]}, {i, i});
  map_.UpdateConnections(keyframes_[0]);
  map_.UpdateConnections(keyframes_[1]);
  EXPECT_EQ(database_.DetectRelocalizationCandidates(Bow(Range(1, 20))),
            (std::vector<KeyFrame*>{keyframes_[0]}));
}

TEST_F(KeyFrameDatabaseTest, ErasedKeyFramesAreNotCandidates) {
  database_.Erase(keyframes_[0]);
  EXPECT_EQ(database_.DetectRelocalizationCandidates(Bow(Range(1, 20))),
            (std::vector<KeyFrame*>{keyframes_[1]}));
}

// Loop detection on the fixture, with keyframe E holding the same words as A
// (the query) and B sharing 20 points with A. Shared words with A: E 20, B 18,
// D 10, C none; scores 1.0 (E), 0.9 (B).
class LoopCandidatesTest : public KeyFrameDatabaseTest {
 protected:
  void SetUp() override {
    KeyFrameDatabaseTest::SetUp();
    KeyFrame* e = MakeGridKeyFrame(&map_, sensor_, 40, Rigid3d::Identity(), rng_);
    e->SetBow(Bow(Range(1, 20)), {});
    database_.Add(e);
    keyframes_.push_back(e);
  }
  void ConnectAAndB() {
    for (uint32_t i = 0; i < 20; ++i)
      MakeObservedPoint(&map_, {keyframes_[0], keyframes_[1]}, {i, i});
    map_.UpdateConnections(keyframes_[0]);
    map_.UpdateConnections(keyframes_[1]);
    ASSERT_EQ(keyframes_[0]->Weight(keyframes_[1]), 20);
  }
};

TEST_F(LoopCandidatesTest, TheQueryAndItsConnectedKeyFramesAreNeverCandidates) {
  KeyFrame *a = keyframes_[0], *b = keyframes_[1], *e = keyframes_[4];
  // Unconnected, B is a candidate next to E (A itself never is).
  EXPECT_EQ(database_.DetectLoopCandidates(*a, 0.0), (std::vector<KeyFrame*>{b, e}));
  ConnectAAndB();
  EXPECT_EQ(database_.DetectLoopCandidates(*a, 0.0), (std::vector<KeyFrame*>{e}));
  // B's query: A is connected to it; E (18 shared words, score 0.9) is not.
  EXPECT_EQ(database_.DetectLoopCandidates(*b, 0.0), (std::vector<KeyFrame*>{e}));
}

TEST_F(LoopCandidatesTest, AnUnconnectedKeyFrameWithTheQuerysWordsIsACandidate) {
  ConnectAAndB();
  // E is A's twin in words but shares no point with it.
  ASSERT_EQ(keyframes_[4]->Weight(keyframes_[0]), 0);
  EXPECT_NEAR(vocabulary_.Score(keyframes_[0]->bow(), keyframes_[4]->bow()), 1.0, 1e-12);
  const std::vector<KeyFrame*> candidates = database_.DetectLoopCandidates(*keyframes_[0], 0.5);
  EXPECT_EQ(candidates, (std::vector<KeyFrame*>{keyframes_[4]}));
}

TEST_F(LoopCandidatesTest, AMinScoreAboveEveryScoreLeavesNoCandidate) {
  KeyFrame *a = keyframes_[0], *e = keyframes_[4];
  // B's 0.9 is below 0.95, E's 1.0 above; nothing reaches 1.01.
  EXPECT_EQ(database_.DetectLoopCandidates(*a, 0.95), (std::vector<KeyFrame*>{e}));
  EXPECT_TRUE(database_.DetectLoopCandidates(*a, 1.01).empty());
}

// ORB-SLAM2's relocalization candidates by a scan of every keyframe (no
// inverted file): shared words by set intersection; no covisibility here,
// so every kept keyframe is its own group.
std::vector<KeyFrame*> BruteForceCandidates(const std::vector<KeyFrame*>& live,
                                            const BowVector& bow, const Vocabulary& vocabulary) {
  std::vector<std::pair<KeyFrame*, int>> sharing;
  for (KeyFrame* kf : live) {
    int shared = 0;
    for (const auto& [word, value] : bow.entries) {
      for (const auto& [w, v] : kf->bow().entries) shared += w == word;
    }
    if (shared > 0) sharing.emplace_back(kf, shared);
  }
  int max_shared = 0;
  for (const auto& [kf, n] : sharing) max_shared = std::max(max_shared, n);
  const int min_shared = static_cast<int>(0.8f * max_shared);
  std::vector<std::pair<KeyFrame*, double>> scored;
  double best = 0;
  for (const auto& [kf, n] : sharing) {
    if (n <= min_shared) continue;
    scored.emplace_back(kf, vocabulary.Score(bow, kf->bow()));
    best = std::max(best, scored.back().second);
  }
  std::vector<KeyFrame*> out;
  for (const auto& [kf, score] : scored) {
    if (score >= 0.75 * best) out.push_back(kf);
  }
  std::sort(out.begin(), out.end(), IdLess());
  return out;
}

BowVector RandomBow(std::mt19937& rng, int words) {
  std::vector<WordId> chosen = Range(0, 99);
  std::shuffle(chosen.begin(), chosen.end(), rng);
  chosen.resize(words);
  std::sort(chosen.begin(), chosen.end());
  return Bow(chosen);
}

// The inverted file (loaded at once, then grown and culled one keyframe at a
// time, with merges and compactions along the way) returns what a scan of
// every live keyframe returns, for many random queries.
TEST(KeyFrameDatabaseScan, InvertedFileGivesTheBruteForceCandidates) {
  std::mt19937 rng(11);
  const SensorModel sensor = TestSensor();
  const Vocabulary vocabulary = HundredWordVocabulary();
  Map map;
  KeyFrameDatabase database(vocabulary, /*recent_max=*/64);
  std::vector<KeyFrame*> live;
  const auto make = [&] {
    KeyFrame* kf = MakeGridKeyFrame(&map, sensor, 4, Rigid3d::Identity(), rng);
    kf->SetBow(RandomBow(rng, 5 + static_cast<int>(rng() % 20)), {});
    return kf;
  };
  for (int i = 0; i < 150; ++i) live.push_back(make());
  std::vector<KeyFrame*> shuffled = live;
  std::shuffle(shuffled.begin(), shuffled.end(), rng);
  database.AddAll(shuffled);
  for (int step = 0; step < 300; ++step) {
    if (rng() % 3 == 0 && !live.empty()) {
      const size_t i = rng() % live.size();
      database.Erase(live[i]);
      live.erase(live.begin() + static_cast<std::ptrdiff_t>(i));
    } else {
      live.push_back(make());
      database.Add(live.back());
    }
    const BowVector query = RandomBow(rng, 3 + static_cast<int>(rng() % 30));
    ASSERT_EQ(database.DetectRelocalizationCandidates(query),
              BruteForceCandidates(live, query, vocabulary))
        << "step " << step;
    const WordId word = static_cast<WordId>(rng() % 100);
    std::vector<KeyFrame*> with_word;
    for (KeyFrame* kf : live) {
      for (const auto& [w, v] : kf->bow().entries) {
        if (w == word) with_word.push_back(kf);
      }
    }
    std::sort(with_word.begin(), with_word.end(), IdLess());
    ASSERT_EQ(database.KeyFramesWithWord(word), with_word) << "step " << step;
  }
  EXPECT_EQ(database.size(), live.size());
}

}  // namespace
}  // namespace rrslam
