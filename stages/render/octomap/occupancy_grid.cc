#include "stages/render/octomap/occupancy_grid.h"

#include <fmt/format.h>
#include <octomap/OcTree.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <iostream>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "common/atomic_file.h"
#include "common/cli.h"
#include "common/errors.h"
#include "common/image_io.h"
#include "common/json_text.h"
#include "common/output_path.h"
#include "common/text.h"
#include "stages/render/image_file.h"

namespace rrslam {
namespace {

// PGM shades of map_saver (ROS 1 and Nav2): occupied, free, unknown.
constexpr uint8_t kPgmOccupied = 0;
constexpr uint8_t kPgmFree = 254;
constexpr uint8_t kPgmUnknown = 205;
// The picture's larger side when --pixels-per-cell is 0.
constexpr int kAutoPictureSide = 800;

bool FailGrid(std::string* why, const std::string& text) {
  *why = text;
  return false;
}

// Cell index of a coordinate on a voxel boundary (leaf corners are
// multiples of the resolution, so rounding is exact).
int CellIndex(double coordinate, double origin, double resolution) {
  return static_cast<int>(std::lround((coordinate - origin) / resolution));
}

cv::Scalar PictureColour(int8_t cell) {
  if (cell == kCellOccupied) return {0, 0, 0};
  if (cell == kCellFree) return {255, 255, 255};
  return {160, 160, 160};
}

// The picture's pixels per cell: `requested`, or (0) about kAutoPictureSide
// pixels on the larger side; never a side beyond kMaxImageSide.
int PixelsPerCell(const OccupancyGrid& grid, int requested) {
  const int side = std::max(1, std::max(grid.width, grid.height));
  const int wanted = requested > 0 ? requested : kAutoPictureSide / side;
  return std::clamp(wanted, 1, std::max(1, kMaxImageSide / side));
}

// The picture with a strip below: a 1 m scale bar (`metre` pixels) and the
// legend of the cells and the trajectory.
cv::Mat WithFooter(const cv::Mat& image, int metre) {
  constexpr int kHeight = 34;
  const int width = std::max(image.cols, 420);
  cv::Mat out(image.rows + kHeight, width, CV_8UC3, cv::Scalar(235, 235, 235));
  image.copyTo(out(cv::Rect(0, 0, image.cols, image.rows)));
  const int y = image.rows + kHeight / 2;
  const auto text = [&](const std::string& label, int x) {
    cv::putText(out, label, {x, y + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.42, {30, 30, 30}, 1,
                cv::LINE_AA);
  };
  int x = 8;
  if (metre > 0 && metre < width / 3) {
    cv::line(out, {x, y + 10}, {x + metre, y + 10}, {30, 30, 30}, 2);
    cv::putText(out, "1 m", {x + metre / 2 - 10, y + 2}, cv::FONT_HERSHEY_SIMPLEX, 0.42,
                {30, 30, 30}, 1, cv::LINE_AA);
    x += metre + 14;
  }
  const auto swatch = [&](const cv::Scalar& colour, const std::string& label) {
    cv::rectangle(out, cv::Rect(x, y - 6, 12, 12), colour, cv::FILLED);
    cv::rectangle(out, cv::Rect(x, y - 6, 12, 12), {90, 90, 90});
    text(label, x + 16);
    x += 16 + 9 * static_cast<int>(label.size());
  };
  swatch(PictureColour(kCellFree), "free");
  swatch(PictureColour(kCellOccupied), "occupied");
  swatch(PictureColour(kCellUnknown), "unknown");
  cv::line(out, {x, y}, {x + 18, y}, {200, 90, 20}, 2, cv::LINE_AA);
  text("keyframes", x + 22);
  return out;
}

}  // namespace

bool OccupancyGrid::CellOf(const Eigen::Vector2d& point, int* x, int* y) const {
  const double fx = std::floor((point.x() - origin.x()) / resolution);
  const double fy = std::floor((point.y() - origin.y()) / resolution);
  if (!(fx >= 0 && fy >= 0 && fx < width && fy < height)) return false;
  *x = static_cast<int>(fx);
  *y = static_cast<int>(fy);
  return true;
}

size_t OccupancyGrid::Count(int8_t value) const {
  return static_cast<size_t>(std::count(cells.begin(), cells.end(), value));
}

OccupancyGrid ProjectOctree(const octomap::OcTree& tree, double min_z, double max_z) {
  OccupancyGrid grid;
  grid.resolution = tree.getResolution();
  double min[3], max[3];
  tree.getMetricMin(min[0], min[1], min[2]);
  tree.getMetricMax(max[0], max[1], max[2]);
  if (tree.size() == 0 || !(max[0] > min[0] && max[1] > min[1])) return grid;
  grid.origin = {min[0], min[1]};
  grid.width = CellIndex(max[0], min[0], grid.resolution);
  grid.height = CellIndex(max[1], min[1], grid.resolution);
  grid.cells.assign(static_cast<size_t>(grid.width) * grid.height, kCellUnknown);
  const double eps = 1e-3 * grid.resolution;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
    const double half = 0.5 * it.getSize();
    const octomap::point3d c = it.getCoordinate();
    if (!(c.z() + half > min_z + eps && c.z() - half < max_z - eps)) continue;
    const int8_t value = tree.isNodeOccupied(*it) ? kCellOccupied : kCellFree;
    const int x0 = std::max(0, CellIndex(c.x() - half, grid.origin.x(), grid.resolution));
    const int x1 = std::min(grid.width, CellIndex(c.x() + half, grid.origin.x(), grid.resolution));
    const int y0 = std::max(0, CellIndex(c.y() - half, grid.origin.y(), grid.resolution));
    const int y1 = std::min(grid.height, CellIndex(c.y() + half, grid.origin.y(), grid.resolution));
    for (int y = y0; y < y1; ++y) {
      for (int x = x0; x < x1; ++x) {
        int8_t& cell = grid.cells[static_cast<size_t>(y) * grid.width + x];
        if (cell != kCellOccupied) cell = value;
      }
    }
  }
  return grid;
}

std::string MapServerYaml(const OccupancyGrid& grid, const std::string& image_name,
                          const std::vector<std::string>& comments) {
  std::string yaml;
  for (const std::string& comment : comments) yaml += "# " + comment + "\n";
  yaml += fmt::format(
      "image: {}\nmode: trinary\nresolution: {:.6f}\norigin: [{:.6f}, {:.6f}, 0.0]\nnegate: 0\n"
      "occupied_thresh: 0.65\nfree_thresh: 0.196\n",
      image_name, grid.resolution, grid.origin.x(), grid.origin.y());
  return yaml;
}

std::string MapServerPgm(const OccupancyGrid& grid) {
  std::string pgm = fmt::format("P5\n{} {}\n255\n", grid.width, grid.height);
  const size_t header = pgm.size();
  pgm.resize(header + static_cast<size_t>(grid.width) * grid.height);
  size_t i = header;
  for (int y = grid.height - 1; y >= 0; --y) {
    for (int x = 0; x < grid.width; ++x) {
      const int8_t cell = grid.at(x, y);
      pgm[i++] = static_cast<char>(cell == kCellOccupied ? kPgmOccupied
                                   : cell == kCellFree   ? kPgmFree
                                                         : kPgmUnknown);
    }
  }
  return pgm;
}

cv::Mat GridPicture(const OccupancyGrid& grid, const std::vector<Eigen::Vector2d>& trajectory,
                    int pixels_per_cell) {
  const int s = std::max(1, pixels_per_cell);
  cv::Mat image(grid.height * s, grid.width * s, CV_8UC3);
  for (int y = 0; y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x) {
      const int row = (grid.height - 1 - y) * s;
      cv::rectangle(image, cv::Rect(x * s, row, s, s), PictureColour(grid.at(x, y)), cv::FILLED);
    }
  }
  // Pixel of a floor-frame point (sub-pixel, y up).
  const auto pixel = [&](const Eigen::Vector2d& p) {
    return cv::Point2d((p.x() - grid.origin.x()) / grid.resolution * s,
                       (grid.height - (p.y() - grid.origin.y()) / grid.resolution) * s);
  };
  // A 1 m grid, light, over everything.
  cv::Mat lines = image.clone();
  for (double x = std::ceil(grid.origin.x()); x < grid.origin.x() + grid.width * grid.resolution;
       x += 1.0) {
    const double px = pixel({x, 0}).x;
    cv::line(lines, {static_cast<int>(px), 0}, {static_cast<int>(px), image.rows}, {200, 150, 90});
  }
  for (double y = std::ceil(grid.origin.y()); y < grid.origin.y() + grid.height * grid.resolution;
       y += 1.0) {
    const double py = pixel({0, y}).y;
    cv::line(lines, {0, static_cast<int>(py)}, {image.cols, static_cast<int>(py)}, {200, 150, 90});
  }
  cv::addWeighted(image, 0.6, lines, 0.4, 0, image);
  constexpr int kShift = 4;  // Sub-pixel bits of OpenCV's drawing.
  const auto fixed = [&](const Eigen::Vector2d& p) {
    const cv::Point2d q = pixel(p) * (1 << kShift);
    return cv::Point(static_cast<int>(std::lround(q.x)), static_cast<int>(std::lround(q.y)));
  };
  const int thickness = std::max(1, s / 2);
  for (size_t i = 1; i < trajectory.size(); ++i) {
    cv::line(image, fixed(trajectory[i - 1]), fixed(trajectory[i]), {200, 90, 20}, thickness,
             cv::LINE_AA, kShift);
  }
  if (!trajectory.empty()) {
    cv::circle(image, fixed(trajectory.front()), (3 * thickness + 2) << kShift, {40, 170, 40},
               cv::FILLED, cv::LINE_AA, kShift);
  }
  return WithFooter(image, static_cast<int>(std::lround(s / grid.resolution)));
}

