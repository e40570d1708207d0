#include "stages/extract/fast_detector.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "stages/extract/test_images.h"

namespace rrslam {
namespace {

const FastKernel kKernels[] = {FastKernel::kScalar, FastKernel::kSse2, FastKernel::kAvx2};

const char* KernelName(FastKernel k) {
  switch (k) {
    case FastKernel::kScalar:
      return "scalar";
    case FastKernel::kSse2:
      return "sse2";
    case FastKernel::kAvx2:
      return "avx2";
  }
  return "?";
}

// cv::FAST's corners inside `box`, run on the box grown by 4 px so that its
// suppression sees every neighbour (as DetectFastCorners does).
std::vector<FastCorner> OpenCvCorners(const cv::Mat& image, const cv::Rect& box, int threshold) {
  const cv::Rect grown(box.x - 4, box.y - 4, box.width + 8, box.height + 8);
  std::vector<cv::KeyPoint> keypoints;
  cv::FAST(image(grown), keypoints, threshold, true);
  std::vector<FastCorner> corners;
  for (const cv::KeyPoint& k : keypoints) {
    const int x = static_cast<int>(k.pt.x) + grown.x;
    const int y = static_cast<int>(k.pt.y) + grown.y;
    if (box.contains({x, y})) corners.push_back({x, y, static_cast<int>(k.response)});
  }
  std::sort(corners.begin(), corners.end(), [](const FastCorner& a, const FastCorner& b) {
    return a.y != b.y ? a.y < b.y : a.x < b.x;
  });
  return corners;
}

void ExpectSameCorners(const std::vector<FastCorner>& expected,
                       const std::vector<FastCorner>& actual, const std::string& what) {
  ASSERT_EQ(actual.size(), expected.size()) << what;
  for (size_t i = 0; i < expected.size(); ++i) {
    ASSERT_EQ(actual[i].x, expected[i].x) << what << " corner " << i;
    ASSERT_EQ(actual[i].y, expected[i].y) << what << " corner " << i;
    ASSERT_EQ(actual[i].score, expected[i].score) << what << " corner " << i;
  }
}

TEST(FastDetector, EqualsOpenCvFastOnTexturedImages) {
  for (uint64_t seed : {1u, 2u}) {
    const cv::Mat image = testing::MakeTexturedImage(320, 240, seed);
    const cv::Rect box(19, 19, 320 - 38, 240 - 38);
    for (int threshold : {7, 20, 45}) {
      const std::vector<FastCorner> expected = OpenCvCorners(image, box, threshold);
      ASSERT_GT(expected.size(), 100u);
      for (FastKernel kernel : kKernels) {
        if (!FastKernelAvailable(kernel)) continue;
        std::vector<FastCorner> corners;
        std::vector<uint8_t> scratch;
        DetectFastCorners(image, box, threshold, &corners, &scratch, kernel);
        ExpectSameCorners(expected, corners,
                          std::string(KernelName(kernel)) + " t=" + std::to_string(threshold));
      }
    }
  }
}

TEST(FastDetector, EqualsOpenCvFastOnNoiseAndOddBoxes) {
  // Pure noise has corners everywhere, including plateaus of equal scores;
  // odd box sizes exercise the block tails.
  cv::Mat noise(97, 131, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  for (const cv::Rect& box : {cv::Rect(4, 4, 123, 89), cv::Rect(10, 20, 17, 5),
                              cv::Rect(5, 6, 33, 40), cv::Rect(40, 30, 1, 1)}) {
    for (int threshold : {1, 30, 90}) {
      const std::vector<FastCorner> expected = OpenCvCorners(noise, box, threshold);
      for (FastKernel kernel : kKernels) {
        if (!FastKernelAvailable(kernel)) continue;
        std::vector<FastCorner> corners;
        std::vector<uint8_t> scratch;
        DetectFastCorners(noise, box, threshold, &corners, &scratch, kernel);
        ExpectSameCorners(expected, corners, std::string(KernelName(kernel)));
      }
    }
  }
}

TEST(FastDetector, ScoreIsThresholdIndependent) {
  // The property the extractor relies on: a pixel is a corner at t exactly
  // when its score is >= t, and the score does not depend on t.
  const cv::Mat image = testing::MakeTexturedImage(160, 120, 3);
  for (int y = 3; y < image.rows - 3; ++y) {
    for (int x = 3; x < image.cols - 3; ++x) {
      const int score = FastScore(image, x, y, 1);
      for (int t : {5, 12, 40}) {
        const int at_t = FastScore(image, x, y, t);
        ASSERT_EQ(at_t, score >= t ? score : 0) << x << "," << y << " t=" << t;
      }
    }
  }
}

TEST(FastDetector, FindsTheCornersOfASquare) {
  // A perfectly uniform square gives plateaus of equal scores that strict
  // suppression removes entirely (as cv::FAST does); mild noise breaks ties.
  const cv::Mat image =
      testing::MakeNoisySquare(cv::Size(100, 100), cv::Rect(30, 30, 40, 40), 40, 200, 5, 12);
  std::vector<FastCorner> corners;
  std::vector<uint8_t> scratch;
  DetectFastCorners(image, cv::Rect(10, 10, 80, 80), 20, &corners, &scratch);
  ASSERT_GE(corners.size(), 4u);
  for (const cv::Point& expected :
       {cv::Point(30, 30), cv::Point(69, 30), cv::Point(30, 69), cv::Point(69, 69)}) {
    bool found = false;
    for (const FastCorner& c : corners) {
      found = found || (std::abs(c.x - expected.x) <= 1 && std::abs(c.y - expected.y) <= 1);
    }
    EXPECT_TRUE(found) << "no corner near " << expected;
  }
  // Straight edges and flat areas give none: every corner is near a vertex.
  for (const FastCorner& c : corners) {
    const bool near_vertex = (std::abs(c.x - 30) <= 2 || std::abs(c.x - 69) <= 2) &&
                             (std::abs(c.y - 30) <= 2 || std::abs(c.y - 69) <= 2);
    EXPECT_TRUE(near_vertex) << c.x << "," << c.y;
  }
}

TEST(FastDetector, RejectsBoxesWithoutMargin) {
  const cv::Mat image(50, 50, CV_8UC1, cv::Scalar(0));
  std::vector<FastCorner> corners;
  std::vector<uint8_t> scratch;
  EXPECT_THROW(DetectFastCorners(image, cv::Rect(3, 10, 10, 10), 10, &corners, &scratch),
               std::invalid_argument);
  EXPECT_THROW(DetectFastCorners(image, cv::Rect(10, 10, 37, 10), 10, &corners, &scratch),
               std::invalid_argument);
  EXPECT_THROW(DetectFastCorners(image, cv::Rect(10, 10, 10, 10), 0, &corners, &scratch),
               std::invalid_argument);
  EXPECT_NO_THROW(DetectFastCorners(image, cv::Rect(4, 4, 42, 42), 10, &corners, &scratch));
  EXPECT_TRUE(corners.empty());
}

}  // namespace
}  // namespace rrslam
