#include "common/chart.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/imgproc.hpp>

namespace rrslam::chart {

static_assert(kFont == cv::FONT_HERSHEY_SIMPLEX);

cv::Point SubPixel(const cv::Point2d& p) {
  return cv::Point(static_cast<int>(std::lround(p.x * kSubPixel)),
                   static_cast<int>(std::lround(p.y * kSubPixel)));
}

double NiceStep(double raw) {
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double normalized = raw / magnitude;
  const double nice = normalized < 1.5 ? 1 : normalized < 3.5 ? 2 : normalized < 7.5 ? 5 : 10;
  return nice * magnitude;
}

std::vector<double> TickValues(double lo, double hi, double step) {
  if (!std::isfinite(lo) || !std::isfinite(hi) || !std::isfinite(step) || !(step > 0) || hi < lo) {
    return {};
  }
  const double first = std::ceil(lo / step), last = std::floor(hi / step);
  // Below 1e15 (< 2^53) the multiples k * step of consecutive integers k are
  // distinct: k is exact, and so is the count.
  constexpr double kMaxMultiple = 1e15;
  if (!(std::fabs(first) <= kMaxMultiple && std::fabs(last) <= kMaxMultiple) || last < first ||
      last - first + 1 > static_cast<double>(kMaxTicks)) {
    return {};
  }
  std::vector<double> values;
  for (double k = first; k <= last; ++k) values.push_back(k * step);
  return values;
}

std::string TickLabel(double value, double step) {
  // At most 17 decimals (all a double has); none for a step that is not a
  // positive finite number.
  const double digits = -std::floor(std::log10(step) + 1e-9);
  const int decimals = std::isfinite(digits) ? static_cast<int>(std::clamp(digits, 0.0, 17.0)) : 0;
  // No "-0.0": a value that prints as zero (-0.004 with one decimal) is zero.
  const double scale = std::pow(10.0, decimals);
  if (std::isfinite(step) && std::fabs(value) * scale < 0.5) value = 0;
  char buffer[48];
  std::snprintf(buffer, sizeof(buffer), "%.*f", decimals, value);
  return buffer;
}

void PutText(cv::Mat& image, const std::string& text, cv::Point2d anchor, double font_scale,
             int thickness, double align_x, double align_y, const cv::Scalar& colour) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFont, font_scale, thickness, &baseline);
  const cv::Point origin(static_cast<int>(std::lround(anchor.x - align_x * size.width)),
                         static_cast<int>(std::lround(anchor.y + (1 - align_y) * size.height)));
  cv::putText(image, text, origin, kFont, font_scale, colour, thickness, cv::LINE_AA);
}

void PutVerticalText(cv::Mat& image, const std::string& text, cv::Point2d centre, double font_scale,
                     int thickness, const cv::Scalar& background) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFont, font_scale, thickness, &baseline);
  cv::Mat patch(size.height + baseline + 4, size.width + 4, image.type(), background);
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

ChartLayout MakeLayout(cv::Size size, bool footer) {
  ChartLayout layout;
  layout.ui = std::min(size.width / 1000.0, size.height / 800.0);
  layout.font = std::max(0.4, 0.55 * layout.ui);
  layout.title_font = std::max(0.5, 0.75 * layout.ui);
  layout.title_thickness = layout.ui >= 0.9 ? 2 : 1;
  int baseline = 0;
  layout.text_height = cv::getTextSize("0", kFont, layout.font, 1, &baseline).height;
  layout.label_width = cv::getTextSize("-000.00", kFont, layout.font, 1, &baseline).width;
  layout.title_height =
      cv::getTextSize("A", kFont, layout.title_font, layout.title_thickness, &baseline).height;
  layout.tick = std::max(4, static_cast<int>(std::lround(6 * layout.ui)));
  layout.line_width = std::max(1, static_cast<int>(std::lround(2 * layout.ui)));

  const int margin_top = static_cast<int>(std::lround(layout.title_height * 3.2));
  const int margin_bottom = static_cast<int>(std::lround(layout.text_height * 5.0));
  const int margin_left =
      static_cast<int>(std::lround(layout.text_height * 3.5)) + layout.label_width;
  const int margin_right = static_cast<int>(std::lround(24 * layout.ui));
  layout.area = cv::Rect(margin_left, margin_top, size.width - margin_left - margin_right,
                         size.height - margin_top - margin_bottom);
  if (footer) {
    layout.area.height -= static_cast<int>(std::lround(1.8 * layout.text_height));
    layout.footer_y =
        layout.area.br().y + layout.tick + static_cast<int>(std::lround(4.7 * layout.text_height));
  }
  return layout;
}

