// Inverted index from vocabulary words to the keyframes that contain them,
// with the place-recognition queries of relocalization and loop detection
// (ORB-SLAM2's KeyFrameDatabase::DetectRelocalizationCandidates and
// DetectLoopCandidates).
//
// The local mapper adds every keyframe it inserts and removes culled ones.
// Lists are kept ordered by keyframe id, so queries are deterministic.
// Thread-safety: none of its own; use it under Map::mutex().
#pragma once

#include <vector>

#include "stages/track/data/keyframe.h"
#include "stages/vocab/vocabulary.h"

namespace rrslam {

class KeyFrameDatabase {
 public:
  // `vocabulary` must outlive the database.
  explicit KeyFrameDatabase(const Vocabulary& vocabulary);

  // Indexes a keyframe by the words of its BoW vector (which must be computed).
  void Add(KeyFrame* keyframe);
  // Removes a keyframe from every list it is in.
  void Erase(const KeyFrame* keyframe);
  void Clear();

  // Keyframes whose lists hold word `word`, by id (for tests and tools).
  const std::vector<KeyFrame*>& KeyFramesWithWord(WordId word) const { return index_.at(word); }

  // Candidate keyframes to relocalize a frame with BoW vector `bow`:
  //  1. keyframes sharing at least one word; keep those sharing at least 80% of
  //     the largest number of shared words;
  //  2. score each kept keyframe against `bow` with the vocabulary's scoring;
  //  3. accumulate each keyframe's score with those of its 10 best covisible
  //     keyframes that were also kept, and remember the best-scoring keyframe
  //     of the group;
  //  4. return the best keyframe of every group whose accumulated score is at
  //     least 75% of the best accumulated score, each once, ordered by id.
  std::vector<KeyFrame*> DetectRelocalizationCandidates(const BowVector& bow) const;

  // Candidate keyframes to close a loop with `keyframe` (ORB-SLAM2's
  // DetectLoopCandidates): as above, but `keyframe` and the keyframes
  // connected to it in the covisibility graph are never candidates, and a
  // group is formed only around a keyframe scoring at least `min_score`
  // (the lowest score of `keyframe` against its covisible keyframes).
  std::vector<KeyFrame*> DetectLoopCandidates(const KeyFrame& keyframe, double min_score) const;

 private:
  std::vector<KeyFrame*> DetectCandidates(const BowVector& bow, const KeyFrame* query,
                                          double min_score) const;

  const Vocabulary& vocabulary_;
  std::vector<std::vector<KeyFrame*>> index_;  // Word id -> keyframes, by id.
};

}  // namespace rrslam
