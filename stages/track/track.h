// The `track` stage: RGB-D SLAM (tracking, local mapping, loop closing) over a
// TUM-layout sequence, writing the camera trajectory, the keyframe trajectory
// and a run report.
//
// Outputs, in the folder --out (written as a whole: a temporary folder
// renamed at the end, so a failed run leaves no partial trajectory; an
// existing --out is replaced only when it is empty or an earlier rrslam-track
// output, otherwise the run stops before tracking with CantCreateError, exit
// 73, and leaves it as it is; common/atomic_file.h):
//   CameraTrajectory.txt    pose of every tracked frame (TUM format)
//   KeyFrameTrajectory.txt  pose of every keyframe in the final map (TUM format)
//   run.json                counts, lost frames, vocabulary identity, options,
//                           producer, timings, start-up and map figures
//                           (see docs/track.md)
//   .rrslam-output          marker: "rrslam-track", this tool's folder
// and, with --save-map, the map file (rrslam.map, stages/mapstore).
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "stages/track/module/atlas.h"
#include "stages/track/module/local_mapper.h"
#include "stages/track/module/revisit_culling.h"
#include "stages/track/module/tracker.h"

namespace rrslam {

struct TrackOptions {
  // TUM RGB-D sequence folder (rgb.txt + depth.txt, or associations.txt). Required.
  std::filesystem::path sequence;
  // ORB-SLAM2 RGB-D settings YAML (common/settings.h). Required.
  std::filesystem::path settings;
  // Vocabulary: rrslam binary (.rrv) or DBoW2 text (ORBvoc.txt). Required.
  std::filesystem::path vocabulary;
  // Output folder. Required. An existing folder is replaced as a whole only
  // when it is empty or an earlier rrslam-track output (its marker, or just
  // the files above with run.json); anything else (the user's notes, the
  // working folder) is refused with CantCreateError (exit 73), untouched.
  std::filesystem::path out;
  // Features file from rrslam-extract (optional). When given, keypoints and
  // descriptors come from it instead of the images; its frames must be
  // frames of the sequence and its settings must agree with --settings.
  std::filesystem::path features;
  // Associations file, absolute or relative to the sequence (optional; as
  // rrslam-extract's --associations).
  std::filesystem::path associations;
  // "batch": local mapping runs in step after each keyframe (bit-identical
  // output run to run); "realtime": local mapping runs in its own thread.
  std::string mode = "batch";
  // Track at most this many frames (0 = all); otherwise >= 2.
  int max_frames = 0;
  // Realtime mode only: hand frames to the tracker no faster than their
  // timestamps (as a live camera would); batch mode ignores it.
  bool pace = false;
  // With `pace`: the longest wait for one gap between frame timestamps, in
  // seconds (finite, > 0). A longer gap (a pause in the recording, sequences
  // glued together) is paced as if it were this long, not slept through.
  double max_pace_gap = 1.0;
  // Threads of the ORB extractor (pyramid levels in parallel); in [1, 16].
  // Does not change the result.
  int extraction_threads = 1;

  // The modules' options, nested as COLMAP nests its options: each field has
  // its one default, check and meaning in the module's header. The tool
  // binds these (CLI flag / run.json name):
  //   tracker.close_tracked                        --close-tracked / close_tracked
  //   tracker.new_view_fraction                    --new-view-fraction
  //   tracker.new_view_min_age                     --new-view-min-age
  //   tracker.expand_all_local_keyframes           --expand-all-local-keyframes
  //   tracker.last_frame_fallback                  --[no-]last-frame-fallback
  //   local_mapping.bundle_adjustment.depth_fallback  --[no-]ba-depth-fallback /
  //                                                   ba_depth_fallback (also
  //                                                   the final refinement's)
  //   local_mapping.changed_point_min_views        --changed-point-views
  //   local_mapping.changed_point_min_found_ratio  --changed-point-ratio
  //   local_mapping.changed_point_min_absent       --changed-point-absent
  //   local_mapping.restore_point_min_found        --restore-point-found
  //   atlas.new_map_after_s                        --new-map-after / new_map_after_s
  // The session sets the fields that follow from the inputs (max_keyframe_gap
  // from Camera.fps, bow_levels_up from the vocabulary, localization_only,
  // restore_mapping, close_tracked with --load-map): their values here are
  // not used. Departures from ORB-SLAM2 are the default when the rule for
  // defaults says so (docs/track.md, "Departures from ORB-SLAM2").
  TrackerOptions tracker;
  LocalMapperOptions local_mapping;
  // Restore mapping (--load-map without --localization-only): a new map when
  // the first frames do not relocalize, merged into the loaded one where
  // they meet (module/atlas.h).
  AtlasOptions atlas;
  // tracker.close_tracked when mapping on a loaded map (restore mapping, with
  // --load-map). ORB-SLAM2's 100: on the synthetic changed room, 300 there
  // culled 9 of the 18 loaded keyframes, added 16 and doubled the loaded
  // points removed (docs/track.md, "Departures from ORB-SLAM2").
  int restore_close_tracked = 100;
  // Vocabularies of fewer than 6 levels group BoW search candidates at depth
  // min(2, L - 1) (ORB-SLAM2: 4 levels above the words).
  bool small_vocab_groups = false;

