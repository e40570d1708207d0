#include "stages/eval/plot.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <functional>
#include <opencv2/imgcodecs.hpp>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/geometry.h"
#include "common/testing.h"

namespace rrslam {
namespace {

// A loop in the x-z plane (y nearly constant), as a camera carried at eye height.
Trajectory MakeGroundTruth(int n) {
  Trajectory gt;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    StampedPose pose;
    pose.timestamp = 100 + i / 30.0;
    pose.T_world_cam.translation =
        Eigen::Vector3d(2 * std::cos(a), 0.05 * std::sin(3 * a), std::sin(a));
    gt.push_back(pose);
  }
  return gt;
}

AteResult MakeResult(const Trajectory& gt) {
  Trajectory est = gt;
  for (size_t i = 0; i < est.size(); ++i) {
    est[i].T_world_cam.translation += Eigen::Vector3d(0.05 * std::sin(0.1 * i), 0, 0.04);
  }
  est.erase(est.begin() + 40, est.begin() + 60);  // Lost tracking: a gap.
  return ComputeAte(gt, est);
}

int CountPixels(const cv::Mat& image, const std::function<bool(const cv::Vec3b&)>& test) {
  int count = 0;
  for (int r = 0; r < image.rows; ++r) {
    for (int c = 0; c < image.cols; ++c) count += test(image.at<cv::Vec3b>(r, c)) ? 1 : 0;
  }
  return count;
}

TEST(ChoosePlotAxes, PicksTheTwoAxesOfLargestExtent) {
  const Trajectory gt = MakeGroundTruth(100);
  EXPECT_EQ(ChoosePlotAxes(gt, PlotAxes::kAuto), std::make_pair(0, 2));
  Trajectory yz = gt;
  for (StampedPose& p : yz) {
    const Eigen::Vector3d t = p.T_world_cam.translation;
    p.T_world_cam.translation = Eigen::Vector3d(t.y(), t.x(), t.z());
  }
  EXPECT_EQ(ChoosePlotAxes(yz, PlotAxes::kAuto), std::make_pair(1, 2));
  EXPECT_EQ(ChoosePlotAxes(gt, PlotAxes::kXY), std::make_pair(0, 1));
  EXPECT_EQ(ChoosePlotAxes(gt, PlotAxes::kYZ), std::make_pair(1, 2));
  EXPECT_EQ(ChoosePlotAxes(gt, PlotAxes::kXZ), std::make_pair(0, 2));
}

TEST(RenderAtePlot, DrawsTrajectoriesErrorsAndFrameAtTheRequestedSize) {
  const Trajectory gt = MakeGroundTruth(200);
  const AteResult result = MakeResult(gt);
  PlotOptions options;
  options.width_px = 900;
  options.height_px = 700;
  const cv::Mat image = RenderAtePlot(gt, result, options);
  ASSERT_EQ(image.type(), CV_8UC3);
  EXPECT_EQ(image.cols, 900);
  EXPECT_EQ(image.rows, 700);
  // Dark ground truth, blue estimate, red differences are all present.
  const int dark =
      CountPixels(image, [](const cv::Vec3b& p) { return p[0] < 60 && p[1] < 60 && p[2] < 60; });
  const int blue = CountPixels(image, [](const cv::Vec3b& p) { return p[0] > 150 && p[2] < 80; });
  const int red =
      CountPixels(image, [](const cv::Vec3b& p) { return p[2] > 180 && p[0] < 140 && p[1] < 140; });
  EXPECT_GT(dark, 1000);
  EXPECT_GT(blue, 1000);
  EXPECT_GT(red, 50);
  // The corners stay background (margins).
  EXPECT_EQ(image.at<cv::Vec3b>(0, 0), cv::Vec3b(255, 255, 255));
  EXPECT_EQ(image.at<cv::Vec3b>(699, 899), cv::Vec3b(255, 255, 255));
}

TEST(RenderAtePlot, RejectsInvalidSize) {
  const Trajectory gt = MakeGroundTruth(50);
  PlotOptions options;
  options.width_px = 100;
  EXPECT_THROW(RenderAtePlot(gt, MakeResult(gt), options), UsageError);
  std::string why;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("width"), std::string::npos);
  options = PlotOptions{};
  options.height_px = 9000;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("height"), std::string::npos);
  EXPECT_TRUE(PlotOptions{}.Check(&why));
}

TEST(PlotAte, WritesAReadablePngAtomically) {
  testing::TempDir dir;
  const Trajectory gt = MakeGroundTruth(120);
  const AteResult result = MakeResult(gt);
  PlotAte(dir / "ate.png", gt, result);
  const cv::Mat read = cv::imread((dir / "ate.png").string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(read.empty());
  EXPECT_EQ(read.cols, PlotOptions{}.width_px);
  EXPECT_EQ(read.rows, PlotOptions{}.height_px);
  EXPECT_EQ(testing::TemporaryLeftovers(dir), std::vector<std::string>{});
  EXPECT_THROW(PlotAte(dir / "missing" / "ate.png", gt, result), CantCreateError);
  EXPECT_FALSE(std::filesystem::exists(dir / "missing"));
}

// Found in review (issue 36): a ground truth 1e17 m from the origin hung the
// plot: its grid loop added a 0.1 m step that 1e17 cannot hold. Such an
// axis now gets no grid; positions beyond 2 * DBL_MAX of span still fit.
TEST(RenderAtePlot, FarFromTheOriginDrawsWithoutAGridInsteadOfHanging) {
  for (const double offset : {1e17, 1e300}) {
    Trajectory gt = MakeGroundTruth(100);
    for (StampedPose& p : gt) p.T_world_cam.translation += Eigen::Vector3d(offset, 0, offset);
    const cv::Mat image = RenderAtePlot(gt, MakeResult(gt), PlotOptions{});
    EXPECT_EQ(image.cols, PlotOptions{}.width_px) << offset;
  }
  Trajectory wide = MakeGroundTruth(100);
  wide[0].T_world_cam.translation.x() = -1.7e308;
  wide[1].T_world_cam.translation.x() = 1.7e308;
  AteResult result;
  result.est_aligned = wide;
  EXPECT_EQ(RenderAtePlot(wide, result, PlotOptions{}).cols, PlotOptions{}.width_px);
}

}  // namespace
}  // namespace rrslam
