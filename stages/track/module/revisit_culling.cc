#include "stages/track/module/revisit_culling.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "common/clock.h"
#include "stages/track/module/local_mapper.h"

namespace rrslam {

bool RevisitCullingOptions::Check(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (!(max_distance >= 0)) {
    return fail("revisit_distance = " + std::to_string(max_distance) + "; must be >= 0 (metres)");
  }
  if (!(max_angle_deg >= 0 && max_angle_deg <= 180)) {
    return fail("revisit_angle = " + std::to_string(max_angle_deg) +
                "; must be in [0, 180] (degrees)");
  }
  return true;
}

bool OlderKeyFrameHoldsView(const KeyFrame& keyframe, const RevisitCullingOptions& options) {
  const double min_cos = std::cos(options.max_angle_deg * M_PI / 180.0);
  // The optical axis in the world: the third row of R_cam_world.
  const Eigen::Vector3d axis = keyframe.R_cam_world().row(2).transpose();
  for (const KeyFrame* other :
       keyframe.CovisibleWithWeight(RevisitCullingOptions::kMinSharedPoints)) {
    if (other->bad() || other->id() + RevisitCullingOptions::kMinAge > keyframe.id()) {
      continue;
    }
    const double distance = (other->camera_centre() - keyframe.camera_centre()).norm();
    const double cos_angle = other->R_cam_world().row(2).dot(axis);
    if (distance <= options.max_distance && cos_angle >= min_cos) return true;
  }
  return false;
}

RevisitCullingStats CullRevisitKeyFrames(const SensorModel& sensor, KeyFrameId first_id, Map* map,
                                         KeyFrameDatabase* database,
                                         const RevisitCullingOptions& options) {
  RevisitCullingStats stats;
  if (!options.enabled) return stats;
  const auto start = SteadyClock::now();
  std::vector<KeyFrame*> keyframes = map->KeyFrames();
  // Oldest first: the keyframe holding a view is older, so already kept or
  // culled (then bad, and no longer a holder): every culled view is held by
  // a keyframe that stays.
  std::sort(keyframes.begin(), keyframes.end(),
            [](const KeyFrame* a, const KeyFrame* b) { return a->id() < b->id(); });
  for (KeyFrame* keyframe : keyframes) {
    if (keyframe->id() < first_id || keyframe->bad()) continue;
    if (!OlderKeyFrameHoldsView(*keyframe, options)) continue;
    ++stats.revisits;
    if (!IsRedundantKeyFrame(*keyframe, sensor, RevisitCullingOptions::kMinObservers,
                             RevisitCullingOptions::kRedundancy)) {
      continue;
    }
    if (map->CullKeyFrame(keyframe)) {
      database->Erase(keyframe);
      ++stats.culled;
    }
  }
  stats.ms = MillisecondsSince(start);
  return stats;
}

}  // namespace rrslam
