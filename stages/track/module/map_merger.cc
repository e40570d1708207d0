#include "stages/track/module/map_merger.h"

#include <cmath>
#include <vector>

#include "stages/track/match/matcher.h"

namespace rrslam {
namespace {

struct Hypothesis {
  KeyFrame* b_keyframe;
  KeyFrame* a_keyframe;
  Rigid3d T_a_b;
  int matches;
};

// The best-matching candidate of a for one keyframe of b, if any passes.
std::optional<Hypothesis> CheckKeyFrame(const SensorModel& sensor, const Map& a,
                                        const KeyFrameDatabase& a_database, KeyFrame* kb,
                                        const MapMergeOptions& options) {
  std::optional<Hypothesis> best;
  for (KeyFrame* ka : a_database.DetectRelocalizationCandidates(kb->bow())) {
    LoopCandidateMatch match;
    if (!CheckLoopCandidate(sensor, options.check, a.num_created_map_points(), kb, ka, &match) ||
        match.matches < options.check.min_loop_matches) {
      continue;
    }
    if (!best || match.matches > best->matches) {
      // match.T_cam_world: kb's camera in a's world.
      best = Hypothesis{kb, ka, match.T_cam_world.Inverse() * kb->T_cam_world(), match.matches};
    }
  }
  return best;
}

bool Agree(const Hypothesis& x, const Hypothesis& y, const Eigen::Vector3d& centre_b,
           const MapMergeOptions& options) {
  const double metres = (x.T_a_b * centre_b - y.T_a_b * centre_b).norm();
  const double degrees = x.T_a_b.rotation.angularDistance(y.T_a_b.rotation) * 180.0 / M_PI;
  return metres <= options.agree_metres && degrees <= options.agree_degrees;
}

}  // namespace

std::optional<MapOverlap> FindOverlap(const SensorModel& sensor, const Map& a,
                                      const KeyFrameDatabase& a_database, const Map& b,
                                      const MapMergeOptions& options) {
  std::vector<Hypothesis> passed;
  for (KeyFrame* kb : b.KeyFrames()) {
    if (kb->bad()) continue;
    if (auto h = CheckKeyFrame(sensor, a, a_database, kb, options)) passed.push_back(*h);
  }
  std::optional<MapOverlap> overlap;
  for (const Hypothesis& h : passed) {
    if (overlap && h.matches <= overlap->matches) continue;
    const Eigen::Vector3d centre_b = h.b_keyframe->camera_centre();
    int agreeing = 0;
    for (const Hypothesis& other : passed) {
      if (&other != &h && Agree(h, other, centre_b, options)) ++agreeing;
    }
    if (agreeing == 0) continue;
    overlap = MapOverlap{h.T_a_b,   h.a_keyframe->id(), h.b_keyframe->id(),
                         h.matches, agreeing,           static_cast<int>(passed.size())};
  }
  return overlap;
}

MapWeldStats WeldJoinedMap(const SensorModel& sensor, Map* joined, KeyFrameId first_b_keyframe,
                           MapPointId first_b_point, const MapMergeOptions& options) {
  MapWeldStats stats;
  std::vector<MapPoint*> a_points;
  for (MapPoint* p : joined->MapPoints()) {
    if (!p->bad() && p->id() < first_b_point) a_points.push_back(p);
  }
  const Matcher matcher(sensor, 0.8, true);
  for (KeyFrame* kb : joined->KeyFrames()) {
    if (kb->bad() || kb->id() < first_b_keyframe) continue;
    std::vector<MapPoint*> replace;
    stats.points_fused +=
        matcher.FuseForLoop(kb, a_points, joined, options.check.fuse_radius, &replace);
    for (size_t p = 0; p < replace.size(); ++p) {
      if (replace[p] != nullptr && !replace[p]->bad() && !a_points[p]->bad()) {
        joined->ReplaceMapPoint(replace[p], a_points[p]);
      }
    }
  }
  for (KeyFrame* kf : joined->KeyFrames()) {
    if (!kf->bad()) joined->UpdateConnections(kf);
  }
  MapRefinementOptions welding = options.welding;
  welding.first_free_keyframe = first_b_keyframe;
  stats.bundle_adjustment = RefineMap(sensor, joined, welding);
  return stats;
}

}  // namespace rrslam
