// The floor of a saved map and the floor-aligned frame (REP 103: z up).
//
// A map's world frame is its first keyframe's camera (x right, y down, z
// forward), so viewers show it upside down and tilted by the first view's
// pitch. The floor frame has z along the floor's normal towards the
// cameras, its origin on the floor under the first keyframe's camera, and x
// along that camera's viewing direction projected onto the floor.
//
// Frames: points and planes in the map's world frame unless named;
// T_floor_map maps map points into the floor frame (metres).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/dataset.h"
#include "common/geometry.h"
#include "stages/mapstore/map_data.h"

namespace rrslam {

struct FloorOptions {
  double inlier_metres = 0.02;  // A point this close to a plane lies on it.
  double max_tilt_deg = 40;  // Planes whose normal is further from the cameras' up are not floors.
  // The floor lies at least this far below the cameras' median height.
  double min_camera_height = 0.3;
  int min_inliers = 200;
  int iterations = 1000;  // RANSAC hypotheses (seeded: the result is reproducible).
  uint64_t seed = 1;
};

struct Floor {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // Unit, towards the cameras.
  double offset = 0;                                  // normal . x + offset = 0 on the floor.
  Rigid3d T_floor_map;
  size_t inliers = 0;        // Points within inlier_metres of the plane.
  size_t points = 0;         // Points searched.
  double tilt_deg = 0;       // Between the normal and the cameras' mean up direction.
  double camera_height = 0;  // Median height of the keyframes' cameras above it, metres.
};

// The cameras' mean up direction: the mean of the keyframes' -y axes.
Eigen::Vector3d CamerasUp(const MapData& map);

// The largest plane among `points` (map frame) within max_tilt_deg of the
// cameras' up and at least min_camera_height below their median height, by
// RANSAC on 3 points and a least-squares refit on its inliers; nullopt when
// no such plane has min_inliers points.
std::optional<Floor> FindFloor(const MapData& map, const std::vector<Eigen::Vector3d>& points,
                               const FloorOptions& options = {});

// The map points' positions, and with a sequence the keyframes' depth images
// sampled every `stride` pixels (map frame; keyframes are found in the
// sequence by timestamp within 0.1 ms, a keyframe without its frame is a
// DataError naming `source`).
std::vector<Eigen::Vector3d> FloorSearchPoints(const MapData& map, const RgbdSequence* sequence,
                                               int stride, const std::string& source);

// The floor as the metadata key "floor" holds it (JSON object text) and back.
std::string FloorToJson(const Floor& floor);
std::optional<Rigid3d> FloorFromMetadata(const std::string& metadata);

}  // namespace rrslam
