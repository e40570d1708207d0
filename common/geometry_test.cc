#include "common/geometry.h"

#include <gtest/gtest.h>

namespace rrslam {
namespace {

TEST(Rigid3d, InverseComposesToIdentity) {
  const Rigid3d T(ExpSO3({0.1, -0.4, 0.7}), {1.0, 2.0, -3.0});
  const Rigid3d I = T * T.Inverse();
  EXPECT_LT(RotationAngle(I.rotation, Eigen::Quaterniond::Identity()), 1e-12);
  EXPECT_LT(I.translation.norm(), 1e-12);
}

TEST(Rigid3d, MatchesMatrixProduct) {
  const Rigid3d a(ExpSO3({0.3, 0.2, -0.1}), {0.5, 0.0, 1.0});
  const Rigid3d b(ExpSO3({-0.2, 0.9, 0.4}), {-1.0, 2.0, 0.3});
  const Eigen::Vector3d p(0.7, -0.2, 2.5);
  EXPECT_LT(((a * b) * p - (a.ToMatrix() * b.ToMatrix() * p.homogeneous()).head<3>()).norm(),
            1e-12);
  EXPECT_LT((Rigid3d::FromMatrix(a.ToMatrix()) * p - a * p).norm(), 1e-12);
}

TEST(SO3, ExpLogRoundTrip) {
  for (const Eigen::Vector3d& w :
       {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1e-12, 0, 0), Eigen::Vector3d(0.3, -0.2, 0.1),
        Eigen::Vector3d(0, 3.0, 0), Eigen::Vector3d(-1.5, 1.5, 1.0)}) {
    EXPECT_LT((LogSO3(ExpSO3(w)) - w).norm(), 1e-9) << w.transpose();
  }
}

TEST(SO3, RotationAngleIsSymmetricAndSignFree) {
  const Eigen::Quaterniond a = ExpSO3({0.0, 0.0, 0.5});
  Eigen::Quaterniond b = ExpSO3({0.0, 0.0, 0.2});
  EXPECT_NEAR(RotationAngle(a, b), 0.3, 1e-12);
  b.coeffs() = -b.coeffs();
  EXPECT_NEAR(RotationAngle(b, a), 0.3, 1e-12);
}

TEST(Rigid3d, InterpolateEndsAndMiddle) {
  const Rigid3d a(ExpSO3({0, 0, 0}), {0, 0, 0});
  const Rigid3d b(ExpSO3({0, 0, 1.0}), {2, 0, 0});
  const Rigid3d m = Interpolate(a, b, 0.5);
  EXPECT_NEAR(RotationAngle(m.rotation, ExpSO3({0, 0, 0.5})), 0, 1e-12);
  EXPECT_NEAR(m.translation.x(), 1.0, 1e-12);
}

TEST(Skew, IsCrossProduct) {
  const Eigen::Vector3d v(1, 2, 3), w(-4, 0.5, 2);
  EXPECT_LT((Skew(v) * w - v.cross(w)).norm(), 1e-12);
}

}  // namespace
}  // namespace rrslam
