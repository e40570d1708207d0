// Rigid transforms and rotation helpers on Eigen.
//
// Naming: a transform is named by the frames it maps between, T_to_from.
// `T_cam_world` maps a point in world coordinates into the camera frame
// (point_cam = T_cam_world * point_world); its inverse `T_world_cam` is the
// camera pose (camera centre = T_world_cam.translation). Units are metres and
// radians unless a name says otherwise (`_deg`).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace rrslam {

// A rigid transform x -> R x + t, stored as a unit quaternion and a translation.
struct Rigid3d {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Rigid3d() = default;
  Rigid3d(const Eigen::Quaterniond& q, const Eigen::Vector3d& t) : rotation(q), translation(t) {}

  static Rigid3d Identity() { return Rigid3d(); }
  // From a 3x4 or 4x4 matrix [R | t]; R is re-orthonormalized through the quaternion.
  static Rigid3d FromMatrix(const Eigen::Matrix<double, 3, 4>& matrix);
  static Rigid3d FromMatrix(const Eigen::Matrix4d& matrix) {
    return FromMatrix(Eigen::Matrix<double, 3, 4>(matrix.topRows<3>()));
  }

  Eigen::Matrix3d RotationMatrix() const { return rotation.toRotationMatrix(); }
  Eigen::Matrix<double, 3, 4> ToMatrix3x4() const;
  Eigen::Matrix4d ToMatrix() const;

  Rigid3d Inverse() const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& point) const {
    return rotation * point + translation;
  }
  Rigid3d operator*(const Rigid3d& other) const {
    return Rigid3d((rotation * other.rotation).normalized(),
                   rotation * other.translation + translation);
  }
};

// The 3x3 matrix [v]x with [v]x w = v x w.
Eigen::Matrix3d Skew(const Eigen::Vector3d& v);

// Rotation vector (axis * angle, radians) to quaternion and back (SO(3) exp/log).
Eigen::Quaterniond ExpSO3(const Eigen::Vector3d& rotation_vector);
Eigen::Vector3d LogSO3(const Eigen::Quaterniond& rotation);

// Angle of the relative rotation between a and b, in radians, in [0, pi].
double RotationAngle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b);

// The unit quaternion with non-negative w (q and -q are the same rotation).
Eigen::Quaterniond CanonicalQuaternion(const Eigen::Quaterniond& q);

// Interpolates between two transforms: slerp on rotation, linear on translation.
// t = 0 gives a, t = 1 gives b.
Rigid3d Interpolate(const Rigid3d& a, const Rigid3d& b, double t);

}  // namespace rrslam
