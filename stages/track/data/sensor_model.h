// The RGB-D sensor as tracking sees it: pinhole intrinsics on ideal
// (undistorted) pixels, the virtual stereo baseline that turns a depth
// measurement into a right-image coordinate, the close/far depth threshold,
// the ORB scale pyramid, and the keypoint grid geometry.
//
// Immutable after construction; shared by const reference between the
// tracker, the local mapper and every frame and keyframe. Thread-safe.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "common/camera.h"
#include "common/settings.h"

namespace rrslam {

// Per-level quantities of the ORB image pyramid (ORB-SLAM2's mvScaleFactors,
// mvLevelSigma2, ...). A keypoint detected on level l has a position
// uncertainty of scale[l] level-0 pixels (variance sigma2[l] = scale[l]^2).
struct ScalePyramid {
  ScalePyramid() = default;
  explicit ScalePyramid(const OrbSettings& orb);

  int n_levels = 1;
  double scale_factor = 1.2;       // Scale between consecutive levels.
  double log_scale_factor = 0.0;   // log(scale_factor).
  std::vector<double> scale;       // scale_factor^l.
  std::vector<double> inv_scale;   // 1 / scale[l].
  std::vector<double> sigma2;      // scale[l]^2, level-0 px^2.
  std::vector<double> inv_sigma2;  // 1 / sigma2[l].
};

struct SensorModel {
  // Builds the model from settings and the image size in pixels (used when
  // the settings give none). Throws DataError when the size is not positive.
  SensorModel(const Settings& settings, int image_width, int image_height);

  // Keypoint grid (ORB-SLAM2's 64 x 48 cells over the undistorted bounds).
  static constexpr int kGridCols = 64;
  static constexpr int kGridRows = 48;

  PinholeCamera camera;  // Intrinsics and distortion (keypoints are undistorted once).
  double fx = 1, fy = 1, cx = 0, cy = 0;
  double inv_fx = 1, inv_fy = 1;
  double bf = 40.0;       // Baseline (m) times fx (px): u_R = u - bf / depth.
  double baseline = 0.0;  // bf / fx, metres.
  double th_depth = 0.0;  // Close/far threshold in metres (bf * ThDepth / fx).
  // Depth noise as a disparity sigma in pixels (DepthNoise::DisparitySigma of
  // the settings); 0 = ORB-SLAM2's weighting of u_R by the keypoint's sigma.
  double disparity_sigma = 0.0;
  ImageBounds bounds;               // Ideal-pixel bounds of the image.
  double grid_inv_cell_width = 0;   // Cells per pixel along u.
  double grid_inv_cell_height = 0;  // Cells per pixel along v.
  ScalePyramid pyramid;

  // Ideal pixel of a point in the camera frame (requires z > 0).
  Eigen::Vector2d Project(const Eigen::Vector3d& point_cam) const {
    const double inv_z = 1.0 / point_cam.z();
    return {fx * point_cam.x() * inv_z + cx, fy * point_cam.y() * inv_z + cy};
  }
  // Camera-frame point of an ideal pixel at `depth` metres.
  Eigen::Vector3d Unproject(double u, double v, double depth) const {
    return {(u - cx) * depth * inv_fx, (v - cy) * depth * inv_fy, depth};
  }
  // Chi-square statistic of a keypoint with depth on pyramid level `octave`
  // against a prediction, from the prediction errors (pixels) of u, v and the
  // virtual right coordinate u_R. With disparity_sigma = 0 (ORB-SLAM2):
  //   (eu^2 + ev^2 + eur^2) / sigma2[octave];
  // otherwise (u, v) are weighted by the octave and the disparity u - u_R by
  // disparity_sigma:
  //   (eu^2 + ev^2) / sigma2[octave] + (eu - eur)^2 / disparity_sigma^2.
  // The Ceres residuals (reprojection_error.h) whiten the same way.
  double StereoChi2(double eu, double ev, double eur, int octave) const;

  // Grid cell of an ideal pixel; false when it falls outside the grid.
  bool GridCell(double u, double v, int* col, int* row) const;

  // Pyramid level at which a point seen at `distance` metres is expected,
  // given the largest distance at which it keeps its scale (ORB-SLAM2's
  // MapPoint::PredictScale), clamped to [0, n_levels - 1].
  int PredictScaleLevel(double max_distance, double distance) const;
};

}  // namespace rrslam
