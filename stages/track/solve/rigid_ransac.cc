#include "stages/track/solve/rigid_ransac.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>

#include "stages/track/solve/ransac.h"

namespace rrslam {
namespace {

// Pixel of camera-frame point `x` (false when not in front of the camera).
bool Project(const Eigen::Matrix3d& K, const Eigen::Vector3d& x, Eigen::Vector2d* pixel) {
  if (x.z() <= 0) return false;
  *pixel = Eigen::Vector2d(K(0, 0) * x.x() / x.z() + K(0, 2), K(1, 1) * x.y() / x.z() + K(1, 2));
  return true;
}

}  // namespace

RigidRansacResult SolveRigidRansac(const std::vector<Eigen::Vector3d>& points1,
                                   const std::vector<Eigen::Vector3d>& points2,
                                   const std::vector<double>& sigma2_1,
                                   const std::vector<double>& sigma2_2, const Eigen::Matrix3d& K,
                                   const RigidRansacOptions& options, uint64_t seed) {
  constexpr int kMinimalSet = 3;
  RigidRansacResult result;
  const int n = static_cast<int>(points1.size());
  if (n < kMinimalSet || points2.size() != points1.size() || sigma2_1.size() != points1.size() ||
      sigma2_2.size() != points1.size() || n < options.min_inliers) {
    return result;
  }
  const int iterations = RansacIterations(
      options.probability, static_cast<double>(options.min_inliers) / n, options.max_iterations);

  // Each point's own projection in its image, and its error bounds.
  std::vector<Eigen::Vector2d> pixel1(n), pixel2(n);
  std::vector<uint8_t> usable(n, 1);
  for (int i = 0; i < n; ++i) {
    usable[i] = Project(K, points1[i], &pixel1[i]) && Project(K, points2[i], &pixel2[i]);
  }
  auto score = [&](const Rigid3d& T_12, std::vector<uint8_t>* inlier) {
    const Rigid3d T_21 = T_12.Inverse();
    int count = 0;
    for (int i = 0; i < n; ++i) {
      Eigen::Vector2d p21, p12;
      const bool ok = usable[i] && Project(K, T_12 * points2[i], &p21) &&
                      Project(K, T_21 * points1[i], &p12) &&
                      (pixel1[i] - p21).squaredNorm() < options.chi2 * sigma2_1[i] &&
                      (pixel2[i] - p12).squaredNorm() < options.chi2 * sigma2_2[i];
      (*inlier)[i] = ok;
      count += ok;
    }
    return count;
  };

  std::mt19937_64 rng(seed);
  std::vector<int> all(n);
  for (int i = 0; i < n; ++i) all[i] = i;
  std::vector<uint8_t> inlier(n);
  Eigen::Matrix3d src, dst;
  for (int it = 0; it < iterations; ++it) {
    ++result.iterations;
    DrawMinimalSet(rng, kMinimalSet, &all);
    for (int k = 0; k < kMinimalSet; ++k) {
      src.col(k) = points2[all[k]];
      dst.col(k) = points1[all[k]];
    }
    const Eigen::Matrix4d T = Eigen::umeyama(src, dst, /*with_scaling=*/false);
    if (!T.allFinite()) continue;
    const Rigid3d T_12 = Rigid3d::FromMatrix(T);
    const int count = score(T_12, &inlier);
    if (count > result.inliers) {
      result.inliers = count;
      result.T_12 = T_12;
      result.inlier = inlier;
      if (count > options.min_inliers) {
        result.ok = true;
        return result;
      }
    }
  }
  return result;
}

}  // namespace rrslam
