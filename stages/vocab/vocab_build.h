// Turning a vocabulary tree (rrslam-cluster) into a weighted vocabulary.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "common/orb_descriptor.h"
#include "common/progress.h"
#include "stages/cluster/vocab_tree.h"
#include "stages/vocab/vocabulary.h"
#include "stages/vocab/vocabulary_format.h"

namespace rrslam {

// The arrays of `tree` as a vocabulary: node ids, centres and structure kept,
// leaves become words (numbered in node order), every weight 0. Throws
// DataError naming `source` when the tree breaks an invariant.
VocabularyData VocabularyFromTree(const VocabTree& tree, WeightingType weighting,
                                  ScoringType scoring, const std::string& source);

// Sets the word weights of `data` from training images, each image being the
// descriptors of one frame, as DBoW2's setNodeWeights:
//   tf, binary:   every word 1;
//   idf, tf-idf:  log(N / N_i), N images, N_i of them with a descriptor whose
//                 word is i; words of no image keep weight 0 (never counted).
// Uses up to `threads` threads (0 = all); the result does not depend on it.
// `progress`, if given, advances by one per image.
void SetWordWeights(std::span<const std::span<const OrbDescriptor>> images, int threads,
                    VocabularyData* data, ProgressBar* progress = nullptr);

}  // namespace rrslam
