// libFuzzer target: the DBoW2 YAML vocabulary parser (vocabulary_yaml.h:
// ParseYamlVocabulary, through OpenCV's FileStorage; gzip-compressed input is
// inflated first), with the guard that keeps OpenCV's parser from looping
// forever (common/yaml_text.h).
//
// Any rrslam::Error is an accepted rejection; anything else (a crash, a hang,
// a sanitizer report, a cv::Exception or another exception, a broken
// property) is a finding. An accepted vocabulary passes the same checks as a
// loaded one (Vocabulary::FromData), is used (Exercise), round-trips through
// the binary and text formats (RoundTrip), and the YAML FormatYamlVocabulary
// writes for it parses back to the same arrays and formats to the same text.
//
// OpenCV and zlib are not instrumented: the sanitizers see their memory
// accesses only through the C library calls they intercept.
#include <cstring>
#include <span>
#include <string>

#include "stages/vocab/fuzz/fuzz_common.h"
#include "stages/vocab/vocabulary_yaml.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using rrslam::fuzz::Check;
  rrslam::VocabularyData parsed;
  try {
    parsed = rrslam::ParseYamlVocabulary({data, size}, "fuzz-input");
  } catch (const rrslam::Error&) {
    return 0;
  }
  // Outside the try: an error on what the parser accepted, or on what the
  // writers wrote, is a finding.
  const std::string yaml = rrslam::FormatYamlVocabulary(parsed.view(), "parsed");
  const std::span<const uint8_t> yaml_bytes(reinterpret_cast<const uint8_t*>(yaml.data()),
                                            yaml.size());
  const rrslam::VocabularyData again = rrslam::ParseYamlVocabulary(yaml_bytes, "formatted");
  const uint64_t n = parsed.info.num_nodes;
  Check(again.info.num_nodes == n && again.info.num_words == parsed.info.num_words);
  Check(std::memcmp(again.view().descriptors, parsed.view().descriptors, 32 * n) == 0);
  Check(std::memcmp(again.view().links, parsed.view().links, 4 * n) == 0);
  Check(std::memcmp(again.view().weights, parsed.view().weights, 4 * n) == 0);
  Check(rrslam::FormatYamlVocabulary(again.view(), "again") == yaml);

  const rrslam::Vocabulary v = rrslam::Vocabulary::FromData(std::move(parsed), "fuzz-input");
  rrslam::fuzz::Exercise(v);
  rrslam::fuzz::RoundTrip(v);
  return 0;
}
