// The final refinement of a finished map (rrslam-track --refine-map): a
// bundle adjustment of every keyframe and map point, run to convergence once
// tracking has ended, before the trajectories and the map are written.
//
// It is the local bundle adjustment's two passes (optimizer.h) over the whole
// map instead of a keyframe's neighbourhood: Huber-robustified reprojection
// errors (u, v, u_R) whitened by the keypoint's octave (and the sensor's
// depth noise, SensorModel), the first keyframe fixed (gauge freedom); then
// the observations beyond the chi-square bounds are classified as outliers,
// a second pass without the robust loss refines on the inliers, and the
// outliers are erased from the map. Frames keep their pose relative to their
// reference keyframe, so CameraTrajectory.txt follows the refined keyframes.
//
// Unlike loop closing's global BA (ORB-SLAM2's 10 plain steps, no outlier
// removal) each pass runs until Ceres' convergence tolerances end it; the
// step caps only bound a pathological solve (docs/track.md, "Map
// refinement", has the steps measured).
//
// Not thread-safe: call with the map locked and no mapping thread running.
#pragma once

#include "stages/track/data/map.h"
#include "stages/track/data/sensor_model.h"
#include "stages/track/optimize/optimizer.h"

namespace rrslam {

struct MapRefinementOptions {
  // Caps on successful Levenberg-Marquardt steps (counted as g2o counts
  // them, optimizer.h) of the robust pass and of the pass on the inliers.
  int robust_steps = 50;
  int final_steps = 100;
  // As LocalBundleAdjustmentOptions::depth_fallback (--ba-depth-fallback).
  bool depth_fallback = false;
  // Keyframes with smaller ids are held fixed too (a merged map: the first
  // map's keyframes, map_merger.h); 0 = only the first keyframe.
  KeyFrameId first_free_keyframe = 0;
};

struct MapRefinementStats {
  int keyframes = 0;  // Keyframes refined (the first one is held fixed).
  int points = 0;
  int observations = 0;
  int outliers = 0;  // Observations erased from the map.
  double initial_cost = 0;
  double final_cost = 0;
  SolveCounts solves;  // Both passes: steps taken, and whether a cap ended one.
  double ms = 0;       // Wall time.
};

// Refines `map` in place. A map with no keyframe besides the first is left
// as it is.
MapRefinementStats RefineMap(const SensorModel& sensor, Map* map,
                             const MapRefinementOptions& options = {});

}  // namespace rrslam
