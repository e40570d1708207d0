// Reprojection residuals of the RGB-D model for Ceres, with analytic
// Jacobians.
//
// A camera pose T_cam_world is one 7-double parameter block
//   [qx, qy, qz, qw, tx, ty, tz]  (Eigen quaternion coefficient order)
// on the manifold PoseManifold() (unit quaternion x R^3; rotation updates
// multiply on the left). A point is a 3-double block in world coordinates.
//
// Residuals are whitened by the keypoint's pyramid level:
//   r = (observed - projected) / sigma,  sigma = scale_factor^octave,
// so that |r|^2 is the chi-square statistic ORB-SLAM2 thresholds (5.991 for
// 2 dof, 7.815 for 3 dof). A "stereo" residual adds a third row for the
// depth of a keypoint with depth, observed as the virtual right coordinate
// u_R = u - bf / z:
//   - inv_sigma_disparity = 0 (ORB-SLAM2): (u_R - projected u_R) / sigma;
//   - inv_sigma_disparity > 0: the disparity d = u - u_R = bf / z,
//     (d - bf / projected z) * inv_sigma_disparity, so that depth is weighted
//     by the sensor's depth noise instead of the keypoint's pixel noise.
// Both give SensorModel::StereoChi2 as |r|^2.
#pragma once

#include <ceres/ceres.h>
#include <ceres/product_manifold.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "stages/track/data/sensor_model.h"