Axes2d FitAxes(Eigen::Vector2d lo, Eigen::Vector2d hi, const cv::Rect& area, AxisScale scale,
               double padding, double min_span) {
  if (!(lo.x() <= hi.x()) || !(lo.y() <= hi.y()) || !lo.allFinite() || !hi.allFinite()) {
    lo = hi = Eigen::Vector2d::Zero();
  }
  const Eigen::Vector2d span = (hi - lo).cwiseMax(min_span);
  Axes2d axes;
  if (span.allFinite() && (lo + hi).allFinite()) {
    axes.centre_u = 0.5 * (lo.x() + hi.x());
    axes.centre_v = 0.5 * (lo.y() + hi.y());
    axes.pixels_per_u = area.width / (span.x() * padding);
    axes.pixels_per_v = area.height / (span.y() * padding);
  } else {
    // hi - lo or lo + hi overflowed past DBL_MAX: halves first.
    const Eigen::Vector2d half_span = (0.5 * hi - 0.5 * lo).cwiseMax(0.5 * min_span);
    axes.centre_u = 0.5 * lo.x() + 0.5 * hi.x();
    axes.centre_v = 0.5 * lo.y() + 0.5 * hi.y();
    axes.pixels_per_u = area.width / 2.0 / padding / half_span.x();
    axes.pixels_per_v = area.height / 2.0 / padding / half_span.y();
  }
  if (scale == AxisScale::kEqual) {
    axes.pixels_per_u = axes.pixels_per_v = std::min(axes.pixels_per_u, axes.pixels_per_v);
  }
  axes.centre_px = cv::Point2d(area.x + area.width / 2.0, area.y + area.height / 2.0);
  return axes;
}

bool CheckChartSize(int width_px, int height_px, const std::string& what, std::string* why) {
  if (width_px < 320 || width_px > 8000) {
    *why = what + " width = " + std::to_string(width_px) + " px; must be in [320, 8000]";
    return false;
  }
  if (height_px < 240 || height_px > 8000) {
    *why = what + " height = " + std::to_string(height_px) + " px; must be in [240, 8000]";
    return false;
  }
  return true;
}

void DrawGrid(cv::Mat& image, const ChartLayout& layout, const Axes2d& axes) {
  const cv::Rect& area = layout.area;
  const int tick = layout.tick;
  const double step_u = NiceStep(110.0 * layout.ui / axes.pixels_per_u);
  const double step_v = NiceStep(110.0 * layout.ui / axes.pixels_per_v);
  const double u_max = axes.u_max(area), v_max = axes.v_max(area);
  for (const double u : TickValues(axes.u_min(area), u_max, step_u)) {
    const double x = axes(Eigen::Vector2d(u, 0)).x;
    cv::line(image, SubPixel({x, double(area.y)}), SubPixel({x, double(area.br().y)}), kGrid, 1,
             cv::LINE_AA, kShift);
    cv::line(image, SubPixel({x, double(area.br().y)}), SubPixel({x, double(area.br().y + tick)}),
             kFrame, 1, cv::LINE_AA, kShift);
    PutText(image, TickLabel(u, step_u), {x, area.br().y + tick + 0.6 * layout.text_height},
            layout.font, 1, 0.5, 0);
  }
  for (const double v : TickValues(axes.v_min(area), v_max, step_v)) {
    const double y = axes(Eigen::Vector2d(0, v)).y;
    cv::line(image, SubPixel({double(area.x), y}), SubPixel({double(area.br().x), y}), kGrid, 1,
             cv::LINE_AA, kShift);
    cv::line(image, SubPixel({double(area.x - tick), y}), SubPixel({double(area.x), y}), kFrame, 1,
             cv::LINE_AA, kShift);
    PutText(image, TickLabel(v, step_v), {area.x - tick - 0.6 * layout.text_height, y}, layout.font,
            1, 1, 0.5);
  }
}

void DrawFrameAndLabels(cv::Mat& image, const ChartLayout& layout, const std::string& u_label,
                        const std::string& v_label, const std::string& title) {
  const cv::Rect& area = layout.area;
  cv::rectangle(image, area, kFrame, 1, cv::LINE_8);
  PutText(image, u_label,
          {area.x + area.width / 2.0, area.br().y + layout.tick + 2.6 * layout.text_height},
          layout.font, 1, 0.5, 0);
  PutVerticalText(image, v_label,
                  {area.x - layout.tick - 1.2 * layout.text_height - layout.label_width,
                   area.y + area.height / 2.0},
                  layout.font, 1);
  const int margin_top = area.y;
  PutText(image, title, {image.cols / 2.0, margin_top / 2.0}, layout.title_font,
          layout.title_thickness, 0.5, 0.5);
}

