// Loop closing (ORB-SLAM2's LoopClosing for RGB-D, written anew): every
// keyframe local mapping has processed is checked for a loop with an
// earlier part of the map, and a loop found is closed.
//  1. Detection: the lowest BoW score of the keyframe against its covisible
//     keyframes is the bar; the keyframe database's loop candidates
//     (KeyFrameDatabase::DetectLoopCandidates: not connected to the
//     keyframe, scoring at least the bar, best of their covisibility
//     groups). A candidate is accepted once its group (it and its connected
//     keyframes) was consistent with candidate groups of 3 consecutive
//     keyframes. No detection while the map holds 10 keyframes or fewer, nor
//     within 10 keyframes of the last loop.
//  2. Geometric check, per accepted candidate in id order: BoW matching of
//     map points (ratio 0.75, at least 20); rigid RANSAC on their 3-D
//     positions (rigid_ransac.h: Eigen's umeyama without scale, since depth
//     gives scale); guided matching with the hypothesis (7.5 px); Ceres
//     refinement (OptimizeRelativePose) keeping at least 20 inliers; then
//     the map points of the candidate and its covisible keyframes are
//     projected with the corrected pose (10 px): at least 40 matches close
//     the loop. (ORB-SLAM2 interleaves 5 RANSAC iterations per candidate in
//     turns; each candidate's RANSAC runs to its end here, so batch runs are
//     bit-identical with a seeded generator.)
//  3. Correction: the keyframe and its covisible keyframes are moved by the
//     loop correction (their points with them), the matched loop points
//     replace the keyframe's own, the loop points are fused into the moved
//     keyframes (4 px), the new covisibility links are the loop connections;
//     the essential graph (spanning tree, loop edges, covisibility edges of
//     weight >= 100, loop connections) is optimized with the loop keyframe
//     fixed, every other point moves with its reference keyframe; both loop
//     keyframes get a loop edge (they are never culled after).
//  4. A global bundle adjustment of the whole map follows.
// Keyframes in use by steps 1-3 are not culled meanwhile (KeyFrame::in_use).
//
// Two ways to run it, like LocalMapper:
//  - batch: Enqueue() (from LocalMapper's sink) and ProcessQueued() right
//    after the mapper, in the same thread; global BA runs there too.
//    Bit-identical runs.
//  - realtime: Start() runs a thread for steps 1-3; the correction pauses the
//    local mapper (the tracker makes no keyframe meanwhile) and holds
//    Map::mutex() while it moves the map, except while Ceres solves the
//    essential graph (EssentialGraphAdjuster), when tracking goes on; global BA
//    runs in a thread of its own, in collect / solve / apply phases (the map
//    is locked and the mapper paused only to collect and to apply), and is
//    aborted (its result dropped) when another loop is to be corrected.
//    Stop() finishes the queue and the global BA and joins.
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <vector>

#include "stages/track/data/keyframe.h"
#include "stages/track/data/keyframe_database.h"
#include "stages/track/data/map.h"
#include "stages/track/data/sensor_model.h"
#include "stages/track/module/local_mapper.h"
#include "stages/track/optimize/loop_optimizer.h"
#include "stages/track/solve/rigid_ransac.h"

