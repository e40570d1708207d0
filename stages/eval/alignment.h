// Closed-form rigid alignment of two corresponding point sets (Horn 1987).
#pragma once

#include <Eigen/Core>

namespace rrslam {

// The rigid transform (rotation R and translation t, no scale) that minimizes
// sum_i |R model_i + t - data_i|^2 over corresponding columns of `model` and
// `data` (3 x n each, same n >= 1), computed as TUM's evaluate_ate.py does:
// both sets are centred on their centroids, the 3x3 correlation
// H = sum_i (data_i - mean_data)(model_i - mean_model)^T is decomposed as
// H = U S V^T, and R = U diag(1, 1, d) V^T with d = -1 when det(U) det(V) < 0
// (so R is a rotation, never a reflection); t = mean_data - R mean_model.
// The rotation is unique when the centred points span at least a plane; for
// collinear points the rotation about their line is arbitrary, which leaves
// every aligned point and error unchanged.
struct RigidAlignment {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Eigen::Vector3d operator*(const Eigen::Vector3d& point) const {
    return rotation * point + translation;
  }
};

RigidAlignment AlignRigid(const Eigen::Matrix3Xd& model, const Eigen::Matrix3Xd& data);

}  // namespace rrslam
