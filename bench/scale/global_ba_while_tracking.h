// Global bundle adjustment on a big map while a camera is tracked in it
// (issue 35: "global BA after a loop on a 3k-keyframe map finishes in the
// background without stalling tracking").
//
// In realtime mode loop closing runs ORB-SLAM2's global BA on a thread of its
// own after each loop (LoopCloser::RunGlobalBundleAdjustment): the map's
// state is collected under the map's lock, solved without it, and applied
// under it again. This runs the same three steps (GlobalBundleAdjuster) on a
// map loaded from a file, on a thread of their own, while the main thread
// tracks a real sequence in it (localization only, frames paced at the
// camera's rate, going back and forth over `frames` frames of the sequence
// so that tracking never runs out of frames). A composed map has no loop to
// close, so the BA is started directly, after `baseline_frames` frames
// tracked without it: what is measured is what tracking sees while a global
// BA of that map runs, and how long the BA takes.
#pragma once

#include <filesystem>
#include <vector>

namespace rrslam::bench {

struct GlobalBaWhileTrackingOptions {
  std::filesystem::path map, vocab, settings, sequence;
  int first_frame = 500;      // Sequence index of the first tracked frame.
  int frames = 300;           // Frames [first_frame, first_frame + frames), back and forth.
  double fps = 30;            // Pacing of the tracked frames.
  int baseline_frames = 150;  // Tracked before the BA starts.
  int iterations = 10;        // Of the BA (LoopClosingOptions::global_ba_iterations).
};

struct GlobalBaWhileTracking {
  int keyframes = 0, points = 0, observations = 0;  // In the BA.
  double collect_ms = 0, solve_ms = 0, apply_ms = 0, total_ms = 0;
  int iterations = 0;  // Successful steps (SolveCounts).
  // Tracking time of each frame before the BA started, and of each frame
  // whose tracking overlapped the BA (from Collect's start to Apply's end).
  std::vector<double> before_ms, during_ms;
  int lost_before = 0, lost_during = 0;
};

// Throws what loading the map, the vocabulary, the settings or the frames throws.
GlobalBaWhileTracking MeasureGlobalBaWhileTracking(const GlobalBaWhileTrackingOptions& options);

}  // namespace rrslam::bench
