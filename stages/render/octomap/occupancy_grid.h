// `rrslam-render grid`: a 2D occupancy grid for navigation, the OctoMap of a
// map's keyframes (occupancy_map.h, floor frame) projected onto the floor:
// a cell is occupied when an occupied voxel between two heights above the
// floor lies over it, free when only free voxels of that band do, and
// unknown where no ray passed through the band. Written as ROS map_server's
// map (map.yaml + map.pgm, what ROS 1's map_server and Nav2's read) and as a
// PNG picture with the keyframe trajectory drawn in.
//
// Frames and units: the floor frame (z up, floor at z = 0), metres. Cell
// (x, y) covers [origin.x + x * resolution, + resolution) along x, the same
// along y; row 0 of the grid is the lowest y (row 0 of the PGM the highest,
// as map_server reads it).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "stages/render/octomap/occupancy_map.h"

namespace CLI {
class App;
}
namespace octomap {
class OcTree;
}

namespace rrslam {

// nav_msgs/OccupancyGrid's cell values.
inline constexpr int8_t kCellUnknown = -1;
inline constexpr int8_t kCellFree = 0;
inline constexpr int8_t kCellOccupied = 100;

struct OccupancyGrid {
  int width = 0, height = 0;                         // Cells.
  double resolution = 0;                             // Metres per cell.
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();  // Corner of cell (0, 0), metres.
  std::vector<int8_t> cells;                         // Row-major from y = origin.y up.

  int8_t at(int x, int y) const { return cells[static_cast<size_t>(y) * width + x]; }
  // The cell holding a point (floor frame x, y), or false outside the grid.
  bool CellOf(const Eigen::Vector2d& point, int* x, int* y) const;
  size_t Count(int8_t value) const;
};

// The cells of `tree` between heights min_z and max_z (metres, the tree's
// z): every leaf overlapping the band marks the cells under it occupied or
// (unless already occupied) free. The grid spans the tree's known x and y.
OccupancyGrid ProjectOctree(const octomap::OcTree& tree, double min_z, double max_z);

// map_server's files: the YAML (image, mode trinary, resolution, origin
// [x, y, 0], negate 0, occupied_thresh 0.65, free_thresh 0.196, as ROS 1's
// map_saver writes them; `comments` become '#' lines) and the PGM (P5:
// occupied 0, free 254, unknown 205).
std::string MapServerYaml(const OccupancyGrid& grid, const std::string& image_name,
                          const std::vector<std::string>& comments);
std::string MapServerPgm(const OccupancyGrid& grid);

// The grid as a picture (BGR; x right, y up): free white, occupied black,
// unknown grey, 1 m lines, the keyframe trajectory (floor-frame x, y) in
// blue with its start in green, and below it a 1 m scale bar and the
// legend; `pixels_per_cell` >= 1.
cv::Mat GridPicture(const OccupancyGrid& grid, const std::vector<Eigen::Vector2d>& trajectory,
                    int pixels_per_cell);

struct GridOptions {
  MapDepthInput input;
  std::filesystem::path out;    // --out: the YAML (map.yaml); the PGM beside it, same stem.
  std::filesystem::path image;  // --image: the PNG picture; empty: OUT with .png.
  double min_height = 0.1;  // --min-height: band's bottom above the floor, metres (floor noise).
  double max_height = 1.5;  // --max-height: band's top, metres (what a robot can hit).
  int pixels_per_cell = 0;  // --pixels-per-cell, in [0, 32]; 0: ~800 px a side (<= 16384 px).
  DepthIntegrationOptions integration;

  std::filesystem::path PgmPath() const;    // OUT with .pgm.
  std::filesystem::path ImagePath() const;  // `image`, or OUT with .png.
  bool Check(std::string* why) const;
  nlohmann::ordered_json ToJson() const;
};
void BindGridOptions(CLI::App* command, GridOptions* options);

struct GridResult {
  IntegrationStats integration;
  int width = 0, height = 0;
  size_t free = 0, occupied = 0, unknown = 0;
  // Keyframes whose camera stands over a free cell, of those over the grid.
  size_t cameras_over_free = 0, cameras = 0;
};

// `rrslam-render grid`: integrates the map in its floor frame (a map where
// no floor is found is a DataError: heights need one), projects the band,
// writes the PGM, the YAML and the PNG (each atomically) and prints a
// summary. Throws UsageError, NoInputError, DataError, CantCreateError.
GridResult RunGrid(const GridOptions& options);

}  // namespace rrslam
