// Loop closing's optimizations on a big map while a camera is tracked in it
// (issue 35: "essential graph and global BA time after a loop on the large
// map ... tracking must go on meanwhile").
//
// Each runs as loop closing runs it (loop_closer.h), in collect / solve /
// apply phases: the map's state is collected under the map's lock, solved
// without it, and applied under it again, on a thread of its own, while the
// main thread tracks a real sequence in the map (loaded as rrslam-track
// --load-map loads it, with its heap preparation; localization only, frames
// paced at the camera's rate, going back and forth over `frames` frames of
// the sequence so that tracking never runs out of frames). The step starts
// after `baseline_frames` frames tracked without it:
//  - kEssentialGraph: a composed map has no loop to close, so one is made:
//    the map's newest keyframe is moved by (correction_m along its camera's
//    x axis, correction_deg about its y axis) as a loop would move it
//    (MoveLoopNeighbourhood, with its covisible keyframes and their points)
//    with the newest keyframe at least `loop_span` keyframes before it that
//    shares no point with it (on a composed map, one in the same copy or
//    the one before), that pair being the loop connection; then the
//    essential graph (EssentialGraphAdjuster). Loop closing's fusion of the
//    loop points, also under the lock, is not part of it.
//  - kGlobalBa: ORB-SLAM2's global BA (GlobalBundleAdjuster) of the map as
//    it is.
// What is measured is how long the step takes and what tracking sees
// meanwhile.
#pragma once

#include <filesystem>
#include <vector>

namespace rrslam::bench {

enum class LoopStep { kEssentialGraph, kGlobalBa };

struct LoopStepWhileTrackingOptions {
  std::filesystem::path map, vocab, settings, sequence;
  LoopStep step = LoopStep::kGlobalBa;
  int first_frame = 500;      // Sequence index of the first tracked frame.
  int frames = 300;           // Frames [first_frame, first_frame + frames), back and forth.
  double fps = 30;            // Pacing of the tracked frames.
  int baseline_frames = 150;  // Tracked before the step starts.
  int iterations = 10;        // Global BA (LoopClosingOptions::global_ba_iterations).
  // The made-up loop of kEssentialGraph.
  double correction_m = 0.10, correction_deg = 2.0;
  int loop_span = 51;  // Keyframes (by id) at least from the newest back to its loop keyframe.
};

struct LoopStepWhileTracking {
  int keyframes = 0, points = 0, observations = 0;  // In the global BA.
  int vertices = 0, edges = 0;                      // Of the essential graph.
  int loop_ids = 0;  // Keyframe ids between the made-up loop's two keyframes.
  double collect_ms = 0, solve_ms = 0, apply_ms = 0, total_ms = 0;
  int iterations = 0;  // Successful steps (SolveCounts).
  // Tracking time of each frame before the step started, and of each frame
  // whose tracking overlapped it (from the collect's start to the apply's end).
  std::vector<double> before_ms, during_ms;
  int lost_before = 0, lost_during = 0;
};

// Throws what loading the map, the vocabulary, the settings or the frames
// throws; std::runtime_error when the map has fewer than loop_span + 1
// keyframes for kEssentialGraph.
LoopStepWhileTracking MeasureLoopStepWhileTracking(const LoopStepWhileTrackingOptions& options);

}  // namespace rrslam::bench
