#include "stages/render/trajectory_picture.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/errors.h"

namespace rrslam {
namespace {

// A circle of radius 1 m in the x-y plane with a little z, 30 Hz for 10 s.
Trajectory Circle(double rate = 30) {
  Trajectory t;
  for (int i = 0; i < static_cast<int>(10 * rate); ++i) {
    const double s = i / rate;
    t.push_back({s, Rigid3d(Eigen::Quaterniond::Identity(),
                            Eigen::Vector3d(std::cos(s), std::sin(s), 0.05 * std::sin(3 * s)))});
  }
  return t;
}

// `t` in another world frame (rotated and shifted), with an offset of
// `bump` metres along y between 4 and 5 s.
Trajectory Moved(const Trajectory& t, double bump) {
  const Rigid3d T(Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ())),
                  Eigen::Vector3d(3, -2, 1));
  Trajectory out;
  for (const StampedPose& p : t) {
    Rigid3d pose = T * p.T_world_cam;
    if (p.timestamp >= 4 && p.timestamp < 5) pose.translation.y() += bump;
    out.push_back({p.timestamp, pose});
  }
  return out;
}

int NonBackground(const cv::Mat& image) {
  int count = 0;
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) {
      const cv::Vec3b p = image.at<cv::Vec3b>(y, x);
      if (p != cv::Vec3b(255, 255, 255)) ++count;
    }
  return count;
}

TEST(TrajectoryPicture, AlignsToGroundTruthAndChoosesThePlaneOfMotion) {
  const Trajectory gt = Circle();
  const TrajectoryPictures pictures =
      RenderTrajectoryPictures({{"est", Moved(gt, 0.0)}}, NamedTrajectory{"gt", gt}, {});
  ASSERT_EQ(pictures.ate.size(), 1u);
  EXPECT_LT(pictures.ate[0].error.rmse, 1e-9);         // Found the rigid transform.
  EXPECT_EQ(pictures.top_axes, std::make_pair(0, 1));  // x-y: the circle's plane.
  EXPECT_EQ(pictures.front_axes, std::make_pair(0, 2));
  EXPECT_EQ(pictures.side_axes, std::make_pair(1, 2));
  for (const cv::Mat* image : {&pictures.top, &pictures.side, &pictures.front, &pictures.error}) {
    ASSERT_EQ(image->size(), cv::Size(1000, 800));
    EXPECT_GT(NonBackground(*image), 5000);
  }
}

TEST(TrajectoryPicture, ErrorIsColouredWhereItIs) {
  const Trajectory gt = Circle();
  const TrajectoryPictures pictures =
      RenderTrajectoryPictures({{"est", Moved(gt, 0.10)}}, NamedTrajectory{"gt", gt}, {});
  // Where the estimate is off by ~10 cm (t in [4, 5) s, at angle 4..5 rad of
  // the circle) the path is drawn in the hot end of the colormap (red);
  // elsewhere in the cold end. Check the red share of the top view grew.
  int red = 0;
  for (int y = 0; y < pictures.top.rows; ++y)
    for (int x = 0; x < pictures.top.cols; ++x) {
      const cv::Vec3b p = pictures.top.at<cv::Vec3b>(y, x);
      if (p[2] > 150 && p[1] < 90 && p[0] < 60) ++red;
    }
  EXPECT_GT(red, 100);
  EXPECT_GT(pictures.ate[0].error.max, 0.05);
}

TEST(TrajectoryPicture, KeyFrameTrajectoriesAndNoGroundTruth) {
  Trajectory keyframes;
  const Trajectory gt = Circle();
  for (size_t i = 0; i < gt.size(); i += 15) keyframes.push_back(gt[i]);  // 2 Hz.
  const TrajectoryPictures pictures = RenderTrajectoryPictures(
      {{"KeyFrameTrajectory.txt", keyframes}, {"all", gt}}, std::nullopt, {});
  EXPECT_TRUE(pictures.ate.empty());
  EXPECT_TRUE(pictures.error.empty());
  EXPECT_GT(NonBackground(pictures.top), 5000);
}

TEST(TrajectoryPicture, Errors) {
  const Trajectory gt = Circle();
  EXPECT_THROW(RenderTrajectoryPictures({}, std::nullopt, {}), UsageError);
  Trajectory late = gt;
  for (StampedPose& p : late) p.timestamp += 1000;
  EXPECT_THROW(RenderTrajectoryPictures({{"late", late}}, NamedTrajectory{"gt", gt}, {}),
               DataError);
  TrajectoryPictureOptions options;
  options.height_px = 10;
  EXPECT_THROW(RenderTrajectoryPictures({{"est", gt}}, std::nullopt, options), UsageError);
}

// Found in review (issue 36): positions near 1e20 hung `rrslam-render
// trajectory` in the grid loop (a step below their precision). Such an axis
// now gets no grid, and the pictures are drawn.
TEST(TrajectoryPicture, CoordinatesNear1e20DrawWithoutHanging) {
  for (const double offset : {1e20, 1e300}) {
    Trajectory far = Circle();
    for (StampedPose& p : far) p.T_world_cam.translation += Eigen::Vector3d(offset, offset, 0);
    const TrajectoryPictures pictures = RenderTrajectoryPictures({{"far", far}}, std::nullopt, {});
    EXPECT_FALSE(pictures.top.empty()) << offset;
    EXPECT_TRUE(pictures.error.empty()) << offset;
    const TrajectoryPictures with_gt =
        RenderTrajectoryPictures({{"far", far}}, NamedTrajectory{"gt", far}, {});
    EXPECT_FALSE(with_gt.error.empty()) << offset;
  }
}

}  // namespace
}  // namespace rrslam
