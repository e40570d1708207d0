// Inverted index from vocabulary words to the keyframes that contain them,
// with the place-recognition queries of relocalization and loop detection
// (ORB-SLAM2's KeyFrameDatabase::DetectRelocalizationCandidates and
// DetectLoopCandidates).
//
// The local mapper adds every keyframe it inserts and removes culled ones.
// Lists are kept ordered by keyframe id, so queries are deterministic.
// Thread-safety: none of its own; use it under Map::mutex().
#pragma once

#include <cstdint>
#include <vector>

#include "stages/track/data/keyframe.h"
#include "stages/vocab/vocabulary.h"

namespace rrslam {

class KeyFrameDatabase {
 public:
  // `vocabulary` must outlive the database.
  explicit KeyFrameDatabase(const Vocabulary& vocabulary);

  // Indexes a keyframe by the words of its BoW vector (which must be
  // computed). Linear in the index's size (a merge).
  void Add(KeyFrame* keyframe);
  // Indexes many keyframes at once (a map being loaded): one sort.
  void AddAll(const std::vector<KeyFrame*>& keyframes);
  // Removes a keyframe from every list it is in.
  void Erase(const KeyFrame* keyframe);
  void Clear();

  // Keyframes whose lists hold word `word`, by id (for tests and tools).
  std::vector<KeyFrame*> KeyFramesWithWord(WordId word) const;

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
  // The inverted index as one array of (word, keyframe) entries sorted by
  // word, then keyframe id: a word's list is an equal range. ORB-SLAM2 keeps
  // a list per vocabulary word; that table alone costs ~20 ms to allocate for
  // a 540k-word vocabulary at every start-up, and filling per-word lists
  // (or hash-map nodes) for a loaded map ~20 ms more, where one sort of this
  // array takes a few.
  // Keyframe ids take the low kIdBits bits of a key, word ids (< 2^27,
  // vocabulary_format.h) the others.
  static constexpr int kIdBits = 37;
  struct Entry {
    uint64_t key;  // word << kIdBits | keyframe id.
    KeyFrame* keyframe;
    bool operator<(const Entry& o) const { return key < o.key; }
  };
  static Entry MakeEntry(WordId word, KeyFrame* keyframe);
  std::vector<Entry> index_;
};

}  // namespace rrslam
