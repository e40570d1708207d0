#include "stages/track/solve/rigid_ransac.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "stages/track/test_scene.h"

namespace rrslam {
namespace {

using testing::TestSensor;

constexpr double kDeg = M_PI / 180;

// Correspondences of camera-frame points, each seen 1-4 m in front of both
// cameras and inside both images; pixels perturbed by Gaussian noise at the
// exact depth.
struct Correspondences {
  std::vector<Eigen::Vector3d> points1, points2;
  std::vector<uint8_t> wrong;
  int num_wrong() const { return static_cast<int>(std::count(wrong.begin(), wrong.end(), 1)); }
};

// ~20 degrees mostly about the vertical axis, ~0.5 m mostly sideways.
Rigid3d TrueT12() {
  return Rigid3d(ExpSO3(Eigen::Vector3d(0.1, 1.0, 0.05).normalized() * 20 * kDeg),
                 Eigen::Vector3d(0.4, 0.05, 0.3));
}

// A point pair (x1, x2 = T_12^-1 x1) seen 1-4 m in front of both cameras.
void RandomVisiblePair(const SensorModel& sensor, const Rigid3d& T_12, std::mt19937& rng,
                       Eigen::Vector3d* x1, Eigen::Vector3d* x2) {
  std::uniform_real_distribution<double> uu(0, 640), uv(0, 480), uz(1.0, 4.0);
  const Rigid3d T_21 = T_12.Inverse();
  while (true) {
    const double z = uz(rng);
    *x1 = Eigen::Vector3d((uu(rng) - 320) / 500 * z, (uv(rng) - 240) / 500 * z, z);
    *x2 = T_21 * *x1;
    if (x2->z() < 1.0 || x2->z() > 4.0) continue;
    const Eigen::Vector2d px = sensor.Project(*x2);
    if (sensor.bounds.Contains(px.x(), px.y())) return;
  }
}

// `x` moved so that its pixel moves by Gaussian noise of `sigma` px, depth kept.
Eigen::Vector3d Noisy(const SensorModel& sensor, const Eigen::Vector3d& x, double sigma,
                      std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, sigma);
  const Eigen::Vector2d px = sensor.Project(x) + Eigen::Vector2d(noise(rng), noise(rng));
  return Eigen::Vector3d((px.x() - 320) / 500 * x.z(), (px.y() - 240) / 500 * x.z(), x.z());
}

// `n` correspondences, every second one wrong: camera 1's point of one pair
// with camera 2's point of another, chosen so that the true transform maps
// it more than 20 px away from where the first projects.
Correspondences MakeCorrespondences(const SensorModel& sensor, const Rigid3d& T_12, int n,
                                    bool with_wrong, double pixel_noise, std::mt19937& rng) {
  Correspondences c;
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d x1, x2;
    RandomVisiblePair(sensor, T_12, rng, &x1, &x2);
    const bool wrong = with_wrong && i % 2 == 1;
    if (wrong) {
      Eigen::Vector3d other1;
      do {
        RandomVisiblePair(sensor, T_12, rng, &other1, &x2);
      } while ((sensor.Project(T_12 * x2) - sensor.Project(x1)).norm() < 20);
    }
    c.points1.push_back(Noisy(sensor, x1, pixel_noise, rng));
    c.points2.push_back(Noisy(sensor, x2, pixel_noise, rng));
    c.wrong.push_back(wrong);
  }
  return c;
}

