// Local mapping (ORB-SLAM2's LocalMapping, written anew): for every new
// keyframe from the tracker
//   1. insertion: bag of words, observations of its matched map points,
//      covisibility and spanning-tree update, keyframe database;
//   2. culling of recently created map points that are rarely found or seen
//      by too few keyframes;
//   3. new map points by triangulation with covisible keyframes (epipolar
//      search, parallax and reprojection checks, scale consistency);
//   4. fusion of duplicate map points with the neighbours;
//   5. local bundle adjustment;
//   6. culling of redundant keyframes.
//
// Two ways to run it:
//  - batch: the caller runs ProcessKeyFrame() right after the tracker made the
//    keyframe, in the same thread (deterministic);
//  - realtime: Start() runs a thread that processes queued keyframes as they
//    come; the tracker queues with Enqueue(), asks AcceptsKeyFrames() and
//    InterruptBundleAdjustment() as ORB-SLAM2 does; Stop() finishes the queue
//    and joins. Map objects are accessed under Map::mutex(), which is
//    released while Ceres solves the bundle adjustment.
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "stages/track/data/keyframe.h"
#include "stages/track/data/keyframe_database.h"
#include "stages/track/data/map.h"
#include "stages/track/data/sensor_model.h"
#include "stages/track/optimize/optimizer.h"

namespace rrslam {

struct LocalMapperOptions {
  int triangulation_neighbours = 10;  // Best covisible keyframes to triangulate with.
  int fusion_neighbours = 10;         // Best covisible keyframes to fuse with (plus 5 of each).
  int culling_min_observers = 3;      // Redundancy: seen by at least this many other keyframes.
  double culling_redundancy = 0.9;    // Fraction of close points that must be redundant.
  int bow_levels_up = 4;              // Feature-vector grouping (TrackerOptions::bow_levels_up).
  LocalBundleAdjustmentOptions bundle_adjustment;
  // Restore mapping (a map loaded from a file, mapped on): a loaded point is
  // culled as changed at the next keyframe only on positive evidence that
  // it is gone: this run predicted it visible in at least
  // `changed_point_min_views` tracked frames, found it in fewer than
  // `changed_point_min_found_ratio` of them, and the frames' depth images
  // saw through where it was (DepthEvidenceAt) from at least
  // `changed_point_min_absent` distinct viewpoints
  // (MapPoint::kDistinctViewMetres apart), in at least
  // kSeenThroughPerPresent times as many frames as they measured a surface
  // there. Failed matches alone never cull a loaded point: blur, lighting
  // and another viewing angle make ORB miss points that are still there,
  // and an occluded point is not seen through. 0 views: loaded points are
  // culled only as any other point. Views and viewpoints >= 0, the ratio in
  // [0, 1]. Only loaded points are judged (LocalMapper::WatchLoadedPoints).
  // 4 viewpoints (3 until 2026-12-04): fewer false changes on both real
  // sequences' identical sessions, the synthetic room's change still found
  // (docs/track.md, "Restore mapping").
  int changed_point_min_views = 20;
  double changed_point_min_found_ratio = 0.25;
  int changed_point_min_absent = 4;
  // Restore mapping: a point made in this session that ORB-SLAM2 would cull
  // for too few keyframe observers two keyframes after its own (weight <= 3:
  // one keyframe with depth) stays when tracking found it in at least this
  // many frames (and in >= 25% of its predicted views, as any recent point).
  // Keyframes come only where the loaded map lacks the view, so a new
  // object's points seldom get a second keyframe observer; tracking's
  // matches are their evidence instead. 0 = ORB-SLAM2's rule. >= 0.
  int restore_point_min_found = 10;

  // Names the first violated constraint ("changed_point_min_views = -1; must be >= 0").
  bool Check(std::string* why) const;
};

// Restore mapping: true when a loaded point is to be culled as changed (see
// LocalMapperOptions::changed_point_min_views). The depth images must see
// through the point at least this many times as often as they measure a
// surface at its depth: a point that some frames confirm is kept.
inline constexpr int kSeenThroughPerPresent = 3;
bool IsChangedPoint(const MapPoint& point, const LocalMapperOptions& options);

// What happens to a recently created map point at a new keyframe.
enum class RecentPointDecision {
  kCull,     // Bad, found in < 25% of its predicted views, or too few observers after 2 keyframes.
  kConfirm,  // Survived 3 keyframes (or too few observers but found in `min_found` frames).
  kWatch,    // Keep watching.
};
// `min_found` > 0: a point with too few observers after 2 keyframes is
// confirmed instead of culled when found in at least that many frames
// (LocalMapperOptions::restore_point_min_found); 0: ORB-SLAM2's rule.
RecentPointDecision ClassifyRecentPoint(const MapPoint& point, KeyFrameId current_keyframe_id,
                                        int min_found = 0);

// True when at least `redundancy` of the keyframe's good map points with a
// close depth (0 < depth <= th_depth) are each seen by at least `min_observers`
// other keyframes at the same, a finer, or the next coarser octave
// (ORB-SLAM2's KeyFrameCulling test).
bool IsRedundantKeyFrame(const KeyFrame& keyframe, const SensorModel& sensor, int min_observers = 3,
                         double redundancy = 0.9);

struct LocalMappingCounters {
  size_t keyframes = 0;  // Keyframes processed.
  size_t culled_keyframes = 0;
  size_t culled_points = 0;          // Recent points culled.
  size_t culled_changed_points = 0;  // Loaded points culled as changed (restore mapping).
  size_t triangulated_points = 0;
  size_t fused_points = 0;
  size_t bundle_adjustments = 0;
  size_t aborted_bundle_adjustments = 0;
  size_t max_queue = 0;                  // Longest keyframe queue seen (realtime).
  SolveCounts bundle_adjustment_solves;  // Both passes of every local BA.
  std::vector<double> keyframe_ms;       // Processing time of each keyframe.
};

class LocalMapper {
 public:
  // All references must outlive the mapper.
  LocalMapper(const SensorModel& sensor, const Vocabulary& vocabulary, Map* map,
              KeyFrameDatabase* database, const LocalMapperOptions& options = {});
  ~LocalMapper();
  LocalMapper(const LocalMapper&) = delete;
  LocalMapper& operator=(const LocalMapper&) = delete;

