// Top-view plot of an ATE result: ground truth, aligned estimate and the
// error of every pair, drawn with OpenCV into a PNG.
#pragma once

#include <filesystem>
#include <opencv2/core/mat.hpp>
#include <string>
#include <utility>
#include <vector>

#include "common/trajectory.h"
#include "stages/eval/ate.h"

namespace rrslam {

enum class PlotAxes {
  kAuto,  // The two world axes along which the ground truth extends most.
  kXY,
  kXZ,
  kYZ,
};

// "auto", "xy", "xz", "yz".
std::string ToString(PlotAxes axes);

struct PlotOptions {
  int width_px = 1000;              // Image width, pixels, in [320, 8000].
  int height_px = 800;              // Image height, pixels, in [240, 8000].
  PlotAxes axes = PlotAxes::kAuto;  // World axes shown (horizontal, vertical).
  std::string title;                // Optional first part of the title (e.g. the sequence name).

  bool Check(std::string* why) const;
  nlohmann::ordered_json ToJson() const;
};

// The two world axes (0 = x, 1 = y, 2 = z) the plot of `gt` shows,
// horizontal then vertical, for `axes`.
std::pair<int, int> ChoosePlotAxes(const Trajectory& gt, PlotAxes axes);

// Renders the plot as an 8-bit BGR image of options.width_px x height_px:
// ground truth (black) and the aligned estimate (blue) as polylines broken at
// time gaps longer than twice their median interval, a red line per pair from
// ground truth to aligned estimate, equal metre scale on both axes with ticks,
// grid, axis labels, a legend and the ATE RMSE in the title.
cv::Mat RenderAtePlot(const Trajectory& gt, const AteResult& result,
                      const PlotOptions& options = {});

// zlib level of plot PNGs (plots are small; favour size over speed).
inline constexpr int kPlotPngCompression = 6;

// Renders and writes the plot atomically as a PNG (common/image_io.h), with
// `text` (keyword, value) as tEXt chunks. Throws CantCreateError
// when the file cannot be written (the final path is then left untouched).
void PlotAte(const std::filesystem::path& png_path, const Trajectory& gt, const AteResult& result,
             const PlotOptions& options = {},
             const std::vector<std::pair<std::string, std::string>>& text = {});

}  // namespace rrslam
