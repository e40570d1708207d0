#include "stages/track/optimize/map_refinement.h"

#include "common/clock.h"

namespace rrslam {

MapRefinementStats RefineMap(const SensorModel& sensor, Map* map,
                             const MapRefinementOptions& options) {
  const auto start = SteadyClock::now();
  MapRefinementStats stats;
  LocalBundleAdjustmentOptions passes;
  passes.first_iterations = options.robust_steps;
  passes.second_iterations = options.final_steps;
  passes.depth_fallback = options.depth_fallback;
  LocalBundleAdjuster adjuster(sensor, passes);
  adjuster.CollectAll(*map, options.first_free_keyframe);
  adjuster.Solve();
  adjuster.Apply(map);
  const LocalBundleAdjustmentStats& s = adjuster.stats();
  stats.keyframes = s.local_keyframes + s.fixed_keyframes;
  stats.points = s.points;
  stats.observations = s.observations;
  stats.outliers = s.outliers;
  stats.initial_cost = s.initial_cost;
  stats.final_cost = s.final_cost;
  stats.solves = s.solves;
  stats.ms = MillisecondsSince(start);
  return stats;
}

}  // namespace rrslam
