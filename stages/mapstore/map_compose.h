// Large maps composed from a real one, for measuring how map operations
// scale (`make bench-scale`): copies of the map laid side by side on a grid,
// each joined to the previous one (JoinMaps: ids after the map so far, a
// loop edge between the two first keyframes) and with its descriptors
// perturbed, so that copies are told apart by matching as different places
// of one building would be.
//
// Frames: copy c is the base map moved by a translation along the base's
// world x and z axes (its first camera's ground directions), metres.
#pragma once

#include <cstdint>
#include <functional>

#include "stages/mapstore/map_data.h"

namespace rrslam {

struct ComposeOptions {
  int copies = 10;        // The result holds this many copies of the base, >= 1.
  double spacing = 20.0;  // Metres between neighbouring copies on the grid.
  // Descriptor bits flipped at random per descriptor in copies 1... (up to:
  // a bit may be drawn twice). Beyond ORB matching's 50-bit threshold
  // (TH_LOW): with 24, every copy still matched the base's keypoints, and
  // a place of the base looked like 100 places of the building.
  int flipped_bits = 64;
  uint64_t seed = 1;  // Of the bit flips: the result is reproducible.
};

// Called on every keyframe of copies 1... after its descriptors changed, to
// recompute what depends on them (its bag of words, with the vocabulary the
// caller holds); may be empty (the bags of words stay the base's).
using KeyFrameRebag = std::function<void(KeyFrameRecord*)>;

// The composed map: `options.copies` copies of `base` (copy 0 unchanged). A
// map point's representative descriptor gets the bits its first
// observation's keypoint got, so points and keypoints keep agreeing. Throws
// DataError when the ids would exceed their bound (MaxNextMapId); the result
// passes ValidateMapData.
MapData ComposeMap(const MapData& base, const ComposeOptions& options,
                   const KeyFrameRebag& rebag = {});

}  // namespace rrslam
