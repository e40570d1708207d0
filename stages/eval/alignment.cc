#include "stages/eval/alignment.h"

#include <Eigen/LU>
#include <Eigen/SVD>
#include <cassert>

namespace rrslam {

RigidAlignment AlignRigid(const Eigen::Matrix3Xd& model, const Eigen::Matrix3Xd& data) {
  assert(model.cols() == data.cols() && model.cols() >= 1);
  const Eigen::Vector3d model_mean = model.rowwise().mean();
  const Eigen::Vector3d data_mean = data.rowwise().mean();
  const Eigen::Matrix3d correlation =
      (data.colwise() - data_mean) * (model.colwise() - model_mean).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(correlation,
                                              Eigen::ComputeFullU | Eigen::ComputeFullV);
  // Singular values are sorted in decreasing order, so flipping the last
  // column changes the fit least (Umeyama 1991, eq. 39-40).
  Eigen::Matrix3d reflection_fix = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) reflection_fix(2, 2) = -1;
  RigidAlignment alignment;
  alignment.rotation = svd.matrixU() * reflection_fix * svd.matrixV().transpose();
  alignment.translation = data_mean - alignment.rotation * model_mean;
  return alignment;
}

}  // namespace rrslam
