#include "stages/eval/alignment.h"

#include <Eigen/LU>
#include <Eigen/SVD>
#include <cassert>
#include <stdexcept>

namespace rrslam {
namespace {

// Umeyama 1991, eq. 39-42; with_scale = false is Horn's rigid fit (scale 1).
Alignment Align(const Eigen::Matrix3Xd& model, const Eigen::Matrix3Xd& data, bool with_scale) {
  assert(model.cols() == data.cols() && model.cols() >= 1);
  const Eigen::Vector3d model_mean = model.rowwise().mean();
  const Eigen::Vector3d data_mean = data.rowwise().mean();
  const Eigen::Matrix3d correlation =
      (data.colwise() - data_mean) * (model.colwise() - model_mean).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(correlation,
                                              Eigen::ComputeFullU | Eigen::ComputeFullV);
  // Singular values are sorted in decreasing order, so flipping the last
  // column changes the fit least (Umeyama 1991, eq. 39-40).
  Eigen::Vector3d reflection_fix(1, 1, 1);
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) reflection_fix(2) = -1;
  Alignment alignment;
  alignment.rotation = svd.matrixU() * reflection_fix.asDiagonal() * svd.matrixV().transpose();
  if (with_scale) {
    const double model_spread = (model.colwise() - model_mean).squaredNorm();
    if (!(model_spread > 0)) {
      throw std::invalid_argument("AlignSimilarity: the model points are all equal");
    }
    alignment.scale = svd.singularValues().dot(reflection_fix) / model_spread;
  }
  alignment.translation = data_mean - alignment.scale * (alignment.rotation * model_mean);
  return alignment;
}

}  // namespace

Alignment AlignRigid(const Eigen::Matrix3Xd& model, const Eigen::Matrix3Xd& data) {
  return Align(model, data, /*with_scale=*/false);
}

Alignment AlignSimilarity(const Eigen::Matrix3Xd& model, const Eigen::Matrix3Xd& data) {
  return Align(model, data, /*with_scale=*/true);
}

}  // namespace rrslam
