// What the render stage draws of a saved map (rrslam.map): map points,
// keyframe poses and the graphs between keyframes, read through mapstore's
// schema and put in the form every view needs (camera poses T_world_cam,
// positions as Eigen vectors, which part of the map an earlier run loaded).
//
// Frames: the map's world frame, metres (stages/mapstore/map_data.h). A
// keyframe's pose here is T_world_cam (camera-to-world: the translation is the
// camera centre), the inverse of what the map file stores.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/dataset.h"
#include "common/geometry.h"
#include "common/trajectory.h"
#include "stages/mapstore/map_data.h"

namespace rrslam {

// Where a keyframe saw a map point: the keypoint's real (distorted) image
// pixel, as in the keyframe's colour image.
struct SceneObservation {
  uint64_t keyframe = 0;
  float pixel_x = 0, pixel_y = 0;
};

struct ScenePoint {
  uint64_t id = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // World, metres.
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();    // Mean viewing direction (unit or zero).
  int observations = 0;                                // Keyframes that observe it.
  std::vector<SceneObservation> seen_at;               // One per observation.
  uint64_t first_keyframe = 0;                         // Keyframe it was created with.
  bool loaded = false;  // Came from the map the saving run loaded (--load-map).
};

struct SceneKeyFrame {
  uint64_t id = 0;
  double timestamp = 0;                                   // Seconds, the sequence's clock.
  Rigid3d T_world_cam;                                    // Camera pose (camera-to-world).
  uint64_t parent = kNoId;                                // Spanning-tree parent id.
  std::vector<std::pair<uint64_t, int32_t>> connections;  // Covisibility (id, shared points).
  std::vector<uint64_t> loop_edges;
  bool loaded = false;  // Came from the map the saving run loaded.

  Eigen::Vector3d centre() const { return T_world_cam.translation; }
};

struct MapScene {
  MapCamera camera;                      // Intrinsics and image size (frusta).
  std::vector<ScenePoint> points;        // Sorted by id.
  std::vector<SceneKeyFrame> keyframes;  // Sorted by id (= creation order).
  // True when the map was saved by a run that had loaded another map
  // (restore mapping), so `loaded` tells the two apart.
  bool has_loaded_part = false;
  std::string source;  // The file it came from (for messages and metadata).
  // The world's up direction when the frame defines one (the floor frame's
  // +z, export_frame.h); nullopt: the cameras' mean up stands in.
  std::optional<Eigen::Vector3d> up;

  // Index of keyframe `id` in `keyframes`, or nullopt.
  std::optional<size_t> FindKeyFrame(uint64_t id) const;
  // The keyframe trajectory (T_world_cam by timestamp), as KeyFrameTrajectory.txt.
  Trajectory KeyFrameTrajectory() const;
};

// Builds the scene of a map. Points and keyframes with an id below the loaded
// map's next ids (metadata "loaded_map", written by rrslam-track --load-map
// ... --save-map) are marked loaded.
MapScene MakeMapScene(const MapData& map, const std::string& source);

// For every keyframe of `scene` (in order), the index of its frame in a
// sequence whose frames have `rgb_timestamps` (seconds): the nearest frame
// within kKeyFrameTimestampTolerance of the keyframe's timestamp, or nullopt
// when none is.
std::vector<std::optional<size_t>> MatchKeyFrameTimestamps(
    const MapScene& scene, const std::vector<double>& rgb_timestamps);

// The index in `sequence` of every keyframe's frame (MatchKeyFrameTimestamps);
// throws DataError naming the map, the keyframe and the sequence when one
// has none.
std::vector<size_t> KeyFrameFrames(const MapScene& scene, const RgbdSequence& sequence);

// Reads and validates a map file (mapstore's ReadMapFile: NoInputError,
// DataError naming the file) and builds its scene.
MapScene LoadMapScene(const std::filesystem::path& path);

// A trajectory of another world frame (ground truth) expressed in the map's
// frame: aligned rigidly (no scale; RGB-D) to the map's keyframe trajectory by
// the ATE alignment (stages/eval/ate.h) over their stamps that associate
// within 20 ms. Throws DataError naming `source` when fewer than 3 stamps
// associate.
Trajectory ExpressInMapFrame(const Trajectory& other, const MapScene& scene,
                             const std::string& source);

}  // namespace rrslam
