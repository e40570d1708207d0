// Test helpers of the vocab stage: random vocabularies in DBoW2 node order
// and small hand-built ones. Test code only.
#pragma once

#include <cstring>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "stages/vocab/vocabulary_format.h"

namespace rrslam::testing {

// A descriptor whose 32 bytes all equal `value`.
inline OrbDescriptor Filled(uint8_t value) {
  OrbDescriptor d;
  std::memset(d.bytes, value, sizeof(d.bytes));
  return d;
}

inline OrbDescriptor RandomOrbDescriptor(std::mt19937_64& rng) {
  OrbDescriptor d;
  for (auto& b : d.bytes) b = static_cast<uint8_t>(rng());
  return d;
}

// A vocabulary from parent ids in DBoW2 order (parents[0] ignored), with the
// given descriptors and weights (weights of inner nodes should be 0).
inline VocabularyData MakeVocabulary(int k, int levels, const std::vector<uint32_t>& parents,
                                     const std::vector<OrbDescriptor>& descriptors,
                                     const std::vector<float>& weights,
                                     WeightingType weighting = WeightingType::kTfIdf,
                                     ScoringType scoring = ScoringType::kL1) {
  VocabularyData data;
  data.info.k = k;
  data.info.levels = levels;
  data.info.weighting = weighting;
  data.info.scoring = scoring;
  data.Allocate(parents.size());
  LinksFromParents(parents, &data.info, data.links(), "test");
  for (size_t i = 0; i < parents.size(); ++i) {
    data.descriptors()[i] = descriptors[i];
    data.weights()[i] = weights[i];
  }
  return data;
}

// A random tree of branching factor <= k and depth <= levels, numbered as
// DBoW2 numbers nodes (children consecutive, assigned in depth-first
// pre-order), with random descriptors and random word weights. `split` is
// the probability that a node above level L is split.
inline VocabularyData RandomVocabulary(int k, int levels, uint64_t seed, double split = 0.8,
                                       size_t max_nodes = 200000) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<uint32_t> parents{0};
  std::vector<int> level{0};
  std::function<void(uint32_t)> expand = [&](uint32_t node) {
    if (level[node] >= levels || parents.size() >= max_nodes) return;
    if (node != 0 && u(rng) > split) return;
    const int children = 1 + static_cast<int>(rng() % static_cast<uint64_t>(k));
    const uint32_t first = static_cast<uint32_t>(parents.size());
    for (int c = 0; c < children; ++c) {
      parents.push_back(node);
      level.push_back(level[node] + 1);
    }
    for (int c = 0; c < children; ++c) expand(first + c);
  };
  expand(0);
  std::vector<OrbDescriptor> descriptors(parents.size());
  std::vector<float> weights(parents.size(), 0.0f);
  for (size_t i = 1; i < parents.size(); ++i) descriptors[i] = RandomOrbDescriptor(rng);
  VocabularyData data = MakeVocabulary(k, levels, parents, descriptors, weights);
  std::uniform_real_distribution<float> w(0.01f, 9.0f);
  for (size_t i = 1; i < parents.size(); ++i) {
    if (LinkChildren(data.links()[i]) == 0) data.weights()[i] = w(rng);
  }
  return data;
}

inline std::string DescriptorText(const OrbDescriptor& d) {
  std::string s;
  for (uint8_t b : d.bytes) s += std::to_string(b) + " ";
  return s;
}

}  // namespace rrslam::testing
