// ORB feature extraction as in ORB-SLAM2 (written anew): image pyramid, FAST
// on grid cells with a fallback threshold, quadtree distribution per level,
// intensity-centroid orientation and rotated BRIEF (256 bits).
//
// Pixels are level-0 image coordinates of the input image (no undistortion
// here: see FinishKeypoints). Not thread-safe: one extractor per thread (it
// keeps its pyramid buffers between calls). An extractor built with
// num_threads > 1 processes the pyramid levels of one image on that many
// threads (its own workers); the output does not depend on the thread count.
//
// Algorithm (see docs/extract.md):
//  1. Pyramid: level l is level l-1 resized (bilinear) by 1 / scale_factor,
//     of size round(width / scale_factor^l) x round(height / scale_factor^l).
//  2. Features per level: n_features split in proportion to the level's
//     linear scale, a geometric series of ratio 1 / scale_factor (ORB-SLAM2's
//     rule; the last level takes the remainder).
//  3. FAST-9 with non-maximum suppression at ini_th_fast over the level
//     (kEdgeThreshold px from the border), then at min_th_fast in every grid
//     cell of about kFastCellSize px that gave no corner.
//  4. Quadtree per level: the detection area is split into quadrants, in
//     breadth-first passes while a pass fits the level's budget and then the
//     most populated nodes first, until there are as many nodes as wanted
//     features (or no node can be split); each node keeps its strongest corner.
//  5. Orientation: intensity centroid over a disc of radius kPatchRadius on the
//     level image.
//  6. Descriptor: the 256 tests of orb_pattern.h rotated by the orientation, on
//     the level image smoothed by a 7x7 Gaussian of sigma 2.
//  7. Positions are mapped to level 0 with pixel centres aligned (the same
//     convention as cv::resize): x0 = (x_l + 0.5) * width0 / width_l - 0.5.
#pragma once

#include <memory>
#include <opencv2/core/mat.hpp>
#include <vector>

#include "common/camera.h"
#include "common/orb_descriptor.h"
#include "common/settings.h"
#include "stages/extract/features_file.h"

namespace rrslam {

class OrbExtractor {
 public:
  // Distance in level pixels from the image border inside which no keypoint
  // is detected: the rotated pattern reaches 13 * sqrt(2) < 19 px.
  static constexpr int kEdgeThreshold = 19;
  // Radius in level pixels of the disc used for the orientation; the BRIEF
  // patch is 31 x 31.
  static constexpr int kPatchRadius = 15;
  // Side in level pixels of the grid cells for the FAST threshold fallback.
  static constexpr int kFastCellSize = 30;

  // Single-threaded extractor. `settings` must pass Settings::Check's ORB
  // constraints (throws std::invalid_argument otherwise).
  explicit OrbExtractor(const OrbSettings& settings);
  // Extractor that spreads each image's pyramid levels over `num_threads`
  // threads (>= 1; the calling thread is one of them).
  OrbExtractor(const OrbSettings& settings, int num_threads);
  ~OrbExtractor();
  OrbExtractor(OrbExtractor&&) noexcept;
  OrbExtractor& operator=(OrbExtractor&&) noexcept;
  OrbExtractor(const OrbExtractor&) = delete;
  OrbExtractor& operator=(const OrbExtractor&) = delete;

  // Detects about settings.n_features keypoints on an 8-bit grayscale image and
  // computes their descriptors. Fills Keypoint::pixel, angle_deg, octave and
  // response; `undistorted` is set equal to `pixel` and `depth` to 0.
  // Keypoints come level by level (octave 0 first), each level in raster order
  // (by y, then x). Fewer keypoints are returned when the image has too few
  // corners. Throws std::invalid_argument unless `gray` is CV_8UC1; images
  // smaller than the border leave the affected levels empty.
  void Extract(const cv::Mat& gray, std::vector<Keypoint>* keypoints,
               std::vector<OrbDescriptor>* descriptors);

  const OrbSettings& settings() const { return settings_; }
  // scale_factor^level, for level in [0, n_levels).
  const std::vector<double>& scale_factors() const { return scale_factors_; }
  // (scale_factor^level)^2: variance of a keypoint's position at that level, in level-0 px^2.
  const std::vector<double>& level_sigma2() const { return level_sigma2_; }
  // Number of features wanted on each level (sums to settings.n_features).
  const std::vector<int>& features_per_level() const { return features_per_level_; }
  int num_threads() const { return num_threads_; }

  // Level images of the last Extract call (level 0 is the input image), and
  // their smoothed versions the descriptors were computed on. Valid until the
  // next call.
  const std::vector<cv::Mat>& pyramid() const { return pyramid_; }
  const std::vector<cv::Mat>& blurred_pyramid() const { return blurred_; }

 private:
  struct Impl;

  OrbSettings settings_;
  std::vector<double> scale_factors_;
  std::vector<double> level_sigma2_;
  std::vector<int> features_per_level_;
  int num_threads_ = 1;
  std::vector<cv::Mat> pyramid_;
  std::vector<cv::Mat> blurred_;
  std::unique_ptr<Impl> impl_;  // Per-level work buffers and worker threads.
};

// Completes keypoints after extraction: `undistorted` from the camera model,
// `depth` (metres) read from `depth_metres` (CV_32FC1, 0 = none) at the
// keypoint's rounded pixel. An empty depth image leaves depth at 0.
// Non-finite or negative depths and pixels outside the depth image give 0.
// Throws std::invalid_argument when a non-empty depth image is not CV_32FC1.
void FinishKeypoints(const PinholeCamera& camera, const cv::Mat& depth_metres,
                     std::vector<Keypoint>* keypoints);

}  // namespace rrslam
