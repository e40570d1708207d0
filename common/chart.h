// Charts drawn with OpenCV: the frame every rrslam picture shares (plot area,
// grid, ticks with round values, axis labels, title, legend), so that eval's
// ATE plot and render's trajectory and map pictures look alike and one piece
// of code draws them.
//
// Data coordinates are (u, v) with u to the right and v up (metres for
// positions, seconds or centimetres for time series); Axes2d maps them to
// image pixels. Colours are BGR. Drawing is antialiased with kShift
// sub-pixel bits. Sizes scale with the image (ChartLayout::ui, 1 at
// 1000 x 800 px).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

namespace rrslam::chart {

// Colours (BGR).
inline const cv::Scalar kBackground(255, 255, 255);
inline const cv::Scalar kGrid(232, 232, 232);
inline const cv::Scalar kFrame(110, 110, 110);
inline const cv::Scalar kText(30, 30, 30);

inline constexpr int kFont = 0;   // cv::FONT_HERSHEY_SIMPLEX
inline constexpr int kShift = 4;  // Sub-pixel bits for antialiased drawing.
inline constexpr double kSubPixel = 1 << kShift;

// A pixel position as a fixed-point cv::Point for drawing with kShift.
cv::Point SubPixel(const cv::Point2d& p);

// Tick step of 1, 2 or 5 times a power of ten, near `raw`.
double NiceStep(double raw);

// Most ticks TickValues gives on one axis (a chart has about 8000 / 110).
inline constexpr size_t kMaxTicks = 1000;

// The multiples of `step` in [lo, hi], ascending: where an axis' grid lines
// and ticks go. Empty where they cannot be drawn: lo, hi or step not finite,
// step <= 0, more than kMaxTicks of them, or a step below the precision of
// the values (they lie more than 1e15 steps from 0, so that consecutive
// multiples are no longer distinct doubles). Every tick loop goes through
// this: a loop `for (v = lo; v <= hi; v += step)` never ends there.
std::vector<double> TickValues(double lo, double hi, double step);

// `value` with as many decimals as `step` needs ("0", not "-0.0").
std::string TickLabel(double value, double step);

// Text anchored at `anchor`: align 0 = left/top, 0.5 = centre, 1 =
// right/bottom of the text box (cap height).
void PutText(cv::Mat& image, const std::string& text, cv::Point2d anchor, double font_scale,
             int thickness, double align_x, double align_y, const cv::Scalar& colour = kText);
// Text rotated 90 degrees counter-clockwise, centred on `centre`, on `background`.
void PutVerticalText(cv::Mat& image, const std::string& text, cv::Point2d centre, double font_scale,
                     int thickness, const cv::Scalar& background = kBackground);

// Sizes of text and margins for an image, and the plot area they leave.
struct ChartLayout {
  double ui = 1;       // Scale of text and margins (1 at 1000 x 800 px).
  double font = 0.55;  // Tick and label font scale.
  double title_font = 0.75;
  int title_thickness = 2;
  int text_height = 0;  // Pixels of a digit at `font`.
  int label_width = 0;  // Pixels of the widest expected tick label.
  int title_height = 0;
  int tick = 6;        // Tick length, pixels.
  int line_width = 2;  // Data line width, pixels.
  cv::Rect area;       // The plot area.
  int footer_y = 0;    // Centre line of the row under the axis label (0 = none).
};
// The layout of a `size` image with room for a title, tick labels and axis
// labels around the plot area, and optionally a footer row under the axis
// label (colour bars, scale bars).
ChartLayout MakeLayout(cv::Size size, bool footer = false);

// Maps data (u right, v up) to image pixels: the data point (centre_u,
// centre_v) lands on centre_px.
struct Axes2d {
  double centre_u = 0, centre_v = 0;
  double pixels_per_u = 1, pixels_per_v = 1;
  cv::Point2d centre_px;

  cv::Point2d operator()(const Eigen::Vector2d& p) const {
    return {centre_px.x + (p.x() - centre_u) * pixels_per_u,
            centre_px.y - (p.y() - centre_v) * pixels_per_v};
  }
  double u_min(const cv::Rect& area) const { return centre_u - area.width / 2.0 / pixels_per_u; }
  double u_max(const cv::Rect& area) const { return centre_u + area.width / 2.0 / pixels_per_u; }
  double v_min(const cv::Rect& area) const { return centre_v - area.height / 2.0 / pixels_per_v; }
  double v_max(const cv::Rect& area) const { return centre_v + area.height / 2.0 / pixels_per_v; }
};

// Fits data bounds [lo, hi] into `area` with `padding` (1.08 = 8% free),
// centred: with kEqual one scale for both axes (maps, metres), with kEach a
// scale per axis (time series). A span below `min_span` counts as min_span.
// Bounds that are not finite count as [0, 0]; finite bounds never overflow
// (a span of up to 2 * DBL_MAX is fitted).
enum class AxisScale { kEqual, kEach };
Axes2d FitAxes(Eigen::Vector2d lo, Eigen::Vector2d hi, const cv::Rect& area,
               AxisScale scale = AxisScale::kEqual, double padding = 1.08, double min_span = 1e-3);

// Image sizes every chart accepts: width in [320, 8000], height in [240,
// 8000] pixels. False with "<what> width = N px; must be in [320, 8000]" in
// `why` otherwise.
bool CheckChartSize(int width_px, int height_px, const std::string& what, std::string* why);

// Grid lines, ticks and tick labels at round values about 110 px apart,
// clipped to the layout's area. An axis whose ticks TickValues cannot give
// (a range not finite, a step below the precision of the values) gets none.
void DrawGrid(cv::Mat& image, const ChartLayout& layout, const Axes2d& axes);

// Frame of the area, axis labels under and left of it, and the title above.
void DrawFrameAndLabels(cv::Mat& image, const ChartLayout& layout, const std::string& u_label,
                        const std::string& v_label, const std::string& title);

struct LegendEntry {
  std::string label;
  cv::Scalar colour;
  int thickness = 2;  // Of the swatch line, pixels.
};

// A legend box in the corner of the area that hides the fewest of
// `occupied` (image pixels of the data), mostly opaque. Skipped when it
// would not fit.
void DrawLegend(cv::Mat& image, const ChartLayout& layout, const std::vector<LegendEntry>& entries,
                const std::vector<cv::Point2d>& occupied);

// A horizontal colour bar of a colormap (cv::ColormapTypes) from `lo` to
// `hi` labelled "<lo> ... <hi> <caption>", its left end centred on `left`.
void DrawColourBar(cv::Mat& image, const ChartLayout& layout, cv::Point2d left, int colormap,
                   double lo, double hi, const std::string& caption);

// The colour of `t` in [0, 1] on an OpenCV colormap (cv::ColormapTypes).
cv::Scalar ColormapColour(int colormap, double t);

}  // namespace rrslam::chart
