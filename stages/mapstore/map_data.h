// The on-disk map schema (rrslam.map): plain structs of a saved SLAM map.
//
// A MapData is what `rrslam-track --save-map` writes and `--load-map` reads,
// what `rrslam-mapstore` inspects (and the render stage will draw). It knows nothing of
// threads or of track's live objects: relations are ids, not pointers, and
// track converts its live map to and from it (stages/track/data/map_io.h).
//
// Frames: poses are T_cam_world (maps world points into the camera; world =
// the map's frame, the first keyframe of the map that built it at identity).
// Positions are metres in the world frame; pixels are ideal (undistorted)
// pixels of the camera in MapCamera unless said otherwise.
//
// Relations (checked by ValidateMapData, map_file.h):
//  - keyframe ids and map point ids are unique; lists are sorted by id;
//  - KeyFrameRecord::map_point_ids[i] names a map point of the map (or is
//    kNoId), and that point lists the observation (keyframe, i); every
//    observation of a point is listed back by its keyframe;
//  - covisibility weights are symmetric and name keyframes of the map;
//  - the spanning tree's parents name keyframes of the map, exactly one
//    keyframe (the root) has none, and following parents always reaches it;
//  - loop edges are symmetric;
//  - a map point's reference keyframe observes it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/keypoint.h"
#include "common/orb_descriptor.h"
#include "stages/mapstore/record_array.h"

namespace rrslam {

// Seconds: a keyframe's timestamp is the rgb timestamp of the frame it was
// made from, printed with 6 decimals in the sequence's lists; a keyframe is
// found in its sequence by timestamp within this (render, floor search).
inline constexpr double kKeyFrameTimestampTolerance = 1e-4;

// "No keyframe / no map point" in an id field.
inline constexpr uint64_t kNoId = ~uint64_t{0};

// Bound on a map's next ids (CheckMapNextIds, map_file.h). A next id exceeds
// the count of keyframes / map points by the ones its run culled, but track
// indexes its live objects by id: loading a map allocates ~9 bytes per id up
// to the next id (and tracking more per-id arrays of the same length), so a
// next id of 1e8..1e19 read from a file would exhaust memory. A run that
// created 2^24 (16.7 million) keyframes or map points held every one of them
// in memory (track's Map keeps culled objects), so no real map comes near
// this bound: at most kMapIdSlack ids plus kMapIdsPerObject per object kept.
inline constexpr uint64_t kMapIdSlack = uint64_t{1} << 24;
inline constexpr uint64_t kMapIdsPerObject = 64;
inline constexpr uint64_t MaxNextMapId(uint64_t count) {
  return count > (~uint64_t{0} - kMapIdSlack) / kMapIdsPerObject
             ? ~uint64_t{0}
             : kMapIdSlack + kMapIdsPerObject * count;
}

// The camera and ORB settings the map was built with. A map is refused when
// loaded with other settings (track compares every field).
struct MapCamera {
  double fx = 0, fy = 0, cx = 0, cy = 0;          // Pinhole intrinsics, pixels.
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;  // Radial-tangential distortion.
  int32_t width = 0, height = 0;                  // Image size, pixels.
  double bf = 0;                                  // Baseline (m) times fx (px), virtual stereo.
  double th_depth = 0;                            // Close/far threshold, in baselines (ThDepth).
  double depth_map_factor = 0;                    // Depth image units per metre.
  // ORB extractor.
  int32_t orb_features = 0;
  double orb_scale_factor = 0;
  int32_t orb_levels = 0;
  int32_t orb_ini_th_fast = 0;
  int32_t orb_min_th_fast = 0;

  bool operator==(const MapCamera&) const = default;
};

// The vocabulary the map's bags of words were computed with, by content
// (Vocabulary::ContentHash: the tree's k, L, weighting, scoring, nodes and
// weights; not the file's name, format or metadata).
struct MapVocabulary {
  uint64_t content_hash = 0;
  int32_t k = 0;
  int32_t levels = 0;
  int32_t weighting = 0;  // WeightingType as an integer.
  int32_t scoring = 0;    // ScoringType as an integer.
  uint64_t num_words = 0;
  std::string name;  // File name when saved (informative only).

