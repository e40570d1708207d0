#include "bench/scale/relocalization_sweep.h"

#include <algorithm>

#include "common/task_thread.h"
#include "stages/track/module/relocalizer.h"
#include "stages/track/module/tracker.h"

namespace rrslam::bench {

RelocalizationSweep SweepRelocalization(const RelocalizationSweepOptions& o) {
  TrackedMap m(o.paths, o.first_frame, o.frames);
  const TrackerOptions tracker;  // rrslam-track's defaults.
  Relocalizer relocalizer(m.sensor(), m.database(), m.map(), tracker.relocalization);
  relocalizer.PrepareIndex();
  RelocalizationSweep sweep;
  // On a thread of its own, as rrslam-track's frame loop (track.cc): its
  // heap is not the one the load left full of holes.
  TaskThread frame_loop;
  frame_loop.Run([&] {
    for (int i = 0; i < m.frames(); i += std::max(o.stride, 1)) {
      Frame frame = m.MakeFrame(static_cast<size_t>(i), static_cast<uint64_t>(i), i / 30.0);
      RelocalizationAttempt attempt;
      const KeyFrame* keyframe =
          relocalizer.RelocalizeTimed(&frame, m.vocabulary(), m.bow_levels_up(), nullptr, &attempt);
      sweep.attempt_ms.push_back(attempt.ms);
      sweep.bow_stage_ms.push_back(attempt.bow_stage_ms);
      sweep.relocalized += keyframe != nullptr;
      sweep.by_direct += keyframe != nullptr && attempt.stage == "direct";
    }
  });
  return sweep;
}

}  // namespace rrslam::bench
