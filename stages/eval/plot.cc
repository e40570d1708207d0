#include "stages/eval/plot.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <string_view>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/image_io.h"
#include "stages/eval/association.h"

namespace rrslam {
namespace {

// Colours (BGR).
const cv::Scalar kBackground(255, 255, 255);
const cv::Scalar kGrid(232, 232, 232);
const cv::Scalar kFrame(110, 110, 110);
const cv::Scalar kText(30, 30, 30);
const cv::Scalar kGroundTruth(35, 35, 35);
const cv::Scalar kEstimate(200, 110, 30);
const cv::Scalar kDifference(70, 70, 225);

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr int kShift = 4;  // Sub-pixel bits for antialiased drawing.
constexpr double kSubPixel = 1 << kShift;

cv::Point SubPixel(const cv::Point2d& p) {
  return cv::Point(static_cast<int>(std::lround(p.x * kSubPixel)),
                   static_cast<int>(std::lround(p.y * kSubPixel)));
}

// Tick step of 1, 2 or 5 times a power of ten, near `raw` metres.
double NiceStep(double raw) {
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double normalized = raw / magnitude;
  const double nice = normalized < 1.5 ? 1 : normalized < 3.5 ? 2 : normalized < 7.5 ? 5 : 10;
  return nice * magnitude;
}

std::string TickLabel(double value, double step) {
  const int decimals = std::max(0, -static_cast<int>(std::floor(std::log10(step) + 1e-9)));
  if (std::fabs(value) < 1e-6 * step) value = 0;  // No "-0.0".
  char buffer[48];
  std::snprintf(buffer, sizeof(buffer), "%.*f", decimals, value);
  return buffer;
}

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

// Maps world metres (u right, v up) to pixels of the plot area.
struct Projection {
  double centre_u = 0, centre_v = 0;  // Metres at the centre of the area.
  double pixels_per_metre = 1;
  cv::Point2d centre_px;

  cv::Point2d operator()(const Eigen::Vector2d& p) const {
    return {centre_px.x + (p.x() - centre_u) * pixels_per_metre,
            centre_px.y - (p.y() - centre_v) * pixels_per_metre};
  }
};

void PutText(cv::Mat& image, const std::string& text, cv::Point2d anchor, double font_scale,
             int thickness, double align_x, double align_y, const cv::Scalar& colour = kText) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFont, font_scale, thickness, &baseline);
  // align 0 = left/top, 0.5 = centre, 1 = right/bottom of the text box (cap height).
  const cv::Point origin(static_cast<int>(std::lround(anchor.x - align_x * size.width)),
                         static_cast<int>(std::lround(anchor.y + (1 - align_y) * size.height)));
  cv::putText(image, text, origin, kFont, font_scale, colour, thickness, cv::LINE_AA);
}

