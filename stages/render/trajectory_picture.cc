#include "stages/render/trajectory_picture.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <opencv2/imgproc.hpp>

#include "common/chart.h"
#include "common/errors.h"
#include "stages/eval/association.h"

namespace rrslam {
namespace {

using namespace chart;

const cv::Scalar kGroundTruth(35, 35, 35);
// Estimates when there are several (BGR of a colour-blind-safe palette).
const cv::Scalar kPalette[] = {{178, 114, 0},   {0, 94, 213},   {115, 158, 0},
                               {167, 121, 204}, {66, 228, 240}, {233, 180, 86}};
constexpr int kErrorColormap = cv::COLORMAP_TURBO;
constexpr char kAxisNames[] = {'x', 'y', 'z'};

double MedianInterval(const Trajectory& trajectory) {
  if (trajectory.size() < 2) return 0;
  std::vector<double> intervals;
  for (size_t k = 1; k < trajectory.size(); ++k) {
    intervals.push_back(trajectory[k].timestamp - trajectory[k - 1].timestamp);
  }
  std::nth_element(intervals.begin(), intervals.begin() + intervals.size() / 2, intervals.end());
  return intervals[intervals.size() / 2];
}

bool IsKeyFrameTrajectory(const Trajectory& trajectory) { return MedianInterval(trajectory) > 0.1; }

// Index runs of a time-sorted trajectory, broken where a dense trajectory
// has a gap of more than twice its median interval (lost tracking), as TUM's
// plots do. Keyframe trajectories are not broken.
std::vector<std::pair<size_t, size_t>> Runs(const Trajectory& trajectory) {
  std::vector<std::pair<size_t, size_t>> runs;
  if (trajectory.empty()) return runs;
  const double median = MedianInterval(trajectory);
  const double max_gap = IsKeyFrameTrajectory(trajectory) || median <= 0
                             ? std::numeric_limits<double>::infinity()
                             : 2 * median;
  size_t start = 0;
  for (size_t k = 1; k < trajectory.size(); ++k) {
    if (trajectory[k].timestamp - trajectory[k - 1].timestamp >= max_gap) {
      runs.emplace_back(start, k);
      start = k;
    }
  }
  runs.emplace_back(start, trajectory.size());
  return runs;
}

std::string FormatDistance(double metres) {
  return metres < 0.1 ? fmt::format("{:.2f} cm", metres * 100) : fmt::format("{:.3f} m", metres);
}

// The two axes of largest extent of `reference` (x, y, z order) and the remaining one.
std::array<int, 3> ChooseAxes(const Trajectory& reference) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const StampedPose& pose : reference) {
    lo = lo.cwiseMin(pose.T_world_cam.translation);
    hi = hi.cwiseMax(pose.T_world_cam.translation);
  }
  const Eigen::Vector3d extent = reference.empty() ? Eigen::Vector3d::Ones() : (hi - lo).eval();
  int smallest = 2;
  for (int axis = 1; axis >= 0; --axis) {
    if (extent[axis] <= extent[smallest]) smallest = axis;
  }
  std::array<int, 3> axes{};
  int k = 0;
  for (int axis = 0; axis < 3; ++axis) {
    if (axis != smallest) axes[k++] = axis;
  }
  axes[2] = smallest;
  return axes;
}

struct Drawn {
  std::string name;
  Trajectory trajectory;      // In the frame drawn (aligned when there is a ground truth).
  std::vector<double> error;  // Per pose, metres; NaN when not paired (empty: no gt).
  cv::Scalar colour;
};

