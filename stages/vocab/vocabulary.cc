#include "stages/vocab/vocabulary.h"

#include <algorithm>
#include <bit>
#include <cfloat>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>
#include <thread>

#include "common/binary_header.h"
#include "common/errors.h"
#include "common/formats.h"
#include "common/text.h"
#include "stages/vocab/vocabulary_format.h"

namespace rrslam {

struct Vocabulary::Impl {
  std::string name;
  uint64_t checksum = 0;
  uint64_t content_hash = 0;
  bool binary = false;
  std::optional<MappedFile> mapped;         // A loaded binary file.
  std::vector<OrbDescriptor> aligned_copy;  // A binary file loaded from memory.
  VocabularyData data;                      // Text or built vocabularies.
  VocabularyView view;
};

namespace {

int ParseThreads() {
  return std::clamp(static_cast<int>(std::thread::hardware_concurrency()), 1, 4);
}

VocabularyView LoadBinary(std::span<const uint8_t> bytes, const std::string& name,
                          uint64_t* checksum, uint64_t* content_hash) {
  BinaryVocabularyHeader header;
  const VocabularyView view = ParseBinaryVocabulary(bytes, name, &header);
  *checksum = header.payload_checksum;
  *content_hash = TreeHashOf(view, header);
  return view;
}

VocabularyData LoadText(std::span<const uint8_t> bytes, const std::string& name,
                        uint64_t* checksum) {
  if (bytes.empty()) throw DataError(name + ": empty file, not a vocabulary");
  if (DetectVocabularyFileFormat(bytes) == VocabularyFileFormat::kDbow2Yaml) {
    // Read by vocabulary_yaml.h, which needs OpenCV and zlib (see there).
    throw DataError(name +
                    ": a DBoW2 YAML vocabulary; convert it first with `rrslam-vocab convert " +
                    name + " <name>.rrv` (the binary form loads in milliseconds)");
  }
  const std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  VocabularyData data = ParseTextVocabulary(text, name, ParseThreads());
  *checksum = Checksum64(bytes);
  return data;
}

}  // namespace

Vocabulary::Vocabulary() : impl_(std::make_unique<Impl>()) {}
Vocabulary::~Vocabulary() = default;
Vocabulary::Vocabulary(Vocabulary&&) noexcept = default;
Vocabulary& Vocabulary::operator=(Vocabulary&&) noexcept = default;

Vocabulary Vocabulary::Load(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    throw NoInputError(path.string() + ": vocabulary file not found");
  }
  {
    // A binary file's header first, from a mapping that reads only the pages
    // it touches: a file padded far beyond the size its header gives is
    // refused before the pre-faulting mapping below would read all of it.
    const MappedFile probe(path);
    if (HasMagic(probe.bytes(), kVocabularyFormat)) {
      ParseBinaryHeader(probe.bytes(), kVocabularyFormat, path.string());
    }
  }
  // Pre-faulting every page costs less than taking the faults one by one, and
  // the checksum reads every page anyway.
  MappedFile file(path, /*populate=*/true);
  Vocabulary v;
  v.impl_->name = path.filename().string();
  Impl& impl = *v.impl_;
  if (HasMagic(file.bytes(), kVocabularyFormat)) {
    impl.view = LoadBinary(file.bytes(), path.string(), &impl.checksum, &impl.content_hash);
    impl.binary = true;
    impl.mapped.emplace(std::move(file));
  } else {
    impl.data = LoadText(file.bytes(), path.string(), &impl.checksum);
    impl.view = impl.data.view();
    impl.content_hash = VocabularyContentHash(impl.view);
  }
  return v;
}

Vocabulary Vocabulary::FromBytes(std::span<const uint8_t> bytes, const std::string& name) {
  Vocabulary v;
  Impl& impl = *v.impl_;
  impl.name = name;
  if (HasMagic(bytes, kVocabularyFormat)) {
    // Copy into 32-byte aligned storage, as a mapped file would be.
    auto& storage = impl.aligned_copy;
    storage.resize((bytes.size() + sizeof(OrbDescriptor) - 1) / sizeof(OrbDescriptor));
    std::memcpy(static_cast<void*>(storage.data()), bytes.data(), bytes.size());
    impl.view = LoadBinary({reinterpret_cast<const uint8_t*>(storage.data()), bytes.size()}, name,
                           &impl.checksum, &impl.content_hash);
    impl.binary = true;
  } else {
    impl.data = LoadText(bytes, name, &impl.checksum);
    impl.view = impl.data.view();
    impl.content_hash = VocabularyContentHash(impl.view);
  }
  return v;
}

Vocabulary Vocabulary::FromData(VocabularyData data, const std::string& name,
                                std::optional<uint64_t> checksum) {
  if (data.descriptors().size() != data.info.num_nodes) {
    throw DataError(name + ": vocabulary arrays differ from the node count");
  }
  ValidateVocabularyLinks(data.view(), name);
  Vocabulary v;
  Impl& impl = *v.impl_;
  impl.name = name;
  impl.data = std::move(data);
  impl.view = impl.data.view();
  // Else the checksum of the arrays as they would be laid out in a binary payload.
  impl.checksum = checksum ? *checksum
                           : Checksum64({reinterpret_cast<const uint8_t*>(impl.view.descriptors),
                                         40 * impl.view.info.num_nodes});
  impl.content_hash = VocabularyContentHash(impl.view);
  return v;
}

