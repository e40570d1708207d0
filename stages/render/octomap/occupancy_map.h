// `rrslam-render octomap`: a saved map's keyframe depth images integrated
// into an OctoMap (octomap::OcTree, liboctomap, Debian's liboctomap-dev):
// every depth pixel (every `pixel_stride`-th in both image axes) is a ray
// from the keyframe's camera centre; the voxels it passes are updated as
// free and the voxel it ends in as occupied, with OctoMap's own sensor model
// (hit 0.7, miss 0.4, clamping 0.12..0.97, occupied above 0.5) and its
// insertPointCloud, which updates a voxel once per scan and lets a hit win
// over a miss. The tree is written in OctoMap's binary format (.bt, maximum
// likelihood: free, occupied or unknown per voxel), which octovis,
// octomap_server and octomap-tools read.
//
// Frames and units: metres; the export frame of `--frame` (export_frame.h),
// by default the floor frame (z up, the floor at z = 0): a navigation grid
// (occupancy_grid.h) takes heights above the floor from it. Camera poses are
// T_frame_cam (camera-to-frame).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/atomic_file.h"
#include "common/geometry.h"
#include "common/output_path.h"
#include "stages/render/export_frame.h"
#include "stages/render/keyframe_images.h"

namespace CLI {
class App;
}
namespace octomap {
class OcTree;
}

namespace rrslam {

// How depth images become an OctoMap.
struct DepthIntegrationOptions {
  // Edge of the smallest voxel, metres, in [0.005, 1] (--resolution).
  double resolution = 0.05;
  // Measurements farther than this from the camera centre, metres, clear
  // free space up to it and mark nothing occupied (octomap_server's
  // sensor_model/max_range); > 0 (--max-range). Kinect-type depth becomes
  // noisy beyond ~4 m.
  double max_range = 4.0;
  // Every n-th pixel of each depth image in both axes, in [1, 16]
  // (--pixel-stride). Every pixel costs little: rays are cast once per
  // voxel they end in (insertPointCloud's discretize), and at 5 cm and 3 m a
  // Kinect pixel covers 0.5 cm, so neighbouring pixels end in one voxel.
  int pixel_stride = 1;

  bool Check(std::string* why) const;
  nlohmann::ordered_json ToJson() const;
};

// Binds --resolution, --max-range and --pixel-stride.
void BindDepthIntegrationOptions(CLI::App* command, DepthIntegrationOptions* options);

// What an integration did.
struct IntegrationStats {
  size_t keyframes = 0;
  size_t rays = 0;               // Depth pixels cast (within and beyond max_range).
  size_t nodes = 0;              // Of the pruned tree (OcTree::size(), what a .bt holds).
  size_t leaves = 0;             // Leaf nodes.
  size_t occupied_leaves = 0;    // Of them, occupied (probability > 0.5).
  size_t memory_bytes = 0;       // OcTree::memoryUsage().
  double integrate_seconds = 0;  // Reading images and inserting the rays.
  Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();  // Known space.

  nlohmann::ordered_json ToJson() const;
};

// Depth image of view `index` (CV_32FC1 metres, 0 = none, the camera's size).
using DepthLoader = std::function<cv::Mat(size_t index)>;

// Integrates views (camera `camera`, poses T_frame_cams, depth from `load`)
// into a new OcTree, inner nodes updated, converted to maximum likelihood
// (free or occupied) and pruned. Throws DataError when a
// depth image does not fit the camera, or no view has depth.
std::unique_ptr<octomap::OcTree> IntegrateDepth(const DepthIntegrationOptions& options,
                                                const KeyFrameCamera& camera,
                                                const std::vector<Rigid3d>& T_frame_cams,
                                                const DepthLoader& load, IntegrationStats* stats);

// What `octomap` and `grid` read: a map and the RGB-D sequence it was built
// from (its keyframes' depth, found by timestamp).
struct MapDepthInput {
  std::filesystem::path map;           // --map. Required.
  std::filesystem::path sequence;      // --sequence. Required.
  std::filesystem::path associations;  // --associations, as rrslam-track's.

  // False, with `why`, when map or sequence is missing or an output breaks
  // the outputs rule against them (CheckOutputs, output_path.h).
  bool Check(const std::vector<NamedPath>& outputs, std::string* why) const;
  void AddToJson(nlohmann::ordered_json* json) const;
};
void BindMapDepthInput(CLI::App* command, MapDepthInput* input);

// A map's keyframes integrated.
struct MapOctree {
  FramedMap map;  // The map in the export frame.
  std::unique_ptr<octomap::OcTree> tree;
  IntegrationStats stats;
};
// Integrates the depth of `map`'s keyframes (the map already in its export
// frame: LoadMapInFrame of input.map), their images found in input.sequence
// (KeyFrameImages). Throws NoInputError, DataError (keyframe_images.h).
MapOctree IntegrateMap(FramedMap map, const MapDepthInput& input,
                       const DepthIntegrationOptions& options);

// Writes the tree in OctoMap's binary format (.bt; the tree is already
// maximum likelihood) with `comments` as '#' lines of its header (OctoMap's
// readers skip them), into the output's temporary file, and commits it.
// Throws CantCreateError.
void WriteOctree(const octomap::OcTree& tree, const std::vector<std::string>& comments,
                 AtomicOutput* output);

struct OctomapOptions {
  MapDepthInput input;
  std::filesystem::path out;    // --out: the .bt file. Required.
  std::string frame = "floor";  // --frame: floor (default: what robots use) or camera.
  DepthIntegrationOptions integration;

  bool Check(std::string* why) const;
  nlohmann::ordered_json ToJson() const;
};
void BindOctomapOptions(CLI::App* command, OctomapOptions* options);

// `rrslam-render octomap`: integrates the map, writes the .bt atomically and
// prints a summary (the frame's T_floor_map among it) on stdout.
// Throws UsageError, NoInputError, DataError, CantCreateError.
IntegrationStats RunOctomap(const OctomapOptions& options);

}  // namespace rrslam