cv::Mat RenderProjection(const std::vector<Drawn>& estimates, const Trajectory* gt, int axis_u,
                         int axis_v, const std::string& view, double error_max,
                         const TrajectoryPictureOptions& options) {
  const bool colour_by_error = gt && estimates.size() == 1;
  cv::Mat image(options.height_px, options.width_px, CV_8UC3, kBackground);
  const ChartLayout layout = MakeLayout(image.size(), /*footer=*/colour_by_error);
  const cv::Rect& area = layout.area;
  const auto uv = [&](const StampedPose& pose) {
    const Eigen::Vector3d& p = pose.T_world_cam.translation;
    return Eigen::Vector2d(p[axis_u], p[axis_v]);
  };
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  const auto extend = [&](const Trajectory& trajectory) {
    for (const StampedPose& pose : trajectory) {
      lo = lo.cwiseMin(uv(pose));
      hi = hi.cwiseMax(uv(pose));
    }
  };
  if (gt) extend(*gt);
  for (const Drawn& d : estimates) extend(d.trajectory);
  const Axes2d axes = FitAxes(lo, hi, area);
  DrawGrid(image, layout, axes);

  cv::Mat canvas = image(area);
  const cv::Point2d origin(area.x, area.y);
  const auto px = [&](const StampedPose& pose) { return SubPixel(axes(uv(pose)) - origin); };
  const int width = layout.line_width;
  std::vector<cv::Point2d> occupied;
  const auto draw = [&](const Trajectory& trajectory, const cv::Scalar& colour,
                        const std::vector<double>* error) {
    for (const auto& [begin, end] : Runs(trajectory)) {
      for (size_t k = begin + 1; k < end; ++k) {
        cv::Scalar c = colour;
        if (error) {
          const double e = (*error)[k - 1];
          c = std::isnan(e) ? cv::Scalar(170, 170, 170)
                            : ColormapColour(kErrorColormap, e / error_max);
        }
        cv::line(canvas, px(trajectory[k - 1]), px(trajectory[k]), c, width, cv::LINE_AA, kShift);
      }
    }
    if (IsKeyFrameTrajectory(trajectory)) {
      for (size_t k = 0; k < trajectory.size(); ++k) {
        cv::Scalar c = colour;
        if (error && !std::isnan((*error)[k]))
          c = ColormapColour(kErrorColormap, (*error)[k] / error_max);
        cv::circle(canvas, px(trajectory[k]), static_cast<int>((width + 2) * kSubPixel), c, -1,
                   cv::LINE_AA, kShift);
      }
    }
    for (const StampedPose& pose : trajectory) occupied.push_back(axes(uv(pose)));
  };
  if (gt) draw(*gt, kGroundTruth, nullptr);
  for (const Drawn& d : estimates)
    draw(d.trajectory, d.colour, colour_by_error ? &d.error : nullptr);

  std::string title = options.title.empty() ? "" : options.title + ": ";
  title += view + " view";
  DrawFrameAndLabels(image, layout, std::string(1, kAxisNames[axis_u]) + " [m]",
                     std::string(1, kAxisNames[axis_v]) + " [m]", title);
  std::vector<LegendEntry> legend;
  if (gt) legend.push_back({"ground truth", kGroundTruth, width});
  for (const Drawn& d : estimates) {
    std::string label = d.name;
    if (gt) label += " (aligned)";
    legend.push_back(
        {label, colour_by_error ? ColormapColour(kErrorColormap, 0.5) : d.colour, width});
  }
  DrawLegend(image, layout, legend, occupied);
  if (colour_by_error) {
    DrawColourBar(image, layout, {area.x + 4.0 * layout.text_height, double(layout.footer_y)},
                  kErrorColormap, 0, error_max * 100, "cm error");
  }
  return image;
}