// The result is the first minimal-set hypothesis with more than min_inliers
// inliers, not refitted to them (as ORB-SLAM2's Sim3Solver; the relative-pose
// optimization refines it): its accuracy is that of three noisy points, so
// the pixel noise is kept small (0.1 px).
TEST(SolveRigidRansacTest, RecoversTheTransformWithHalfTheCorrespondencesWrong) {
  std::mt19937 rng(5);
  const SensorModel sensor = TestSensor();
  const Rigid3d T_12 = TrueT12();
  ASSERT_NEAR(RotationAngle(T_12.rotation, Eigen::Quaterniond::Identity()), 20 * kDeg, 1e-9);
  const Correspondences c = MakeCorrespondences(sensor, T_12, 100, true, 0.1, rng);
  ASSERT_EQ(c.num_wrong(), 50);
  const std::vector<double> sigma2(c.points1.size(), 1.0);
  const RigidRansacResult r =
      SolveRigidRansac(c.points1, c.points2, sigma2, sigma2, sensor.camera.K(), {}, 11);
  ASSERT_TRUE(r.ok);
  ASSERT_EQ(r.inlier.size(), c.points1.size());
  EXPECT_EQ(r.inliers, static_cast<int>(std::count(r.inlier.begin(), r.inlier.end(), 1)));
  int right_kept = 0, wrong_kept = 0;
  for (size_t i = 0; i < c.points1.size(); ++i)
    (c.wrong[i] ? wrong_kept : right_kept) += r.inlier[i];
  EXPECT_GE(right_kept, 50 - 3);
  EXPECT_EQ(wrong_kept, 0);
  EXPECT_LT(RotationAngle(r.T_12.rotation, T_12.rotation), 0.5 * kDeg);
  EXPECT_LT((r.T_12.translation - T_12.translation).norm(), 0.01);
}

TEST(SolveRigidRansacTest, IsDeterministicForASeed) {
  std::mt19937 rng(6);
  const SensorModel sensor = TestSensor();
  const Correspondences c = MakeCorrespondences(sensor, TrueT12(), 100, true, 0.1, rng);
  const std::vector<double> sigma2(c.points1.size(), 1.0);
  const Eigen::Matrix3d K = sensor.camera.K();
  const RigidRansacResult a = SolveRigidRansac(c.points1, c.points2, sigma2, sigma2, K, {}, 3);
  const RigidRansacResult b = SolveRigidRansac(c.points1, c.points2, sigma2, sigma2, K, {}, 3);
  ASSERT_TRUE(a.ok);
  EXPECT_EQ(a.ok, b.ok);
  EXPECT_EQ(a.inliers, b.inliers);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.inlier, b.inlier);
  EXPECT_EQ(a.T_12.rotation.coeffs(), b.T_12.rotation.coeffs());
  EXPECT_EQ(a.T_12.translation, b.T_12.translation);
}

TEST(SolveRigidRansacTest, NeedsMoreThanMinInliersCorrespondences) {
  std::mt19937 rng(7);
  const SensorModel sensor = TestSensor();
  const Eigen::Matrix3d K = sensor.camera.K();
  RigidRansacOptions options;
  options.min_inliers = 20;
  // Exact correspondences: every one is an inlier of the true transform.
  for (int n : {15, 20}) {
    const Correspondences c = MakeCorrespondences(sensor, TrueT12(), n, false, 0.0, rng);
    const std::vector<double> sigma2(n, 1.0);
    EXPECT_FALSE(SolveRigidRansac(c.points1, c.points2, sigma2, sigma2, K, options, 1).ok) << n;
  }
  const Correspondences c = MakeCorrespondences(sensor, TrueT12(), 21, false, 0.0, rng);
  const std::vector<double> sigma2(21, 1.0);
  const RigidRansacResult r = SolveRigidRansac(c.points1, c.points2, sigma2, sigma2, K, options, 1);
  EXPECT_TRUE(r.ok);
  EXPECT_EQ(r.inliers, 21);
}

TEST(SolveRigidRansacTest, FailsOnRandomPairs) {
  std::mt19937 rng(8);
  const SensorModel sensor = TestSensor();
  const Rigid3d T_12 = TrueT12();
  Correspondences c;
  for (int i = 0; i < 100; ++i) {
    Eigen::Vector3d x1, x2, unused;
    RandomVisiblePair(sensor, T_12, rng, &x1, &unused);
    RandomVisiblePair(sensor, T_12, rng, &unused, &x2);
    c.points1.push_back(x1);
    c.points2.push_back(x2);
  }
  const std::vector<double> sigma2(c.points1.size(), 1.0);
  const RigidRansacResult r =
      SolveRigidRansac(c.points1, c.points2, sigma2, sigma2, sensor.camera.K(), {}, 2);
  EXPECT_FALSE(r.ok);
  EXPECT_LE(r.inliers, 20);
  EXPECT_EQ(r.iterations, 300);  // The adaptive count at 20 / 100 is capped.
}

}  // namespace
}  // namespace rrslam
