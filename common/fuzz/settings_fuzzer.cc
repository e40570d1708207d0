// libFuzzer target: the settings YAML reader (common/settings.h:
// ParseSettings and ParseViewpoint, ORB-SLAM2's layout through OpenCV's
// FileStorage), the text that ReadSettings and ReadViewpoint read from a file
// and that a features file records.
//
// Any rrslam::Error is an accepted rejection; anything else (a crash, a
// sanitizer report, a cv::Exception or another exception, a broken property)
// is a finding. Properties: accepted settings pass Check; the text
// FormatSettings writes for them parses again (rrslam reads back what it
// writes) to settings that format to the same text; an accepted viewpoint
// has a finite eye off the origin and f > 0.
//
// OpenCV itself is not instrumented: the sanitizers see its memory accesses
// only through the C library calls they intercept.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <string>

#include "common/errors.h"
#include "common/fuzz/check.h"
#include "common/settings.h"

using rrslam::fuzz::Check;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::optional<rrslam::Settings> s;
  try {
    s = rrslam::ParseSettings(text, "fuzz-input");
  } catch (const rrslam::Error&) {
  }
  if (s) {
    std::string why;
    Check(s->Check(&why));
    // Outside the try: an error reading back what FormatSettings wrote is a finding.
    const std::string formatted = rrslam::FormatSettings(*s);
    const rrslam::Settings again = rrslam::ParseSettings(formatted, "formatted");
    Check(rrslam::FormatSettings(again) == formatted);
  }
  try {
    const rrslam::Viewpoint v = rrslam::ParseViewpoint(text, "fuzz-input");
    Check(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z) && std::isfinite(v.f));
    Check(v.f > 0 && (v.x != 0 || v.y != 0 || v.z != 0));
  } catch (const rrslam::Error&) {
  }
  return 0;
}
