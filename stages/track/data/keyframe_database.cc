#include "stages/track/data/keyframe_database.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

namespace rrslam {

KeyFrameDatabase::KeyFrameDatabase(const Vocabulary& vocabulary, size_t recent_max)
    : vocabulary_(vocabulary), recent_max_(recent_max) {}

namespace {

uint64_t Posting(WordId word, uint32_t slot) { return (uint64_t{word} << 32) | slot; }
WordId WordOf(uint64_t posting) { return static_cast<WordId>(posting >> 32); }
uint32_t SlotOf(uint64_t posting) { return static_cast<uint32_t>(posting); }

// Merges the sorted `tail` into the sorted `sorted`, in place.
void MergeInto(std::vector<uint64_t>* sorted, const std::vector<uint64_t>& tail) {
  const auto middle = static_cast<std::ptrdiff_t>(sorted->size());
  sorted->insert(sorted->end(), tail.begin(), tail.end());
  std::inplace_merge(sorted->begin(), sorted->begin() + middle, sorted->end());
}

}  // namespace

uint32_t KeyFrameDatabase::NewSlot(KeyFrame* keyframe) {
  const auto slot = static_cast<uint32_t>(slots_.size());
  slots_.push_back(keyframe);
  slot_postings_.push_back(static_cast<uint32_t>(keyframe->bow().size()));
  slot_of_.emplace(keyframe, slot);
  return slot;
}

void KeyFrameDatabase::Add(KeyFrame* keyframe) {
  if (slot_of_.count(keyframe) > 0) return;
  const uint32_t slot = NewSlot(keyframe);
  std::vector<uint64_t> added;
  added.reserve(keyframe->bow().size());
  for (const auto& [word, value] : keyframe->bow().entries) added.push_back(Posting(word, slot));
  std::sort(added.begin(), added.end());  // BoW entries are sorted by word already.
  MergeInto(&recent_, added);
  if (recent_.size() > recent_max_) MergeRecent();
}

void KeyFrameDatabase::AddAll(const std::vector<KeyFrame*>& keyframes) {
  std::vector<uint32_t> slots;
  for (KeyFrame* kf : keyframes) {
    if (slot_of_.count(kf) == 0) slots.push_back(NewSlot(kf));
  }
  // Counting sort of the new postings by word (within a word, by slot: the
  // slots were given in increasing order).
  WordId words = static_cast<WordId>(vocabulary_.num_words());
  size_t total = 0;
  for (uint32_t slot : slots) {
    for (const auto& [word, value] : slots_[slot]->bow().entries) words = std::max(words, word + 1);
    total += slots_[slot]->bow().size();
  }
  std::vector<size_t> start(size_t{words} + 1, 0);
  for (uint32_t slot : slots) {
    for (const auto& [word, value] : slots_[slot]->bow().entries) ++start[word + 1];
  }
  for (size_t w = 0; w < words; ++w) start[w + 1] += start[w];
  std::vector<uint64_t> added(total);
  for (uint32_t slot : slots) {
    for (const auto& [word, value] : slots_[slot]->bow().entries) {
      added[start[word]++] = Posting(word, slot);
    }
  }
  if (base_.empty()) {
    base_ = std::move(added);
  } else {
    MergeInto(&base_, added);
  }
  IndexBase();
}

void KeyFrameDatabase::IndexBase() {
  base_start_.clear();
  if (base_.empty()) return;
  const size_t words = std::max<size_t>(vocabulary_.num_words(), size_t{WordOf(base_.back())} + 1);
  base_start_.assign(words + 1, 0);
  for (const uint64_t posting : base_) ++base_start_[size_t{WordOf(posting)} + 1];
  for (size_t w = 0; w < words; ++w) base_start_[w + 1] += base_start_[w];
}

std::pair<const uint64_t*, const uint64_t*> KeyFrameDatabase::BaseRange(WordId word) const {
  if (size_t{word} + 1 >= base_start_.size()) return {nullptr, nullptr};
  return {base_.data() + base_start_[word], base_.data() + base_start_[size_t{word} + 1]};
}

std::pair<const uint64_t*, const uint64_t*> KeyFrameDatabase::RecentRange(WordId word) const {
  const auto [first, last] =
      std::equal_range(recent_.begin(), recent_.end(), Posting(word, 0),
                       [](uint64_t a, uint64_t b) { return WordOf(a) < WordOf(b); });
  return {recent_.data() + (first - recent_.begin()), recent_.data() + (last - recent_.begin())};
}

void KeyFrameDatabase::MergeRecent() {
  MergeInto(&base_, recent_);
  recent_.clear();
  IndexBase();
}

void KeyFrameDatabase::Erase(const KeyFrame* keyframe) {
  const auto it = slot_of_.find(keyframe);
  if (it == slot_of_.end()) return;
  slots_[it->second] = nullptr;
  erased_postings_ += slot_postings_[it->second];
  slot_of_.erase(it);
  CompactIfMostlyErased();
}

void KeyFrameDatabase::CompactIfMostlyErased() {
  if (erased_postings_ * 4 <= base_.size() + recent_.size()) return;
  const auto erased = [&](uint64_t posting) { return slots_[SlotOf(posting)] == nullptr; };
  std::erase_if(base_, erased);
  std::erase_if(recent_, erased);
  erased_postings_ = 0;
  IndexBase();
}

void KeyFrameDatabase::Clear() {
  base_.clear();
  base_start_.clear();
  recent_.clear();
  slots_.clear();
  slot_postings_.clear();
  slot_of_.clear();
  erased_postings_ = 0;
}

std::vector<KeyFrame*> KeyFrameDatabase::KeyFramesWithWord(WordId word) const {
  std::vector<KeyFrame*> out;
  for (const auto& [first, last] : {BaseRange(word), RecentRange(word)}) {
    for (const uint64_t* it = first; it != last; ++it) {
      if (KeyFrame* kf = slots_[SlotOf(*it)]) out.push_back(kf);
    }
  }
  std::sort(out.begin(), out.end(), IdLess());
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

std::vector<KeyFrameDatabase::Candidate> KeyFrameDatabase::SharingWords(
    const BowVector& bow, const KeyFrame* query) const {
  // Shared words per slot, counted over the query's postings.
  std::vector<int> shared(slots_.size(), 0);
  std::vector<uint32_t> touched;
  for (const auto& [word, value] : bow.entries) {
    for (const auto& [first, last] : {BaseRange(word), RecentRange(word)}) {
      for (const uint64_t* it = first; it != last; ++it) {
        const uint32_t slot = SlotOf(*it);
        if (shared[slot]++ == 0) touched.push_back(slot);
      }
    }
  }
  // A loop query excludes itself and the keyframes connected to it.
  std::vector<KeyFrameId> excluded;
  if (query != nullptr) {
    excluded.push_back(query->id());
    for (const KeyFrame::Connection& c : query->connections()) excluded.push_back(c.keyframe->id());
    std::sort(excluded.begin(), excluded.end());
  }
  std::vector<Candidate> out;
  for (const uint32_t slot : touched) {
    KeyFrame* keyframe = slots_[slot];
    if (keyframe == nullptr || keyframe->bad() ||
        std::binary_search(excluded.begin(), excluded.end(), keyframe->id())) {
      continue;
    }
    out.push_back({keyframe, slot, shared[slot]});
  }
  std::sort(out.begin(), out.end(), [](const Candidate& a, const Candidate& b) {
    return a.keyframe->id() < b.keyframe->id();
  });
  return out;
}

std::vector<KeyFrame*> KeyFrameDatabase::DetectCandidates(const BowVector& bow,
                                                          const KeyFrame* query,
                                                          double min_score) const {
  const std::vector<Candidate> candidates = SharingWords(bow, query);
  if (candidates.empty()) return {};

  int max_shared = 0;
  for (const Candidate& c : candidates) max_shared = std::max(max_shared, c.shared_words);
  const int min_shared = static_cast<int>(0.8f * max_shared);

  // Score the keyframes sharing enough words (by slot; NaN: not scored); the
  // others drop out.
  std::vector<double> score(slots_.size(), std::numeric_limits<double>::quiet_NaN());
  std::vector<const Candidate*> scored;
  for (const Candidate& c : candidates) {
    if (c.shared_words > min_shared) {
      score[c.slot] = vocabulary_.Score(bow, c.keyframe->bow());
      scored.push_back(&c);
    }
  }
  if (scored.empty()) return {};
  const auto score_of = [&](const KeyFrame* keyframe) {
    const auto it = slot_of_.find(keyframe);
    return it == slot_of_.end() ? std::numeric_limits<double>::quiet_NaN() : score[it->second];
  };

  // Group each candidate scoring at least min_score with its best covisible
  // keyframes (whose scores count whatever they are).
  struct Group {
    double accumulated;
    KeyFrame* best;
  };
  std::vector<Group> groups;
  double best_accumulated = 0;
  for (const Candidate* c : scored) {
    const double own = score[c->slot];
    if (own < min_score) continue;
    double accumulated = own;
    double best_score = own;
    KeyFrame* best = c->keyframe;
    for (KeyFrame* neighbour : c->keyframe->BestCovisible(10)) {
      const double s = score_of(neighbour);
      if (std::isnan(s)) continue;
      accumulated += s;
      if (s > best_score) {
        best_score = s;
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
