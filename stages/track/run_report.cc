#include "stages/track/run_report.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace rrslam {

TimingSummary SummarizeTimings(std::vector<double> values) {
  TimingSummary s;
  s.count = values.size();
  if (values.empty()) return s;
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  s.median = n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
  s.total = std::accumulate(values.begin(), values.end(), 0.0);
  s.mean = s.total / n;
  const size_t rank = static_cast<size_t>(std::ceil(0.95 * n));
  s.p95 = values[std::max<size_t>(rank, 1) - 1];
  s.max = values.back();
  return s;
}

nlohmann::json ToJson(const TimingSummary& s) {
  return {{"count", s.count}, {"median_ms", s.median}, {"mean_ms", s.mean},
          {"p95_ms", s.p95},  {"max_ms", s.max},       {"total_ms", s.total}};
}

Trajectory ResolveCameraTrajectory(const std::vector<TrackedFrame>& records) {
  Trajectory trajectory;
  for (const TrackedFrame& r : records) {
    if (!r.tracked || r.reference == nullptr) continue;
    const Rigid3d T_cam_world = ResolvePose(r.reference, r.T_cam_reference);
    trajectory.push_back({r.timestamp, T_cam_world.Inverse()});
  }
  return trajectory;
}

Trajectory KeyFrameTrajectory(const Map& map) {
  Trajectory trajectory;
  for (const KeyFrame* kf : map.KeyFrames()) {
    trajectory.push_back({kf->timestamp(), kf->T_world_cam()});
  }
  return trajectory;
}

}  // namespace rrslam
