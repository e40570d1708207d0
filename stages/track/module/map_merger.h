// Map merging (issue 31): two maps of one place, made with the same
// vocabulary and camera, welded into one in the first map's world frame
// (`rrslam-mapstore merge`; the schema side is mapstore's JoinMaps).
//  1. Overlap: every keyframe of map b asks map a's keyframe database for
//     candidates (bag of words, as relocalization does) and checks each as
//     loop closing checks a loop candidate (CheckLoopCandidate: BoW
//     matching, rigid 3D-3D RANSAC with Eigen's umeyama on the RGB-D points,
//     guided matching, relative-pose optimization, then the points of the
//     candidate and its covisible keyframes projected: at least
//     min_loop_matches). Each keyframe of b that passes gives a transform
//     T_a_b; the one with the most matches is taken when another keyframe of
//     b gives a transform that agrees with it (loop closing's consistency:
//     one view alone can match a look-alike place).
//  2. Join (JoinMaps): b moved by T_a_b, its ids after a's, its spanning tree
//     hung from the matched keyframe of a.
//  3. Weld: the points of a projected into every keyframe of b fuse with the
//     keypoints they match (loop fusion: a's point survives), covisibility
//     is rebuilt, and a bundle adjustment of b's keyframes and every point
//     they see, a's keyframes held fixed, runs to convergence (the map
//     refinement's two passes): it spreads the correction over b, as the
//     essential graph and global BA do after a loop.
//
// Frames: T_a_b maps map b's world points into map a's (x_a = T_a_b * x_b).
// Not thread-safe: offline, no other thread on the maps.
#pragma once

#include <optional>

#include "stages/track/data/keyframe_database.h"
#include "stages/track/data/map.h"
#include "stages/track/data/sensor_model.h"
#include "stages/track/module/loop_closer.h"
#include "stages/track/optimize/map_refinement.h"

namespace rrslam {

struct MapMergeOptions {
  LoopClosingOptions check;  // The loop candidates' geometric check and fusion radius.
  // Two keyframes' transforms agree when they place the best keyframe's
  // camera within these of each other.
  double agree_metres = 0.05;
  double agree_degrees = 2.0;
  MapRefinementOptions welding;  // first_free_keyframe is set by WeldJoinedMap.
};

// Where map b sees map a.
struct MapOverlap {
  Rigid3d T_a_b;
  KeyFrameId a_keyframe = 0;  // Id in map a.
  KeyFrameId b_keyframe = 0;  // Id in map b.
  int matches = 0;            // Of the best keyframe (CheckLoopCandidate's projection search).
  int agreeing = 0;           // Other keyframes of b whose transform agrees.
  int matched_keyframes = 0;  // Keyframes of b that passed the check.
};

// Step 1 for one keyframe of b: the candidate of a (a's keyframe database,
// bag of words) that passes CheckLoopCandidate with the most matches, as
// the transform it gives; nullopt when none passes. The caller holds the
// maps' locks.
struct KeyFrameOverlap {
  KeyFrame* b_keyframe = nullptr;
  KeyFrame* a_keyframe = nullptr;
  Rigid3d T_a_b;
  int matches = 0;
};
std::optional<KeyFrameOverlap> MatchKeyFrame(const SensorModel& sensor, const Map& a,
                                             const KeyFrameDatabase& a_database, KeyFrame* kb,
                                             const MapMergeOptions& options = {});
// Whether two keyframes' transforms agree (MapMergeOptions::agree_*), at
// x's keyframe of b.
bool OverlapsAgree(const KeyFrameOverlap& x, const KeyFrameOverlap& y,
                   const MapMergeOptions& options = {});

// Step 1; nullopt when no keyframe of b passes with another agreeing.
std::optional<MapOverlap> FindOverlap(const SensorModel& sensor, const Map& a,
                                      const KeyFrameDatabase& a_database, const Map& b,
                                      const MapMergeOptions& options = {});

struct MapWeldStats {
  int points_fused = 0;  // Points of b replaced by a's, or observations a's points gained.
  MapRefinementStats bundle_adjustment;
};

// Step 3 on the joined map: keyframes with ids >= first_b_keyframe and
// points with ids >= first_b_point came from map b.
MapWeldStats WeldJoinedMap(const SensorModel& sensor, Map* joined, KeyFrameId first_b_keyframe,
                           MapPointId first_b_point, const MapMergeOptions& options = {});

// Online merge (module/atlas.h), steps 2 and 3 on live maps: `b` (the map
// being tracked) is moved into a's world by overlap.T_a_b, its spanning tree
// re-rooted at overlap.b_keyframe and hung from overlap.a_keyframe (a loop
// edge between the two), then `b` absorbs every object of `a` (Map::Absorb:
// b's ids must all be above a's), a's keyframes join `b_database`, and the
// joined map is welded. Pointers to b's objects stay valid; poses held
// outside the maps (the tracker's) must be moved by T_a_b too. The caller
// holds b's lock; no other thread may use the maps.
MapWeldStats MergeLiveMaps(const SensorModel& sensor, const KeyFrameOverlap& overlap, Map* a,
                           Map* b, KeyFrameDatabase* b_database,
                           const MapMergeOptions& options = {});

}  // namespace rrslam
