#include "stages/eval/alignment.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <stdexcept>

#include "common/geometry.h"

namespace rrslam {
namespace {

Eigen::Matrix3Xd Transform(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                           const Eigen::Matrix3Xd& points) {
  return (R * points).colwise() + t;
}

TEST(AlignRigid, RecoversAnExactRigidTransform) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0, 1);
  Eigen::Matrix3Xd data(3, 20);
  for (int c = 0; c < data.cols(); ++c) data.col(c) = Eigen::Vector3d(n(rng), n(rng), n(rng));
  const Eigen::Matrix3d R = ExpSO3(Eigen::Vector3d(0.4, -1.1, 2.0)).toRotationMatrix();
  const Eigen::Vector3d t(3, -2, 0.5);
  // model = R^T (data - t), so the alignment model -> data is (R, t).
  const Eigen::Matrix3Xd model = R.transpose() * (data.colwise() - t);
  const Alignment a = AlignRigid(model, data);
  EXPECT_LT((a.rotation - R).norm(), 1e-12);
  EXPECT_LT((a.translation - t).norm(), 1e-12);
  EXPECT_NEAR(a.rotation.determinant(), 1.0, 1e-12);
}

TEST(AlignRigid, TetrahedronWithSymmetricDeformationHasIdentityOptimum) {
  // Centred tetrahedron P (sum P P^T = 4 I). Model = R0 (P + S P) + t0 with S
  // symmetric: the correlation 4 (I + S) is symmetric positive definite, so the
  // optimal alignment undoes exactly (R0, t0) and leaves the errors |S P_i|.
  Eigen::Matrix3Xd P(3, 4);
  P << 1, 1, -1, -1,  //
      1, -1, 1, -1,   //
      1, -1, -1, 1;
  Eigen::Matrix3d S;
  S << 0.1, 0.03, 0,  //
      0.03, 0.05, 0,  //
      0, 0, 0.02;
  const Eigen::Matrix3d R0 = ExpSO3(Eigen::Vector3d(0.3, 0.2, -0.9)).toRotationMatrix();
  const Eigen::Vector3d t0(-1, 4, 2);
  const Eigen::Matrix3Xd model = Transform(R0, t0, P + S * P);
  const Alignment a = AlignRigid(model, P);
  EXPECT_LT((a.rotation - R0.transpose()).norm(), 1e-12);
  EXPECT_LT((a.translation + R0.transpose() * t0).norm(), 1e-12);
  for (int c = 0; c < 4; ++c) {
    EXPECT_NEAR((a * Eigen::Vector3d(model.col(c)) - P.col(c)).norm(), (S * P.col(c)).norm(),
                1e-12);
  }
}

TEST(AlignRigid, AgreesWithEigenUmeyamaWithoutScaleOnNoisyData) {
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0, 1), noise(0, 0.05);
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::Matrix3Xd data(3, 50);
    for (int c = 0; c < data.cols(); ++c)
      data.col(c) = Eigen::Vector3d(n(rng), n(rng), 0.3 * n(rng));
    const Eigen::Matrix3d R = ExpSO3(Eigen::Vector3d(n(rng), n(rng), n(rng))).toRotationMatrix();
    Eigen::Matrix3Xd model = Transform(R, Eigen::Vector3d(n(rng), n(rng), n(rng)), data);
    for (int c = 0; c < model.cols(); ++c)
      model.col(c) += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    const Alignment a = AlignRigid(model, data);
    const Eigen::Matrix4d expected = Eigen::umeyama(model, data, /*with_scaling=*/false);
    EXPECT_LT((a.rotation - expected.topLeftCorner<3, 3>()).norm(), 1e-9) << trial;
    EXPECT_LT((a.translation - expected.topRightCorner<3, 1>()).norm(), 1e-9) << trial;
  }
}

