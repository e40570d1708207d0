// Camera pose from map points matched to an RGB-D frame's keypoints, with
// outliers: the solver of relocalization's direct stage (module/relocalizer.h).
//
// Hypotheses come from minimal sets of 3 correspondences whose keypoints have
// depth: each keypoint back-projected is a point in the camera frame, so three
// of them and their map points fix the pose by Eigen's umeyama without scale
// (a 3-D to 3-D fit, as the RGB-D loop check fits, solve/rigid_ransac.h).
// Samples whose three points lie within `min_spread` metres of each other, or
// near one line, are drawn again. Every correspondence, with depth or
// without, scores a hypothesis: it is an inlier when its chi-square error at
// that pose is within the bound of ORB-SLAM2's pose optimization (7.815 for
// a keypoint with depth, u, v and the virtual right u_R; 5.991 for u, v
// alone; SensorModel::StereoChi2's weighting). The best hypothesis is fitted
// again to its inliers with depth and rescored. The iteration count adapts
// to the best inlier ratio among the correspondences with depth.
//
// Frames: map points in world coordinates (metres), keypoints in ideal
// (undistorted) pixels of `sensor`; the result maps world to camera
// coordinates.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "common/geometry.h"
#include "stages/track/data/sensor_model.h"

namespace rrslam {

struct PoseCorrespondence {
  Eigen::Vector3d point_world;
  Eigen::Vector2d pixel;  // Ideal pixel of the keypoint.
  double u_right = -1;    // Virtual right u; negative: the keypoint has no depth.
  double depth = 0;       // Metres; 0: none.
  int octave = 0;
};

struct AbsolutePoseRansacOptions {
  double probability = 0.99;  // Of drawing one all-inlier minimal set.
  int max_iterations = 1000;
  int min_inliers = 10;      // Fewer: no pose.
  double min_spread = 0.05;  // Metres between the sample's points in the camera.
};

struct AbsolutePoseResult {
  bool ok = false;
  Rigid3d T_cam_world;
  std::vector<uint8_t> inlier;  // Per correspondence.
  int inliers = 0;
  int iterations = 0;
};

// Deterministic for a `seed`. Returns no pose when fewer than 3
// correspondences have depth.
AbsolutePoseResult SolveAbsolutePoseRansac(const std::vector<PoseCorrespondence>& matches,
                                           const SensorModel& sensor,
                                           const AbsolutePoseRansacOptions& options, uint64_t seed);

// The chi-square bounds above: an inlier of pose `T_cam_world`.
bool IsPoseInlier(const PoseCorrespondence& match, const SensorModel& sensor,
                  const Rigid3d& T_cam_world);

}  // namespace rrslam
