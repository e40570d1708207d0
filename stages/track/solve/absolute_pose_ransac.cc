#include "stages/track/solve/absolute_pose_ransac.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <random>

#include "stages/track/solve/ransac.h"

namespace rrslam {
namespace {

constexpr int kMinimalSet = 3;
constexpr double kChi2Mono = 5.991;    // 95%, two degrees of freedom.
constexpr double kChi2Stereo = 7.815;  // 95%, three.

// Whether three camera points are far enough apart and not near one line:
// the smallest side at least `min_spread`, the triangle's height over its
// longest side at least a tenth of `min_spread`.
bool WellSpread(const Eigen::Matrix3d& points, double min_spread) {
  const Eigen::Vector3d a = points.col(1) - points.col(0);
  const Eigen::Vector3d b = points.col(2) - points.col(0);
  const Eigen::Vector3d c = points.col(2) - points.col(1);
  const double shortest = std::min({a.norm(), b.norm(), c.norm()});
  const double longest = std::max({a.norm(), b.norm(), c.norm()});
  if (shortest < min_spread) return false;
  const double height = a.cross(b).norm() / longest;
  return height >= 0.1 * min_spread;
}

int Score(const std::vector<PoseCorrespondence>& matches, const SensorModel& sensor,
          const Rigid3d& T, std::vector<uint8_t>* inlier, int* inliers_with_depth) {
  int count = 0;
  *inliers_with_depth = 0;
  for (size_t i = 0; i < matches.size(); ++i) {
    const bool ok = IsPoseInlier(matches[i], sensor, T);
    (*inlier)[i] = ok;
    count += ok;
    *inliers_with_depth += ok && matches[i].depth > 0;
  }
  return count;
}

// Least-squares pose from the correspondences with depth among `chosen`.
bool Fit(const std::vector<PoseCorrespondence>& matches, const SensorModel& sensor,
         const std::vector<int>& chosen, Rigid3d* T) {
  Eigen::Matrix3Xd world(3, chosen.size()), cam(3, chosen.size());
  for (size_t k = 0; k < chosen.size(); ++k) {
    const PoseCorrespondence& m = matches[chosen[k]];
    world.col(k) = m.point_world;
    cam.col(k) = sensor.Unproject(m.pixel.x(), m.pixel.y(), m.depth);
  }
  const Eigen::Matrix4d fit = Eigen::umeyama(world, cam, /*with_scaling=*/false);
  if (!fit.allFinite()) return false;
  *T = Rigid3d::FromMatrix(fit);
  return true;
}

}  // namespace

bool IsPoseInlier(const PoseCorrespondence& m, const SensorModel& sensor, const Rigid3d& T) {
  const Eigen::Vector3d p = T * m.point_world;
  if (p.z() <= 0) return false;
  const Eigen::Vector2d uv = sensor.Project(p);
  const double eu = m.pixel.x() - uv.x();
  const double ev = m.pixel.y() - uv.y();
  if (m.u_right < 0) {
    return (eu * eu + ev * ev) * sensor.pyramid.inv_sigma2[m.octave] < kChi2Mono;
  }
  const double eur = m.u_right - (uv.x() - sensor.bf / p.z());
  return sensor.StereoChi2(eu, ev, eur, m.octave) < kChi2Stereo;
}

AbsolutePoseResult SolveAbsolutePoseRansac(const std::vector<PoseCorrespondence>& matches,
                                           const SensorModel& sensor,
                                           const AbsolutePoseRansacOptions& options,
                                           uint64_t seed) {
  AbsolutePoseResult result;
  std::vector<int> with_depth;
  for (size_t i = 0; i < matches.size(); ++i) {
    if (matches[i].depth > 0) with_depth.push_back(static_cast<int>(i));
  }
  const int n_depth = static_cast<int>(with_depth.size());
  if (n_depth < kMinimalSet) return result;

  std::mt19937_64 rng(seed);
  std::vector<uint8_t> inlier(matches.size());
  int best = -1;
  int iterations = options.max_iterations;
  std::vector<int> sample(kMinimalSet);
  for (int it = 0; it < iterations; ++it) {
    ++result.iterations;
    DrawMinimalSet(rng, kMinimalSet, &with_depth);
    std::copy(with_depth.begin(), with_depth.begin() + kMinimalSet, sample.begin());
    Eigen::Matrix3d cam;
    for (int k = 0; k < kMinimalSet; ++k) {
      const PoseCorrespondence& m = matches[sample[k]];
      cam.col(k) = sensor.Unproject(m.pixel.x(), m.pixel.y(), m.depth);
    }
    if (!WellSpread(cam, options.min_spread)) continue;
    Rigid3d T;
    if (!Fit(matches, sensor, sample, &T)) continue;
    int count_depth = 0;
    const int count = Score(matches, sensor, T, &inlier, &count_depth);
    if (count > best && count_depth >= kMinimalSet) {
      best = count;
      result.T_cam_world = T;
      result.inlier = inlier;
      // The all-inlier chance of a sample grows with the ratio among the
      // correspondences it is drawn from.
      const double ratio = static_cast<double>(count_depth) / n_depth;
      iterations = std::max(
          it + 1, std::min(iterations,
                           RansacIterations(options.probability, ratio, options.max_iterations)));
    }
  }
  if (best < options.min_inliers) return result;

  // Fitted again to the inliers with depth, kept when it scores as well.
  std::vector<int> chosen;
  for (int i : with_depth) {
    if (result.inlier[i]) chosen.push_back(i);
  }
  Rigid3d refined;
  if (chosen.size() >= kMinimalSet && Fit(matches, sensor, chosen, &refined)) {
    int count_depth = 0;
    const int count = Score(matches, sensor, refined, &inlier, &count_depth);
    if (count >= best) {
      best = count;
      result.T_cam_world = refined;
      result.inlier = inlier;
    }
  }
  result.ok = true;
  result.inliers = best;
  return result;
}

}  // namespace rrslam
