#include "common/camera.h"

#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>

namespace rrslam {
namespace {

// freiburg1 intrinsics and distortion (../shared/data/settings/tum1.yaml).
PinholeCamera Freiburg1() {
  return PinholeCamera(517.306408, 516.469215, 318.643040, 255.313989, 640, 480,
                       {0.262383, -0.953104, -0.005358, 0.002628, 1.163314});
}

TEST(PinholeCamera, DistortUndistortRoundTripOverImage) {
  const PinholeCamera camera = Freiburg1();
  double worst = 0;
  for (double u = 0; u <= 640; u += 16) {
    for (double v = 0; v <= 480; v += 16) {
      const Eigen::Vector2d ideal = camera.UndistortPixel({u, v});
      worst = std::max(worst, (camera.DistortPixel(ideal) - Eigen::Vector2d(u, v)).norm());
    }
  }
  EXPECT_LT(worst, 1e-6);
}

TEST(PinholeCamera, MatchesOpenCvProjectPoints) {
  const PinholeCamera camera = Freiburg1();
  cv::Mat K =
      (cv::Mat_<double>(3, 3) << camera.fx(), 0, camera.cx(), 0, camera.fy(), camera.cy(), 0, 0, 1);
  const Distortion& d = camera.distortion();
  cv::Mat dist = (cv::Mat_<double>(1, 5) << d.k1, d.k2, d.p1, d.p2, d.k3);
  std::vector<cv::Point3d> points = {{0.1, -0.2, 1.5}, {-0.6, 0.4, 2.0}, {0.5, 0.35, 1.0}};
  std::vector<cv::Point2d> projected;
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, dist, projected);
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d ours = camera.ProjectDistorted({points[i].x, points[i].y, points[i].z});
    EXPECT_NEAR(ours.x(), projected[i].x, 1e-9);
    EXPECT_NEAR(ours.y(), projected[i].y, 1e-9);
  }
}

TEST(PinholeCamera, UndistortAgreesWithOpenCvWhereItConverges) {
  const PinholeCamera camera = Freiburg1();
  cv::Mat K =
      (cv::Mat_<double>(3, 3) << camera.fx(), 0, camera.cx(), 0, camera.fy(), camera.cy(), 0, 0, 1);
  const Distortion& d = camera.distortion();
  cv::Mat dist = (cv::Mat_<double>(1, 5) << d.k1, d.k2, d.p1, d.p2, d.k3);
  std::vector<cv::Point2d> pixels = {{320, 240}, {200, 150}, {450, 330}}, out;
  cv::undistortPoints(
      pixels, out, K, dist, cv::noArray(), K,
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-12));
  for (size_t i = 0; i < pixels.size(); ++i) {
    const Eigen::Vector2d ours = camera.UndistortPixel({pixels[i].x, pixels[i].y});
    EXPECT_NEAR(ours.x(), out[i].x, 1e-4);
    EXPECT_NEAR(ours.y(), out[i].y, 1e-4);
  }
}

TEST(PinholeCamera, ProjectUnprojectRoundTrip) {
  const PinholeCamera camera(585, 585, 320, 240, 640, 480);
  const Eigen::Vector3d point_cam(0.3, -0.2, 2.5);
  const Eigen::Vector2d pixel = camera.Project(point_cam);
  EXPECT_LT((camera.Unproject(pixel, 2.5) - point_cam).norm(), 1e-12);
  EXPECT_EQ(camera.UndistortPixel(pixel), pixel);  // No distortion: identity.
}

TEST(PinholeCamera, UndistortedBounds) {
  const PinholeCamera plain(585, 585, 320, 240, 640, 480);
  const ImageBounds b = plain.UndistortedBounds();
  EXPECT_EQ(b.min_x, 0);
  EXPECT_EQ(b.max_x, 640);
  EXPECT_TRUE(b.Contains(639.5, 479.5));
  EXPECT_FALSE(b.Contains(640, 10));
  const PinholeCamera fr1 = Freiburg1();
  const ImageBounds d = fr1.UndistortedBounds();
  const Eigen::Vector2d tl = fr1.UndistortPixel({0, 0}), br = fr1.UndistortPixel({640, 480});
  const Eigen::Vector2d bl = fr1.UndistortPixel({0, 480}), tr = fr1.UndistortPixel({640, 0});
  EXPECT_DOUBLE_EQ(d.min_x, std::min(tl.x(), bl.x()));
  EXPECT_DOUBLE_EQ(d.max_x, std::max(tr.x(), br.x()));
  EXPECT_DOUBLE_EQ(d.min_y, std::min(tl.y(), tr.y()));
  EXPECT_DOUBLE_EQ(d.max_y, std::max(bl.y(), br.y()));
  EXPECT_NE(d.min_x, 0.0);  // freiburg1's distortion moves the corners.
}

}  // namespace
}  // namespace rrslam