  // Loop closing (ORB-SLAM2's LoopClosing, with global bundle adjustment
  // after each loop); off: tracking and local mapping only.
  bool loop_closing = true;
  // After the last frame, refine every keyframe and map point by a bundle
  // adjustment run to convergence (optimize/map_refinement.h) before the
  // trajectories and the map are written; every frame keeps its pose
  // relative to its reference keyframe. Not with --localization-only (the
  // map is not changed there). ORB-SLAM2 has no such step.
  bool refine_map = false;
  // After the last frame (before --refine-map), the keyframes this run made
  // where an older keyframe holds the view and whose points the map holds
  // already are culled (module/revisit_culling.h): revisits leave the map
  // about the size of the first pass; every frame keeps its pose. Not with
  // --localization-only. ORB-SLAM2 keeps them.
  RevisitCullingOptions revisit_culling;

  // Offline maps (docs/mapstore.md).
  // Map file (rrslam.map) written at the end of the run, after the last
  // global BA, atomically; empty = none.
  std::filesystem::path save_map;
  // Map file loaded at start-up: tracking starts lost and the first frames
  // relocalize in it; poses are in the map's world frame. It must have been
  // built with the same vocabulary tree and camera settings. Empty = none
  // (a new map is built from the first frame).
  std::filesystem::path load_map;
  // Index of the first frame of the sequence to track (>= 0).
  int first_frame = 0;
  // ORB-SLAM2's localization mode (requires --load-map): no keyframes or map
  // points are added; with few map points matched, frames are tracked as
  // visual odometry until relocalization finds the map again. Without it, a
  // loaded map is mapped on (restore mapping).
  bool localization_only = false;

  // Names the first violated constraint ("--mode = x; must be batch or realtime").
  bool Check(std::string* why) const;
  // The options recorded in run.json.
  nlohmann::json ToJson() const;
};

// Start-up and offline-map figures of a run (run.json "startup" and "map").
struct TrackStartup {
  double vocabulary_load_ms = 0;
  double map_load_ms = 0;  // Read, check and rebuild; 0 without --load-map.
  double map_read_ms = 0;  // Of which reading and checking the file.
  // Relocalization's map-point index built on the loaded map (on a thread
  // of its own from the end of map_load_ms, while tracking starts; 0 with
  // --relocalization bow).
  double relocalization_index_ms = 0;
  double first_pose_ms = -1;      // From process start to the first pose; -1 = none.
  int64_t first_pose_frame = -1;  // Sequence index of that frame.
};

// Counts of a finished run (also in run.json).
struct TrackSummary {
  size_t frames = 0;
  size_t tracked = 0;
  size_t lost = 0;
  size_t keyframes = 0;
  size_t map_points = 0;
  std::vector<double> lost_timestamps;
  TrackStartup startup;
};

// Runs the stage. Throws UsageError (bad options), NoInputError (missing
// inputs), DataError (malformed or inconsistent inputs: a sequence with fewer
// than 2 frames, settings without intrinsics, a vocabulary that is not an ORB
// vocabulary, a features file of other frames or settings, a map file that is
// corrupt or was built with another vocabulary or camera), AlgorithmError
// (tracking never initialized, e.g. depth all zero), CantCreateError.
TrackSummary RunTrack(const TrackOptions& options);

}  // namespace rrslam
