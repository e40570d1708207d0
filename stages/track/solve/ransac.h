// What the RANSAC solvers share (PnP in module/relocalizer.h, rigid 3-D in
// solve/rigid_ransac.h): the adaptive iteration count and the drawing of
// minimal sets, as ORB-SLAM2's solvers do them.
#pragma once

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace rrslam {

// Iterations that draw one all-inlier set of 3 with `probability` when a
// fraction `inlier_ratio` of the data are inliers, at least 1 and at most
// `max_iterations` (ORB-SLAM2 uses the cube for its PnP and Sim3 solvers
// alike); 1 when every correspondence must be an inlier (ratio 1),
// `max_iterations` when none is (ratio 0).
inline int RansacIterations(double probability, double inlier_ratio, int max_iterations) {
  if (inlier_ratio >= 1) return 1;
  if (!(inlier_ratio > 0)) return max_iterations;
  const double needed =
      std::ceil(std::log(1 - probability) / std::log(1 - std::pow(inlier_ratio, 3)));
  return std::max(1, std::min(static_cast<int>(needed), max_iterations));
}

// Draws a minimal set of `size` distinct indices into the first `size`
// entries of `indices` (a permutation of 0 .. n-1, kept between draws): a
// partial Fisher-Yates shuffle.
inline void DrawMinimalSet(std::mt19937_64& rng, int size, std::vector<int>* indices) {
  const int n = static_cast<int>(indices->size());
  for (int k = 0; k < size; ++k) {
    std::uniform_int_distribution<int> pick(k, n - 1);
    std::swap((*indices)[k], (*indices)[pick(rng)]);
  }
}

}  // namespace rrslam