  // Same tree (name ignored).
  bool SameTree(const MapVocabulary& o) const {
    return content_hash == o.content_hash && k == o.k && levels == o.levels &&
           weighting == o.weighting && scoring == o.scoring && num_words == o.num_words;
  }
};

struct MapPose {
  double qw = 1, qx = 0, qy = 0, qz = 0;  // Rotation of T_cam_world (unit quaternion).
  double tx = 0, ty = 0, tz = 0;          // Translation of T_cam_world, metres.
  bool operator==(const MapPose&) const = default;
};

struct KeyFrameRecord {
  uint64_t id = 0;
  uint64_t frame_id = 0;  // Index of its frame in the run that made it.
  double timestamp = 0;   // Seconds (the sequence's clock).
  MapPose T_cam_world;
  // Parallel arrays, one entry per keypoint; views of the file's bytes in a
  // map read from a file (record_array.h; the keypoints of a format 1.x file
  // are copied). A keypoint's virtual right coordinate is not stored: it
  // follows from its depth and the camera's bf.
  RecordArray<Keypoint> keypoints;
  RecordArray<OrbDescriptor> descriptors;
  RecordArray<uint64_t> map_point_ids;  // kNoId = none.
  // Bag of words: (word, value) sorted by word, and the feature vector
  // (node, sorted keypoint indices) grouped `MapData::bow_levels_up` levels
  // above the words, sorted by node.
  std::vector<std::pair<uint32_t, double>> bow;
  std::vector<std::pair<uint32_t, std::vector<uint32_t>>> feature_vector;
  // Covisibility: (keyframe id, shared points), sorted by id.
  std::vector<std::pair<uint64_t, int32_t>> connections;
  uint64_t parent = kNoId;           // Spanning-tree parent; kNoId for the root.
  std::vector<uint64_t> loop_edges;  // Sorted by id.
};

struct MapPointRecord {
  uint64_t id = 0;
  double position[3] = {0, 0, 0};  // World frame, metres.
  double normal[3] = {0, 0, 0};    // Mean unit viewing direction (towards the point).
  double min_distance = 0;         // Scale-invariance distances, metres.
  double max_distance = 0;
  OrbDescriptor descriptor;  // Representative descriptor.
  int32_t visible = 0;       // Times predicted visible in a tracked frame.
  int32_t found = 0;         // Times matched there.
  uint64_t reference_keyframe = 0;
  uint64_t first_keyframe = 0;  // Keyframe it was created with.
  // (keyframe id, keypoint index), sorted by keyframe id.
  std::vector<std::pair<uint64_t, uint32_t>> observations;
};

struct MapData {
  MapCamera camera;
  MapVocabulary vocabulary;
  int32_t bow_levels_up = 4;               // Levels above the words of the feature vectors.
  std::vector<KeyFrameRecord> keyframes;   // Sorted by id.
  std::vector<MapPointRecord> map_points;  // Sorted by id.
  // Ids the live map gives its next keyframe / map point (> every id above,
  // at most MaxNextMapId of the count).
  uint64_t next_keyframe_id = 0;
  uint64_t next_map_point_id = 0;
  // JSON: producer (tool, version) and the options of the run that saved it.
  std::string metadata;
  // Since format 1.1: maps of the same place, camera and vocabulary kept beside
  // this one, each in a world frame of its own and complete in itself (ids
  // may repeat across maps; their own other_maps empty): a session whose new
  // map never met the loaded one (docs/track.md, "Several maps in one
  // session"). At most kMaxOtherMaps.
  std::vector<MapData> other_maps;
};

inline constexpr size_t kMaxOtherMaps = 99;

}  // namespace rrslam
