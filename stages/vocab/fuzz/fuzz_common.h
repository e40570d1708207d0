// Shared body of the vocabulary fuzz targets: load from bytes, and when that
// succeeds, use the vocabulary and check the round-trip properties. Any
// rrslam::Error is an accepted rejection; anything else (a crash, a sanitizer
// report, another exception, a broken property) is a finding.
#pragma once

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include "common/errors.h"
#include "common/fuzz/check.h"
#include "stages/vocab/vocabulary.h"
#include "stages/vocab/vocabulary_format.h"

namespace rrslam::fuzz {

// Transforms a fixed set of descriptors (feature vectors at every level) and
// scores the result with itself.
inline void Exercise(const Vocabulary& v) {
  std::vector<OrbDescriptor> q(24);
  for (size_t i = 0; i < q.size(); ++i) {
    for (int b = 0; b < 32; ++b)
      q[i].bytes[b] = static_cast<uint8_t>(i * 37 + b * 11 + (i * b) % 7);
  }
  for (int levels_up = 0; levels_up <= v.levels() + 1; ++levels_up) {
    BowVector bow;
    FeatureVector fv;
    v.Transform(q, &bow, &fv, levels_up);
    for (const auto& [word, value] : bow.entries) Check(word < v.num_words());
    for (const auto& [node, indices] : fv.entries) {
      Check(node < v.num_nodes());
      for (uint32_t i : indices) Check(i < q.size());
    }
    (void)v.Score(bow, bow);
  }
  for (const OrbDescriptor& d : q) Check(v.Transform(d) < v.num_words());
}

// Binary re-encoding gives an identical vocabulary; where the vocabulary can
// be written as DBoW2 text, text -> parse -> text is stable.
inline void RoundTrip(const Vocabulary& v) {
  const std::vector<uint8_t> encoded = EncodeBinaryVocabulary(v.view());
  const Vocabulary again = Vocabulary::FromBytes(encoded, "re-encoded");
  Check(again.num_nodes() == v.num_nodes() && again.num_words() == v.num_words());
  Check(std::memcmp(again.view().descriptors, v.view().descriptors, 32 * v.num_nodes()) == 0);
  Check(std::memcmp(again.view().links, v.view().links, 4 * v.num_nodes()) == 0);
  std::string text;
  try {
    text = FormatTextVocabulary(v.view(), "fuzz");
  } catch (const DataError&) {
    return;  // Not writable as DBoW2 text (k > 20, L > 10, or not a tree).
  }
  const VocabularyData parsed = ParseTextVocabulary(text, "formatted", 1);
  Check(parsed.info.num_nodes == v.num_nodes());
  Check(std::memcmp(parsed.view().links, v.view().links, 4 * v.num_nodes()) == 0);
  Check(FormatTextVocabulary(parsed.view(), "again") == text);
}

inline int Run(const uint8_t* data, size_t size) {
  Vocabulary v;
  try {
    v = Vocabulary::FromBytes({data, size}, "fuzz-input");
  } catch (const Error&) {
    return 0;
  }
  // Outside the try: an error using the vocabulary, or reading back what
  // the encoders wrote, is a finding.
  Exercise(v);
  RoundTrip(v);
  return 0;
}

}  // namespace rrslam::fuzz