void PutVerticalText(cv::Mat& image, const std::string& text, cv::Point2d centre, double font_scale,
                     int thickness) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFont, font_scale, thickness, &baseline);
  cv::Mat patch(size.height + baseline + 4, size.width + 4, image.type(), kBackground);
  cv::putText(patch, text, cv::Point(2, size.height + 2), kFont, font_scale, kText, thickness,
              cv::LINE_AA);
  cv::Mat rotated;
  cv::rotate(patch, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
  const cv::Rect target(static_cast<int>(std::lround(centre.x - rotated.cols / 2.0)),
                        static_cast<int>(std::lround(centre.y - rotated.rows / 2.0)), rotated.cols,
                        rotated.rows);
  const cv::Rect clipped = target & cv::Rect(0, 0, image.cols, image.rows);
  if (clipped.area() == 0) return;
  rotated(cv::Rect(clipped.x - target.x, clipped.y - target.y, clipped.width, clipped.height))
      .copyTo(image(clipped));
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
  if (width_px < 320 || width_px > 8000) {
    *why = "plot width = " + std::to_string(width_px) + " px; must be in [320, 8000]";
    return false;
  }
  if (height_px < 240 || height_px > 8000) {
    *why = "plot height = " + std::to_string(height_px) + " px; must be in [240, 8000]";
    return false;
  }
  return true;
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
  const double ui = std::min(width / 1000.0, height / 800.0);  // Size of text and margins.
  const double font = std::max(0.4, 0.55 * ui);
  const double title_font = std::max(0.5, 0.75 * ui);
  const int title_thickness = ui >= 0.9 ? 2 : 1;
  int baseline = 0;
  const int text_height = cv::getTextSize("0", kFont, font, 1, &baseline).height;
  const int label_width = cv::getTextSize("-000.00", kFont, font, 1, &baseline).width;
  const int title_height =
      cv::getTextSize("A", kFont, title_font, title_thickness, &baseline).height;

  const int margin_top = static_cast<int>(std::lround(title_height * 3.2));
  const int margin_bottom = static_cast<int>(std::lround(text_height * 5.0));
  const int margin_left = static_cast<int>(std::lround(text_height * 3.5)) + label_width;
  const int margin_right = static_cast<int>(std::lround(24 * ui));
  const cv::Rect area(margin_left, margin_top, width - margin_left - margin_right,
                      height - margin_top - margin_bottom);

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
  if (!(lo.x() <= hi.x())) lo = hi = Eigen::Vector2d::Zero();
  const double kMinSpan = 1e-3;  // Metres; a single point still gets a scale.
  const Eigen::Vector2d span = (hi - lo).cwiseMax(kMinSpan);
  const double kPadding = 1.08;
  Projection projection;
  projection.centre_u = 0.5 * (lo.x() + hi.x());
  projection.centre_v = 0.5 * (lo.y() + hi.y());
  projection.pixels_per_metre =
      std::min(area.width / (span.x() * kPadding), area.height / (span.y() * kPadding));
  projection.centre_px = cv::Point2d(area.x + area.width / 2.0, area.y + area.height / 2.0);

  // Grid and ticks: the same step on both axes (equal scale), ~110 px apart.
  const double step = NiceStep(110.0 * ui / projection.pixels_per_metre);
  const double u_min = projection.centre_u - area.width / 2.0 / projection.pixels_per_metre;
  const double u_max = projection.centre_u + area.width / 2.0 / projection.pixels_per_metre;
  const double v_min = projection.centre_v - area.height / 2.0 / projection.pixels_per_metre;
  const double v_max = projection.centre_v + area.height / 2.0 / projection.pixels_per_metre;
  const int tick = std::max(4, static_cast<int>(std::lround(6 * ui)));
  for (double u = std::ceil(u_min / step) * step; u <= u_max; u += step) {
    const double x = projection(Eigen::Vector2d(u, 0)).x;
    cv::line(image, SubPixel({x, double(area.y)}), SubPixel({x, double(area.br().y)}), kGrid, 1,
             cv::LINE_AA, kShift);
    cv::line(image, SubPixel({x, double(area.br().y)}), SubPixel({x, double(area.br().y + tick)}),
             kFrame, 1, cv::LINE_AA, kShift);
    PutText(image, TickLabel(u, step), {x, area.br().y + tick + 0.6 * text_height}, font, 1, 0.5,
            0);
  }
  for (double v = std::ceil(v_min / step) * step; v <= v_max; v += step) {
    const double y = projection(Eigen::Vector2d(0, v)).y;
    cv::line(image, SubPixel({double(area.x), y}), SubPixel({double(area.br().x), y}), kGrid, 1,
             cv::LINE_AA, kShift);
    cv::line(image, SubPixel({double(area.x - tick), y}), SubPixel({double(area.x), y}), kFrame, 1,
             cv::LINE_AA, kShift);
    PutText(image, TickLabel(v, step), {area.x - tick - 0.6 * text_height, y}, font, 1, 1, 0.5);
  }

  // Data, clipped to the plot area: differences under the trajectories.
  cv::Mat canvas = image(area);
  const cv::Point2d origin(area.x, area.y);
  const auto to_canvas = [&](const Eigen::Vector3d& p) {
    return SubPixel(projection(Eigen::Vector2d(p[axis_u], p[axis_v])) - origin);
  };
  const int line_width = std::max(1, static_cast<int>(std::lround(2 * ui)));
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
  cv::rectangle(image, area, kFrame, 1, cv::LINE_8);

  // Axis labels and title.
  const std::string u_label = std::string(1, kAxisNames[axis_u]) + " [m]";
  const std::string v_label = std::string(1, kAxisNames[axis_v]) + " [m]";
  PutText(image, u_label, {area.x + area.width / 2.0, area.br().y + tick + 2.6 * text_height}, font,
          1, 0.5, 0);
  PutVerticalText(image, v_label,
                  {area.x - tick - 1.2 * text_height - label_width, area.y + area.height / 2.0},
                  font, 1);
  std::string title = options.title.empty() ? "" : options.title + ": ";
  title += "ATE RMSE " + FormatRmse(result.error.rmse) + " (" +
           std::to_string(result.pairs.size()) + " pairs)";
  PutText(image, title, {width / 2.0, margin_top / 2.0}, title_font, title_thickness, 0.5, 0.5);

  // Legend in the corner of the plot area that hides the fewest points.
  const std::array<std::pair<std::string, cv::Scalar>, 3> entries = {
      std::pair<std::string, cv::Scalar>{"ground truth", kGroundTruth},
      {"estimate (aligned)", kEstimate},
      {"difference", kDifference}};
  int entry_width = 0;
  for (const auto& entry : entries) {
    entry_width =
        std::max(entry_width, cv::getTextSize(entry.first, kFont, font, 1, &baseline).width);
  }
  const int pad = static_cast<int>(std::lround(text_height * 0.9));
  const int swatch = static_cast<int>(std::lround(text_height * 2.6));
  const int row = static_cast<int>(std::lround(text_height * 2.0));
  const cv::Size box_size(pad * 3 + swatch + entry_width, pad * 2 + row * 3 - (row - text_height));
  const int inset = pad;
  const std::array<cv::Rect, 4> corners = {
      cv::Rect(area.x + inset, area.y + inset, box_size.width, box_size.height),
      cv::Rect(area.br().x - inset - box_size.width, area.y + inset, box_size.width,
               box_size.height),
      cv::Rect(area.x + inset, area.br().y - inset - box_size.height, box_size.width,
               box_size.height),
      cv::Rect(area.br().x - inset - box_size.width, area.br().y - inset - box_size.height,
               box_size.width, box_size.height)};
  size_t best_corner = 0, best_hidden = std::numeric_limits<size_t>::max();
  for (size_t c = 0; c < corners.size(); ++c) {
    size_t hidden = 0;
    const auto count = [&](const Trajectory& trajectory) {
      for (const StampedPose& pose : trajectory) {
        const Eigen::Vector3d& p = pose.T_world_cam.translation;
        if (corners[c].contains(projection(Eigen::Vector2d(p[axis_u], p[axis_v])))) ++hidden;
      }
    };
    count(gt);
    count(result.est_aligned);
    if (hidden < best_hidden) {
      best_hidden = hidden;
      best_corner = c;
    }
  }
  const cv::Rect box = corners[best_corner];
  if (box.width < area.width && box.height < area.height) {
    cv::Mat region = image(box);
    cv::Mat white(region.size(), region.type(), kBackground);
    cv::addWeighted(region, 0.15, white, 0.85, 0, region);  // Mostly opaque.
    cv::rectangle(image, box, kFrame, 1, cv::LINE_8);
    for (size_t k = 0; k < entries.size(); ++k) {
      const double y = box.y + pad + text_height / 2.0 + k * row;
      const int entry_thickness = k == 2 ? 1 : line_width;
      cv::line(image, SubPixel({double(box.x + pad), y}),
               SubPixel({double(box.x + pad + swatch), y}), entries[k].second, entry_thickness,
               cv::LINE_AA, kShift);
      PutText(image, entries[k].first, {double(box.x + 2 * pad + swatch), y}, font, 1, 0, 0.5);
    }
  }
  return image;
}

void PlotAte(const std::filesystem::path& png_path, const Trajectory& gt, const AteResult& result,
             const PlotOptions& options,
             const std::vector<std::pair<std::string, std::string>>& text) {
  WritePng(png_path, RenderAtePlot(gt, result, options), kPlotPngCompression, text);
}

}  // namespace rrslam
