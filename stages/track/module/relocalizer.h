// Relocalization (ORB-SLAM2's Tracking::Relocalization, written anew): finds
// the pose of a frame that lost track, against the whole map.
//  1. Candidates: the keyframe database's relocalization candidates for the
//     frame's bag of words (shared words, covisibility-group scores).
//  2. Per candidate: BoW matching of the frame's keypoints to the
//     candidate's map points (ratio 0.75, rotation histogram); at least 15.
//  3. PnP RANSAC on those 2D-3D matches (SolvePnpRansac below), then pose
//     optimization; fewer than 10 inliers rejects the candidate.
//  4. With fewer than 50 inliers, the candidate's other map points are
//     projected with that pose and matched in a 10 px window (distance
//     <= 100), the pose optimized again; between 30 and 50 inliers, once more
//     in a 3 px window (distance <= 64). 50 inliers relocalize the frame.
// Candidates are tried in the database's order (by id); the first that
// reaches 50 inliers wins. (ORB-SLAM2 interleaves 5 RANSAC iterations per
// candidate in turns; running each candidate's RANSAC to its end instead
// keeps batch runs bit-identical with a seeded generator and, since the
// winner needs 50 inliers either way, finds the same poses.)
//
// Thread-safety: the caller holds Map::mutex().
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "common/geometry.h"
#include "stages/track/data/frame.h"
#include "stages/track/data/keyframe.h"
#include "stages/track/data/keyframe_database.h"
#include "stages/track/data/sensor_model.h"
#include "stages/track/optimize/optimizer.h"

namespace rrslam {

struct PnpRansacOptions {
  // ORB-SLAM2's PnPsolver::SetRansacParameters(0.99, 10, 300, 4, 0.5, 5.991).
  double probability = 0.99;  // Of drawing one all-inlier minimal set.
  int min_inliers = 10;       // And at least min_inlier_ratio of the matches.
  double min_inlier_ratio = 0.5;
  int max_iterations = 300;
  // Inlier: squared reprojection error below chi2 * sigma^2 of the keypoint's
  // octave (5.991: 95% for two degrees of freedom).
  double chi2 = 5.991;
};

struct PnpResult {
  bool ok = false;
  Rigid3d T_cam_world;
  std::vector<uint8_t> inlier;  // Per correspondence.
  int inliers = 0;
  int iterations = 0;
};

// Camera pose from 2D-3D correspondences with outliers: RANSAC over minimal
// sets of 4 correspondences solved by EPnP (OpenCV's cv::solvePnP with
// SOLVEPNP_EPNP), each hypothesis scored by the correspondences within their
// octave's chi-square bound; the best hypothesis is refitted by EPnP on its
// inliers and rescored. The iteration count adapts to the inlier ratio, as
// ORB-SLAM2's PnPsolver does. (Not cv::solvePnPRansac: it has one pixel
// threshold for all correspondences, where ORB-SLAM2 scales it with each
// keypoint's octave.) `pixels` are ideal (undistorted) pixels of the camera
// `K`; `sigma2` the squared pixel sigma of each. Deterministic for a `seed`.
PnpResult SolvePnpRansac(const std::vector<Eigen::Vector3d>& points_world,
                         const std::vector<Eigen::Vector2d>& pixels,
                         const std::vector<double>& sigma2, const Eigen::Matrix3d& K,
                         const PnpRansacOptions& options, uint64_t seed);

struct RelocalizationOptions {
  double bow_ratio = 0.75;
  int min_bow_matches = 15;
  int min_pose_inliers = 10;  // After the first pose optimization.
  int min_inliers = 50;       // To accept the pose.
  PnpRansacOptions ransac;
};

class Relocalizer {
 public:
  // References must outlive the relocalizer.
  Relocalizer(const SensorModel& sensor, const KeyFrameDatabase& database,
              const RelocalizationOptions& options = {})
      : sensor_(sensor), database_(database), options_(options) {}

  // Tries to relocalize `frame` (its bag of words computed). On success sets
  // its pose and its map points (inliers only) and returns the candidate
  // keyframe that gave the pose; otherwise returns nullptr and leaves the
  // frame's map points empty. `solves` (may be null) counts the pose
  // optimizations.
  KeyFrame* Relocalize(Frame* frame, SolveCounts* solves = nullptr) const;

 private:
  const SensorModel& sensor_;
  const KeyFrameDatabase& database_;
  RelocalizationOptions options_;
};

}  // namespace rrslam
