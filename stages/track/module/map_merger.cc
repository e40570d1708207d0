#include "stages/track/module/map_merger.h"

#include <cmath>
#include <vector>

#include "stages/track/match/matcher.h"

namespace rrslam {
namespace {

// Every keyframe and point of `map` moved into another world frame
// (x_new = T_new_old * x_old): keyframes not yet in the map too (realtime
// mode: created by the tracker, with their points in the map, and queued
// for local mapping); culled keyframes keep their pose relative to their
// parent, which moves with it.
void MoveLiveMap(const Rigid3d& T_new_old, Map* map) {
  const Rigid3d T_old_new = T_new_old.Inverse();
  for (KeyFrameId id = 0; id < map->num_created_keyframes(); ++id) {
    KeyFrame* kf = map->keyframe_by_id(id);
    if (kf != nullptr && !kf->bad()) kf->SetPose(kf->T_cam_world() * T_old_new);
  }
  for (MapPoint* p : map->MapPoints()) {
    p->SetPosition(T_new_old * p->position_world());
    p->SetNormalAndDistances(T_new_old.rotation * p->normal(), p->min_distance(),
                             p->max_distance());
  }
}

// `new_root`'s part of the spanning tree re-rooted at it (the parent links
// from it up to its root reversed), then hung from `parent`.
void HangTreeFrom(KeyFrame* new_root, KeyFrame* parent) {
  std::vector<KeyFrame*> path;
  for (KeyFrame* k = new_root; k != nullptr; k = k->parent()) path.push_back(k);
  for (size_t i = path.size() - 1; i > 0; --i) path[i]->SetParent(path[i - 1]);
  new_root->SetParent(parent);
  new_root->AddLoopEdge(parent);
  parent->AddLoopEdge(new_root);
}

}  // namespace

std::optional<KeyFrameOverlap> MatchKeyFrame(const SensorModel& sensor, const Map& a,
                                             const KeyFrameDatabase& a_database, KeyFrame* kb,
                                             const MapMergeOptions& options) {
  std::optional<KeyFrameOverlap> best;
  for (KeyFrame* ka : a_database.DetectRelocalizationCandidates(kb->bow())) {
    LoopCandidateMatch match;
    if (!CheckLoopCandidate(sensor, options.check, a.num_created_map_points(), kb, ka, &match) ||
        match.matches < options.check.min_loop_matches) {
      continue;
    }
    if (!best || match.matches > best->matches) {
      // match.T_cam_world: kb's camera in a's world.
      best =
          KeyFrameOverlap{kb, ka, match.T_cam_world.Inverse() * kb->T_cam_world(), match.matches};
    }
  }
  return best;
}

bool OverlapsAgree(const KeyFrameOverlap& x, const KeyFrameOverlap& y,
                   const MapMergeOptions& options) {
  const Eigen::Vector3d centre_b = x.b_keyframe->camera_centre();
  const double metres = (x.T_a_b * centre_b - y.T_a_b * centre_b).norm();
  const double degrees = x.T_a_b.rotation.angularDistance(y.T_a_b.rotation) * 180.0 / M_PI;
  return metres <= options.agree_metres && degrees <= options.agree_degrees;
}

std::optional<MapOverlap> FindOverlap(const SensorModel& sensor, const Map& a,
                                      const KeyFrameDatabase& a_database, const Map& b,
                                      const MapMergeOptions& options) {
  std::vector<KeyFrameOverlap> passed;
  for (KeyFrame* kb : b.KeyFrames()) {
    if (kb->bad()) continue;
    if (auto h = MatchKeyFrame(sensor, a, a_database, kb, options)) passed.push_back(*h);
  }
  std::optional<MapOverlap> overlap;
  for (const KeyFrameOverlap& h : passed) {
    if (overlap && h.matches <= overlap->matches) continue;
    int agreeing = 0;
    for (const KeyFrameOverlap& other : passed) {
      if (&other != &h && OverlapsAgree(h, other, options)) ++agreeing;
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

MapWeldStats MergeLiveMaps(const SensorModel& sensor, const KeyFrameOverlap& overlap, Map* a,
                           Map* b, KeyFrameDatabase* b_database, const MapMergeOptions& options) {
  const KeyFrameId first_b_keyframe = a->num_created_keyframes();
  const MapPointId first_b_point = a->num_created_map_points();
  MoveLiveMap(overlap.T_a_b, b);
  HangTreeFrom(overlap.b_keyframe, overlap.a_keyframe);
  const std::vector<KeyFrame*> a_keyframes = a->KeyFrames();
  b->Absorb(a);
  b_database->AddAll(a_keyframes);
  return WeldJoinedMap(sensor, b, first_b_keyframe, first_b_point, options);
}

}  // namespace rrslam
