// libFuzzer target: the vocabulary tree reader (rrslam.vocab_tree, HDF5).
//
// Each input describes a tree file (vocab_tree_schema.h), which
// common/fuzz/h5_image_builder.h writes as an HDF5 file image in memory,
// keeping or damaging each object as the input decides; the reader then
// opens the image's bytes (ReadVocabTreeImage, through OpenH5FileImage's
// core driver: no file is written), so the mutations reach the root
// attribute checks, the schema checks and ValidateVocabTree. (Why not mutate
// the file's bytes themselves: see h5_image_builder.h. With
// RRSLAM_FUZZ_H5_RAW=1 in the environment the input is the file image
// itself, to fuzz libhdf5's parser; seeds in fuzz/corpus_h5.)
//
// Any rrslam::Error is an accepted rejection; anything else (a crash, a
// sanitizer report, an H5::Exception or another exception, a broken
// property) is a finding. Properties of an accepted tree, which
// `rrslam-vocab build` relies on: the child ranges cover every node but the
// root once, inside the tree, with at most k children each, and the leaves
// counted by NumLeaves are the nodes without children.
//
// libhdf5 itself is not instrumented: the sanitizers see its memory accesses
// only through the C library calls they intercept (memcpy, strlen, ...).
#include <H5Cpp.h>

#include <cstdint>
#include <cstdlib>
#include <span>
#include <string>
#include <vector>

#include "common/errors.h"
#include "common/fuzz/check.h"
#include "common/fuzz/h5_fuzz_main.h"
#include "stages/cluster/fuzz/vocab_tree_schema.h"
#include "stages/cluster/vocab_tree.h"

namespace rrslam::fuzz {

std::vector<H5Object> TargetObjects(FuzzInput& in) { return VocabTreeObjects(in); }

void TargetExercise(std::span<const uint8_t> bytes) {
  try {
    const rrslam::VocabTree tree = rrslam::ReadVocabTreeImage(bytes, "fuzz-input");
    const size_t n = tree.num_nodes();
    Check(n >= 2 && tree.level.size() == n && tree.centre.size() == n && tree.count.size() == n);
    const auto ranges = tree.ChildRanges();
    Check(ranges.size() == n);
    std::vector<uint8_t> covered(n, 0);
    size_t childless = 0;
    for (size_t i = 0; i < n; ++i) {
      const auto [first, count] = ranges[i];
      Check(count <= static_cast<uint32_t>(tree.k));
      if (count == 0) {
        childless += i > 0;
        continue;
      }
      Check(first > i && uint64_t{first} + count <= n);
      for (uint32_t c = first; c < first + count; ++c) {
        Check(covered[c] == 0 && tree.parent[c] == static_cast<int32_t>(i));
        covered[c] = 1;
      }
    }
    for (size_t i = 1; i < n; ++i) Check(covered[i] == 1);
    Check(tree.NumLeaves() == childless && childless >= 1);
  } catch (const rrslam::Error&) {
  }
}

}  // namespace rrslam::fuzz