// ---------------------------------------------------------------------------
// The command

std::filesystem::path GridOptions::PgmPath() const {
  return std::filesystem::path(out).replace_extension(".pgm");
}

std::filesystem::path GridOptions::ImagePath() const {
  return image.empty() ? std::filesystem::path(out).replace_extension(".png") : image;
}

bool GridOptions::Check(std::string* why) const {
  if (out.empty()) return FailGrid(why, "--out is required");
  if (AsciiLowercase(out.extension().string()) != ".yaml") {
    return FailGrid(why, "--out " + out.string() + " must be a .yaml file (map_server's map)");
  }
  if (AsciiLowercase(ImagePath().extension().string()) != ".png") {
    return FailGrid(why, "--image " + ImagePath().string() + " must be a .png file");
  }
  if (!input.Check({{"--out", out}, {"--out (.pgm)", PgmPath()}, {"--image", ImagePath()}}, why)) {
    return false;
  }
  if (!(min_height >= 0 && max_height > min_height && max_height < 100)) {
    return FailGrid(why, "--min-height " + Format("%g", min_height) + ", --max-height " +
                             Format("%g", max_height) + ": must satisfy 0 <= min < max < 100 m");
  }
  if (pixels_per_cell < 0 || pixels_per_cell > 32) {
    return FailGrid(why, "--pixels-per-cell = " + std::to_string(pixels_per_cell) +
                             "; must be in [0, 32] (0: automatic)");
  }
  return integration.Check(why);
}