TEST(AlignRigid, MirroredPointsGiveARotationNotAReflection) {
  // data is model mirrored in z: the best proper rotation is the identity
  // (a reflection would fit exactly), as the det(U) det(V) < 0 fix ensures.
  Eigen::Matrix3Xd model(3, 4);
  model << 1, -1, 0, 0,  //
      0, 0, 2, -2,       //
      0.5, 0.5, -0.5, -0.5;
  Eigen::Matrix3Xd data = model;
  data.row(2) *= -1;
  const Alignment a = AlignRigid(model, data);
  EXPECT_NEAR(a.rotation.determinant(), 1.0, 1e-12);
  EXPECT_LT((a.rotation - Eigen::Matrix3d::Identity()).norm(), 1e-12);
}

TEST(AlignRigid, PlanarPointsHaveAUniqueRotation) {
  Eigen::Matrix3Xd data(3, 5);
  data << 0, 1, 2, 0, 1,  //
      0, 0, 1, 2, 3,      //
      0, 0, 0, 0, 0;
  const Eigen::Matrix3d R = ExpSO3(Eigen::Vector3d(1.0, 0.5, -0.2)).toRotationMatrix();
  const Eigen::Matrix3Xd model = R.transpose() * data;
  const Alignment a = AlignRigid(model, data);
  EXPECT_LT((a.rotation - R).norm(), 1e-10);
}

TEST(AlignSimilarity, RecoversAnExactSimilarity) {
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, 1);
  Eigen::Matrix3Xd model(3, 30);
  for (int c = 0; c < model.cols(); ++c) model.col(c) = Eigen::Vector3d(n(rng), n(rng), n(rng));
  const Eigen::Matrix3d R = ExpSO3(Eigen::Vector3d(-0.7, 0.2, 1.3)).toRotationMatrix();
  const Eigen::Vector3d t(0.5, 1, -4);
  const double s = 1.04;
  const Eigen::Matrix3Xd data = Transform(s * R, t, model);
  const Alignment a = AlignSimilarity(model, data);
  EXPECT_NEAR(a.scale, s, 1e-12);
  EXPECT_LT((a.rotation - R).norm(), 1e-12);
  EXPECT_LT((a.translation - t).norm(), 1e-12);
  for (int c = 0; c < model.cols(); ++c) {
    EXPECT_LT((a * Eigen::Vector3d(model.col(c)) - data.col(c)).norm(), 1e-12);
  }
}

TEST(AlignSimilarity, AgreesWithEigenUmeyamaWithScaleOnNoisyData) {
  std::mt19937 rng(13);
  std::normal_distribution<double> n(0, 1), noise(0, 0.05);
  std::uniform_real_distribution<double> scale(0.5, 2.0);
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::Matrix3Xd data(3, 40);
    for (int c = 0; c < data.cols(); ++c)
      data.col(c) = Eigen::Vector3d(n(rng), 0.5 * n(rng), n(rng));
    const Eigen::Matrix3d R = ExpSO3(Eigen::Vector3d(n(rng), n(rng), n(rng))).toRotationMatrix();
    Eigen::Matrix3Xd model =
        Transform(scale(rng) * R, Eigen::Vector3d(n(rng), n(rng), n(rng)), data);
    for (int c = 0; c < model.cols(); ++c)
      model.col(c) += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    const Alignment a = AlignSimilarity(model, data);
    const Eigen::Matrix4d expected = Eigen::umeyama(model, data, /*with_scaling=*/true);
    const double expected_scale = expected.topLeftCorner<3, 3>().determinant() > 0
                                      ? std::cbrt(expected.topLeftCorner<3, 3>().determinant())
                                      : 0.0;
    EXPECT_NEAR(a.scale, expected_scale, 1e-9) << trial;
    EXPECT_LT((a.scale * a.rotation - expected.topLeftCorner<3, 3>()).norm(), 1e-9) << trial;
    EXPECT_LT((a.translation - expected.topRightCorner<3, 1>()).norm(), 1e-9) << trial;
  }
}

TEST(AlignSimilarity, IdenticalModelPointsAreRejected) {
  const Eigen::Matrix3Xd model = Eigen::Vector3d(1, 2, 3).replicate(1, 4);
  Eigen::Matrix3Xd data(3, 4);
  data << 0, 1, 0, 1,  //
      0, 0, 1, 1,      //
      0, 0, 0, 0;
  EXPECT_THROW(AlignSimilarity(model, data), std::invalid_argument);
}

}  // namespace
}  // namespace rrslam