  // Batch mode: runs every step on `keyframe` now (takes the map lock per step).
  void ProcessKeyFrame(KeyFrame* keyframe);
  // Batch mode: processes the queued keyframes (from Enqueue) in order, now.
  void ProcessQueued();

  // Realtime mode.
  void Start();
  void Enqueue(KeyFrame* keyframe);
  // False while a keyframe is being processed (ORB-SLAM2's AcceptKeyFrames).
  bool AcceptsKeyFrames() const { return accepting_.load(); }
  size_t QueueSize() const;
  // Asks a running bundle adjustment to stop at its next iteration.
  void InterruptBundleAdjustment() { abort_ba_.store(true); }
  // Processes what is queued, then stops and joins the thread.
  void Stop();
  // For a map reset (the caller then clears the map): finishes the keyframe
  // in progress, drops the queue and the recently created points it watches.
  // A running thread is restarted. Call without holding the map lock.
  void Reset();

  // Called with each keyframe once processed (in the mapper's thread in
  // realtime mode): hands it on to loop closing. Set before Start().
  void SetKeyFrameSink(std::function<void(KeyFrame*)> sink) { sink_ = std::move(sink); }

  // Restore mapping: the points of a loaded map, watched for scene changes
  // (LocalMapperOptions::changed_point_min_views) from now on, and recent
  // points judged by restore mapping's rule (restore_point_min_found) until
  // Reset(). Call before Start(), under the map lock or with no other thread
  // running.
  void WatchLoadedPoints(const std::vector<MapPoint*>& points);

  // Realtime mode: Pause() returns once the mapper is between keyframes and
  // keeps it there until the matching Resume() (loop correction, global BA;
  // ORB-SLAM2's RequestStop / Release; pauses nest); keyframes queued
  // meanwhile wait. No-ops in batch mode.
  void Pause();
  void Resume();
  // Between Pause() and its Resume(): the tracker makes no keyframe then
  // (ORB-SLAM2's isStopped / stopRequested in NeedNewKeyFrame).
  bool Paused() const;

  // Counters; read them after Stop() in realtime mode.
  const LocalMappingCounters& counters() const { return counters_; }

  // The steps, public for tests; the caller holds the map lock.
  void InsertKeyFrame(KeyFrame* keyframe);
  size_t CullRecentPoints(const KeyFrame* keyframe);
  size_t CullChangedPoints();
  size_t TriangulateNewPoints(KeyFrame* keyframe, bool check_queue);
  size_t FuseWithNeighbours(KeyFrame* keyframe);
  size_t CullRedundantKeyFrames(const KeyFrame* keyframe);

 private:
  void Run();
  void Process(KeyFrame* keyframe, bool realtime);
  bool HasQueued() const;

  const SensorModel& sensor_;
  const Vocabulary& vocabulary_;
  Map* map_;
  KeyFrameDatabase* database_;
  LocalMapperOptions options_;
  LocalBundleAdjuster adjuster_;
  std::vector<MapPoint*> recent_points_;
  std::vector<MapPoint*> loaded_points_;  // Watched for changes (restore mapping).
  bool restore_mapping_ = false;          // From WatchLoadedPoints() until Reset().
  LocalMappingCounters counters_;

  mutable std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::deque<KeyFrame*> queue_;
  bool stop_requested_ = false;
  int pauses_ = 0;                    // Pause() calls not yet resumed.
  bool busy_ = false;                 // Processing a keyframe (realtime).
  std::atomic<bool> running_{false};  // Between Start() and the end of Stop().
  std::condition_variable idle_cv_;
  std::function<void(KeyFrame*)> sink_;
  std::atomic<bool> accepting_{true};
  std::atomic<bool> abort_ba_{false};
  std::thread thread_;
};

}  // namespace rrslam
