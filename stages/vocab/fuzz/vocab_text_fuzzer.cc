// libFuzzer target: the DBoW2 text vocabulary parser.
#include <cstring>

#include "common/formats.h"
#include "stages/vocab/fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // Inputs with the binary magic belong to the other target.
  if (size >= 8 && std::memcmp(data, rrslam::kVocabularyFormat.magic, 8) == 0) return 0;
  return rrslam::fuzz::Run(data, size);
}
