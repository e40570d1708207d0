// Closed-form alignment of two corresponding point sets: rigid (Horn 1987, as
// TUM's evaluate_ate.py) or with scale (Umeyama 1991, as evo's
// --correct_scale).
#pragma once

#include <Eigen/Core>

namespace rrslam {

// x -> scale * rotation * x + translation.
struct Alignment {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  double scale = 1.0;

  Eigen::Vector3d operator*(const Eigen::Vector3d& point) const {
    return scale * (rotation * point) + translation;
  }
};

// The rigid transform (scale 1) that minimizes
// sum_i |R model_i + t - data_i|^2 over corresponding columns of `model` and
// `data` (3 x n each, same n >= 1), computed as TUM's evaluate_ate.py does:
// both sets are centred on their centroids, the 3x3 correlation
// H = sum_i (data_i - mean_data)(model_i - mean_model)^T is decomposed as
// H = U S V^T, and R = U diag(1, 1, d) V^T with d = -1 when det(U) det(V) < 0
// (so R is a rotation, never a reflection); t = mean_data - R mean_model.
// The rotation is unique when the centred points span at least a plane; for
// collinear points the rotation about their line is arbitrary, which leaves
// every aligned point and error unchanged.
Alignment AlignRigid(const Eigen::Matrix3Xd& model, const Eigen::Matrix3Xd& data);

// The similarity (rotation, translation and scale s > 0) that minimizes
// sum_i |s R model_i + t - data_i|^2: R as AlignRigid, and
// s = trace(diag(S) diag(1, 1, d)) / sum_i |model_i - mean_model|^2,
// t = mean_data - s R mean_model (Umeyama 1991, eq. 41-42). Needs model
// points that are not all equal (throws std::invalid_argument otherwise).
Alignment AlignSimilarity(const Eigen::Matrix3Xd& model, const Eigen::Matrix3Xd& data);

}  // namespace rrslam
