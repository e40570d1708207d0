// Differences between two saved maps: map points added or removed (by
// position, within a radius) and keyframes added or removed (by id).
//
// Thread-safety: reentrant; no shared state.
#pragma once

#include <cstdint>
#include <vector>

#include "stages/mapstore/map_data.h"

namespace rrslam {

// A map point named in a diff: its id in its own map and its position.
struct MapDiffPoint {
  uint64_t id = 0;
  double position[3] = {0, 0, 0};  // World frame of its map, metres.
};

struct MapDiff {
  double radius = 0;  // Metres, as given to DiffMaps.
  uint64_t a_keyframes = 0, b_keyframes = 0;
  uint64_t a_map_points = 0, b_map_points = 0;
  // Points of B with no point of A within `radius` (sorted by id), and points
  // of A with no point of B within `radius` (sorted by id).
  std::vector<MapDiffPoint> added_points;
  std::vector<MapDiffPoint> removed_points;
  // Keyframe ids in B and not in A, and in A and not in B (sorted).
  std::vector<uint64_t> added_keyframes;
  std::vector<uint64_t> removed_keyframes;
};

// Compares `a` (before) with `b` (after). Both maps' positions are taken in
// their own world frames as they are (no alignment): maps saved by runs that
// share their first keyframe share their frame. Nearest neighbours come from
// an exact FLANN kd-tree; a point is matched when its nearest neighbour in the
// other map lies at distance <= `radius` (> 0, metres). Throws
// std::invalid_argument when radius is not positive and finite.
MapDiff DiffMaps(const MapData& a, const MapData& b, double radius);

}  // namespace rrslam
