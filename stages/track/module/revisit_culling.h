// Revisit culling: after the last frame, the keyframes a session made where
// the map already held the view are culled, so that a camera that passes
// through the same rooms again leaves a map of about the first pass's size
// (issue 35: later passes add at most 10% of the first's keyframes).
//
// While the camera is there, such keyframes help: tracking and local BA use
// them as ORB-SLAM2 does (issue 30's rule: keyframes withheld on revisits,
// `--new-view-fraction`, cost fr1_xyz 2.5% of its accuracy). Once the run
// ends they only make the saved map bigger. A keyframe K made in this session
// is culled, oldest first, when
//  1. an older keyframe that stays holds its view: one made at least kMinAge
//     keyframes before K, sharing at least kMinSharedPoints map points
//     with it, whose camera centre lies within `max_distance` metres of K's
//     and whose optical axis within `max_angle_deg` degrees of K's (so
//     relocalization from K's view still finds a keyframe of it), and
//  2. its points are mostly the map's already: more than kRedundancy of its
//     close points (depth within th_depth) are each seen by at least
//     kMinObservers other keyframes at the same, a finer or the next
//     coarser octave (ORB-SLAM2's KeyFrameCulling test, local_mapper.h, with
//     0.7 and 2 where ORB-SLAM2 culls at 0.9 and 3 while mapping).
// The cull is Map::CullKeyFrame's (the spanning tree re-attached, points'
// observations erased; a point left with too few observers goes with it).
// Every frame keeps its pose: its culled reference keyframe resolves through
// its parent (keyframe.h, ResolvePose), so CameraTrajectory.txt is the one
// the run made; KeyFrameTrajectory.txt and the saved map lose the culled
// keyframes.
//
// Thread-safety: call with no other thread using the map (after tracking),
// or holding Map::mutex().
#pragma once

#include <cstddef>
#include <string>

#include "stages/track/data/keyframe.h"
#include "stages/track/data/keyframe_database.h"
#include "stages/track/data/map.h"
#include "stages/track/data/sensor_model.h"

namespace rrslam {

struct RevisitCullingOptions {
  bool enabled = true;         // --cull-revisits; false: every keyframe stays (ORB-SLAM2).
  double max_distance = 0.15;  // Metres between the camera centres.
  double max_angle_deg = 15;   // Degrees between the optical axes.
  // Fixed: "older" as --new-view-min-age's revisits, a covisibility edge as
  // ORB-SLAM2's (15 shared points), the redundancy test's bounds above.
  static constexpr int kMinAge = 8;
  static constexpr int kMinSharedPoints = 15;
  static constexpr int kMinObservers = 2;
  static constexpr double kRedundancy = 0.7;
  // Names the first field out of range.
  bool Check(std::string* why) const;
};

struct RevisitCullingStats {
  size_t revisits = 0;  // Keyframes whose view an older keyframe holds (test 1).
  size_t culled = 0;    // Of those, culled (test 2 too).
  double ms = 0;
};

// Culls the revisit keyframes of `map` with ids >= `first_id` (the session's:
// a loaded map's keyframes stay), erasing them from `database`.
RevisitCullingStats CullRevisitKeyFrames(const SensorModel& sensor, KeyFrameId first_id, Map* map,
                                         KeyFrameDatabase* database,
                                         const RevisitCullingOptions& options = {});

// Test 1 alone: an older keyframe (by kMinAge ids) holds `keyframe`'s view.
bool OlderKeyFrameHoldsView(const KeyFrame& keyframe, const RevisitCullingOptions& options);

}  // namespace rrslam