void DrawLegend(cv::Mat& image, const ChartLayout& layout, const std::vector<LegendEntry>& entries,
                const std::vector<cv::Point2d>& occupied) {
  if (entries.empty()) return;
  const cv::Rect& area = layout.area;
  const int text_height = layout.text_height;
  int baseline = 0;
  int entry_width = 0;
  for (const auto& entry : entries) {
    entry_width =
        std::max(entry_width, cv::getTextSize(entry.label, kFont, layout.font, 1, &baseline).width);
  }
  const int rows = static_cast<int>(entries.size());
  const int pad = static_cast<int>(std::lround(text_height * 0.9));
  const int swatch = static_cast<int>(std::lround(text_height * 2.6));
  const int row = static_cast<int>(std::lround(text_height * 2.0));
  const cv::Size box_size(pad * 3 + swatch + entry_width,
                          pad * 2 + row * rows - (row - text_height));
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
    for (const cv::Point2d& p : occupied) {
      if (corners[c].contains(p)) ++hidden;
    }
    if (hidden < best_hidden) {
      best_hidden = hidden;
      best_corner = c;
    }
  }
  const cv::Rect box = corners[best_corner];
  if (box.width >= area.width || box.height >= area.height) return;
  cv::Mat region = image(box);
  cv::Mat white(region.size(), region.type(), kBackground);
  cv::addWeighted(region, 0.15, white, 0.85, 0, region);  // Mostly opaque.
  cv::rectangle(image, box, kFrame, 1, cv::LINE_8);
  for (size_t k = 0; k < entries.size(); ++k) {
    const double y = box.y + pad + text_height / 2.0 + k * row;
    cv::line(image, SubPixel({double(box.x + pad), y}), SubPixel({double(box.x + pad + swatch), y}),
             entries[k].colour, entries[k].thickness, cv::LINE_AA, kShift);
    PutText(image, entries[k].label, {double(box.x + 2 * pad + swatch), y}, layout.font, 1, 0, 0.5);
  }
}

cv::Scalar ColormapColour(int colormap, double t) {
  cv::Mat grey(1, 1, CV_8UC1,
               cv::Scalar(static_cast<int>(std::lround(std::clamp(t, 0.0, 1.0) * 255))));
  cv::Mat colour;
  cv::applyColorMap(grey, colour, colormap);
  const cv::Vec3b c = colour.at<cv::Vec3b>(0, 0);
  return cv::Scalar(c[0], c[1], c[2]);
}

void DrawColourBar(cv::Mat& image, const ChartLayout& layout, cv::Point2d left, int colormap,
                   double lo, double hi, const std::string& caption) {
  const int width = static_cast<int>(std::lround(180 * layout.ui));
  const int height = std::max(6, layout.text_height);
  cv::Mat ramp(1, 256, CV_8UC1);
  for (int i = 0; i < 256; ++i) ramp.at<uint8_t>(0, i) = static_cast<uint8_t>(i);
  cv::Mat colours, bar;
  cv::applyColorMap(ramp, colours, colormap);
  cv::resize(colours, bar, cv::Size(width, height), 0, 0, cv::INTER_LINEAR);
  const cv::Point origin(static_cast<int>(std::lround(left.x)),
                         static_cast<int>(std::lround(left.y - height / 2.0)));
  const cv::Rect target = cv::Rect(origin, bar.size()) & cv::Rect(0, 0, image.cols, image.rows);
  if (target.area() != width * height || image.type() != CV_8UC3) return;
  bar.copyTo(image(target));
  cv::rectangle(image, target, kFrame, 1, cv::LINE_8);
  const double step = NiceStep(std::max(std::fabs(hi - lo), 1e-9) / 4);
  const double y = target.y + height / 2.0;
  PutText(image, TickLabel(lo, step), {target.x - 0.5 * layout.text_height, y}, layout.font, 1, 1,
          0.5);
  PutText(image, TickLabel(hi, step) + " " + caption, {target.br().x + 0.5 * layout.text_height, y},
          layout.font, 1, 0, 0.5);
}

}  // namespace rrslam::chart