namespace rrslam {

// Defaults are ORB-SLAM2's.
struct LoopClosingOptions {
  int min_map_keyframes = 10;     // No detection with this many keyframes or fewer.
  int keyframes_after_loop = 10;  // Nor within this many keyframe ids of the last loop.
  int consistency = 3;            // Consecutive consistent detections to accept a candidate.
  double bow_ratio = 0.75;
  int min_bow_matches = 20;
  RigidRansacOptions ransac;
  double guided_radius = 7.5;  // Pixels (times the scale of the level), SearchByRelativePose.
  double relative_pose_chi2 = 10;
  int min_optimized_inliers = 20;
  double projection_radius = 10;  // SearchByProjection of the loop points.
  int min_loop_matches = 40;
  double fuse_radius = 4;
  int essential_graph_min_weight = 100;
  int essential_graph_iterations = 20;
  bool global_bundle_adjustment = true;
  int global_ba_iterations = 10;
};

// One closed loop.
struct LoopClosure {
  KeyFrameId keyframe = 0;  // The keyframe that closed it.
  KeyFrameId matched = 0;   // The earlier keyframe it matched.
  double timestamp = 0;     // Timestamps (s) of both keyframes.
  double matched_timestamp = 0;
  int bow_matches = 0;
  int ransac_inliers = 0;
  int optimized_inliers = 0;
  int matches = 0;                 // After the projection search (>= 40).
  double correction_m = 0;         // How far the keyframe's camera centre moved.
  double correction_deg = 0;       // And its rotation.
  double correction_ms = 0;        // Correction with essential graph.
  double global_ba_ms = 0;         // 0 when none ran.
  bool global_ba_aborted = false;  // Aborted by a later loop (result dropped).
};

struct LoopClosingCounters {
  size_t keyframes = 0;   // Keyframes checked.
  size_t detections = 0;  // Keyframes with an accepted (consistent) candidate.
  size_t geometric_fails = 0;
  std::vector<LoopClosure> loops;
  std::vector<double> detection_ms;  // Steps 1-2 per keyframe.
  SolveCounts essential_graph;
  SolveCounts global_ba;
};

// The geometric check of one loop candidate (step 2).
struct LoopCandidateMatch {
  KeyFrame* matched = nullptr;            // Set when the relative-pose optimization passed.
  Rigid3d T_cam_world;                    // The keyframe's pose that closes the loop.
  std::vector<MapPoint*> matched_points;  // Loop map point per keypoint of the keyframe.
  std::vector<MapPoint*> loop_points;     // Of the candidate and its covisible keyframes.
  int bow_matches = 0;
  int ransac_inliers = 0;  // Of the best hypothesis.
  int inliers = 0;         // After the relative-pose optimization.
  int matches = 0;         // After the projection search; the loop needs min_loop_matches.
};

// Step 2 for one candidate (the caller holds the map lock): true when it
// passes the relative-pose optimization, then `match` has the projection
// search's matches too (a loop needs options.min_loop_matches of them).
// `num_point_ids`: Map::num_created_map_points() of the candidate's map.
// The keyframe may belong to another map than the candidate (map_merger.h).
bool CheckLoopCandidate(const SensorModel& sensor, const LoopClosingOptions& options,
                        size_t num_point_ids, KeyFrame* keyframe, KeyFrame* candidate,
                        LoopCandidateMatch* match);

class LoopCloser {
 public:
  // All references must outlive the loop closer. `mapper` is paused during a
  // correction in realtime mode.
  LoopCloser(const SensorModel& sensor, const Vocabulary& vocabulary, Map* map,
             KeyFrameDatabase* database, LocalMapper* mapper,
             const LoopClosingOptions& options = {});
  ~LoopCloser();
  LoopCloser(const LoopCloser&) = delete;
  LoopCloser& operator=(const LoopCloser&) = delete;

  void Enqueue(KeyFrame* keyframe);
  // Batch mode: checks the queued keyframes in order, now.
  void ProcessQueued();
  // Realtime mode.
  void Start();
  void Stop();
  // For a map reset (call without the map lock): stops a running global BA,
  // drops the queue and the consistency state. A running thread is restarted.
  void Reset();

  // Read after Stop() in realtime mode.
  const LoopClosingCounters& counters() const { return counters_; }

  // The steps, public for tests; each takes the map lock itself.
  // Step 1: true when a candidate was accepted.
  bool DetectLoop(KeyFrame* keyframe);
  // Step 2 on the accepted candidates: true when one closes the loop.
  bool ComputeLoopTransform(KeyFrame* keyframe);
  // Step 2 for one candidate: CheckLoopCandidate on this map.
  bool CheckCandidate(KeyFrame* keyframe, KeyFrame* candidate, LoopCandidateMatch* match) const;
  // Step 3 (and 4 in batch mode).
  void CorrectLoop(KeyFrame* keyframe);

 private:
  struct Group {
    std::set<KeyFrameId> keyframes;
    int consistency;
  };

  void Process(KeyFrame* keyframe);
  void Run();
  void ReleaseCandidates(const KeyFrame* keep);
  void RunGlobalBundleAdjustment(size_t loop_index, bool realtime);
  void StopGlobalBundleAdjustment();

  const SensorModel& sensor_;
  const Vocabulary& vocabulary_;
  Map* map_;
  KeyFrameDatabase* database_;
  LocalMapper* mapper_;
  LoopClosingOptions options_;
  LoopClosingCounters counters_;

  // Detection state.
  std::vector<Group> consistent_groups_;
  std::vector<KeyFrame*> accepted_candidates_;
  std::optional<KeyFrameId> last_loop_keyframe_;  // Keyframe of the last loop closed.
  // The loop found by ComputeLoopTransform.
  LoopCandidateMatch loop_;

  // Realtime.
  bool realtime_ = false;
  std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::deque<KeyFrame*> queue_;
  bool stop_requested_ = false;
  std::thread thread_;
  std::thread ba_thread_;
  std::atomic<bool> abort_ba_{false};
  std::mutex counters_mutex_;  // The global BA thread writes its loop's record.
};

}  // namespace rrslam
