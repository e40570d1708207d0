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
// When tracking fails the frame is lost; each following frame tries to resume
// by BoW matching against the reference keyframe (and the last keyframe).
//
// Thread-safety: Track() is called from one thread; it holds Map::mutex()
// while it touches the map, so it can run beside a realtime LocalMapper.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "stages/track/frame.h"
#include "stages/track/keyframe.h"
#include "stages/track/local_mapper.h"
#include "stages/track/map.h"
#include "stages/track/matcher.h"
#include "stages/track/sensor_model.h"

namespace rrslam {

struct TrackerOptions {
  // Initialization: keypoints with depth needed in the first frame.
  int min_initial_points = 200;
  // Motion model search window (pixels at level 0; doubled on a retry).
  double motion_search_radius = 7.0;
  int min_motion_matches = 20;             // Projection matches needed before pose optimization.
  int min_bow_matches = 15;                // BoW matches needed to track the reference keyframe.
  int min_pose_inliers = 10;               // Map inliers needed after either pose optimization.
  int min_local_map_inliers = 30;          // After local-map tracking.
  int min_local_map_inliers_resumed = 50;  // ... within max_keyframe_gap frames of a resume.
  // Keyframe decision (ORB-SLAM2): at most this many frames without a keyframe
  // (the camera frame rate), ...
  int max_keyframe_gap = 30;
  // ... and a keyframe is needed when fewer than `close_tracked` close points
  // are tracked while more than `close_untracked` could be created.
  // ORB-SLAM2 uses 100; 300 (denser keyframes) measured 1.2 cm instead of
  // 2.8 cm ATE on a 600-frame synthetic room loop and 4.2 instead of 4.4 cm on
  // 7scenes-kitchen (bench/results/track-*.txt, docs/track.md).
  int close_tracked = 300;
  int close_untracked = 70;
  double reference_ratio = 0.75;  // Inliers / reference keyframe's tracked points.
  int new_keyframe_points = 100;  // Close-depth points a new keyframe gets at least.
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
  // keyframes through LocalMapper::Enqueue().
  Tracker(const SensorModel& sensor, const Vocabulary& vocabulary, Map* map, LocalMapper* mapper,
          const TrackerOptions& options = {});

  // Tracks one frame (frames must come in order). Returns true when the frame
  // got a pose. `new_keyframe` (optional) tells whether it made a keyframe.
  bool Track(Frame frame, bool* new_keyframe = nullptr);

  State state() const { return state_; }
  const std::vector<TrackedFrame>& records() const { return records_; }
  const Frame& last_frame() const { return last_frame_; }
  // Frames that resumed tracking after being lost.
  size_t resumed() const { return resumed_; }

 private:
  bool Initialize();
  void ReplaceInLastFrame();
  bool TrackWithMotionModel();
  bool TrackReferenceKeyFrame(KeyFrame* keyframe, const Rigid3d& initial_T_cam_world);
  bool Resume();
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
  KeyFrame* last_keyframe_ = nullptr;
  uint64_t last_keyframe_frame_id_ = 0;
  uint64_t resumed_frame_id_ = 0;
  bool has_resumed_ = false;
  size_t resumed_ = 0;
  int matches_inliers_ = 0;

  std::vector<KeyFrame*> local_keyframes_;
  std::vector<MapPoint*> local_points_;
  // Per-id marks for the local map of the current frame (frame id + 1).
  std::vector<uint64_t> keyframe_mark_;
  std::vector<uint64_t> point_mark_;  // In local_points_.
  std::vector<uint64_t> seen_mark_;   // Matched (or rejected) in the current frame.
  bool last_frame_tracked_ = false;
  std::vector<TrackedFrame> records_;
};

}  // namespace rrslam