const Vocabulary::Impl& Vocabulary::impl() const {
  static const Impl kEmpty;
  return impl_ ? *impl_ : kEmpty;
}

int Vocabulary::k() const { return impl().view.info.k; }
int Vocabulary::levels() const { return impl().view.info.levels; }
WeightingType Vocabulary::weighting() const { return impl().view.info.weighting; }
ScoringType Vocabulary::scoring() const { return impl().view.info.scoring; }
size_t Vocabulary::num_nodes() const { return impl().view.info.num_nodes; }
size_t Vocabulary::num_words() const { return impl().view.info.num_words; }
bool Vocabulary::is_binary() const { return impl().binary; }
uint64_t Vocabulary::checksum() const { return impl().checksum; }
uint64_t Vocabulary::content_hash() const { return impl().content_hash; }
const VocabularyView& Vocabulary::view() const { return impl().view; }

std::string Vocabulary::Identity() const {
  const Impl& impl = this->impl();
  return impl.name + " k=" + std::to_string(k()) + " L=" + std::to_string(levels()) +
         " words=" + std::to_string(num_words()) + " tree=" + Hex64(impl.content_hash);
}

WordId Vocabulary::Transform(const OrbDescriptor& descriptor) const {
  const VocabularyView& v = view();
  if (v.info.num_words == 0) return 0;
  return LinkIndex(v.links[DescendToLeaf(v, descriptor)]);
}

namespace {

// Descends a batch of descriptors level by level: while one descriptor waits
// for its children's descriptors to arrive from memory, the others compute,
// so the cache misses of the deep, cold levels overlap (the tree is ~40 MB).
// leaf[i] = leaf node of descriptor i; group[i] (if non-null) = node at level
// `group_level` on its path, or its leaf when shallower, or the root.
void DescendBatched(const VocabularyView& v, std::span<const OrbDescriptor> q, uint32_t* leaf,
                    uint32_t* group, int group_level) {
  constexpr size_t kBatch = 16;
  for (size_t base = 0; base < q.size(); base += kBatch) {
    const size_t m = std::min(kBatch, q.size() - base);
    DescriptorWords words[kBatch];
    uint32_t node[kBatch], grp[kBatch], first[kBatch], count[kBatch], active[kBatch];
    for (size_t i = 0; i < m; ++i) {
      words[i] = ToWords(q[base + i]);
      node[i] = 0;
      grp[i] = 0;
      active[i] = static_cast<uint32_t>(i);
    }
    size_t num_active = m;
    for (int level = 1; num_active > 0; ++level) {
      size_t still = 0;
      for (size_t a = 0; a < num_active; ++a) {
        const uint32_t i = active[a];
        const uint32_t link = v.links[node[i]];
        const uint32_t c = LinkChildren(link);
        if (c == 0) {
          leaf[base + i] = node[i];
          if (group != nullptr) group[base + i] = grp[i];
          continue;
        }
        first[i] = LinkIndex(link);
        count[i] = c;
        const char* children = reinterpret_cast<const char*>(v.descriptors + first[i]);
        for (uint32_t b = 0; b < 32 * c; b += 64) __builtin_prefetch(children + b);
        __builtin_prefetch(v.links + first[i]);
        active[still++] = i;
      }
      num_active = still;
      for (size_t a = 0; a < num_active; ++a) {
        const uint32_t i = active[a];
        uint32_t best = first[i];
        int best_d = HammingDistance(words[i], ToWords(v.descriptors[best]));
        for (uint32_t j = first[i] + 1; j < first[i] + count[i]; ++j) {
          const int d = HammingDistance(words[i], ToWords(v.descriptors[j]));
          if (d < best_d) {
            best_d = d;
            best = j;
          }
        }
        node[i] = best;
        if (level <= group_level) grp[i] = best;
      }
    }
  }
}

}  // namespace

