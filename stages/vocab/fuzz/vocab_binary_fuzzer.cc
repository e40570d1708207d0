// libFuzzer target: the binary vocabulary loader (rrslam.vocabulary).
// Inputs that do not start with the magic are given one, so the fuzzer spends
// its time past the magic check.
#include <cstring>

#include "common/formats.h"
#include "stages/vocab/fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size >= 8 && std::memcmp(data, rrslam::kVocabularyFormat.magic, 8) == 0) {
    return rrslam::fuzz::Run(data, size);
  }
  std::vector<uint8_t> with_magic(rrslam::kVocabularyFormat.magic,
                                  rrslam::kVocabularyFormat.magic + 8);
  with_magic.insert(with_magic.end(), data, data + size);
  return rrslam::fuzz::Run(with_magic.data(), with_magic.size());
}
