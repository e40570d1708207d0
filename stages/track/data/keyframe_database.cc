#include "stages/track/data/keyframe_database.h"

#include <algorithm>
#include <cassert>
#include <iterator>
#include <map>

namespace rrslam {

KeyFrameDatabase::KeyFrameDatabase(const Vocabulary& vocabulary) : vocabulary_(vocabulary) {}

KeyFrameDatabase::Entry KeyFrameDatabase::MakeEntry(WordId word, KeyFrame* keyframe) {
  assert(keyframe->id() < (uint64_t{1} << kIdBits) && word < (uint64_t{1} << (64 - kIdBits)));
  return {(uint64_t{word} << kIdBits) | keyframe->id(), keyframe};
}

void KeyFrameDatabase::Add(KeyFrame* keyframe) {
  std::vector<Entry> added;
  added.reserve(keyframe->bow().size());
  for (const auto& [word, value] : keyframe->bow().entries) {
    added.push_back(MakeEntry(word, keyframe));  // BoW entries are sorted by word.
  }
  std::vector<Entry> merged;
  merged.reserve(index_.size() + added.size());
  std::merge(index_.begin(), index_.end(), added.begin(), added.end(), std::back_inserter(merged));
  merged.erase(std::unique(merged.begin(), merged.end(),
                           [](const Entry& a, const Entry& b) { return a.key == b.key; }),
               merged.end());
  index_ = std::move(merged);
}

void KeyFrameDatabase::AddAll(const std::vector<KeyFrame*>& keyframes) {
  size_t n = index_.size();
  for (const KeyFrame* kf : keyframes) n += kf->bow().size();
  index_.reserve(n);
  for (KeyFrame* kf : keyframes) {
    for (const auto& [word, value] : kf->bow().entries) index_.push_back(MakeEntry(word, kf));
  }
  std::sort(index_.begin(), index_.end());
  index_.erase(std::unique(index_.begin(), index_.end(),
                           [](const Entry& a, const Entry& b) { return a.key == b.key; }),
               index_.end());
}

void KeyFrameDatabase::Erase(const KeyFrame* keyframe) {
  index_.erase(std::remove_if(index_.begin(), index_.end(),
                              [keyframe](const Entry& e) { return e.keyframe == keyframe; }),
               index_.end());
}

void KeyFrameDatabase::Clear() { index_.clear(); }

std::vector<KeyFrame*> KeyFrameDatabase::KeyFramesWithWord(WordId word) const {
  std::vector<KeyFrame*> out;
  const uint64_t first = uint64_t{word} << kIdBits;
  for (auto it = std::lower_bound(index_.begin(), index_.end(), Entry{first, nullptr});
       it != index_.end() && (it->key >> kIdBits) == word; ++it) {
    out.push_back(it->keyframe);
  }
  return out;
}

std::vector<KeyFrame*> KeyFrameDatabase::DetectRelocalizationCandidates(
    const BowVector& bow) const {
  return DetectCandidates(bow, nullptr, 0.0);
}

std::vector<KeyFrame*> KeyFrameDatabase::DetectLoopCandidates(const KeyFrame& keyframe,
                                                              double min_score) const {
  return DetectCandidates(keyframe.bow(), &keyframe, min_score);
}

std::vector<KeyFrame*> KeyFrameDatabase::DetectCandidates(const BowVector& bow,
                                                          const KeyFrame* query,
                                                          double min_score) const {
  // A loop query excludes itself and the keyframes connected to it.
  std::vector<KeyFrameId> excluded;
  if (query != nullptr) {
    excluded.push_back(query->id());
    for (const KeyFrame::Connection& c : query->connections()) excluded.push_back(c.keyframe->id());
    std::sort(excluded.begin(), excluded.end());
  }
  // Shared words per keyframe, by keyframe id.
  struct Candidate {
    KeyFrame* keyframe;
    int shared_words = 0;
    double score = 0;
  };
  std::map<KeyFrameId, Candidate> candidates;
  // The query's words are sorted, so each search starts where the last ended.
  auto from = index_.begin();
  for (const auto& [word, value] : bow.entries) {
    from = std::lower_bound(from, index_.end(), Entry{uint64_t{word} << kIdBits, nullptr});
    for (; from != index_.end() && (from->key >> kIdBits) == word; ++from) {
      KeyFrame* keyframe = from->keyframe;
      if (keyframe->bad() || std::binary_search(excluded.begin(), excluded.end(), keyframe->id())) {
        continue;
      }
      auto [it, inserted] = candidates.try_emplace(keyframe->id(), Candidate{keyframe});
      ++it->second.shared_words;
    }
  }
  if (candidates.empty()) return {};

  int max_shared = 0;
  for (const auto& [id, c] : candidates) max_shared = std::max(max_shared, c.shared_words);
  const int min_shared = static_cast<int>(0.8f * max_shared);

  // Score the keyframes sharing enough words; the others drop out.
  std::map<KeyFrameId, Candidate> scored;
  for (auto& [id, c] : candidates) {
    if (c.shared_words > min_shared) {
      c.score = vocabulary_.Score(bow, c.keyframe->bow());
      scored.emplace(id, c);
    }
  }
  if (scored.empty()) return {};

  // Group each candidate scoring at least min_score with its best covisible
  // keyframes (whose scores count whatever they are).
  struct Group {
    double accumulated;
    KeyFrame* best;
  };
  std::vector<Group> groups;
  double best_accumulated = 0;
  for (const auto& [id, c] : scored) {
    if (c.score < min_score) continue;
    double accumulated = c.score;
    double best_score = c.score;
    KeyFrame* best = c.keyframe;
    for (KeyFrame* neighbour : c.keyframe->BestCovisible(10)) {
      auto it = scored.find(neighbour->id());
      if (it == scored.end()) continue;
      accumulated += it->second.score;
      if (it->second.score > best_score) {
        best_score = it->second.score;
        best = neighbour;
      }
    }
    groups.push_back({accumulated, best});
    best_accumulated = std::max(best_accumulated, accumulated);
  }

  const double min_accumulated = 0.75 * best_accumulated;
  std::vector<KeyFrame*> out;
  for (const Group& g : groups) {
    if (g.accumulated >= min_accumulated) out.push_back(g.best);
  }
  std::sort(out.begin(), out.end(), IdLess());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

}  // namespace rrslam
