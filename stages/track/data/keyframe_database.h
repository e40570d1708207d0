// Inverted index from vocabulary words to the keyframes that contain them,
// with the place-recognition queries of relocalization and loop detection
// (ORB-SLAM2's KeyFrameDatabase::DetectRelocalizationCandidates and
// DetectLoopCandidates).
//
// The local mapper adds every keyframe it inserts and removes culled ones.
// Results are ordered by keyframe id and do not depend on the order in
// which keyframes were added: queries are deterministic.
// Thread-safety: none of its own; use it under Map::mutex().
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include "stages/track/data/keyframe.h"
#include "stages/vocab/vocabulary.h"

namespace rrslam {

class KeyFrameDatabase {
 public:
  // Postings (below) added one keyframe at a time before they are merged into
  // the main array: 2 MB, about 250 keyframes of 1000 words.
  static constexpr size_t kRecentMax = size_t{1} << 18;

  // `vocabulary` must outlive the database. `recent_max`: postings added one
  // keyframe at a time that are merged into the main array (tests make it
  // small to exercise the merge).
  explicit KeyFrameDatabase(const Vocabulary& vocabulary, size_t recent_max = kRecentMax);

  // Indexes a keyframe by the words of its BoW vector (which must be
  // computed); a keyframe already indexed is left as it is. Amortized time
  // in proportion to its words (see "Postings" below), not to the index.
  void Add(KeyFrame* keyframe);
  // Indexes many keyframes at once (a map being loaded): one counting sort by
  // word, linear in their words plus the vocabulary's size.
  void AddAll(const std::vector<KeyFrame*>& keyframes);
  // Removes a keyframe from every list it is in (in constant time; its
  // postings are dropped with the next compaction).
  void Erase(const KeyFrame* keyframe);
  void Clear();

  // Keyframes whose lists hold word `word`, by id (for tests and tools).
  std::vector<KeyFrame*> KeyFramesWithWord(WordId word) const;
  // Keyframes indexed (erased ones not counted).
  size_t size() const { return slot_of_.size(); }

  // Candidate keyframes to relocalize a frame with BoW vector `bow`:
  //  1. keyframes sharing at least one word; keep those sharing at least 80% of
  //     the largest number of shared words;
  //  2. score each kept keyframe against `bow` with the vocabulary's scoring;
  //  3. accumulate each keyframe's score with those of its 10 best covisible
  //     keyframes that were also kept, and remember the best-scoring keyframe
  //     of the group;
  //  4. return the best keyframe of every group whose accumulated score is at
  //     least 75% of the best accumulated score, each once, ordered by id.
  // Time: the query's postings (one counter per indexed keyframe, no search
  // structure), then the kept keyframes' scores.
  std::vector<KeyFrame*> DetectRelocalizationCandidates(const BowVector& bow) const;

  // Candidate keyframes to close a loop with `keyframe` (ORB-SLAM2's
  // DetectLoopCandidates): as above, but `keyframe` and the keyframes
  // connected to it in the covisibility graph are never candidates, and a
  // group is formed only around a keyframe scoring at least `min_score`
  // (the lowest score of `keyframe` against its covisible keyframes).
  std::vector<KeyFrame*> DetectLoopCandidates(const KeyFrame& keyframe, double min_score) const;

 private:
  struct Candidate {
    KeyFrame* keyframe;
    uint32_t slot;
    int shared_words;
  };
  std::vector<Candidate> SharingWords(const BowVector& bow, const KeyFrame* query) const;
  std::vector<KeyFrame*> DetectCandidates(const BowVector& bow, const KeyFrame* query,
                                          double min_score) const;
  uint32_t NewSlot(KeyFrame* keyframe);
  // The postings of `word`: its equal range in base_ (by base_start_) and in
  // recent_ (by binary search).
  std::pair<const uint64_t*, const uint64_t*> BaseRange(WordId word) const;
  std::pair<const uint64_t*, const uint64_t*> RecentRange(WordId word) const;
  // Recomputes base_start_ after base_ changed (in time base_ + words).
  void IndexBase();
  void MergeRecent();
  void CompactIfMostlyErased();

  const Vocabulary& vocabulary_;
  const size_t recent_max_;

  // Postings: every (word, keyframe) pair as one key, word << 32 | slot,
  // where a slot numbers an indexed keyframe (slots_). A word's list is an
  // equal range of a sorted array. ORB-SLAM2 keeps a list per vocabulary word;
  // that table alone costs ~20 ms to allocate for a 540k-word vocabulary at
  // every start-up. `base_` holds most postings; `recent_` those added one
  // keyframe at a time since the last merge, kept under recent_max_ entries
  // so that an Add merges into a small array, and merged into `base_` (in
  // place) when it outgrows that. Postings of erased keyframes stay until the
  // arrays are compacted, when they are a quarter of all.
  std::vector<uint64_t> base_, recent_;
  // Word -> index of its first posting in base_ (one past the last word's
  // end at the back): a word's list without a search through base_, whose
  // binary searches cost ~10 ms of cache misses a query at 10k keyframes
  // (7M postings). 4 bytes a vocabulary word, one allocation.
  std::vector<uint32_t> base_start_;
  std::vector<KeyFrame*> slots_;                           // Slot -> keyframe; null once erased.
  std::vector<uint32_t> slot_postings_;                    // Slot -> its number of postings.
  std::unordered_map<const KeyFrame*, uint32_t> slot_of_;  // Indexed keyframes.
  size_t erased_postings_ = 0;                             // Postings of erased slots still stored.
};

}  // namespace rrslam
