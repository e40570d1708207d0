// Per-frame camera tracking against the map (ORB-SLAM2's Tracking for RGB-D,
// written anew):
//  - initialization from the first frame with enough keypoints with depth
//    (its camera is the world frame; one map point per such keypoint);
//  - constant-velocity motion model with projection search from the last
//    frame, falling back to BoW matching against the reference keyframe;
//  - local-map tracking: local keyframes (observers of the matched points and
//    their covisibility neighbours), their map points projected and matched,
//    then pose-only optimization;
//  - keyframe decision and creation with new map points from close depth.
// When tracking fails the frame is lost; each following frame is relocalized
// against the whole map (relocalizer.h) until one succeeds; lost with at most
// 5 keyframes in the map, the map is reset instead (ORB-SLAM2).
//
// Thread-safety: Track() is called from one thread; it holds Map::mutex()
// while it touches the map, so it can run beside a realtime LocalMapper.
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "stages/track/data/frame.h"
#include "stages/track/data/keyframe.h"
#include "stages/track/data/map.h"
#include "stages/track/data/sensor_model.h"
#include "stages/track/match/matcher.h"
#include "stages/track/module/local_mapper.h"
#include "stages/track/module/relocalizer.h"
#include "stages/track/optimize/optimizer.h"

namespace rrslam {

// Defaults are ORB-SLAM2's RGB-D values, but for departures the rule for
// defaults chose (marked "departure"); docs/track.md ("Departures from
// ORB-SLAM2") has the measurements that decide them. rrslam-track binds the
// fields TrackOptions lists.
struct TrackerOptions {
  // Initialization: the first frame with more than this many keypoints
  // (ORB-SLAM2: N > 500); its keypoints with depth become map points. A guard
  // of rrslam's: at least min_initial_points of them must have depth (ORB-SLAM2
  // would make a map without points, lose the next frame and reset, forever,
  // on a sequence without depth).
  int min_initial_keypoints = 500;
  int min_initial_points = 50;
  // Motion-model search window, pixels at level 0 times the scale of the last
  // frame's keypoint; doubled on the retry when fewer than min_motion_matches
  // are found. ORB-SLAM2 uses 15 for RGB-D (7 is its stereo value).
  double motion_search_radius = 15.0;
  // Local-map search window factor (ORB-SLAM2's th for RGB-D: 3; its
  // monocular value is 1), and within two frames of a relocalization (5).
  double local_map_search_radius = 3.0;
  double local_map_search_radius_relocalized = 5.0;
  int min_motion_matches = 20;     // Projection matches needed before pose optimization.
  int min_bow_matches = 15;        // BoW matches needed to track the reference keyframe.
  int min_pose_inliers = 10;       // Map inliers needed after either pose optimization.
  int min_local_map_inliers = 30;  // After local-map tracking.
  int min_local_map_inliers_relocalized =
      50;  // ... within max_keyframe_gap frames of a relocalization.
  // Keyframe decision (ORB-SLAM2): at most this many frames without a keyframe
  // (the camera frame rate), ...
  int max_keyframe_gap = 30;
  // ... and a keyframe is needed when fewer than `close_tracked` close points
  // are tracked while more than `close_untracked` could be created (>= 0).
  // ORB-SLAM2: 100. Departure, the default: 300 (denser keyframes; lower
  // score under the rule for defaults).
  int close_tracked = 300;
  int close_untracked = 70;
  double reference_ratio = 0.75;  // Inliers / reference keyframe's tracked points.
  int new_keyframe_points = 100;  // Close-depth points a new keyframe gets at least.
  // Local keyframes: ORB-SLAM2 adds a best covisible keyframe, a child and the
  // parent of each keyframe observing the frame's points, in id order, but its
  // loop ends at the first parent added (a quirk of its code). Departure
  // (true): add the neighbours of every observing keyframe.
  bool expand_all_local_keyframes = false;
  // When ORB-SLAM2's ways to track a frame fail (the motion model, then the
  // reference keyframe's bag-of-words matches), search the last frame's
  // points where they were, as the motion model would without motion.
  // ORB-SLAM2 (false) loses the frame. Right after a relocalization ORB-SLAM2
  // tries the reference keyframe alone, whose bag-of-words matches fall
  // short where the frame sees it from another side, although the
  // relocalized frame tracked 100 map points and more.
  bool last_frame_fallback = true;
  // Vocabulary levels above the words whose nodes group features for BoW
  // search (ORB-SLAM2: 4; see FeatureVectorLevelsUp).
  int bow_levels_up = 4;
  // Lost with at most this many keyframes in the map: the map is discarded
  // and tracking initializes again (ORB-SLAM2's reset; the caller does it when
  // reset_requested() is true). Negative: never.
  int reset_max_keyframes = 5;
  // ORB-SLAM2's localization mode (mbOnlyTracking): no keyframes are made, so
  // the map is not changed (but for the points' visible/found counters).
  // While fewer than `vo_min_map_matches` map points are matched by the
  // motion model, the frame is tracked as visual odometry: against temporary
  // points made from the last frame's close depth (never in the map), with
  // relocalization tried on every frame until the map is seen again.
  bool localization_only = false;
  // Restore mapping (a loaded map mapped on; not ORB-SLAM2, which cannot load
  // maps): what the frame's depth image (Frame::depth_metres) says about the
  // local points it predicts visible and did not match is counted
  // (MapPoint::evidence, for LocalMapperOptions::changed_point_min_absent).
  // Keyframes are made only where the map lacks the view: more than
  // close_untracked close keypoints that no local point accounts for
  // (CompareWithLocalMap) on LacksView's frames in a row; then ORB-SLAM2's
  // rule applies, and also a keyframe once max_keyframe_gap frames passed
  // since the last (ORB-SLAM2's rule waits for the tracked points to drop,
  // which a loaded map covering the rest of the view never lets happen).
  // A view the map has gets no keyframe however few of its points ORB
  // matches, so sessions in the same place do not grow the map. Redundant
  // keyframes are culled as usual.
  bool restore_mapping = false;
  // Keyframes only where the map lacks the view in every mapping run, not
  // only on a loaded map, on the frames new_view_min_age says (revisits add
  // few keyframes): the frame's close keypoints that no local point accounts
  // for must be more than this fraction of its close keypoints (and more
  // than close_untracked) on kLacksViewFrames tracked frames in a row;
  // ORB-SLAM2's rule decides from there. The same gate tightens restore mapping's. 0: ORB-SLAM2's
  // rule alone (restore mapping: close_untracked alone). In [0, 1).
  double new_view_fraction = 0.0;
  // Where new_view_fraction's gate applies outside restore mapping: on
  // revisits, frames whose reference keyframe (the local keyframe sharing
  // most points) is at least this many keyframes older than the newest
  // (keyframe ids); a camera exploring new ground tracks its newest
  // keyframes and keeps ORB-SLAM2's rule. 0: on every frame. With 8, three
  // laps of the synthetic room and the kitchen's frames 0-299 shown twice
  // added 10% and 6% of the first pass's keyframes (every frame: 0% and
  // 24%) and fr1_xyz kept 50-61 keyframes of 66-69 (every frame: 16);
  // docs/track.md. >= 0.
  int new_view_min_age = 8;
  int vo_min_map_matches = 10;
  // Points matched by the motion model in visual-odometry tracking (ORB-SLAM2: > 20).
  int vo_min_matches = 20;

