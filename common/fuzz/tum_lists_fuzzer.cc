// libFuzzer target: the TUM RGB-D sequence lists (common/dataset.h):
// ParseTimestampList (rgb.txt, depth.txt), ParseAssociations (associations
// files) and AssociateTimestamps (associate.py's pairing of rgb.txt with
// depth.txt), the text RgbdSequence::Open reads.
//
// The input is one list, or two separated by a form feed ('\f', which no
// list contains): the rgb and the depth list. Any rrslam::Error is an
// accepted rejection; anything else (a crash, a sanitizer report, another
// exception, a broken property) is a finding. Properties: timestamps are
// finite; associations pair each stamp at most once, closer than the window,
// in increasing rgb time.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string_view>
#include <utility>
#include <vector>

#include "common/dataset.h"
#include "common/errors.h"
#include "common/fuzz/check.h"

using rrslam::fuzz::Check;

namespace {

std::vector<double> Stamps(std::string_view text, const std::string& source) {
  std::vector<double> stamps;
  for (const auto& [stamp, path] : rrslam::ParseTimestampList(text, source)) {
    Check(std::isfinite(stamp) && !path.empty());
    stamps.push_back(stamp);
  }
  return stamps;
}

void CheckAssociation(const std::vector<double>& a, const std::vector<double>& b,
                      double max_difference, double offset) {
  const auto pairs = rrslam::AssociateTimestamps(a, b, max_difference, offset);
  Check(pairs.size() <= std::min(a.size(), b.size()));
  std::vector<uint8_t> used_a(a.size(), 0), used_b(b.size(), 0);
  for (size_t k = 0; k < pairs.size(); ++k) {
    const auto [i, j] = pairs[k];
    Check(i < a.size() && j < b.size() && !used_a[i] && !used_b[j]);
    used_a[i] = used_b[j] = 1;
    Check(std::fabs(a[i] - (b[j] + offset)) < max_difference);
    if (k > 0) Check(a[pairs[k - 1].first] <= a[i]);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const size_t split = text.find('\f');
  const std::string_view rgb = text.substr(0, split);
  const std::string_view depth = split == std::string_view::npos ? text : text.substr(split + 1);
  try {
    const std::vector<double> a = Stamps(rgb, "rgb.txt");
    const std::vector<double> b = Stamps(depth, "depth.txt");
    CheckAssociation(a, b, 0.02, 0.0);
    CheckAssociation(a, b, 0.5, -0.01);
  } catch (const rrslam::Error&) {
  }
  try {
    for (const rrslam::RgbdFrameRef& f :
         rrslam::ParseAssociations(text, "seq", "associations.txt")) {
      Check(std::isfinite(f.rgb_timestamp) && std::isfinite(f.depth_timestamp));
      // Relative paths are taken inside the sequence folder (a path naming a
      // folder or nothing is RgbdSequence::Open's error, not the parser's).
      for (const std::filesystem::path& p : {f.rgb_path, f.depth_path}) {
        Check(p.is_absolute() || p.string().starts_with("seq/"));
      }
    }
  } catch (const rrslam::Error&) {
  }
  return 0;
}
