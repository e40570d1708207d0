#include "common/chart.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

namespace rrslam::chart {
namespace {

TEST(TickValues, MultiplesOfTheStepInTheRange) {
  EXPECT_EQ(TickValues(-0.25, 1.0, 0.5), (std::vector<double>{0.0, 0.5, 1.0}));
  EXPECT_EQ(TickValues(0.1, 0.4, 0.5), std::vector<double>{});
  EXPECT_EQ(TickValues(3, 3, 1), std::vector<double>{3.0});
  EXPECT_EQ(TickValues(0, 999, 1).size(), 1000u);
}

// Found in review (issue 36): `for (v = lo; v <= hi; v += step)` never ends
// when step is below the precision of v (v + step == v: positions near 1e17
// with a 0.1 step) or the range is not finite; every tick loop goes through
// TickValues, which gives nothing then.
TEST(TickValues, NoneWhereTheyCannotBeDrawn) {
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(TickValues(1e17, 1e17 + 1000, 0.1).empty());
  EXPECT_TRUE(TickValues(-inf, 1, 0.1).empty());
  EXPECT_TRUE(TickValues(0, inf, 0.1).empty());
  EXPECT_TRUE(TickValues(0, 1, nan).empty());
  EXPECT_TRUE(TickValues(0, 1, 0).empty());
  EXPECT_TRUE(TickValues(0, 1, -0.1).empty());
  EXPECT_TRUE(TickValues(1, 0, 0.1).empty());
  EXPECT_TRUE(TickValues(0, 1e6, 1).empty());  // More than kMaxTicks.
  EXPECT_EQ(TickValues(1e17, 1e17 + 4e16, 1e16).size(), 5u);
}

TEST(FitAxes, SpansBeyondDblMaxStayFinite) {
  const cv::Rect area(0, 0, 800, 600);
  const Axes2d axes =
      FitAxes(Eigen::Vector2d(-1.7e308, 0), Eigen::Vector2d(1.7e308, 1), area, AxisScale::kEach);
  EXPECT_TRUE(std::isfinite(axes.centre_u));
  EXPECT_GT(axes.pixels_per_u, 0);
  EXPECT_NEAR(axes(Eigen::Vector2d(1.7e308, 0)).x, 400 + 400 / 1.08, 1e-6);
  // Bounds that are not finite: the unit square around 0.
  const Axes2d none = FitAxes(Eigen::Vector2d(0, 0),
                              Eigen::Vector2d(std::numeric_limits<double>::infinity(), 1), area);
  EXPECT_EQ(none.centre_u, 0);
  EXPECT_TRUE(std::isfinite(none.pixels_per_u));
}

TEST(DrawGrid, EndsOnCoordinatesBeyondTheirPrecision) {
  cv::Mat image(600, 800, CV_8UC3, kBackground);
  const ChartLayout layout = MakeLayout(image.size());
  for (const double offset : {1e17, 1e20, 1e300}) {
    DrawGrid(image, layout,
             FitAxes(Eigen::Vector2d(offset, offset), Eigen::Vector2d(offset + 2, offset + 1),
                     layout.area));
  }
  DrawGrid(image, layout, FitAxes(Eigen::Vector2d(0, 0), Eigen::Vector2d(2, 1), layout.area));
  EXPECT_NE(image.at<cv::Vec3b>(layout.area.y + 1, layout.area.x + layout.area.width / 2),
            cv::Vec3b(255, 255, 255));  // The grid line through u = 1.
}

TEST(TickLabel, DecimalsOfTheStep) {
  EXPECT_EQ(TickLabel(0.25, 0.05), "0.25");
  EXPECT_EQ(TickLabel(-1e-12, 0.1), "0.0");
  EXPECT_EQ(TickLabel(-0.004, 0.5), "0.0");  // Prints as zero: no minus sign.
  EXPECT_EQ(TickLabel(3, std::numeric_limits<double>::infinity()), "3");
  EXPECT_EQ(TickLabel(3, 0), "3");
}

}  // namespace
}  // namespace rrslam::chart