  // Relocalization's stages and thresholds (module/relocalizer.h).
  RelocalizationOptions relocalization;

  // Names the first violated constraint ("close_tracked = -1; must be >= 0").
  bool Check(std::string* why) const;
};

// Pose of a frame as recorded for the trajectory: relative to its reference
// keyframe, resolved against the final keyframe poses when written out.
struct TrackedFrame {
  uint64_t frame_id = 0;
  double timestamp = 0;
  bool tracked = false;
  KeyFrame* reference = nullptr;  // Valid when tracked.
  Rigid3d T_cam_reference;        // Valid when tracked.
};

class Tracker {
 public:
  enum class State { kNotInitialized, kOk, kLost };

  // All references must outlive the tracker. `mapper` receives the new
  // keyframes through LocalMapper::Enqueue(); `database` (filled by the
  // mapper) gives relocalization candidates.
  Tracker(const SensorModel& sensor, const Vocabulary& vocabulary, Map* map, LocalMapper* mapper,
          const KeyFrameDatabase& database, const TrackerOptions& options = {});

  // Tracks one frame (frames must come in order). Returns true when the frame
  // got a pose. `new_keyframe` (optional) tells whether it made a keyframe.
  bool Track(Frame frame, bool* new_keyframe = nullptr);

  State state() const { return state_; }
  const std::vector<TrackedFrame>& records() const { return records_; }
  const Frame& last_frame() const { return last_frame_; }
  // Frames relocalized after being lost.
  size_t relocalizations() const { return relocalizations_; }
  // Duration of every relocalization attempt (successful or not), ms.
  const std::vector<double>& relocalization_ms() const { return relocalization_ms_; }
  // What every attempt did, in order.
  const std::vector<RelocalizationAttempt>& relocalization_attempts() const {
    return relocalization_attempts_;
  }
  // True after a frame was lost with at most reset_max_keyframes keyframes in
  // the map. The caller then clears the mapper, the map and the keyframe
  // database and calls Reset() (ORB-SLAM2's System::Reset).
  bool reset_requested() const { return reset_requested_; }
  // Forgets the map: the next frame initializes a new one. Frames tracked
  // before are marked lost (their poses referred to the discarded map).
  void Reset();
  // Starts on a map loaded from a file (the paper's start-up): the tracker is
  // lost, so the next frames relocalize in the map; it never resets the map.
  // Call before the first Track(). Starts building relocalization's
  // map-point index on a thread of its own (Relocalizer::
  // PrepareIndexInBackground; the first direct attempt waits for it).
  void StartOnLoadedMap();
  // That build's ms, once it is done (waits for it); 0 when none was started.
  double relocalization_index_ms() { return relocalizer_.WaitForBackgroundIndex(); }
  // Atlas (module/atlas.h): the loaded map was set aside; the next frame
  // initializes a new map (its camera the new world frame), which resets as
  // ORB-SLAM2's would (reset_max_keyframes as given). Frames before stay lost.
  void StartNewMap();
  // The keyframe rule's close_tracked and restore_mapping from now on (the
  // atlas: a new map is mapped as a new map, the merged one as a loaded one).
  void SetMappingRule(int close_tracked, bool restore_mapping) {
    options_.close_tracked = close_tracked;
    options_.restore_mapping = restore_mapping;
  }
  // The map was moved into another world frame (x_new = T_new_old * x_old):
  // the poses the tracker holds follow. Call between frames.
  void MoveWorld(const Rigid3d& T_new_old);
  // Localization only: the last frame was tracked as visual odometry.
  bool visual_odometry() const { return vo_; }
  // Frames tracked as visual odometry (localization only).
  size_t visual_odometry_frames() const { return visual_odometry_frames_; }
  // Tracked frames whose view the map lacked (LacksView, counted when the
  // keyframe rule is gated by it: restore mapping, or new_view_fraction on
  // revisits, where only they may make a keyframe).
  size_t frames_lacking_view() const { return frames_lacking_view_; }
  // Frames tracked by last_frame_fallback (lost by ORB-SLAM2's ways).
  size_t last_frame_fallbacks() const { return last_frame_fallbacks_; }
  size_t resets() const { return resets_; }
  // The pose optimizations' solves so far.
  const SolveCounts& pose_solves() const { return pose_solves_; }

