// Two saved maps of one place as one (the schema side of map merging,
// `rrslam-mapstore merge`; track finds the transform and welds the maps).
//
// Frames: each MapData's poses are T_cam_world in its own world frame.
// T_a_b maps map b's world points into map a's world (x_a = T_a_b * x_b).
#pragma once

#include <cstdint>

#include "common/geometry.h"
#include "stages/mapstore/map_data.h"

namespace rrslam {

// A MapPose as a transform and back, bit for bit (ValidateMapData checks
// that a record's quaternion is of unit norm).
Rigid3d RigidOf(const MapPose& pose);
MapPose MapPoseOf(const Rigid3d& T);

// Every keyframe pose, map point position and normal of `map` moved into
// another world frame by T_new_old (x_new = T_new_old * x_old); ids, graphs
// and metadata unchanged.
void MoveMap(const Rigid3d& T_new_old, MapData* map);

// Map `b` moved into map `a`'s world frame by T_a_b and appended to `a`:
// b's keyframe and map point ids follow a's (b's id + a's next id, so a's
// ids are kept and b's keep their order), its poses, positions and normals
// are moved, and its spanning tree is re-rooted at `b_keyframe` (an id of
// b), which becomes a child of `a_keyframe` (an id of a); both get a loop
// edge, so the place where the maps were joined is never culled. Nothing
// is fused: the maps share no point and no covisibility edge yet. The
// camera, vocabulary, BoW grouping and metadata are a's; a's other maps,
// then b's, are kept beside it (map_data.h). Throws DataError
// naming `source` when either keyframe id is not in its map or the joined
// next ids exceed MaxNextMapId; the result passes ValidateMapData.
MapData JoinMaps(MapData a, MapData b, const Rigid3d& T_a_b, uint64_t a_keyframe,
                 uint64_t b_keyframe, const std::string& source);

}  // namespace rrslam
