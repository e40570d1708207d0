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
#include "common/fuzz/h5_image_builder.h"
#include "stages/cluster/fuzz/vocab_tree_schema.h"
#include "stages/cluster/vocab_tree.h"

namespace {

void Check(bool condition) {
  if (!condition) std::abort();
}

bool raw = false;

void Exercise(std::span<const uint8_t> bytes) {
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

}  // namespace

// A 16 MB quarantine for freed memory instead of AddressSanitizer's 256 MB:
// libhdf5 allocates and frees megabytes per file, and with the large
// quarantine nearly every allocation touched fresh pages (3 to 4 times fewer
// runs per second). Freed memory is still held back long enough to catch a
// use after free within one run. ASAN_OPTIONS overrides it.
extern "C" const char* __asan_default_options() { return "quarantine_size_mb=16"; }

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  H5::Exception::dontPrint();  // As the tools do (common/cli.cc): errors are exceptions.
  rrslam::fuzz::KeepH5FreeLists();
  const char* mode = std::getenv("RRSLAM_FUZZ_H5_RAW");
  raw = mode != nullptr && std::string(mode) == "1";
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (raw) {
    Exercise({data, size});
    return 0;
  }
  rrslam::fuzz::FuzzInput in(data, size);
  const std::vector<rrslam::fuzz::H5Object> objects = rrslam::fuzz::VocabTreeObjects(in);
  Exercise(rrslam::fuzz::BuildH5Image(in, objects));
  return 0;
}