void Vocabulary::Transform(std::span<const OrbDescriptor> descriptors, BowVector* bow,
                           FeatureVector* features, int levels_up) const {
  bow->entries.clear();
  if (features != nullptr) features->entries.clear();
  const VocabularyView& v = view();
  if (v.info.num_words == 0 || descriptors.empty()) return;
  const size_t n = descriptors.size();
  std::vector<uint32_t> leaf(n);
  std::vector<uint32_t> group(features != nullptr ? n : 0);
  DescendBatched(v, descriptors, leaf.data(), features != nullptr ? group.data() : nullptr,
                 v.info.levels - levels_up);

  // (word, feature) of every descriptor whose word is not stopped (weight 0).
  std::vector<uint64_t> hits;
  hits.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    if (v.weights[leaf[i]] > 0) hits.push_back((uint64_t{LinkIndex(v.links[leaf[i]])} << 32) | i);
  }
  std::sort(hits.begin(), hits.end());
  const bool accumulate =
      v.info.weighting == WeightingType::kTf || v.info.weighting == WeightingType::kTfIdf;
  auto& entries = bow->entries;
  entries.reserve(hits.size());
  for (size_t h = 0; h < hits.size();) {
    const WordId word = static_cast<WordId>(hits[h] >> 32);
    // In feature order, as DBoW2 adds them.
    WordValue value = v.weights[leaf[hits[h] & 0xffffffffu]];
    size_t next = h + 1;
    for (; next < hits.size() && (hits[next] >> 32) == word; ++next) {
      if (accumulate) value += v.weights[leaf[hits[next] & 0xffffffffu]];
    }
    entries.emplace_back(word, value);
    h = next;
  }
  switch (v.info.scoring) {
    case ScoringType::kDotProduct:
      if (accumulate && !entries.empty()) {
        const double nd = static_cast<double>(entries.size());
        for (auto& e : entries) e.second /= nd;
      }
      break;
    case ScoringType::kL2: {
      double norm = 0;
      for (const auto& e : entries) norm += e.second * e.second;
      norm = std::sqrt(norm);
      if (norm > 0) {
        for (auto& e : entries) e.second /= norm;
      }
      break;
    }
    default: {
      double norm = 0;
      for (const auto& e : entries) norm += std::fabs(e.second);
      if (norm > 0) {
        for (auto& e : entries) e.second /= norm;
      }
      break;
    }
  }

  if (features != nullptr) {
    std::vector<uint64_t> grouped;
    grouped.reserve(hits.size());
    for (uint64_t h : hits) {
      const uint64_t i = h & 0xffffffffu;
      grouped.push_back((uint64_t{group[i]} << 32) | i);
    }
    std::sort(grouped.begin(), grouped.end());
    auto& fe = features->entries;
    for (size_t g = 0; g < grouped.size();) {
      const NodeId node = static_cast<NodeId>(grouped[g] >> 32);
      size_t next = g;
      while (next < grouped.size() && (grouped[next] >> 32) == node) ++next;
      std::vector<uint32_t> indices(next - g);
      for (size_t j = g; j < next; ++j)
        indices[j - g] = static_cast<uint32_t>(grouped[j] & 0xffffffffu);
      fe.emplace_back(node, std::move(indices));
      g = next;
    }
  }
}

namespace {

// Sum of fn(v_i, w_i) over the words both sorted vectors hold.
template <typename Fn>
double SumOverCommonWords(const std::vector<std::pair<WordId, WordValue>>& v,
                          const std::vector<std::pair<WordId, WordValue>>& w, Fn fn) {
  double sum = 0;
  size_t i = 0, j = 0;
  while (i < v.size() && j < w.size()) {
    if (v[i].first == w[j].first) {
      sum += fn(v[i++].second, w[j++].second);
    } else if (v[i].first < w[j].first) {
      ++i;
    } else {
      ++j;
    }
  }
  return sum;
}

}  // namespace

double Vocabulary::Score(const BowVector& a, const BowVector& b) const {
  // DBoW2's scoring objects (ScoringObject.cpp), over the words both vectors
  // hold; the vectors are normalized as Transform leaves them.
  const auto& v = a.entries;
  const auto& w = b.entries;
  const auto product = [](double vi, double wi) { return vi * wi; };
  switch (scoring()) {
    case ScoringType::kL1:
      // |v - w|_1 = 2 + sum over common words (|vi - wi| - |vi| - |wi|) (Nister 2006).
      return -SumOverCommonWords(v, w, [](double vi, double wi) {
        return std::fabs(vi - wi) - std::fabs(vi) - std::fabs(wi);
      }) / 2.0;
    case ScoringType::kL2: {
      const double score = SumOverCommonWords(v, w, product);
      return score >= 1 ? 1.0 : 1.0 - std::sqrt(1.0 - score);
    }
    case ScoringType::kChiSquare:
      return 2.0 * SumOverCommonWords(v, w, [](double vi, double wi) {
               return vi + wi != 0.0 ? vi * wi / (vi + wi) : 0.0;
             });
    case ScoringType::kKL: {
      // Every word of a counts; words missing from b are charged log(eps).
      const double log_eps = std::log(DBL_EPSILON);
      double score = 0;
      size_t j = 0;
      for (const auto& [word, vi] : v) {
        while (j < w.size() && w[j].first < word) ++j;
        if (j < w.size() && w[j].first == word) {
          const double wi = w[j].second;
          if (vi != 0 && wi != 0) score += vi * std::log(vi / wi);
        } else if (vi != 0) {
          score += vi * (std::log(vi) - log_eps);
        }
      }
      return score;
    }
    case ScoringType::kBhattacharyya:
      return SumOverCommonWords(v, w, [](double vi, double wi) { return std::sqrt(vi * wi); });
    case ScoringType::kDotProduct:
      return SumOverCommonWords(v, w, product);
  }
  return 0;
}

}  // namespace rrslam
