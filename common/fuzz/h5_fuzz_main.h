// Fuzz-only: the libFuzzer entry points of a fuzz target for an HDF5 reader
// (stages/extract/fuzz/features_fuzzer.cc, stages/cluster/fuzz/
// vocab_tree_fuzzer.cc). Include it in the target's one source file, which
// defines the two functions declared below.
//
// Each input is a description of a file (h5_image_builder.h), built into an
// HDF5 file image and passed to TargetExercise; with RRSLAM_FUZZ_H5_RAW=1 in
// the environment the input is passed as the file image itself, to fuzz
// libhdf5's own parser (seeds in the target's fuzz/corpus_h5).
#pragma once

#include <H5Cpp.h>

#include <cstdint>
#include <cstdlib>
#include <span>
#include <string>
#include <vector>

#include "common/fuzz/h5_image_builder.h"

namespace rrslam::fuzz {

// The objects of a well-formed file, as far as `in` keeps them (the target's
// schema, e.g. FeaturesObjects).
std::vector<H5Object> TargetObjects(FuzzInput& in);

// Reads the file image with the reader under test and checks its properties
// (Check); an rrslam::Error is an accepted rejection.
void TargetExercise(std::span<const uint8_t> image);

inline bool h5_fuzz_raw = false;

}  // namespace rrslam::fuzz

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
  rrslam::fuzz::h5_fuzz_raw = mode != nullptr && std::string(mode) == "1";
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (rrslam::fuzz::h5_fuzz_raw) {
    rrslam::fuzz::TargetExercise({data, size});
  } else {
    rrslam::fuzz::TargetExercise(
        rrslam::fuzz::BuildH5Image({data, size}, rrslam::fuzz::TargetObjects));
  }
  return 0;
}
