// Pinhole camera with OpenCV's radial-tangential distortion (k1 k2 p1 p2 k3).
//
// Frames and units: `point_cam` is in the camera frame (x right, y down,
// z forward, metres). Pixels are (u, v) with (0, 0) the centre of the top-left
// pixel. "Distorted" pixels are where points appear in the real image;
// "ideal" (undistorted) pixels are where a distortion-free camera with the
// same fx, fy, cx, cy would see them. SLAM works on ideal pixels: keypoints
// are undistorted once after extraction. Immutable; thread-safe.
#pragma once

#include <Eigen/Core>

namespace rrslam {

// Coefficients of OpenCV's plumb-bob model on normalized coordinates (x, y):
//   r2 = x^2 + y^2,  radial = 1 + k1 r2 + k2 r2^2 + k3 r2^3
//   x_d = x radial + 2 p1 x y + p2 (r2 + 2 x^2)
//   y_d = y radial + p1 (r2 + 2 y^2) + 2 p2 x y
struct Distortion {
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;
  bool IsZero() const { return k1 == 0 && k2 == 0 && p1 == 0 && p2 == 0 && k3 == 0; }
};

// Axis-aligned bounds of the image in ideal pixels (ORB-SLAM2's mnMinX..mnMaxY).
struct ImageBounds {
  double min_x = 0, max_x = 0, min_y = 0, max_y = 0;
  bool Contains(double u, double v) const {
    return u >= min_x && u < max_x && v >= min_y && v < max_y;
  }
};

class PinholeCamera {
 public:
  PinholeCamera() = default;
  PinholeCamera(double fx, double fy, double cx, double cy, int width, int height,
                const Distortion& distortion = {});

  double fx() const { return fx_; }
  double fy() const { return fy_; }
  double cx() const { return cx_; }
  double cy() const { return cy_; }
  int width() const { return width_; }
  int height() const { return height_; }
  const Distortion& distortion() const { return distortion_; }
  Eigen::Matrix3d K() const;

  // Normalized coordinates -> distorted normalized coordinates.
  Eigen::Vector2d Distort(const Eigen::Vector2d& normalized) const;
  // Inverse of Distort by Gauss-Newton (converges to < 1e-12 in a few steps for
  // realistic lenses); returns the input unchanged when there is no distortion.
  Eigen::Vector2d Undistort(const Eigen::Vector2d& distorted_normalized) const;

  // Real image pixel -> ideal pixel, and back.
  Eigen::Vector2d UndistortPixel(const Eigen::Vector2d& pixel) const;
  Eigen::Vector2d DistortPixel(const Eigen::Vector2d& ideal_pixel) const;

  // point_cam -> ideal pixel (no distortion). Requires point_cam.z() > 0.
  Eigen::Vector2d Project(const Eigen::Vector3d& point_cam) const {
    return {fx_ * point_cam.x() / point_cam.z() + cx_, fy_ * point_cam.y() / point_cam.z() + cy_};
  }
  // point_cam -> real image pixel (with distortion).
  Eigen::Vector2d ProjectDistorted(const Eigen::Vector3d& point_cam) const;
  // Ideal pixel and depth (metres along z) -> point_cam.
  Eigen::Vector3d Unproject(const Eigen::Vector2d& ideal_pixel, double depth) const {
    return {(ideal_pixel.x() - cx_) * depth / fx_, (ideal_pixel.y() - cy_) * depth / fy_, depth};
  }

  // Bounds of the undistorted image corners (the whole image when undistorted).
  ImageBounds UndistortedBounds() const;

 private:
  double fx_ = 1, fy_ = 1, cx_ = 0, cy_ = 0;
  int width_ = 0, height_ = 0;
  Distortion distortion_;
};

}  // namespace rrslam
