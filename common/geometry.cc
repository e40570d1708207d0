#include "common/geometry.h"

#include <cmath>

namespace rrslam {

Rigid3d Rigid3d::FromMatrix(const Eigen::Matrix<double, 3, 4>& matrix) {
  Eigen::Quaterniond q(Eigen::Matrix3d(matrix.leftCols<3>()));
  return Rigid3d(q.normalized(), matrix.col(3));
}

Eigen::Matrix<double, 3, 4> Rigid3d::ToMatrix3x4() const {
  Eigen::Matrix<double, 3, 4> m;
  m.leftCols<3>() = RotationMatrix();
  m.col(3) = translation;
  return m;
}

Eigen::Matrix4d Rigid3d::ToMatrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topRows<3>() = ToMatrix3x4();
  return m;
}

Rigid3d Rigid3d::Inverse() const {
  const Eigen::Quaterniond inverse = rotation.conjugate();
  return Rigid3d(inverse, -(inverse * translation));
}

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

Eigen::Quaterniond ExpSO3(const Eigen::Vector3d& rotation_vector) {
  const double angle = rotation_vector.norm();
  if (angle < 1e-10) {
    // First-order expansion keeps the map smooth at zero.
    return Eigen::Quaterniond(1.0, 0.5 * rotation_vector.x(), 0.5 * rotation_vector.y(),
                              0.5 * rotation_vector.z())
        .normalized();
  }
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, rotation_vector / angle));
}

Eigen::Vector3d LogSO3(const Eigen::Quaterniond& rotation) {
  const Eigen::Quaterniond q = CanonicalQuaternion(rotation);
  const double sin_half = q.vec().norm();
  if (sin_half < 1e-10) return 2.0 * q.vec();
  const double angle = 2.0 * std::atan2(sin_half, q.w());
  return q.vec() * (angle / sin_half);
}

double RotationAngle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return LogSO3(a.conjugate() * b).norm();
}

Eigen::Quaterniond CanonicalQuaternion(const Eigen::Quaterniond& q) {
  Eigen::Quaterniond n = q.normalized();
  if (n.w() < 0) n.coeffs() = -n.coeffs();
  return n;
}

Rigid3d Interpolate(const Rigid3d& a, const Rigid3d& b, double t) {
  return Rigid3d(a.rotation.slerp(t, b.rotation).normalized(),
                 (1.0 - t) * a.translation + t * b.translation);
}

}  // namespace rrslam
