// The atlas of a session started on a loaded map (issue 31; ORB-SLAM3's
// Atlas for two maps): when the first frames do not relocalize in the
// loaded map, the loaded map is set aside and tracking starts a new map in
// its own world frame; every keyframe of the new map is then looked for in
// the loaded map (map_merger.h's MatchKeyFrame: bag-of-words candidates,
// rigid 3D-3D RANSAC, guided matching, relative-pose optimization, the
// candidate's covisible points), and when two keyframes give transforms
// that agree (loop closing's consistency) the new map is merged into the
// loaded one (MergeLiveMaps: moved into the loaded map's frame, points
// fused, a welding bundle adjustment with the loaded keyframes fixed). The
// tracker goes on in the merged map; the frames tracked before the merge
// are anchored to the new map's keyframes, so they come out in the loaded
// map's frame too.
//
// Thread-safety: Enqueue and TakeQueued may be called from any thread; the
// rest from one. SetLoadedMapAside and Merge need every other module
// stopped or paused; Check needs the active map's lock.
#pragma once

#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "stages/track/data/keyframe_database.h"
#include "stages/track/data/map.h"
#include "stages/track/data/sensor_model.h"
#include "stages/track/module/map_merger.h"
#include "stages/vocab/vocabulary.h"

namespace rrslam {

struct AtlasOptions {
  // Camera time (seconds, from the first frame) without a relocalization
  // in the loaded map after which a new map is started; negative: never
  // (ORB-SLAM2: a session on a loaded map waits to relocalize). 1 s: the
  // mission's "knows where it is within a second"; a robot that does not by
  // then is better off mapping than standing blind.
  double new_map_after_s = 1.0;
  MapMergeOptions merge;

  // Names the first violated constraint.
  bool Check(std::string* why) const;
};

// One merge of the new map into the loaded one.
struct AtlasMerge {
  double timestamp = 0;              // Of the keyframe that completed the agreement,
  uint64_t frame_id = 0;             // and its Frame::id (the tracker's frame count).
  double first_match_timestamp = 0;  // Of the first keyframe of the new map that matched.
  KeyFrameOverlap overlap;           // The keyframe pair with the most matches.
  int keyframes_checked = 0;         // Keyframes of the new map looked for in the loaded map.
  int keyframes_matched = 0;         // Those that matched.
  MapWeldStats weld;
  double ms = 0;  // The merge (move, fuse, weld), not the checks.
};

class Atlas {
 public:
  Atlas(const SensorModel& sensor, const Vocabulary& vocabulary, const AtlasOptions& options = {});

  const AtlasOptions& options() const { return options_; }

  // The loaded map's objects move from `active` into the atlas (with its
  // keyframe database, built here); `active` and `active_database` are left
  // empty for a new map whose ids follow the loaded map's.
  void SetLoadedMapAside(Map* active, KeyFrameDatabase* active_database);
  // True from SetLoadedMapAside until Merge.
  bool holds_loaded_map() const { return holds_loaded_map_; }
  // The loaded map while set aside (holds_loaded_map()).
  const Map& loaded_map() const { return loaded_; }

  // Keyframes of the new map handed over by local mapping (its sink), to
  // be checked by the tracking thread.
  void Enqueue(KeyFrame* keyframe);
  std::vector<KeyFrame*> TakeQueued();

  // A keyframe of the new map: looked for in the loaded map. True when it
  // matched and its transform agrees with an earlier keyframe's: Merge()
  // can then run.
  bool Check(KeyFrame* keyframe);
  // Merges the new map (`active`, lock held) into the loaded one and
  // returns the merge: overlap.T_a_b moves the new map's world into the
  // loaded map's, and the tracker must be moved with it
  // (Tracker::MoveWorld). nullptr, and no merge, when a keyframe of the
  // agreed pair was culled since Check (the next agreement will do).
  const AtlasMerge* Merge(Map* active, KeyFrameDatabase* active_database);

  // Every merge so far (at most one: after it the atlas holds nothing).
  const std::vector<AtlasMerge>& merges() const { return merges_; }
  int keyframes_checked() const { return checked_; }
  // Check's time per keyframe, ms.
  const std::vector<double>& check_ms() const { return check_ms_; }

 private:
  const SensorModel& sensor_;
  AtlasOptions options_;
  Map loaded_;
  KeyFrameDatabase loaded_database_;
  bool holds_loaded_map_ = false;
  std::vector<KeyFrameOverlap> matched_;   // Keyframes of the new map that matched.
  std::optional<KeyFrameOverlap> agreed_;  // Set by Check when Merge can run.
  int checked_ = 0;
  std::vector<double> check_ms_;
  std::vector<AtlasMerge> merges_;
  std::mutex queue_mutex_;
  std::vector<KeyFrame*> queue_;
};

}  // namespace rrslam
