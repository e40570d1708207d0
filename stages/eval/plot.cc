#include "stages/eval/plot.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <string_view>

#include "common/atomic_file.h"
#include "common/chart.h"
#include "common/errors.h"
#include "common/image_io.h"
#include "stages/eval/association.h"

namespace rrslam {
namespace {

using namespace chart;

// Colours (BGR) of the data.
const cv::Scalar kGroundTruth(35, 35, 35);
const cv::Scalar kEstimate(200, 110, 30);
const cv::Scalar kDifference(70, 70, 225);

std::string FormatRmse(double rmse) {
  char buffer[64];
  if (rmse < 0.1) {
    std::snprintf(buffer, sizeof(buffer), "%.2f cm", rmse * 100);
  } else {
    std::snprintf(buffer, sizeof(buffer), "%.3f m", rmse);
  }
  return buffer;
}

// Splits a time-sorted trajectory where consecutive stamps are further apart
// than twice the median interval (lost tracking), as TUM's plot does.
std::vector<std::vector<Eigen::Vector2d>> Polylines(const Trajectory& trajectory, int axis_u,
                                                    int axis_v) {
  std::vector<std::vector<Eigen::Vector2d>> lines;
  if (trajectory.empty()) return lines;
  double max_gap = std::numeric_limits<double>::infinity();
  if (trajectory.size() > 1) {
    std::vector<double> intervals;
    for (size_t k = 1; k < trajectory.size(); ++k) {
      intervals.push_back(trajectory[k].timestamp - trajectory[k - 1].timestamp);
    }
    std::nth_element(intervals.begin(), intervals.begin() + intervals.size() / 2, intervals.end());
    max_gap = 2 * intervals[intervals.size() / 2];
  }
  lines.emplace_back();
  for (size_t k = 0; k < trajectory.size(); ++k) {
    if (k > 0 && trajectory[k].timestamp - trajectory[k - 1].timestamp >= max_gap) {
      lines.emplace_back();
    }
    const Eigen::Vector3d& p = trajectory[k].T_world_cam.translation;
    lines.back().emplace_back(p[axis_u], p[axis_v]);
  }
  return lines;
}

}  // namespace

std::string ToString(PlotAxes axes) {
  switch (axes) {
    case PlotAxes::kXY:
      return "xy";
    case PlotAxes::kXZ:
      return "xz";
    case PlotAxes::kYZ:
      return "yz";
    case PlotAxes::kAuto:
      break;
  }
  return "auto";
}

bool PlotOptions::Check(std::string* why) const {
  return CheckChartSize(width_px, height_px, "plot", why);
}

nlohmann::ordered_json PlotOptions::ToJson() const {
  return {
      {"width_px", width_px}, {"height_px", height_px}, {"axes", ToString(axes)}, {"title", title}};
}

std::pair<int, int> ChoosePlotAxes(const Trajectory& gt, PlotAxes axes) {
  switch (axes) {
    case PlotAxes::kXY:
      return {0, 1};
    case PlotAxes::kXZ:
      return {0, 2};
    case PlotAxes::kYZ:
      return {1, 2};
    case PlotAxes::kAuto:
      break;
  }
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const StampedPose& pose : gt) {
    lo = lo.cwiseMin(pose.T_world_cam.translation);
    hi = hi.cwiseMax(pose.T_world_cam.translation);
  }
  if (gt.empty()) return {0, 1};
  const Eigen::Vector3d extent = hi - lo;
  // Leave out the axis of least extent (the first of equals); keep x, y, z order.
  int smallest = 2;
  for (int axis = 1; axis >= 0; --axis) {
    if (extent[axis] <= extent[smallest]) smallest = axis;
  }
  if (smallest == 0) return {1, 2};
  if (smallest == 1) return {0, 2};
  return {0, 1};
}

cv::Mat RenderAtePlot(const Trajectory& gt_input, const AteResult& result,
                      const PlotOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError("plot options: " + why);
  const Trajectory gt = DistinctByTimestamp(gt_input);
  const auto [axis_u, axis_v] = ChoosePlotAxes(gt, options.axes);
  const char kAxisNames[] = {'x', 'y', 'z'};

  const int width = options.width_px, height = options.height_px;
  cv::Mat image(height, width, CV_8UC3, kBackground);
  const ChartLayout layout = MakeLayout(image.size());
  const cv::Rect& area = layout.area;

  // Data bounds over everything drawn.
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  const auto extend = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector2d q(p[axis_u], p[axis_v]);
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  };
  for (const StampedPose& pose : gt) extend(pose.T_world_cam.translation);
  for (const StampedPose& pose : result.est_aligned) extend(pose.T_world_cam.translation);
  for (const AtePair& pair : result.pairs) {
    extend(pair.gt_position);
    extend(pair.est_position_aligned);
  }
  const Axes2d projection = FitAxes(lo, hi, area);
  DrawGrid(image, layout, projection);

  // Data, clipped to the plot area: differences under the trajectories.
  cv::Mat canvas = image(area);
  const cv::Point2d origin(area.x, area.y);
  const auto to_canvas = [&](const Eigen::Vector3d& p) {
    return SubPixel(projection(Eigen::Vector2d(p[axis_u], p[axis_v])) - origin);
  };
  const int line_width = layout.line_width;
  for (const AtePair& pair : result.pairs) {
    cv::line(canvas, to_canvas(pair.gt_position), to_canvas(pair.est_position_aligned), kDifference,
             1, cv::LINE_AA, kShift);
  }
  const auto draw_trajectory = [&](const Trajectory& trajectory, const cv::Scalar& colour) {
    for (const auto& line : Polylines(trajectory, axis_u, axis_v)) {
      std::vector<cv::Point> points;
      points.reserve(line.size());
      for (const Eigen::Vector2d& p : line) points.push_back(SubPixel(projection(p) - origin));
      if (points.size() == 1) {
        cv::circle(canvas, points[0], line_width * static_cast<int>(kSubPixel), colour, -1,
                   cv::LINE_AA, kShift);
      } else {
        cv::polylines(canvas, points, false, colour, line_width, cv::LINE_AA, kShift);
      }
    }
  };
  draw_trajectory(gt, kGroundTruth);
  draw_trajectory(result.est_aligned, kEstimate);

  // Frame, axis labels and title.
  std::string title = options.title.empty() ? "" : options.title + ": ";
  title += "ATE RMSE " + FormatRmse(result.error.rmse) + " (" +
           std::to_string(result.pairs.size()) + " pairs)";
  DrawFrameAndLabels(image, layout, std::string(1, kAxisNames[axis_u]) + " [m]",
                     std::string(1, kAxisNames[axis_v]) + " [m]", title);

  // Legend in the corner of the plot area that hides the fewest poses.
  std::vector<cv::Point2d> occupied;
  for (const Trajectory* trajectory : {&gt, &result.est_aligned}) {
    for (const StampedPose& pose : *trajectory) {
      const Eigen::Vector3d& p = pose.T_world_cam.translation;
      occupied.push_back(projection(Eigen::Vector2d(p[axis_u], p[axis_v])));
    }
  }
  DrawLegend(image, layout,
             {{"ground truth", kGroundTruth, line_width},
              {"estimate (aligned)", kEstimate, line_width},
              {"difference", kDifference, 1}},
             occupied);
  return image;
}

void PlotAte(const std::filesystem::path& png_path, const Trajectory& gt, const AteResult& result,
             const PlotOptions& options,
             const std::vector<std::pair<std::string, std::string>>& text) {
  WritePng(png_path, RenderAtePlot(gt, result, options), kPlotPngCompression, text);
}

}  // namespace rrslam
