// Rigid transform between two keyframes' cameras from 3-D to 3-D point
// correspondences with outliers: the geometric check of RGB-D loop closing
// (ORB-SLAM2's Sim3Solver with the scale fixed, as ORB-SLAM2 runs it for
// RGB-D, written anew).
//
// Hypotheses come from minimal sets of 3 correspondences fitted by Eigen's
// umeyama without scale (least-squares rotation and translation). A
// correspondence is an inlier when each point, mapped into the other camera,
// projects within its keypoint octave's chi-square bound of where the other
// point projects (both directions; 9.210 * sigma^2, ORB-SLAM2's bound).
//
// Frames: points1 are in camera 1 coordinates, points2 in camera 2
// coordinates (metres); the result T_12 maps camera 2 coordinates to
// camera 1 coordinates (x1 = T_12 * x2).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "common/geometry.h"

namespace rrslam {

struct RigidRansacOptions {
  // ORB-SLAM2's loop closing: SetRansacParameters(0.99, 20, 300).
  double probability = 0.99;  // Of drawing one all-inlier minimal set.
  int min_inliers = 20;       // A hypothesis with more inliers ends the search.
  int max_iterations = 300;
  double chi2 = 9.210;  // 99% for two degrees of freedom.
};

struct RigidRansacResult {
  bool ok = false;  // A hypothesis with more than min_inliers inliers was found.
  Rigid3d T_12;
  std::vector<uint8_t> inlier;  // Per correspondence.
  int inliers = 0;
  int iterations = 0;
};

// `sigma2_1[i]` / `sigma2_2[i]`: squared pixel sigma of the keypoint of
// correspondence i in image 1 / 2; `K`: the pinhole intrinsics of both
// images. Runs at most the adaptive iteration count (probability at an
// inlier ratio of min_inliers / n, capped at max_iterations) and stops at
// the first hypothesis with more than min_inliers inliers. Deterministic for
// a `seed`.
RigidRansacResult SolveRigidRansac(const std::vector<Eigen::Vector3d>& points1,
                                   const std::vector<Eigen::Vector3d>& points2,
                                   const std::vector<double>& sigma2_1,
                                   const std::vector<double>& sigma2_2, const Eigen::Matrix3d& K,
                                   const RigidRansacOptions& options, uint64_t seed);

}  // namespace rrslam
