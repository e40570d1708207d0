// ORB feature extraction as in ORB-SLAM2 (written anew): image pyramid, FAST
// on grid cells with a fallback threshold, quadtree distribution per level,
// intensity-centroid orientation and rotated BRIEF (256 bits).
//
// Pixels are level-0 image coordinates of the input image (no undistortion
// here: see FinishKeypoints). Not thread-safe: one extractor per thread (it
// keeps its pyramid buffers between calls).
#pragma once

#include <opencv2/core/mat.hpp>
#include <vector>

#include "common/camera.h"
#include "common/orb_descriptor.h"
#include "common/settings.h"
#include "stages/extract/features_file.h"

namespace rrslam {

class OrbExtractor {
 public:
  explicit OrbExtractor(const OrbSettings& settings);

  // Detects about settings.n_features keypoints on an 8-bit grayscale image and
  // computes their descriptors. Fills Keypoint::pixel, angle_deg, octave and
  // response; `undistorted` is set equal to `pixel` and `depth` to 0.
  void Extract(const cv::Mat& gray, std::vector<Keypoint>* keypoints,
               std::vector<OrbDescriptor>* descriptors);

  const OrbSettings& settings() const { return settings_; }
  // scale_factor^level, for level in [0, n_levels).
  const std::vector<double>& scale_factors() const { return scale_factors_; }
  // (scale_factor^level)^2: variance of a keypoint's position at that level, in level-0 px^2.
  const std::vector<double>& level_sigma2() const { return level_sigma2_; }

 private:
  OrbSettings settings_;
  std::vector<double> scale_factors_;
  std::vector<double> level_sigma2_;
  // Implementation state (pyramid buffers, features per level, ...) is added
  // by the implementation.
};

// Completes keypoints after extraction: `undistorted` from the camera model,
// `depth` (metres) read from `depth_metres` (CV_32FC1, 0 = none) at the
// keypoint's rounded pixel. An empty depth image leaves depth at 0.
void FinishKeypoints(const PinholeCamera& camera, const cv::Mat& depth_metres,
                     std::vector<Keypoint>* keypoints);

}  // namespace rrslam
