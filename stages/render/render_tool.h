// The commands of `rrslam-render`: map, trajectory, ply, html, dense, colmap,
// octomap, grid. Each has an options struct (defaults, units, Check) and a
// Run function; main.cc only binds them to CLI11 subcommands. html, dense,
// octomap and grid live in html/, dense/ and octomap/ (html_viewer.h,
// dense_model.h, occupancy_map.h, occupancy_grid.h).
//
// Picture outputs go into a folder (--out DIR, created when missing; its
// parent must exist): each file is written atomically and files of other
// names in the folder are left alone.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "stages/render/colmap_model.h"
#include "stages/render/dense/dense_model.h"
#include "stages/render/html/html_viewer.h"
#include "stages/render/map_picture.h"
#include "stages/render/octomap/occupancy_grid.h"
#include "stages/render/octomap/occupancy_map.h"
#include "stages/render/ply.h"
#include "stages/render/trajectory_picture.h"

namespace CLI {
class App;
}

namespace rrslam {

// `map`: PNG pictures of a saved map, DIR/map_<view>.png per view.
struct RenderMapOptions {
  std::filesystem::path map;  // rrslam.map file.
  std::filesystem::path out;  // Folder.
  std::vector<std::string> views = {"top", "side", "front", "perspective"};
  std::filesystem::path viewpoint;  // Settings file with Viewer.Viewpoint*; empty = automatic.
  std::string colour = "height";    // height, observations, age.
  std::string frame = "camera";     // camera or floor (export_frame.h); floor: up = z.
  MapPictureOptions picture;  // Size, up axis, what is drawn (colouring/viewpoint set from above).

  bool Check(std::string* why) const;
};

// `trajectory`: DIR/trajectory_{top,side,front}.png and, with a ground
// truth, DIR/trajectory_error.png.
struct RenderTrajectoryOptions {
  std::vector<std::filesystem::path> estimates;  // TUM files (--est, repeatable).
  std::filesystem::path ground_truth;            // TUM file; empty = none.
  std::filesystem::path out;                     // Folder.
  TrajectoryPictureOptions picture;

  bool Check(std::string* why) const;
};

// `ply`: the map points as a PLY file.
struct RenderPlyOptions {
  std::filesystem::path map;
  std::filesystem::path out;       // .ply file.
  std::filesystem::path sequence;  // Sequence folder for colours; empty = grey.
  std::filesystem::path
      associations;    // As rrslam-track's --associations (relative to the sequence).
  bool binary = true;  // binary_little_endian (--binary, the default); false: ASCII (--ascii).
  std::string frame = "camera";  // camera or floor (export_frame.h).

  bool Check(std::string* why) const;
};

// `colmap`: the map as a COLMAP sparse model (colmap_model.h):
// DIR/sparse/0/{cameras,images,points3D}.{txt,bin} and the keyframes'
// colour images copied to DIR/images/, COLMAP's project layout.
struct RenderColmapOptions {
  std::filesystem::path map;
  std::filesystem::path sequence;      // The sequence the map was built from (images, colours).
  std::filesystem::path associations;  // As rrslam-track's --associations.
  std::filesystem::path out;           // Folder (created when missing).
  bool binary = false;                 // .bin instead of .txt (--binary).
  std::string frame = "camera";        // camera or floor (export_frame.h); DIR/frame.txt names it.

  bool Check(std::string* why) const;
};

struct RenderCommands {
  RenderMapOptions map;
  RenderTrajectoryOptions trajectory;
  RenderPlyOptions ply;
  HtmlOptions html;
  DenseOptions dense;
  RenderColmapOptions colmap;
  OctomapOptions octomap;
  GridOptions grid;
  std::string chosen;
};
void BindRenderCommands(CLI::App& app, RenderCommands* commands);
void RunRenderCommand(const RenderCommands& commands);

// Each throws UsageError for invalid options, NoInputError for a missing
// input, DataError for a malformed one, CantCreateError when an output cannot
// be written, and returns the paths it wrote.
std::vector<std::filesystem::path> RunRenderMap(const RenderMapOptions& options);
std::vector<std::filesystem::path> RunRenderTrajectory(const RenderTrajectoryOptions& options);
std::filesystem::path RunRenderPly(const RenderPlyOptions& options);
std::vector<std::filesystem::path> RunRenderColmap(const RenderColmapOptions& options);

// The map points of `scene` as a PLY cloud: positions, normals (unit, from
// the point towards the cameras that see it, for shading), observation
// counts, and colours: the mean colour at the point's keypoints in the
// keyframes' colour images of `sequence` (a keyframe whose frame is not in
// the sequence is a DataError), or grey (128) when `sequence` is empty.
PlyCloud MapPointCloud(const MapScene& scene, const std::filesystem::path& sequence,
                       const std::filesystem::path& associations = {});

// Creates the output folder of a picture command (not its parent). Throws
// CantCreateError naming it.
void PrepareOutputFolder(const std::filesystem::path& out);

}  // namespace rrslam