 private:
  bool Initialize();
  void ReplaceInLastFrame();
  // Localization only (ORB-SLAM2's UpdateLastFrame for RGB-D): temporary
  // points for the last frame's close keypoints without a map point.
  void AddTemporaryPoints();
  // One pass over the local points the frame predicts visible (restore
  // mapping, or new_view_fraction > 0): with a depth image, what it says
  // about each not matched (MapPoint::evidence); returns whether the frame
  // lacks the view: more than close_untracked, and more than
  // new_view_fraction of its close keypoints, are close keypoints not
  // tracked that no local point accounts for (none projects within the
  // local-map search window at a depth within DepthCoverGap).
  bool CompareWithLocalMap();
  // True when each of the last kLacksViewFrames tracked frames lacked the
  // view: a view the map lacks stays uncovered, a blurred frame or a bad
  // depth image passes.
  bool LacksView() const;
  // The frame revisits mapped ground: its reference keyframe is at least
  // new_view_min_age keyframes older than the newest.
  bool Revisits() const;
  // The keyframe rule is gated by LacksView (restore mapping or
  // new_view_fraction > 0).
  bool GatesKeyFramesByView() const {
    return options_.restore_mapping || options_.new_view_fraction > 0;
  }
  static constexpr size_t kLacksViewFrames = 3;
  // The tracking step of localization mode; returns whether it gave a pose.
  bool TrackLocalizationOnly();
  // Marks a point as handled in the current frame's local-map search.
  void MarkSeen(const MapPoint* point, uint64_t stamp) {
    if (point->id() < seen_mark_.size()) seen_mark_[point->id()] = stamp;
  }
  // The last frame's points searched around where `velocity` (T_cam_cam of
  // this frame from the last) puts them.
  bool TrackWithMotionModel(const Rigid3d& velocity);
  // last_frame_fallback: the motion model without motion, when the last
  // frame was tracked.
  bool TrackLastFrameStill();
  // BoW matching against the reference keyframe from the last frame's pose.
  bool TrackReferenceKeyFrame();
  // `has_pose`: the frame is tracked by visual odometry (Relocalizer::Relocalize).
  bool Relocalize(bool has_pose = false);
  bool TrackLocalMap();
  void UpdateLocalKeyFrames();
  void UpdateLocalPoints();
  int SearchLocalPoints();
  bool NeedNewKeyFrame() const;
  void CreateNewKeyFrame();
  int DiscardOutliers();

