// Relocalization attempts on a big map, many of them (issue 35: "relocalization
// attempt time (median, p95)"): a cold start makes one attempt per process,
// so its three starts give a p95 of three values. Here the map is loaded
// once (TrackedMap), its map-point index built, and every `stride`-th frame
// of `frames` frames relocalized from scratch as rrslam-track's tracker
// makes and times an attempt (Relocalizer::RelocalizeTimed, with
// rrslam-track's default options), one at a time with nothing beside, on a
// thread of their own as rrslam-track's frame loop is.
#pragma once

#include <string>
#include <vector>

#include "bench/scale/tracked_map.h"

namespace rrslam::bench {

struct RelocalizationSweepOptions {
  TrackedMapPaths paths;
  int first_frame = 500;  // Sequence index of the first frame.
  int frames = 500;
  int stride = 10;
};

struct RelocalizationSweep {
  std::vector<double> attempt_ms;    // Each attempt's, in frame order.
  std::vector<double> bow_stage_ms;  // Of each, the bag-of-words stage (RelocalizationAttempt).
  int relocalized = 0;               // Attempts that gave a pose.
  int by_direct = 0;                 // Of those, by the direct stage.
};

// Throws as TrackedMap.
RelocalizationSweep SweepRelocalization(const RelocalizationSweepOptions& options);

}  // namespace rrslam::bench
