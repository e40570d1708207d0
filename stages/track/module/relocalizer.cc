#include "stages/track/module/relocalizer.h"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <random>

#include "stages/track/match/matcher.h"
#include "stages/track/solve/ransac.h"

namespace rrslam {
namespace {

// EPnP on the correspondences `indices`; false when OpenCV finds no pose.
bool Epnp(const std::vector<Eigen::Vector3d>& points_world,
          const std::vector<Eigen::Vector2d>& pixels, const std::vector<int>& indices,
          const cv::Mat& K, Rigid3d* T_cam_world) {
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  object.reserve(indices.size());
  image.reserve(indices.size());
  for (int i : indices) {
    object.emplace_back(points_world[i].x(), points_world[i].y(), points_world[i].z());
    image.emplace_back(pixels[i].x(), pixels[i].y());
  }
  cv::Mat rvec, tvec;
  if (!cv::solvePnP(object, image, K, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_EPNP)) {
    return false;
  }
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d R_eigen;
  Eigen::Vector3d t_eigen;
  cv::cv2eigen(R, R_eigen);
  cv::cv2eigen(tvec, t_eigen);
  if (!R_eigen.allFinite() || !t_eigen.allFinite()) return false;
  *T_cam_world = Rigid3d(Eigen::Quaterniond(R_eigen).normalized(), t_eigen);
  return true;
}

// Marks the correspondences within their chi-square bound at pose T.
int Score(const std::vector<Eigen::Vector3d>& points_world,
          const std::vector<Eigen::Vector2d>& pixels, const std::vector<double>& max_error2,
          const Eigen::Matrix3d& K, const Rigid3d& T, std::vector<uint8_t>* inlier) {
  int n = 0;
  for (size_t i = 0; i < points_world.size(); ++i) {
    const Eigen::Vector3d p = T * points_world[i];
    bool ok = p.z() > 0;
    if (ok) {
      const Eigen::Vector2d uv(K(0, 0) * p.x() / p.z() + K(0, 2),
                               K(1, 1) * p.y() / p.z() + K(1, 2));
      ok = (uv - pixels[i]).squaredNorm() < max_error2[i];
    }
    (*inlier)[i] = ok;
    n += ok;
  }
  return n;
}

}  // namespace

PnpResult SolvePnpRansac(const std::vector<Eigen::Vector3d>& points_world,
                         const std::vector<Eigen::Vector2d>& pixels,
                         const std::vector<double>& sigma2, const Eigen::Matrix3d& K,
                         const PnpRansacOptions& options, uint64_t seed) {
  constexpr int kMinimalSet = 4;
  PnpResult result;
  const int n = static_cast<int>(points_world.size());
  if (n < kMinimalSet || pixels.size() != points_world.size() ||
      sigma2.size() != points_world.size()) {
    return result;
  }
  // ORB-SLAM2: at least max(min_inliers, ratio * n, 4) inliers, and as many
  // iterations as find an all-inlier set with `probability` at that ratio.
  const int min_inliers =
      std::max({options.min_inliers, static_cast<int>(options.min_inlier_ratio * n), kMinimalSet});
  if (min_inliers > n) return result;
  const double ratio = std::max(options.min_inlier_ratio, static_cast<double>(min_inliers) / n);
  const int iterations = RansacIterations(options.probability, ratio, options.max_iterations);

  std::vector<double> max_error2(n);
  for (int i = 0; i < n; ++i) max_error2[i] = options.chi2 * sigma2[i];
  cv::Mat K_cv;
  cv::eigen2cv(K, K_cv);

  std::mt19937_64 rng(seed);
  std::vector<int> all(n);
  for (int i = 0; i < n; ++i) all[i] = i;
  std::vector<uint8_t> inlier(n), best_inlier(n);
  int best = -1;
  Rigid3d best_T;
  std::vector<int> sample(kMinimalSet);
  for (int it = 0; it < iterations; ++it) {
    ++result.iterations;
    DrawMinimalSet(rng, kMinimalSet, &all);
    std::copy(all.begin(), all.begin() + kMinimalSet, sample.begin());
    Rigid3d T;
    if (!Epnp(points_world, pixels, sample, K_cv, &T)) continue;
    const int count = Score(points_world, pixels, max_error2, K, T, &inlier);
    if (count > best) {
      best = count;
      best_T = T;
      best_inlier = inlier;
    }
  }
  if (best < min_inliers) return result;

  // Refit on the inliers and rescore (ORB-SLAM2's Refine).
  std::vector<int> inliers;
  for (int i = 0; i < n; ++i) {
    if (best_inlier[i]) inliers.push_back(i);
  }
  Rigid3d refined;
  if (Epnp(points_world, pixels, inliers, K_cv, &refined)) {
    const int count = Score(points_world, pixels, max_error2, K, refined, &inlier);
    if (count >= min_inliers) {
      best = count;
      best_T = refined;
      best_inlier = inlier;
    }
  }
  result.ok = true;
  result.T_cam_world = best_T;
  result.inlier = std::move(best_inlier);
  result.inliers = best;
  return result;
}

KeyFrame* Relocalizer::Relocalize(Frame* frame, SolveCounts* solves) const {
  std::fill(frame->map_points.begin(), frame->map_points.end(), nullptr);
  const std::vector<KeyFrame*> candidates = database_.DetectRelocalizationCandidates(frame->bow());
  const FrameFeatures& f = frame->features();
  const Eigen::Matrix3d K = sensor_.camera.K();
  const Matcher bow_matcher(sensor_, options_.bow_ratio, true);
  const Matcher projection_matcher(sensor_, 0.9, true);

  // Inliers of the frame's current matches; non-inliers are dropped.
  auto optimize = [&]() {
    const int good = OptimizeFramePose(sensor_, frame, {}, solves);
    for (size_t i = 0; i < frame->size(); ++i) {
      if (frame->map_points[i] != nullptr && frame->outlier[i]) {
        frame->map_points[i] = nullptr;
        frame->outlier[i] = 0;
      }
    }
    return good;
  };
  auto found_ids = [&]() {
    std::vector<MapPointId> ids;
    for (MapPoint* p : frame->map_points) {
      if (p != nullptr) ids.push_back(p->id());
    }
    std::sort(ids.begin(), ids.end());
    return ids;
  };

  for (KeyFrame* kf : candidates) {
    if (kf->bad()) continue;
    std::vector<MapPoint*> matches;
    if (bow_matcher.SearchByBow(*kf, *frame, &matches) < options_.min_bow_matches) continue;

    std::vector<Eigen::Vector3d> points_world;
    std::vector<Eigen::Vector2d> pixels;
    std::vector<double> sigma2;
    std::vector<uint32_t> keypoint;
    for (size_t i = 0; i < matches.size(); ++i) {
      if (matches[i] == nullptr || matches[i]->bad()) continue;
      points_world.push_back(matches[i]->position_world());
      const Keypoint& kp = f.keypoints[i];
      pixels.emplace_back(kp.undistorted.x(), kp.undistorted.y());
      sigma2.push_back(sensor_.pyramid.sigma2[kp.octave]);
      keypoint.push_back(static_cast<uint32_t>(i));
    }
    const PnpResult pnp =
        SolvePnpRansac(points_world, pixels, sigma2, K, options_.ransac, frame->id() ^ kf->id());
    if (!pnp.ok) continue;

    std::fill(frame->map_points.begin(), frame->map_points.end(), nullptr);
    std::fill(frame->outlier.begin(), frame->outlier.end(), 0);
    for (size_t j = 0; j < keypoint.size(); ++j) {
      if (pnp.inlier[j]) frame->map_points[keypoint[j]] = matches[keypoint[j]];
    }
    frame->SetPose(pnp.T_cam_world);
    int good = optimize();
    if (good < options_.min_pose_inliers) continue;

    // Few inliers: more of the candidate's points, by projection, in a
    // coarse window, then (when close) in a narrow one.
    if (good < options_.min_inliers) {
      const int added = projection_matcher.SearchByProjection(frame, *kf, found_ids(), 10, 100);
      if (added + good >= options_.min_inliers) {
        good = optimize();
        if (good > 30 && good < options_.min_inliers) {
          const int more = projection_matcher.SearchByProjection(frame, *kf, found_ids(), 3, 64);
          if (good + more >= options_.min_inliers) good = optimize();
        }
      }
    }
    if (good >= options_.min_inliers) return kf;
  }
  std::fill(frame->map_points.begin(), frame->map_points.end(), nullptr);
  std::fill(frame->outlier.begin(), frame->outlier.end(), 0);
  return nullptr;
}

}  // namespace rrslam