namespace rrslam {

// Pinhole intrinsics and the virtual baseline, copied into each residual.
struct ProjectionParameters {
  double fx, fy, cx, cy, bf;
  double inv_sigma_disparity = 0;  // 1 / SensorModel::disparity_sigma; 0 = ORB-SLAM2's u_R row.
};

// The residuals' view of a sensor.
inline ProjectionParameters ProjectionParametersOf(const SensorModel& sensor) {
  return {sensor.fx, sensor.fy, sensor.cx,
          sensor.cy, sensor.bf, sensor.disparity_sigma > 0 ? 1.0 / sensor.disparity_sigma : 0.0};
}

using PoseManifoldType =
    ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>;
// One shared instance (stateless, thread-safe). Problems must not own it:
// use Problem::Options::manifold_ownership = DO_NOT_TAKE_OWNERSHIP.
ceres::Manifold* PoseManifold();

namespace internal {

inline Eigen::Matrix3d SkewOf(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// Evaluates the whitened residual of dimension N (2: u, v; 3: u, v, u_R) and,
// when requested, its Jacobians with respect to the pose block (N x 7,
// row-major) and the point (N x 3, row-major). Returns false when the point
// is not in front of the camera.
template <int N>
bool EvaluateReprojection(const ProjectionParameters& k, const double* observed, double inv_sigma,
                          const double* pose, const double* point, double* residuals,
                          double* jacobian_pose, double* jacobian_point) {
  const Eigen::Map<const Eigen::Quaterniond> q(pose);
  const Eigen::Map<const Eigen::Vector3d> t(pose + 4);
  const Eigen::Map<const Eigen::Vector3d> p(point);
  const Eigen::Matrix3d R = q.toRotationMatrix();
  const Eigen::Vector3d pc = R * p + t;
  if (pc.z() <= 1e-9) return false;
  const double inv_z = 1.0 / pc.z();
  const double u = k.fx * pc.x() * inv_z + k.cx;
  const double v = k.fy * pc.y() * inv_z + k.cy;
  residuals[0] = (observed[0] - u) * inv_sigma;
  residuals[1] = (observed[1] - v) * inv_sigma;
  if constexpr (N == 3) {
    residuals[2] = k.inv_sigma_disparity > 0
                       ? (observed[0] - observed[2] - k.bf * inv_z) * k.inv_sigma_disparity
                       : (observed[2] - (u - k.bf * inv_z)) * inv_sigma;
  }
  if (jacobian_pose == nullptr && jacobian_point == nullptr) return true;

  // d residual / d point_cam = -weight * d prediction / d point_cam.
  Eigen::Matrix<double, N, 3> J;
  const double inv_z2 = inv_z * inv_z;
  J(0, 0) = k.fx * inv_z;
  J(0, 1) = 0;
  J(0, 2) = -k.fx * pc.x() * inv_z2;
  J(1, 0) = 0;
  J(1, 1) = k.fy * inv_z;
  J(1, 2) = -k.fy * pc.y() * inv_z2;
  J.template topRows<2>() *= -inv_sigma;
  if constexpr (N == 3) {
    if (k.inv_sigma_disparity > 0) {  // Prediction bf / z.
      J(2, 0) = 0;
      J(2, 1) = 0;
      J(2, 2) = k.bf * inv_z2 * k.inv_sigma_disparity;
    } else {  // Prediction u - bf / z.
      J(2, 0) = J(0, 0);
      J(2, 1) = 0;
      J(2, 2) = J(0, 2) - k.bf * inv_z2 * inv_sigma;
    }
  }

  if (jacobian_pose != nullptr) {
    // point_cam = R(q) p + t with R(q) p = p + 2 w (v x p) + 2 v x (v x p)
    // for the unit quaternion q = (v, w); its derivatives in the ambient
    // coordinates (exact on the unit sphere, which is all the manifold's
    // tangent directions see).
    const Eigen::Vector3d vq(q.x(), q.y(), q.z());
    const double w = q.w();
    Eigen::Matrix<double, 3, 4> dpc_dq;
    dpc_dq.leftCols<3>() = 2.0 * (-w * SkewOf(p) + vq.dot(p) * Eigen::Matrix3d::Identity() +
                                  vq * p.transpose() - 2.0 * p * vq.transpose());
    dpc_dq.col(3) = 2.0 * vq.cross(p);
    Eigen::Map<Eigen::Matrix<double, N, 7, Eigen::RowMajor>> Jp(jacobian_pose);
    Jp.template leftCols<4>() = J * dpc_dq;
    Jp.template rightCols<3>() = J;
  }
  if (jacobian_point != nullptr) {
    Eigen::Map<Eigen::Matrix<double, N, 3, Eigen::RowMajor>> Jx(jacobian_point);
    Jx = J * R;
  }
  return true;
}

}  // namespace internal

// Residual of an observation of a point held fixed (pose-only optimization).
template <int N>
class PoseOnlyReprojectionError final : public ceres::SizedCostFunction<N, 7> {
 public:
  PoseOnlyReprojectionError(const ProjectionParameters& k,
                            const Eigen::Matrix<double, N, 1>& observed, double inv_sigma,
                            const Eigen::Vector3d& point_world)
      : k_(k), observed_(observed), inv_sigma_(inv_sigma), point_(point_world) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    return internal::EvaluateReprojection<N>(
        k_, observed_.data(), inv_sigma_, parameters[0], point_.data(), residuals,
        jacobians != nullptr ? jacobians[0] : nullptr, nullptr);
  }

 private:
  ProjectionParameters k_;
  Eigen::Matrix<double, N, 1> observed_;
  double inv_sigma_;
  Eigen::Vector3d point_;
};

// Residual of an observation in bundle adjustment (pose and point blocks).
template <int N>
class ReprojectionError final : public ceres::SizedCostFunction<N, 7, 3> {
 public:
  ReprojectionError(const ProjectionParameters& k, const Eigen::Matrix<double, N, 1>& observed,
                    double inv_sigma)
      : k_(k), observed_(observed), inv_sigma_(inv_sigma) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    return internal::EvaluateReprojection<N>(k_, observed_.data(), inv_sigma_, parameters[0],
                                             parameters[1], residuals,
                                             jacobians != nullptr ? jacobians[0] : nullptr,
                                             jacobians != nullptr ? jacobians[1] : nullptr);
  }

 private:
  ProjectionParameters k_;
  Eigen::Matrix<double, N, 1> observed_;
  double inv_sigma_;
};

}  // namespace rrslam
