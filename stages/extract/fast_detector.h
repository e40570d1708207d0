// FAST-9 corner detection (Rosten and Drummond 2006) with non-maximum
// suppression, computed densely with SIMD for the ORB extractor.
//
// A pixel p is a corner at threshold t when 9 contiguous pixels of the
// 16-pixel Bresenham circle of radius 3 are all brighter than p + t or all
// darker than p - t. Its score is the largest such margin minus one,
//   score = max over the 16 arcs of 9 and both polarities of
//           min over the arc of (I_k - p) (or p - I_k), minus 1,
// so a pixel is a corner at t exactly when score >= t, and the score does not
// depend on t. A corner is kept when its score is larger than the scores of
// its 8 neighbours (0 for neighbours that are not corners at t). Corners and
// scores are those of cv::FAST(image, keypoints, t, true) with the default
// TYPE_9_16 (tested), which lets one pass at a low threshold also answer any
// higher threshold: the corners at t' >= t are those with score >= t'.
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <vector>

namespace rrslam {

struct FastCorner {
  int x = 0;      // Pixel column.
  int y = 0;      // Pixel row.
  int score = 0;  // In [threshold, 254].
};

// Implementations of the score computation; all give identical results.
enum class FastKernel {
  kScalar,  // Portable reference.
  kSse2,    // 16 pixels at a time (x86-64 baseline).
  kAvx2,    // 32 pixels at a time, on CPUs with AVX2 (chosen at run time).
};

// Whether `kernel` is compiled in and supported by this CPU.
bool FastKernelAvailable(FastKernel kernel);
// The fastest available kernel.
FastKernel BestFastKernel();

// Appends to `corners`, in raster order, the corners at `threshold` (in
// [1, 255]) with their pixel inside `box`, after non-maximum suppression.
// The image (CV_8UC1) must hold 4 pixels around `box` (3 for the circle and 1
// for the suppression neighbours); throws std::invalid_argument otherwise.
// `scratch` is a reusable buffer for the score map. `kernel` selects the
// implementation (an unavailable one falls back to the best available).
// Thread-safe (no shared state).
void DetectFastCorners(const cv::Mat& image, const cv::Rect& box, int threshold,
                       std::vector<FastCorner>* corners, std::vector<uint8_t>* scratch,
                       FastKernel kernel = BestFastKernel());

// Score of pixel (x, y) as above, or 0 when it is not a corner at
// `threshold`; the pixel must be >= 3 px inside the image. Scalar reference.
int FastScore(const cv::Mat& image, int x, int y, int threshold);

}  // namespace rrslam
