#include "stages/track/data/depth_evidence.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>

namespace rrslam {

double DepthEvidenceGap(double z) {
  constexpr double kMinGapMetres = 0.1, kMinGapRelative = 0.15;
  return std::max(kMinGapMetres, kMinGapRelative * z);
}

double DepthCoverGap(double z) {
  constexpr double kMinGapMetres = 0.03, kMinGapRelative = 0.03;
  return std::max(kMinGapMetres, kMinGapRelative * z);
}

DepthEvidence DepthEvidenceAt(const cv::Mat& depth_metres, const Eigen::Vector2d& pixel, double z) {
  // A window rather than one pixel: a point on an edge has the edge's near
  // side in its window, so a depth edge is never taken for seeing through.
  constexpr int kRadius = 2;
  constexpr int kWindow = (2 * kRadius + 1) * (2 * kRadius + 1);
  const int u = static_cast<int>(std::lround(pixel.x()));
  const int v = static_cast<int>(std::lround(pixel.y()));
  if (depth_metres.empty() || u - kRadius < 0 || v - kRadius < 0 ||
      u + kRadius >= depth_metres.cols || v + kRadius >= depth_metres.rows) {
    return DepthEvidence::kNone;
  }
  const double gap = DepthEvidenceGap(z);
  int valid = 0;
  bool present = false;
  for (int y = v - kRadius; y <= v + kRadius; ++y) {
    const float* row = depth_metres.ptr<float>(y);
    for (int x = u - kRadius; x <= u + kRadius; ++x) {
      const float d = row[x];
      if (!(d > 0) || !std::isfinite(d)) continue;
      ++valid;
      if (d < z - gap) return DepthEvidence::kNone;  // In front: occluded, or an edge.
      if (d <= z + gap) present = true;
    }
  }
  if (2 * valid < kWindow) return DepthEvidence::kNone;
  return present ? DepthEvidence::kPresent : DepthEvidence::kSeenThrough;
}

}  // namespace rrslam
