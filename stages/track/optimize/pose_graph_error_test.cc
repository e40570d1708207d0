#include "stages/track/optimize/pose_graph_error.h"

#include <ceres/autodiff_cost_function.h>
#include <gtest/gtest.h>

#include <array>
#include <random>

#include "stages/track/optimize/optimizer.h"

namespace rrslam {
namespace {

// The residual as the automatic differentiation of earlier versions had it.
struct AutoDiffEdge {
  explicit AutoDiffEdge(const Rigid3d& T_j_i) : T_j_i(T_j_i) {}
  template <typename T>
  bool operator()(const T* pose_i, const T* pose_j, T* residuals) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q_i(pose_i);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_i(pose_i + 4);
    const Eigen::Map<const Eigen::Quaternion<T>> q_j(pose_j);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_j(pose_j + 4);
    const Eigen::Quaternion<T> q_a = q_i * q_j.conjugate();
    const Eigen::Matrix<T, 3, 1> t_a = t_i - q_a * t_j;
    const Eigen::Quaternion<T> q_e = T_j_i.rotation.cast<T>() * q_a;
    const Eigen::Matrix<T, 3, 1> t_e = T_j_i.rotation.cast<T>() * t_a + T_j_i.translation.cast<T>();
    const T sign = q_e.w() < T(0) ? T(-1) : T(1);
    for (int k = 0; k < 3; ++k) residuals[k] = T(2) * sign * q_e.vec()[k];
    for (int k = 0; k < 3; ++k) residuals[3 + k] = t_e[k];
    return true;
  }
  Rigid3d T_j_i;
};

Rigid3d RandomPose(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Quaterniond q = Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized();
  return Rigid3d(q, Eigen::Vector3d(n(rng), n(rng), n(rng)));
}

TEST(PoseGraphEdgeCostTest, MatchesAutomaticDifferentiation) {
  std::mt19937 rng(5);
  int negative_w = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const Rigid3d T_j_i = RandomPose(rng);
    std::array<double, 7> pose_i = ToPoseBlock(RandomPose(rng));
    std::array<double, 7> pose_j = ToPoseBlock(RandomPose(rng));
    const double* parameters[] = {pose_i.data(), pose_j.data()};
    double r_analytic[6], r_auto[6];
    double J_analytic[2][42], J_auto[2][42];
    double* j_analytic[] = {J_analytic[0], J_analytic[1]};
    double* j_auto[] = {J_auto[0], J_auto[1]};
    PoseGraphEdgeCost analytic(T_j_i);
    ceres::AutoDiffCostFunction<AutoDiffEdge, 6, 7, 7> automatic(new AutoDiffEdge(T_j_i));
    ASSERT_TRUE(analytic.Evaluate(parameters, r_analytic, j_analytic));
    ASSERT_TRUE(automatic.Evaluate(parameters, r_auto, j_auto));
    for (int k = 0; k < 6; ++k) EXPECT_NEAR(r_analytic[k], r_auto[k], 1e-12) << trial;
    for (int b = 0; b < 2; ++b) {
      for (int k = 0; k < 42; ++k) {
        EXPECT_NEAR(J_analytic[b][k], J_auto[b][k], 1e-10) << trial << " block " << b << " " << k;
      }
    }
    // Which sign the residual's quaternion took: both branches are tried.
    const Eigen::Quaterniond q_e =
        T_j_i.rotation * (Eigen::Map<const Eigen::Quaterniond>(pose_i.data()) *
                          Eigen::Map<const Eigen::Quaterniond>(pose_j.data()).conjugate());
    negative_w += q_e.w() < 0;
  }
  EXPECT_GT(negative_w, 20);
  EXPECT_LT(negative_w, 180);
}

TEST(PoseGraphEdgeCostTest, ZeroWhenThePosesAgreeWithTheMeasurement) {
  std::mt19937 rng(9);
  const Rigid3d T_iw = RandomPose(rng), T_jw = RandomPose(rng);
  const Rigid3d T_j_i = T_jw * T_iw.Inverse();
  std::array<double, 7> pose_i = ToPoseBlock(T_iw), pose_j = ToPoseBlock(T_jw);
  const double* parameters[] = {pose_i.data(), pose_j.data()};
  double r[6];
  ASSERT_TRUE(PoseGraphEdgeCost(T_j_i).Evaluate(parameters, r, nullptr));
  for (double v : r) EXPECT_NEAR(v, 0.0, 1e-12);
}

}  // namespace
}  // namespace rrslam