  const SensorModel& sensor_;
  const Vocabulary& vocabulary_;
  Map* map_;
  LocalMapper* mapper_;
  TrackerOptions options_;

  State state_ = State::kNotInitialized;
  Frame current_;
  Frame last_frame_;
  std::optional<Rigid3d> velocity_;  // T_cam_last: current pose times last pose inverse.
  std::optional<Rigid3d> last_good_T_cam_world_;
  KeyFrame* reference_keyframe_ = nullptr;
  uint64_t last_keyframe_frame_id_ = 0;
  // ORB-SLAM2's mnLastRelocFrameId: the frame of the last relocalization, or
  // of the initialization (which ORB-SLAM2 treats alike: frame 0).
  uint64_t relocalized_frame_id_ = 0;
  // The per-id marks below sized to the map's ids (new ones zero).
  void SizeMarks();
  bool RecentlyRelocalized(uint64_t frames) const {
    return current_.id() < relocalized_frame_id_ + frames;
  }
  size_t relocalizations_ = 0;
  std::vector<double> relocalization_ms_;
  std::vector<RelocalizationAttempt> relocalization_attempts_;
  Relocalizer relocalizer_;
  bool reset_requested_ = false;
  int given_reset_max_keyframes_ = options_.reset_max_keyframes;  // Before StartOnLoadedMap.
  SolveCounts pose_solves_;
  size_t resets_ = 0;
  int matches_inliers_ = 0;
  // CompareWithLocalMap() of the last tracked frames, oldest first (when
  // GatesKeyFramesByView; emptied when tracking is lost).
  std::deque<bool> lacking_history_;

  std::vector<KeyFrame*> local_keyframes_;
  std::vector<MapPoint*> local_points_;
  // Per-id marks for the local map of the current frame (frame id + 1).
  std::vector<uint64_t> keyframe_mark_;
  std::vector<uint64_t> point_mark_;  // In local_points_.
  std::vector<uint64_t> seen_mark_;   // Matched (or rejected) in the current frame.
  bool last_frame_tracked_ = false;
  std::vector<TrackedFrame> records_;
  // Localization only.
  bool vo_ = false;
  size_t visual_odometry_frames_ = 0;
  size_t frames_lacking_view_ = 0;
  size_t last_frame_fallbacks_ = 0;
  // Points of the current visual-odometry step, owned here and never in the
  // map; ids from kTemporaryPointIdBase up (beyond any map point id).
  std::vector<std::unique_ptr<MapPoint>> temporary_points_;
};

}  // namespace rrslam