nlohmann::ordered_json GridOptions::ToJson() const {
  nlohmann::ordered_json j;
  input.AddToJson(&j);
  j["out"] = out.string();
  j["image"] = ImagePath().string();
  j["min_height"] = min_height;
  j["max_height"] = max_height;
  j["pixels_per_cell"] = pixels_per_cell;
  j["integration"] = integration.ToJson();
  return j;
}

void BindGridOptions(CLI::App* command, GridOptions* o) {
  BindMapDepthInput(command, &o->input);
  command
      ->add_option("--out", o->out,
                   "map_server YAML to write (map.yaml); the PGM beside it (map.pgm)")
      ->required();
  command->add_option("--image", o->image, "PNG picture (default: --out with .png)");
  command->add_option("--min-height", o->min_height, "Band's bottom above the floor, metres")
      ->capture_default_str();
  command->add_option("--max-height", o->max_height, "Band's top above the floor, metres")
      ->capture_default_str();
  command
      ->add_option("--pixels-per-cell", o->pixels_per_cell,
                   "Picture pixels per cell (0: the larger side about 800 pixels)")
      ->capture_default_str();
  BindDepthIntegrationOptions(command, &o->integration);
}

namespace {

// The keyframe trajectory on the floor (x, y), and how many of its cameras
// stand over the grid and over free cells (into `result`).
std::vector<Eigen::Vector2d> CamerasOverCells(const MapScene& scene, const OccupancyGrid& grid,
                                              GridResult* result) {
  std::vector<Eigen::Vector2d> trajectory;
  for (const StampedPose& pose : scene.KeyFrameTrajectory()) {
    const Eigen::Vector2d xy = pose.T_world_cam.translation.head<2>();
    trajectory.push_back(xy);
    int x = 0, y = 0;
    if (!grid.CellOf(xy, &x, &y)) continue;
    ++result->cameras;
    if (grid.at(x, y) == kCellFree) ++result->cameras_over_free;
    spdlog::debug("grid: camera at ({:.2f}, {:.2f}, {:.2f}) m over a cell {}", xy.x(), xy.y(),
                  pose.T_world_cam.translation.z(), grid.at(x, y));
  }
  return trajectory;
}

// The picture (its folder checked when written), then the PGM and the YAML
// (reserved before the integration).
void WriteGridFiles(const GridOptions& options, const OccupancyGrid& grid,
                    const std::vector<Eigen::Vector2d>& trajectory,
                    const std::string& frame_comment, AtomicOutput* pgm_out,
                    AtomicOutput* yaml_out) {
  const std::string producer = Producer("render");
  const std::string options_json = DumpJson(options.ToJson());
  ImageMetadata metadata;
  metadata.software = producer;
  metadata.description = fmt::format(
      "Occupancy grid of {} ({}-{} m above the floor, {} m cells; free white, occupied black, "
      "unknown grey; keyframe trajectory blue from the green start; 1 m lines)",
      options.input.map.string(), options.min_height, options.max_height, grid.resolution);
  metadata.attributes = {{"rrslam:options", options_json}};
  WritePicture(options.ImagePath(),
               GridPicture(grid, trajectory, PixelsPerCell(grid, options.pixels_per_cell)),
               metadata);
  CommitContent(pgm_out, MapServerPgm(grid));
  const std::vector<std::string> comments = {
      fmt::format("{}: grid of {}, cells {}-{} m above the floor", producer,
                  options.input.map.string(), options.min_height, options.max_height),
      frame_comment, "options " + options_json};
  CommitContent(yaml_out, MapServerYaml(grid, options.PgmPath().filename().string(), comments));
}

}  // namespace

