#include "stages/mapstore/map_compose.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <unordered_map>
#include <utility>

#include "common/errors.h"
#include "stages/mapstore/map_join.h"

namespace rrslam {
namespace {

// Flips `bits` distinct random bits of every keyframe descriptor, and gives
// each map point the descriptor of its first observation's keypoint as
// changed (or its own, flipped, when it has none in this map).
void PerturbDescriptors(MapData* map, int bits, std::mt19937_64* rng) {
  std::uniform_int_distribution<int> bit(0, 255);
  const auto flip = [&](OrbDescriptor* d) {
    for (int b = 0; b < bits; ++b) {
      const int i = bit(*rng);
      d->bytes[i / 8] ^= static_cast<uint8_t>(1u << (i % 8));
    }
  };
  std::unordered_map<uint64_t, const KeyFrameRecord*> by_id;
  for (KeyFrameRecord& kf : map->keyframes) {
    for (OrbDescriptor& d : kf.descriptors) flip(&d);
    by_id[kf.id] = &kf;
  }
  for (MapPointRecord& p : map->map_points) {
    const auto first = p.observations.empty() ? by_id.end() : by_id.find(p.observations[0].first);
    if (first != by_id.end() && p.observations[0].second < first->second->descriptors.size()) {
      p.descriptor = first->second->descriptors[p.observations[0].second];
    } else {
      flip(&p.descriptor);
    }
  }
}

}  // namespace

MapData ComposeMap(const MapData& base, const ComposeOptions& options, const KeyFrameRebag& rebag) {
  if (options.copies < 1 || base.keyframes.empty()) {
    throw DataError("compose: need at least one copy of a map with keyframes");
  }
  const int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(options.copies))));
  std::mt19937_64 rng(options.seed);
  MapData composed = base;
  uint64_t previous_first = base.keyframes.front().id;  // Of the last copy joined.
  for (int c = 1; c < options.copies; ++c) {
    MapData copy = base;
    PerturbDescriptors(&copy, options.flipped_bits, &rng);
    if (rebag) {
      for (KeyFrameRecord& kf : copy.keyframes) rebag(&kf);
    }
    const Eigen::Vector3d offset(options.spacing * (c % side), 0, options.spacing * (c / side));
    const uint64_t first_id = composed.next_keyframe_id + base.keyframes.front().id;
    composed = JoinMaps(std::move(composed), std::move(copy),
                        Rigid3d(Eigen::Quaterniond::Identity(), offset), previous_first,
                        base.keyframes.front().id, "compose");
    previous_first = first_id;
  }
  return composed;
}

}  // namespace rrslam
