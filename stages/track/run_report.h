// Outputs of a tracking run: the camera and keyframe trajectories (TUM
// format) and the timing statistics recorded in run.json.
#pragma once

#include <nlohmann/json.hpp>
#include <vector>

#include "common/trajectory.h"
#include "stages/track/data/map.h"
#include "stages/track/module/tracker.h"

namespace rrslam {

// Statistics of per-item durations in milliseconds. The median of an even
// count is the mean of the two middle values; p95 is the nearest-rank 95th
// percentile (the smallest value with at least 95% of the values <= it).
struct TimingSummary {
  size_t count = 0;
  double median = 0, mean = 0, p95 = 0, max = 0, total = 0;
};
TimingSummary SummarizeTimings(std::vector<double> values_ms);
nlohmann::json ToJson(const TimingSummary& summary);

// Pose of every tracked frame, as ORB-SLAM2 writes CameraTrajectory.txt: the
// frame's pose relative to its reference keyframe composed with that
// keyframe's final pose; a culled reference is replaced by its parent
// (T_cam_parent recorded at culling), repeatedly. Untracked frames are left out.
Trajectory ResolveCameraTrajectory(const std::vector<TrackedFrame>& records);

// Final pose of every keyframe in the map, by id (KeyFrameTrajectory.txt).
Trajectory KeyFrameTrajectory(const Map& map);

}  // namespace rrslam