GridResult RunGrid(const GridOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  // The folders checked before the integration; each file committed at the end.
  AtomicOutput pgm_out(options.PgmPath()), yaml_out(options.out);
  const MapDepthInput& in = options.input;
  FramedMap map = LoadMapInFrame(in.map, "floor", in.sequence, in.associations);
  // Refused before the integration: heights need a floor.
  if (!map.floor()) {
    throw AlgorithmError(in.map.string() +
                         ": no floor found, so no heights above it (rrslam-mapstore align-floor "
                         "--sequence searches the keyframes' depth too)");
  }
  MapOctree octree = IntegrateMap(std::move(map), in, options.integration);
  const OccupancyGrid grid = ProjectOctree(*octree.tree, options.min_height, options.max_height);
  GridResult result;
  result.integration = octree.stats;
  result.width = grid.width;
  result.height = grid.height;
  result.free = grid.Count(kCellFree);
  result.occupied = grid.Count(kCellOccupied);
  result.unknown = grid.Count(kCellUnknown);
  const std::vector<Eigen::Vector2d> trajectory = CamerasOverCells(octree.map.scene, grid, &result);
  WriteGridFiles(options, grid, trajectory, octree.map.comment, &pgm_out, &yaml_out);
  std::cout << fmt::format(
      "grid: {} x {} cells of {} m: {} free, {} occupied, {} unknown; {} of {} keyframe "
      "cameras over free cells; integration {:.1f} s\nwrote {}, {} and {}\n",
      grid.width, grid.height, grid.resolution, result.free, result.occupied, result.unknown,
      result.cameras_over_free, result.cameras, octree.stats.integrate_seconds,
      options.out.string(), options.PgmPath().string(), options.ImagePath().string());
  return result;
}

}  // namespace rrslam