cv::Mat RenderErrorOverTime(const std::vector<Drawn>& estimates, double t0,
                            const std::vector<AteResult>& ate,
                            const TrajectoryPictureOptions& options) {
  cv::Mat image(options.height_px, options.width_px, CV_8UC3, kBackground);
  const ChartLayout layout = MakeLayout(image.size());
  const cv::Rect& area = layout.area;
  Eigen::Vector2d lo(std::numeric_limits<double>::infinity(), 0);
  Eigen::Vector2d hi(-std::numeric_limits<double>::infinity(), 0);
  for (const Drawn& d : estimates) {
    for (size_t k = 0; k < d.trajectory.size(); ++k) {
      if (std::isnan(d.error[k])) continue;
      const Eigen::Vector2d p(d.trajectory[k].timestamp - t0, d.error[k] * 100);
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  lo.y() = 0;
  const Axes2d axes = FitAxes(lo, hi, area, AxisScale::kEach, 1.04);
  DrawGrid(image, layout, axes);
  cv::Mat canvas = image(area);
  const cv::Point2d origin(area.x, area.y);
  std::vector<cv::Point2d> occupied;
  std::vector<LegendEntry> legend;
  for (size_t i = 0; i < estimates.size(); ++i) {
    const Drawn& d = estimates[i];
    const bool keyframes = IsKeyFrameTrajectory(d.trajectory);
    std::vector<cv::Point> line;
    const auto flush = [&] {
      if (line.size() > 1) {
        cv::polylines(canvas, line, false, d.colour, layout.line_width, cv::LINE_AA, kShift);
      }
      line.clear();
    };
    for (size_t k = 0; k < d.trajectory.size(); ++k) {
      if (std::isnan(d.error[k])) {
        flush();
        continue;
      }
      const cv::Point2d p = axes(Eigen::Vector2d(d.trajectory[k].timestamp - t0, d.error[k] * 100));
      line.push_back(SubPixel(p - origin));
      occupied.push_back(p);
      if (keyframes) {
        cv::circle(canvas, SubPixel(p - origin),
                   static_cast<int>((layout.line_width + 1) * kSubPixel), d.colour, -1, cv::LINE_AA,
                   kShift);
      }
    }
    flush();
    legend.push_back({fmt::format("{}: RMSE {}", d.name, FormatDistance(ate[i].error.rmse)),
                      d.colour, layout.line_width});
  }
  std::string title = options.title.empty() ? "" : options.title + ": ";
  DrawFrameAndLabels(image, layout, "time [s]", "ATE error [cm]", title + "error over time");
  DrawLegend(image, layout, legend, occupied);
  return image;
}

}  // namespace

std::string ToString(TrajectoryView view) {
  switch (view) {
    case TrajectoryView::kTop:
      return "top";
    case TrajectoryView::kSide:
      return "side";
    case TrajectoryView::kFront:
      return "front";
  }
  return "?";
}

bool TrajectoryPictureOptions::Check(std::string* why) const {
  if (!CheckChartSize(width_px, height_px, "image", why)) return false;
  if (!(max_difference > 0) || !std::isfinite(max_difference)) {
    *why = fmt::format("max difference = {} s; must be > 0", max_difference);
    return false;
  }
  return true;
}

nlohmann::ordered_json TrajectoryPictureOptions::ToJson() const {
  return {{"width_px", width_px},
          {"height_px", height_px},
          {"max_difference_s", max_difference},
          {"title", title}};
}

TrajectoryPictures RenderTrajectoryPictures(const std::vector<NamedTrajectory>& estimates,
                                            const std::optional<NamedTrajectory>& ground_truth,
                                            const TrajectoryPictureOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError("trajectory picture: " + why);
  if (estimates.empty()) throw UsageError("trajectory picture: no estimate given");

  TrajectoryPictures pictures;
  std::optional<Trajectory> gt;
  if (ground_truth) {
    if (ground_truth->trajectory.empty()) throw DataError(ground_truth->name + ": no poses");
    gt = DistinctByTimestamp(ground_truth->trajectory);
  }
  std::vector<Drawn> drawn;
  double error_max = 0;
  for (size_t i = 0; i < estimates.size(); ++i) {
    const NamedTrajectory& estimate = estimates[i];
    if (estimate.trajectory.empty()) throw DataError(estimate.name + ": no poses");
    Drawn d;
    d.name = estimate.name;
    d.colour = kPalette[i % std::size(kPalette)];
    if (gt) {
      AteOptions ate_options;
      ate_options.max_difference = options.max_difference;
      AteResult result;
      try {
        result = ComputeAte(*gt, estimate.trajectory, ate_options);
      } catch (const DataError& e) {
        throw DataError(estimate.name + ": cannot be aligned to " + ground_truth->name + " (" +
                        e.what() + ")");
      }
      d.trajectory = result.est_aligned;
      std::map<double, double> error_at;
      for (const AtePair& pair : result.pairs) {
        error_at[pair.est_timestamp] = (pair.gt_position - pair.est_position_aligned).norm();
      }
      d.error.assign(d.trajectory.size(), std::numeric_limits<double>::quiet_NaN());
      for (size_t k = 0; k < d.trajectory.size(); ++k) {
        const auto it = error_at.find(d.trajectory[k].timestamp);
        if (it != error_at.end()) d.error[k] = it->second;
      }
      std::vector<double> errors;
      for (const auto& [t, e] : error_at) errors.push_back(e);
      std::sort(errors.begin(), errors.end());
      if (!errors.empty()) error_max = std::max(error_max, errors[errors.size() * 95 / 100]);
      pictures.ate.push_back(std::move(result));
    } else {
      d.trajectory = DistinctByTimestamp(estimate.trajectory);
    }
    drawn.push_back(std::move(d));
  }
  if (!(error_max > 0)) error_max = 0.01;

  const Trajectory& reference = gt ? *gt : drawn.front().trajectory;
  const std::array<int, 3> axes = ChooseAxes(reference);
  pictures.top_axes = {axes[0], axes[1]};
  pictures.front_axes = {axes[0], axes[2]};
  pictures.side_axes = {axes[1], axes[2]};
  const Trajectory* gt_ptr = gt ? &*gt : nullptr;
  pictures.top = RenderProjection(drawn, gt_ptr, axes[0], axes[1], "top", error_max, options);
  pictures.front = RenderProjection(drawn, gt_ptr, axes[0], axes[2], "front", error_max, options);
  pictures.side = RenderProjection(drawn, gt_ptr, axes[1], axes[2], "side", error_max, options);
  if (gt) pictures.error = RenderErrorOverTime(drawn, gt->front().timestamp, pictures.ate, options);
  return pictures;
}

}  // namespace rrslam
