// rrslam-track: RGB-D SLAM (tracking, local mapping, loop closing) over a TUM-layout sequence.
#include <CLI/CLI.hpp>

#include "common/cli.h"
#include "stages/track/track.h"

namespace {

void BindTrackOptions(CLI::App& app, rrslam::TrackOptions* o) {
  app.add_option("--sequence", o->sequence, "TUM RGB-D sequence folder")->required();
  app.add_option("--settings", o->settings, "ORB-SLAM2 RGB-D settings YAML")->required();
  app.add_option("--vocab", o->vocabulary,
                 "Vocabulary: rrslam binary (.rrv) or DBoW2 text (ORBvoc.txt)")
      ->required();
  app.add_option("--out", o->out,
                 "Output folder (CameraTrajectory.txt, KeyFrameTrajectory.txt, run.json); an "
                 "existing one is replaced as a whole only when empty or an earlier "
                 "rrslam-track output (else exit 73, nothing touched)")
      ->required();
  app.add_option("--features", o->features,
                 "Features file from rrslam-extract to use instead of extracting (its frames "
                 "must be frames of the sequence, extracted from the same image files, its "
                 "settings those of --settings)")
      ->capture_default_str();
  app.add_option("--associations", o->associations,
                 "Associations file (rgb_ts rgb depth_ts depth), relative to the sequence; "
                 "default: pair rgb.txt and depth.txt")
      ->capture_default_str();
  app.add_option("--mode", o->mode,
                 "batch: local mapping and loop closing in step after each keyframe "
                 "(bit-identical runs); realtime: each in its own thread")
      ->capture_default_str();
  app.add_option("--max-frames", o->max_frames, "Track at most this many frames (0 = all)")
      ->capture_default_str();
  app.add_flag("--pace", o->pace,
               "Realtime mode: deliver frames no faster than their timestamps, as a live "
               "camera");
  app.add_option("--max-pace-gap", o->max_pace_gap,
                 "With --pace: a gap between frame timestamps longer than this many seconds is "
                 "paced as this long (a warning at start names the largest)")
      ->capture_default_str();
  app.add_option("--extraction-threads", o->extraction_threads,
                 "Threads of the ORB extractor (does not change the result)")
      ->capture_default_str();
  app.add_flag_callback(
      "--no-loop-closing", [o] { o->loop_closing = false; },
      "Turn loop closing (and its global bundle adjustment) off");
  app.add_flag("--refine-map,!--no-refine-map", o->refine_map,
               "After the last frame, refine every keyframe and map point by a bundle "
               "adjustment run to convergence, before the trajectories and the map are written "
               "(default: off; not with --localization-only; ORB-SLAM2 has no such step)")
      ->capture_default_str();
  app.add_flag("--cull-revisits,!--no-cull-revisits", o->revisit_culling.enabled,
               "After the last frame, cull the keyframes this run made where an older keyframe "
               "holds the view (--revisit-distance, --revisit-angle) and whose points the map "
               "holds already: revisits leave the map about the size of the first pass; every "
               "frame keeps its pose (default: on; ORB-SLAM2 keeps them)")
      ->capture_default_str();
  app.add_option("--revisit-distance", o->revisit_culling.max_distance,
                 "--cull-revisits: the older keyframe's camera centre within this many metres")
      ->capture_default_str();
  app.add_option("--revisit-angle", o->revisit_culling.max_angle_deg,
                 "--cull-revisits: its optical axis within this many degrees")
      ->capture_default_str();
  // Offline maps.
  app.add_option("--save-map", o->save_map,
                 "Write the final map (rrslam.map: keyframes, map points, graphs, bags of "
                 "words) to this file, atomically, after the last global BA")
      ->capture_default_str();
  app.add_option("--load-map", o->load_map,
                 "Start on this saved map (same vocabulary tree and camera settings): the first "
                 "frames relocalize in it, poses are in its world frame; mapping goes on in it "
                 "unless --localization-only. The file stays mapped while the run lasts: "
                 "replace it by rename (as --save-map does), not in place")
      ->capture_default_str();
  app.add_option("--first-frame", o->first_frame,
                 "Start at this frame of the sequence (index from 0)")
      ->capture_default_str();
  app.add_flag("--localization-only", o->localization_only,
               "With --load-map: localize in the map without changing it (ORB-SLAM2's "
               "localization mode: visual odometry where the map is not seen)");
  app.add_option("--changed-point-views", o->local_mapping.changed_point_min_views,
                 "Restore mapping: cull a loaded point as changed when predicted visible in "
                 "this many frames, found in fewer than --changed-point-ratio of them, and "
                 "seen through by their depth images (--changed-point-absent); 0 = never")
      ->capture_default_str();
  app.add_option("--changed-point-ratio", o->local_mapping.changed_point_min_found_ratio,
                 "Restore mapping: see --changed-point-views; in [0, 1]")
      ->capture_default_str();
  app.add_option("--changed-point-absent", o->local_mapping.changed_point_min_absent,
                 "Restore mapping: ... seen through (the depth image measured only depths "
                 "beyond it, by max(10 cm, 15%), round its pixel) from at least this many "
                 "viewpoints 5 cm apart, and in 3x as many frames as it measured a surface there")
      ->capture_default_str();
  app.add_option("--restore-point-found", o->local_mapping.restore_point_min_found,
                 "Restore mapping: a point made in the session that fewer than two "
                 "keyframes observe stays when tracking found it in at least this many "
                 "frames (ORB-SLAM2 culls it two keyframes on); 0 = ORB-SLAM2's rule")
      ->capture_default_str();
  app.add_option("--new-map-after", o->atlas.new_map_after_s,
                 "Restore mapping: seconds of camera time without relocalizing in the "
                 "--load-map map after which a new map is started and merged into it where "
                 "they meet (negative: never, wait as ORB-SLAM2)")
      ->capture_default_str();
  // Departures from ORB-SLAM2; docs/track.md gives the measurements.
  app.add_option("--close-tracked", o->tracker.close_tracked,
                 "Keyframe when fewer close points are tracked (ORB-SLAM2: 100; the default "
                 "follows the rule for defaults, docs/track.md)")
      ->capture_default_str();
  app.add_option("--new-view-fraction", o->tracker.new_view_fraction,
                 "Keyframes only where more than this fraction of the close keypoints is new "
                 "to the map, on 3 frames in a row, on revisits (--new-view-min-age), so they "
                 "add few (0: ORB-SLAM2's rule alone; docs/track.md)")
      ->capture_default_str();
  app.add_option("--new-view-min-age", o->tracker.new_view_min_age,
                 "With --new-view-fraction: its gate only on revisits, frames whose reference "
                 "keyframe is at least this many keyframes older than the newest (0: every frame)")
      ->capture_default_str();
  app.add_option("--restore-close-tracked", o->restore_close_tracked,
                 "The same when mapping on a --load-map map (restore mapping; ORB-SLAM2: 100)")
      ->capture_default_str();
  app.add_flag("--ba-depth-fallback,!--no-ba-depth-fallback",
               o->local_mapping.bundle_adjustment.depth_fallback,
               "Local BA keeps an observation whose depth disagrees as (u, v) (default: on); "
               "--no-ba-depth-fallback removes it, as ORB-SLAM2")
      ->capture_default_str();
  app.add_flag("--small-vocab-groups", o->small_vocab_groups,
               "Vocabularies of < 6 levels group BoW candidates at depth 2 (ORB-SLAM2: 4 "
               "levels above the words)");
  app.add_option_function<std::string>(
         "--relocalization",
         [o](const std::string& name) {
           rrslam::ParseRelocalizationMethod(name, &o->tracker.relocalization.method);
         },
         "Relocalization stages: bow (ORB-SLAM2: keyframe shortlist by bag of words), direct "
         "(frame descriptors against every map point's and its keyframes' descriptors) or "
         "bow+direct (direct when bow finds no pose and the frame has none: a frame tracked by "
         "visual odometry in localization mode checks by bow alone)")
      ->check(CLI::IsMember(rrslam::RelocalizationMethodNames()))
      ->default_str(rrslam::ToString(o->tracker.relocalization.method));
  app.add_option("--relocalization-covisible", o->tracker.relocalization.bow_covisible,
                 "Bag-of-words stage: each candidate's matches joined by those of its N best "
                 "covisible keyframes and verified against their local map (ORB-SLAM3's "
                 "covisible window; 0 = the candidate alone, ORB-SLAM2)")
      ->check(CLI::Range(0, 20))
      ->capture_default_str();
  app.add_flag("--expand-all-local-keyframes", o->tracker.expand_all_local_keyframes,
               "Local map: neighbours of every observing keyframe (ORB-SLAM2 stops at the "
               "first parent)");
  app.add_flag("--last-frame-fallback,!--no-last-frame-fallback", o->tracker.last_frame_fallback,
               "When the motion model and the reference keyframe both fail (as right after a "
               "relocalization, seen from another side), search the last frame's points where "
               "they were (default: on); --no-last-frame-fallback loses the frame, as ORB-SLAM2")
      ->capture_default_str();
}

}  // namespace

int main(int argc, char** argv) {
  rrslam::TrackOptions options;
  return rrslam::RunTool(
      argc, argv,
      {"track",
       "Tracks an RGB-D sequence, maps it and closes its loops (ORB-SLAM2's RGB-D SLAM with "
       "Ceres); writes CameraTrajectory.txt, KeyFrameTrajectory.txt and run.json."},
      [&](CLI::App& app) { BindTrackOptions(app, &options); }, [&] { rrslam::RunTrack(options); });
}
