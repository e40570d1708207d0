// Writes an ORBvoc-shaped DBoW2 text vocabulary for the vocabulary benchmark:
// k = 10, L = 6, about 1.08 M nodes (ORB-SLAM2's ORBvoc.txt has 1,082,073),
// random descriptors and random idf-like word weights, nodes numbered and
// laid out exactly as DBoW2's saveToTextFile writes them.
//
// Shape: levels 1-5 full (111,111 nodes with the root); each level-5 node
// has 10 children with probability 0.88, else 6 to 9, and 0.5 % of them are
// leaves, which gives 1.08 M nodes like the real file.
//
// Usage: vocab_bench_generate OUT.txt [SEED]
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <random>
#include <vector>

#include "stages/vocab/vocabulary_format.h"

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s OUT.txt [SEED]\n", argv[0]);
    return 64;
  }
  const uint64_t seed = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : 1;
  constexpr int kK = 10, kL = 6;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);

  // Parent ids in DBoW2 order: a node's children get consecutive ids when the
  // node is visited, nodes are visited in depth-first pre-order.
  std::vector<uint32_t> parents{0};
  std::vector<uint8_t> level{0};
  std::function<void(uint32_t)> visit = [&](uint32_t node) {
    if (level[node] == kL) return;
    int children = kK;
    if (level[node] == kL - 1) {
      if (u(rng) < 0.005) return;  // A leaf one level up.
      if (u(rng) >= 0.88) children = 6 + static_cast<int>(rng() % 4);
    }
    const uint32_t first = static_cast<uint32_t>(parents.size());
    for (int c = 0; c < children; ++c) {
      parents.push_back(node);
      level.push_back(static_cast<uint8_t>(level[node] + 1));
    }
    for (int c = 0; c < children; ++c) visit(first + c);
  };
  visit(0);

  rrslam::VocabularyData data;
  data.info.k = kK;
  data.info.levels = kL;
  data.info.weighting = rrslam::WeightingType::kTfIdf;
  data.info.scoring = rrslam::ScoringType::kL1;
  data.Allocate(parents.size());
  rrslam::LinksFromParents(parents, &data.info, data.links(), "generated");
  std::uniform_real_distribution<float> idf(0.05f, 12.0f);
  for (size_t i = 0; i < parents.size(); ++i) {
    rrslam::OrbDescriptor& d = data.descriptors()[i];
    for (auto& b : d.bytes) b = i == 0 ? 0 : static_cast<uint8_t>(rng());
    data.weights()[i] = rrslam::LinkChildren(data.links()[i]) == 0 && i > 0 ? idf(rng) : 0.0f;
  }
  rrslam::WriteTextVocabulary(argv[1], data.view(), argv[1]);
  std::printf("%s: k=%d L=%d nodes=%llu words=%llu\n", argv[1], kK, kL,
              static_cast<unsigned long long>(data.info.num_nodes),
              static_cast<unsigned long long>(data.info.num_words));
  return 0;
}
