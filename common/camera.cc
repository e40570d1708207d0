#include "common/camera.h"

#include <Eigen/LU>
#include <algorithm>

namespace rrslam {

PinholeCamera::PinholeCamera(double fx, double fy, double cx, double cy, int width, int height,
                             const Distortion& distortion)
    : fx_(fx), fy_(fy), cx_(cx), cy_(cy), width_(width), height_(height), distortion_(distortion) {}

Eigen::Matrix3d PinholeCamera::K() const {
  Eigen::Matrix3d k;
  k << fx_, 0, cx_, 0, fy_, cy_, 0, 0, 1;
  return k;
}

Eigen::Vector2d PinholeCamera::Distort(const Eigen::Vector2d& n) const {
  const Distortion& d = distortion_;
  const double x = n.x(), y = n.y();
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (d.k1 + r2 * (d.k2 + r2 * d.k3));
  return {x * radial + 2 * d.p1 * x * y + d.p2 * (r2 + 2 * x * x),
          y * radial + d.p1 * (r2 + 2 * y * y) + 2 * d.p2 * x * y};
}

Eigen::Vector2d PinholeCamera::Undistort(const Eigen::Vector2d& distorted) const {
  if (distortion_.IsZero()) return distorted;
  const Distortion& d = distortion_;
  Eigen::Vector2d n = distorted;
  for (int iteration = 0; iteration < 20; ++iteration) {
    const Eigen::Vector2d residual = Distort(n) - distorted;
    if (residual.squaredNorm() < 1e-26) break;
    // Jacobian of Distort at n.
    const double x = n.x(), y = n.y();
    const double r2 = x * x + y * y;
    const double radial = 1 + r2 * (d.k1 + r2 * (d.k2 + r2 * d.k3));
    const double dradial_dr2 = d.k1 + r2 * (2 * d.k2 + 3 * r2 * d.k3);
    Eigen::Matrix2d J;
    J(0, 0) = radial + 2 * x * x * dradial_dr2 + 2 * d.p1 * y + 6 * d.p2 * x;
    J(0, 1) = 2 * x * y * dradial_dr2 + 2 * d.p1 * x + 2 * d.p2 * y;
    J(1, 0) = 2 * x * y * dradial_dr2 + 2 * d.p1 * x + 2 * d.p2 * y;
    J(1, 1) = radial + 2 * y * y * dradial_dr2 + 6 * d.p1 * y + 2 * d.p2 * x;
    n -= J.partialPivLu().solve(residual);
  }
  return n;
}

Eigen::Vector2d PinholeCamera::UndistortPixel(const Eigen::Vector2d& pixel) const {
  if (distortion_.IsZero()) return pixel;
  const Eigen::Vector2d n = Undistort({(pixel.x() - cx_) / fx_, (pixel.y() - cy_) / fy_});
  return {fx_ * n.x() + cx_, fy_ * n.y() + cy_};
}

Eigen::Vector2d PinholeCamera::DistortPixel(const Eigen::Vector2d& ideal_pixel) const {
  if (distortion_.IsZero()) return ideal_pixel;
  const Eigen::Vector2d n = Distort({(ideal_pixel.x() - cx_) / fx_, (ideal_pixel.y() - cy_) / fy_});
  return {fx_ * n.x() + cx_, fy_ * n.y() + cy_};
}

Eigen::Vector2d PinholeCamera::ProjectDistorted(const Eigen::Vector3d& point_cam) const {
  return DistortPixel(Project(point_cam));
}

ImageBounds PinholeCamera::UndistortedBounds() const {
  if (distortion_.IsZero()) return {0.0, double(width_), 0.0, double(height_)};
  const Eigen::Vector2d tl = UndistortPixel({0, 0});
  const Eigen::Vector2d tr = UndistortPixel({double(width_), 0});
  const Eigen::Vector2d bl = UndistortPixel({0, double(height_)});
  const Eigen::Vector2d br = UndistortPixel({double(width_), double(height_)});
  return {std::min(tl.x(), bl.x()), std::max(tr.x(), br.x()), std::min(tl.y(), tr.y()),
          std::max(bl.y(), br.y())};
}

}  // namespace rrslam
