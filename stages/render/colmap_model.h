// A saved map as a COLMAP sparse model (cameras, images, points3D), for
// Gaussian splatting, NeRF and dense MVS tools that start from COLMAP.
//
// COLMAP's conventions, which differ from rrslam's:
//  - pixels: (0.5, 0.5) is the centre of the top-left pixel (rrslam: (0, 0)),
//    so every 2D point and the principal point are shifted by +0.5;
//  - the 2D points are where the keypoints are in the real (distorted)
//    image, with the camera's distortion in its model: PINHOLE without
//    distortion, OPENCV (fx fy cx cy k1 k2 p1 p2) when k3 = 0, FULL_OPENCV
//    otherwise;
//  - an image's pose is world-to-camera (q = QW QX QY QZ, t), rrslam's
//    T_cam_world; ids start at 1; a 2D point without a 3D point has id -1.
// Each image lists every keypoint of its keyframe; each 3D point's track
// lists its observations (image, keypoint index); its error is the mean
// reprojection error (pixels) of its observations through the model.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "stages/mapstore/map_data.h"

namespace rrslam {

struct ColmapCamera {
  uint32_t id = 1;
  std::string model;  // PINHOLE, OPENCV or FULL_OPENCV.
  uint64_t width = 0, height = 0;
  std::vector<double> params;
};

struct ColmapImage {
  uint32_t id = 0;
  Rigid3d T_cam_world;  // World to camera.
  uint32_t camera_id = 1;
  std::string name;                             // File name under the model's image folder.
  std::vector<std::array<double, 2>> points2d;  // COLMAP pixels.
  std::vector<int64_t> point3d_ids;             // Parallel; -1 = none.
};

struct ColmapPoint {
  uint64_t id = 0;
  std::array<double, 3> xyz = {0, 0, 0};
  std::array<uint8_t, 3> rgb = {128, 128, 128};
  double error = 0;                                  // Mean reprojection error, pixels.
  std::vector<std::pair<uint32_t, uint32_t>> track;  // (image id, 2D point index).
};

struct ColmapModel {
  std::vector<ColmapCamera> cameras;
  std::vector<ColmapImage> images;
  std::vector<ColmapPoint> points;
};

// The model of `map`: keyframe k becomes image k + 1 named `image_names[k]`,
// map point i (in the map's order) point i + 1 coloured `colours[i]`.
// Throws std::invalid_argument when the sizes differ from the map's.
ColmapModel ColmapModelOf(const MapData& map, const std::vector<std::string>& image_names,
                          const std::vector<std::array<uint8_t, 3>>& colours);

// Writes DIR/cameras, DIR/images and DIR/points3D as .txt or .bin (each file
// atomically). Throws CantCreateError naming the file.
void WriteColmapModel(const ColmapModel& model, const std::filesystem::path& dir, bool binary);

// Reads a model WriteColmapModel (or COLMAP) wrote. Throws NoInputError when
// a file is missing, DataError naming the file when it is malformed.
ColmapModel ReadColmapModel(const std::filesystem::path& dir, bool binary);

}  // namespace rrslam
