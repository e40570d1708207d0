// The residual of a pose-graph edge (OptimizePoseGraph, loop_optimizer.h)
// with analytic Jacobians. Poses are blocks of 7 (Eigen's quaternion x, y,
// z, w, then the translation) of T_cam_world, on PoseManifold(); the
// Jacobians are with respect to those 7 ambient coordinates, of the
// expressions the residual evaluates (Eigen's quaternion products and its
// quaternion-vector product): automatic differentiation's up to rounding
// (pose_graph_error_test.cc), at a third of its cost.
#pragma once

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "common/geometry.h"

namespace rrslam {
namespace internal {

// The 4 x 4 matrices of q -> p * q (Left(p)) and p -> p * q (Right(q)) on
// (x, y, z, w) coordinates.
inline Eigen::Matrix4d QuaternionLeft(const Eigen::Quaterniond& p) {
  Eigen::Matrix4d m;
  m << p.w(), -p.z(), p.y(), p.x(),  //
      p.z(), p.w(), -p.x(), p.y(),   //
      -p.y(), p.x(), p.w(), p.z(),   //
      -p.x(), -p.y(), -p.z(), p.w();
  return m;
}
inline Eigen::Matrix4d QuaternionRight(const Eigen::Quaterniond& q) {
  Eigen::Matrix4d m;
  m << q.w(), q.z(), -q.y(), q.x(),  //
      -q.z(), q.w(), q.x(), q.y(),   //
      q.y(), -q.x(), q.w(), q.z(),   //
      -q.x(), -q.y(), -q.z(), q.w();
  return m;
}

// d (q * v) / d (x, y, z, w) of Eigen's q * v = v + 2 w (u x v) + 2 u x (u x v),
// u the vector part of q.
inline Eigen::Matrix<double, 3, 4> RotatedVectorJacobian(const Eigen::Quaterniond& q,
                                                         const Eigen::Vector3d& v) {
  const Eigen::Vector3d u = q.vec();
  Eigen::Matrix3d v_cross;
  v_cross << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  Eigen::Matrix<double, 3, 4> d;
  d.leftCols<3>() = -2 * q.w() * v_cross + 2 * (u.dot(v) * Eigen::Matrix3d::Identity() +
                                                u * v.transpose() - 2 * v * u.transpose());
  d.col(3) = 2 * u.cross(v);
  return d;
}

}  // namespace internal

// r = (2 * vector part of q_e, t_e) for E = T_j_i * T_iw * T_jw^-1 (the
// quaternion's sign chosen with w >= 0), T_jw^-1 taken as (conj(q_j),
// -conj(q_j) t_j): zero when the poses agree with the measured T_j_i.
class PoseGraphEdgeCost final : public ceres::SizedCostFunction<6, 7, 7> {
 public:
  explicit PoseGraphEdgeCost(const Rigid3d& T_j_i) : T_j_i_(T_j_i) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const Eigen::Map<const Eigen::Quaterniond> q_i(parameters[0]);
    const Eigen::Map<const Eigen::Vector3d> t_i(parameters[0] + 4);
    const Eigen::Map<const Eigen::Quaterniond> q_j(parameters[1]);
    const Eigen::Map<const Eigen::Vector3d> t_j(parameters[1] + 4);
    const Eigen::Quaterniond& q_m = T_j_i_.rotation;
    const Eigen::Quaterniond q_a = q_i * q_j.conjugate();
    const Eigen::Vector3d t_a = t_i - q_a * t_j;
    const Eigen::Quaterniond q_e = q_m * q_a;
    const Eigen::Vector3d t_e = q_m * t_a + T_j_i_.translation;
    const double sign = q_e.w() < 0 ? -1.0 : 1.0;
    Eigen::Map<Eigen::Matrix<double, 6, 1>> r(residuals);
    r.head<3>() = 2 * sign * q_e.vec();
    r.tail<3>() = t_e;
    if (jacobians == nullptr) return true;

    // q_a = Right(conj q_j) q_i = Left(q_i) C q_j, C = diag(-1, -1, -1, 1);
    // q_e = Left(q_m) q_a; t_e = R_m (t_i - q_a * t_j) + t_m.
    const Eigen::Matrix3d R_m = q_m.toRotationMatrix();
    const Eigen::Matrix4d left_m = internal::QuaternionLeft(q_m);
    const Eigen::Matrix<double, 3, 4> dt_dqa = -R_m * internal::RotatedVectorJacobian(q_a, t_j);
    const Eigen::Vector4d conj(-1, -1, -1, 1);
    using Jacobian = Eigen::Matrix<double, 6, 7, Eigen::RowMajor>;
    if (jacobians[0] != nullptr) {
      Eigen::Map<Jacobian> J(jacobians[0]);
      const Eigen::Matrix4d dqa = internal::QuaternionRight(q_j.conjugate());
      J.block<3, 4>(0, 0) = 2 * sign * (left_m * dqa).topRows<3>();
      J.block<3, 3>(0, 4).setZero();
      J.block<3, 4>(3, 0) = dt_dqa * dqa;
      J.block<3, 3>(3, 4) = R_m;
    }
    if (jacobians[1] != nullptr) {
      Eigen::Map<Jacobian> J(jacobians[1]);
      const Eigen::Matrix4d dqa = internal::QuaternionLeft(q_i) * conj.asDiagonal();
      J.block<3, 4>(0, 0) = 2 * sign * (left_m * dqa).topRows<3>();
      J.block<3, 3>(0, 4).setZero();
      J.block<3, 4>(3, 0) = dt_dqa * dqa;
      // d (q_a * t_j) / d t_j: Eigen's formula is linear in t_j.
      const Eigen::Vector3d u = q_a.vec();
      Eigen::Matrix3d u_cross;
      u_cross << 0, -u.z(), u.y(), u.z(), 0, -u.x(), -u.y(), u.x(), 0;
      const Eigen::Matrix3d R_a =
          Eigen::Matrix3d::Identity() + 2 * q_a.w() * u_cross + 2 * u_cross * u_cross;
      J.block<3, 3>(3, 4) = -R_m * R_a;
    }
    return true;
  }

 private:
  Rigid3d T_j_i_;
};

}  // namespace rrslam
