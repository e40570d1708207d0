#include "stages/extract/orb_extractor.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "common/dataset.h"
#include "common/settings.h"
#include "common/testing.h"
#include "stages/extract/orb_pattern.h"
#include "stages/extract/test_images.h"

namespace rrslam {
namespace {

struct Extraction {
  std::vector<Keypoint> keypoints;
  std::vector<OrbDescriptor> descriptors;
};

Extraction Extract(OrbExtractor* extractor, const cv::Mat& image) {
  Extraction e;
  extractor->Extract(image, &e.keypoints, &e.descriptors);
  return e;
}

// Signed difference a - b of two angles in degrees, in (-180, 180].
double AngleDifference(double a, double b) {
  double d = std::fmod(a - b, 360.0);
  if (d <= -180.0) d += 360.0;
  if (d > 180.0) d -= 360.0;
  return d;
}

// Fraction of the cells of a cols x rows grid over the image holding a keypoint.
double GridCoverage(const std::vector<Keypoint>& keypoints, int width, int height, int cols,
                    int rows) {
  std::vector<bool> hit(cols * rows, false);
  for (const Keypoint& k : keypoints) {
    const int c = std::clamp(static_cast<int>(k.pixel.x() * cols / width), 0, cols - 1);
    const int r = std::clamp(static_cast<int>(k.pixel.y() * rows / height), 0, rows - 1);
    hit[r * cols + c] = true;
  }
  return static_cast<double>(std::count(hit.begin(), hit.end(), true)) / (cols * rows);
}

void ExpectSameExtraction(const Extraction& a, const Extraction& b) {
  ASSERT_EQ(a.keypoints.size(), b.keypoints.size());
  for (size_t i = 0; i < a.keypoints.size(); ++i) {
    ASSERT_EQ(a.keypoints[i].pixel, b.keypoints[i].pixel) << i;
    ASSERT_EQ(a.keypoints[i].angle_deg, b.keypoints[i].angle_deg) << i;
    ASSERT_EQ(a.keypoints[i].octave, b.keypoints[i].octave) << i;
    ASSERT_EQ(a.keypoints[i].response, b.keypoints[i].response) << i;
    ASSERT_EQ(a.descriptors[i], b.descriptors[i]) << i;
  }
}

TEST(OrbExtractor, LevelScalesAndFeatureBudget) {
  const OrbSettings settings;  // 1000 features, 8 levels, scale 1.2.
  const OrbExtractor extractor(settings);
  ASSERT_EQ(extractor.scale_factors().size(), 8u);
  ASSERT_EQ(extractor.level_sigma2().size(), 8u);
  for (int l = 0; l < 8; ++l) {
    EXPECT_NEAR(extractor.scale_factors()[l], std::pow(1.2, l), 1e-12);
    EXPECT_NEAR(extractor.level_sigma2()[l], std::pow(1.44, l), 1e-12);
  }
  const std::vector<int>& per_level = extractor.features_per_level();
  ASSERT_EQ(per_level.size(), 8u);
  EXPECT_EQ(std::accumulate(per_level.begin(), per_level.end(), 0), 1000);
  // ORB-SLAM2's split, proportional to the level's linear scale (ratio 1 / 1.2,
  // not the area's 1 / 1.44): 217 181 151 126 105 87 73, the rest on level 7.
  const std::vector<int> orbslam2 = {217, 181, 151, 126, 105, 87, 73, 60};
  EXPECT_EQ(per_level, orbslam2);
  EXPECT_GT(per_level[7], 0);
}

TEST(OrbExtractor, RejectsInvalidSettingsAndImages) {
  OrbSettings bad;
  bad.n_levels = 0;
  EXPECT_THROW(OrbExtractor{bad}, std::invalid_argument);
  bad = {};
  bad.scale_factor = 1.0;
  EXPECT_THROW(OrbExtractor{bad}, std::invalid_argument);
  bad = {};
  bad.min_th_fast = 30;  // Above ini_th_fast.
  EXPECT_THROW(OrbExtractor{bad}, std::invalid_argument);
  bad = {};
  bad.n_features = 0;
  EXPECT_THROW(OrbExtractor{bad}, std::invalid_argument);
  EXPECT_THROW(OrbExtractor(OrbSettings{}, 0), std::invalid_argument);

  OrbExtractor extractor{OrbSettings{}};
  std::vector<Keypoint> keypoints;
  std::vector<OrbDescriptor> descriptors;
  const cv::Mat colour(120, 160, CV_8UC3, cv::Scalar(0, 0, 0));
  EXPECT_THROW(extractor.Extract(colour, &keypoints, &descriptors), std::invalid_argument);
  const cv::Mat depth(120, 160, CV_16UC1, cv::Scalar(0));
  EXPECT_THROW(extractor.Extract(depth, &keypoints, &descriptors), std::invalid_argument);
}

TEST(OrbExtractor, AboutNFeaturesOnTexturedImagesOnAllLevels) {
  OrbExtractor extractor{OrbSettings{}};
  for (uint64_t seed : {11u, 12u, 13u}) {
    const cv::Mat image = testing::MakeTexturedImage(640, 480, seed);
    const Extraction e = Extract(&extractor, image);
    EXPECT_GE(e.keypoints.size(), 950u) << "seed " << seed;
    EXPECT_LE(e.keypoints.size(), 1000u) << "seed " << seed;
    ASSERT_EQ(e.descriptors.size(), e.keypoints.size());
    std::vector<int> per_level(8, 0);
    for (const Keypoint& k : e.keypoints) {
      ASSERT_LT(k.octave, 8);
      ++per_level[k.octave];
      EXPECT_GE(k.pixel.x(), 0);
      EXPECT_LT(k.pixel.x(), 640);
      EXPECT_GE(k.pixel.y(), 0);
      EXPECT_LT(k.pixel.y(), 480);
      EXPECT_GE(k.angle_deg, 0.0f);
      EXPECT_LT(k.angle_deg, 360.0f);
      EXPECT_GE(k.response, OrbSettings{}.min_th_fast);
      EXPECT_EQ(k.undistorted, k.pixel);
      EXPECT_EQ(k.depth, 0.0f);
    }
    for (int l = 0; l < 8; ++l) {
      EXPECT_GT(per_level[l], 0) << "level " << l << " unused, seed " << seed;
      EXPECT_LE(per_level[l], extractor.features_per_level()[l]);
      EXPECT_GE(per_level[l], 0.9 * extractor.features_per_level()[l]) << "level " << l;
    }
    // Keypoints come level by level, each level in raster order.
    for (size_t i = 1; i < e.keypoints.size(); ++i) {
      const Keypoint& a = e.keypoints[i - 1];
      const Keypoint& b = e.keypoints[i];
      ASSERT_LE(a.octave, b.octave);
      if (a.octave == b.octave) {
        ASSERT_TRUE(a.pixel.y() < b.pixel.y() ||
                    (a.pixel.y() == b.pixel.y() && a.pixel.x() < b.pixel.x()));
      }
    }
  }
}

TEST(OrbExtractor, FeaturesSpreadOverTheImage) {
  OrbExtractor extractor{OrbSettings{}};
  const cv::Mat image = testing::MakeTexturedImage(640, 480, 21);
  const Extraction e = Extract(&extractor, image);
  EXPECT_GE(GridCoverage(e.keypoints, 640, 480, 8, 6), 0.8);
  // Level 0 alone covers the image too: the quadtree keeps it from clumping.
  std::vector<Keypoint> level0;
  for (const Keypoint& k : e.keypoints) {
    if (k.octave == 0) level0.push_back(k);
  }
  EXPECT_GE(GridCoverage(level0, 640, 480, 8, 6), 0.8);

  // A frame textured only on its left half keeps features everywhere there is
  // texture, and the right half (flat) gets none.
  cv::Mat half = image.clone();
  half(cv::Rect(320, 0, 320, 480)).setTo(128);
  const Extraction h = Extract(&extractor, half);
  int right = 0;
  for (const Keypoint& k : h.keypoints) right += k.pixel.x() > 340 ? 1 : 0;
  EXPECT_EQ(right, 0);
  EXPECT_GE(h.keypoints.size(), 900u);  // The left half has enough texture for the budget.
}

TEST(OrbExtractor, FastThresholdFallsBackInLowContrastCells) {
  // Low-contrast texture: few corners pass iniThFAST = 20, but minThFAST = 7
  // in the cells without any still finds features everywhere.
  OrbExtractor extractor{OrbSettings{}};
  cv::Mat faint;
  testing::MakeTexturedImage(640, 480, 31).convertTo(faint, CV_8UC1, 0.12, 110);
  const Extraction e = Extract(&extractor, faint);
  EXPECT_GE(GridCoverage(e.keypoints, 640, 480, 8, 6), 0.8);
  int weak = 0;
  for (const Keypoint& k : e.keypoints) weak += k.response < 20 ? 1 : 0;
  EXPECT_GT(weak, 100);

  // Without the fallback (minThFAST = iniThFAST) far fewer features survive.
  OrbSettings strict;
  strict.min_th_fast = strict.ini_th_fast;
  OrbExtractor strict_extractor(strict);
  const Extraction s = Extract(&strict_extractor, faint);
  EXPECT_LT(s.keypoints.size(), e.keypoints.size());
  for (const Keypoint& k : s.keypoints) EXPECT_GE(k.response, 20.0f);
}

TEST(OrbExtractor, OrientationPointsToTheIntensityCentroid) {
  // A bright square on a dark background: at each vertex the bright mass lies
  // inside the square, so the angle (atan2(m01, m10), y down) points inward:
  // 45 deg at the top-left vertex, 135 at top-right, 225 at bottom-right and
  // 315 at bottom-left.
  const cv::Mat image =
      testing::MakeNoisySquare(cv::Size(640, 480), cv::Rect(200, 140, 240, 200), 50, 190, 3, 6);
  OrbExtractor extractor{OrbSettings{}};
  const Extraction e = Extract(&extractor, image);
  struct Vertex {
    float x, y, angle;
  };
  for (const Vertex& v : {Vertex{200, 140, 45}, Vertex{439, 140, 135}, Vertex{439, 339, 225},
                          Vertex{200, 339, 315}}) {
    int found = 0;
    for (const Keypoint& k : e.keypoints) {
      if (k.octave > 2 || (k.pixel.vec() - Eigen::Vector2f(v.x, v.y)).norm() > 4.0f) continue;
      ++found;
      EXPECT_NEAR(AngleDifference(k.angle_deg, v.angle), 0.0, 8.0)
          << "vertex " << v.x << "," << v.y << " octave " << int(k.octave);
    }
    EXPECT_GT(found, 0) << "no keypoint at vertex " << v.x << "," << v.y;
  }
}

TEST(OrbExtractor, DescriptorIsRotatedBriefOnTheSmoothedLevel) {
  // Recomputes every descriptor from its definition: test i compares the
  // smoothed level image at the pattern's two points rotated by the angle.
  OrbExtractor extractor{OrbSettings{}};
  const cv::Mat image = testing::MakeTexturedImage(640, 480, 41);
  const Extraction e = Extract(&extractor, image);
  ASSERT_FALSE(e.keypoints.empty());
  size_t checked = 0;
  for (size_t i = 0; i < e.keypoints.size(); i += 7) {
    const Keypoint& k = e.keypoints[i];
    const cv::Mat& smoothed = extractor.blurred_pyramid()[k.octave];
    const cv::Mat& level = extractor.pyramid()[k.octave];
    ASSERT_EQ(smoothed.size(), level.size());
    // Level pixel of the keypoint (inverse of the level-0 mapping).
    const float sx = 640.0f / level.cols, sy = 480.0f / level.rows;
    const int x = static_cast<int>(std::lround((k.pixel.x() + 0.5f) / sx - 0.5f));
    const int y = static_cast<int>(std::lround((k.pixel.y() + 0.5f) / sy - 0.5f));
    const float radians = k.angle_deg * static_cast<float>(M_PI / 180.0);
    const float c = std::cos(radians), s = std::sin(radians);
    OrbDescriptor expected;
    for (int t = 0; t < kOrbPatternTests; ++t) {
      auto value = [&](float u, float v) {
        const int col = x + static_cast<int>(std::nearbyint(u * c - v * s));
        const int row = y + static_cast<int>(std::nearbyint(u * s + v * c));
        return smoothed.at<uint8_t>(row, col);
      };
      expected.SetBit(t, value(kOrbPattern[t][0], kOrbPattern[t][1]) <
                             value(kOrbPattern[t][2], kOrbPattern[t][3]));
    }
    EXPECT_EQ(HammingDistance(expected, e.descriptors[i]), 0) << "keypoint " << i;
    ++checked;
  }
  EXPECT_GT(checked, 100u);
  // The smoothing is the 7x7 Gaussian of sigma 2.
  cv::Mat reference;
  cv::GaussianBlur(extractor.pyramid()[3], reference, cv::Size(7, 7), 2.0, 2.0,
                   cv::BORDER_REFLECT_101);
  EXPECT_EQ(cv::norm(reference, extractor.blurred_pyramid()[3], cv::NORM_INF), 0.0);
}

TEST(OrbExtractor, PatternIsTheStandardOrbPattern) {
  // Spot checks of the table against the published pattern (first, second
  // and last tests) and its range.
  const int8_t first[4] = {8, -3, 9, 5}, second[4] = {4, 2, 7, -12}, last[4] = {-1, -6, 0, -11};
  for (int j = 0; j < 4; ++j) {
    EXPECT_EQ(kOrbPattern[0][j], first[j]);
    EXPECT_EQ(kOrbPattern[1][j], second[j]);
    EXPECT_EQ(kOrbPattern[255][j], last[j]);
  }
  long sum = 0;
  for (int i = 0; i < kOrbPatternTests; ++i) {
    for (int j = 0; j < 4; ++j) {
      EXPECT_GE(kOrbPattern[i][j], -13);
      EXPECT_LE(kOrbPattern[i][j], 12);
      sum += (i + 1) * (j + 1) * kOrbPattern[i][j];
    }
  }
  EXPECT_EQ(sum, -17372);  // Weighted checksum of the whole table (OpenCV 4.6 orb.cpp).
}

TEST(OrbExtractor, RotatedImageGivesRotatedAnglesAndMatchingDescriptors) {
  const cv::Mat image = testing::MakeTexturedImage(640, 480, 51);
  cv::Mat rotated;  // 90 deg clockwise: (x, y) -> (H - 1 - y, x).
  cv::rotate(image, rotated, cv::ROTATE_90_CLOCKWISE);
  OrbExtractor extractor{OrbSettings{}};
  const Extraction a = Extract(&extractor, image);
  const Extraction b = Extract(&extractor, rotated);
  ASSERT_GT(a.keypoints.size(), 900u);
  ASSERT_GT(b.keypoints.size(), 900u);

  // Keypoints found at the same place and level in both: the angle turns by
  // +90 deg (a direction (dx, dy) becomes (-dy, dx)) and the descriptor stays.
  int matched = 0, angle_ok = 0, descriptor_ok = 0;
  for (size_t i = 0; i < a.keypoints.size(); ++i) {
    const Keypoint& ka = a.keypoints[i];
    const Eigen::Vector2f expected(479.0f - ka.pixel.y(), ka.pixel.x());
    const float tolerance = 0.75f * static_cast<float>(extractor.scale_factors()[ka.octave]);
    for (size_t j = 0; j < b.keypoints.size(); ++j) {
      const Keypoint& kb = b.keypoints[j];
      if (kb.octave != ka.octave || (kb.pixel.vec() - expected).norm() > tolerance) continue;
      ++matched;
      angle_ok += std::abs(AngleDifference(kb.angle_deg, ka.angle_deg + 90.0)) < 3.0 ? 1 : 0;
      descriptor_ok += HammingDistance(a.descriptors[i], b.descriptors[j]) <= 50 ? 1 : 0;
      break;
    }
  }
  EXPECT_GT(matched, 600);
  EXPECT_GE(angle_ok, 0.95 * matched);
  EXPECT_GE(descriptor_ok, 0.95 * matched);

  // Without positions: most descriptors of the rotated image have their
  // nearest neighbour among the original's within Hamming distance 50.
  int close = 0;
  for (const OrbDescriptor& d : b.descriptors) {
    int best = 256;
    for (const OrbDescriptor& o : a.descriptors) best = std::min(best, HammingDistance(d, o));
    close += best <= 50 ? 1 : 0;
  }
  EXPECT_GE(close, 0.75 * b.descriptors.size());
}

TEST(OrbExtractor, DeterministicAndIndependentOfThreads) {
  const cv::Mat image = testing::MakeTexturedImage(640, 480, 61);
  OrbExtractor one{OrbSettings{}};
  OrbExtractor two(OrbSettings{}, 2);
  OrbExtractor three(OrbSettings{}, 3);
  EXPECT_EQ(two.num_threads(), 2);
  const Extraction reference = Extract(&one, image);
  ExpectSameExtraction(reference, Extract(&one, image));  // Buffers reused.
  ExpectSameExtraction(reference, Extract(&two, image));
  ExpectSameExtraction(reference, Extract(&three, image));
  // A different image in between leaves no trace.
  Extract(&two, testing::MakeTexturedImage(320, 240, 62));
  ExpectSameExtraction(reference, Extract(&two, image));
  // A moved extractor keeps working.
  OrbExtractor moved = std::move(two);
  ExpectSameExtraction(reference, Extract(&moved, image));
}

TEST(OrbExtractor, SmallAndFlatImages) {
  OrbExtractor extractor(OrbSettings{}, 2);
  // Flat: no corners at all.
  const Extraction flat = Extract(&extractor, cv::Mat(480, 640, CV_8UC1, cv::Scalar(77)));
  EXPECT_TRUE(flat.keypoints.empty());
  EXPECT_TRUE(flat.descriptors.empty());
  // Tiny images: levels smaller than the borders are simply empty.
  for (const cv::Size size :
       {cv::Size(1, 1), cv::Size(30, 20), cv::Size(45, 45), cv::Size(80, 60)}) {
    const cv::Mat image = testing::MakeTexturedImage(size.width, size.height, 71);
    const Extraction e = Extract(&extractor, image);
    EXPECT_EQ(e.keypoints.size(), e.descriptors.size());
    for (const Keypoint& k : e.keypoints) {
      EXPECT_GE(k.pixel.x(), OrbExtractor::kEdgeThreshold - 1.0f);
      EXPECT_LE(k.pixel.x(), size.width - OrbExtractor::kEdgeThreshold);
    }
  }
  // A non-contiguous view (ROI) is accepted.
  const cv::Mat big = testing::MakeTexturedImage(700, 520, 72);
  const Extraction roi = Extract(&extractor, big(cv::Rect(30, 20, 640, 480)));
  const Extraction copy = Extract(&extractor, big(cv::Rect(30, 20, 640, 480)).clone());
  ExpectSameExtraction(roi, copy);
}

TEST(OrbExtractor, LevelKeypointsMapToLevelZeroPixelCentres) {
  // A level-l keypoint at level pixel (x, y) sits at level-0 pixel
  // (x + 0.5) * W0 / Wl - 0.5: the same image point as cv::resize samples.
  OrbExtractor extractor{OrbSettings{}};
  const cv::Mat image = testing::MakeTexturedImage(640, 480, 81);
  const Extraction e = Extract(&extractor, image);
  for (const Keypoint& k : e.keypoints) {
    const cv::Mat& level = extractor.pyramid()[k.octave];
    const double sx = 640.0 / level.cols, sy = 480.0 / level.rows;
    const double lx = (k.pixel.x() + 0.5) / sx - 0.5;
    const double ly = (k.pixel.y() + 0.5) / sy - 0.5;
    ASSERT_NEAR(lx, std::round(lx), 1e-3);
    ASSERT_NEAR(ly, std::round(ly), 1e-3);
    ASSERT_GE(std::round(lx), OrbExtractor::kEdgeThreshold);
    ASSERT_LT(std::round(lx), level.cols - OrbExtractor::kEdgeThreshold);
    ASSERT_GE(std::round(ly), OrbExtractor::kEdgeThreshold);
    ASSERT_LT(std::round(ly), level.rows - OrbExtractor::kEdgeThreshold);
  }
  for (int l = 1; l < 8; ++l) {
    EXPECT_EQ(extractor.pyramid()[l].cols, std::lround(640 / std::pow(1.2, l)));
    EXPECT_EQ(extractor.pyramid()[l].rows, std::lround(480 / std::pow(1.2, l)));
  }
}

TEST(FinishKeypoints, UndistortsWithTheCameraAndReadsDepth) {
  const Distortion distortion{0.262383, -0.953104, -0.005358, 0.002628, 1.163314};  // tum1.
  const PinholeCamera camera(517.3, 516.5, 318.6, 255.3, 640, 480, distortion);
  cv::Mat depth(480, 640, CV_32FC1);
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) depth.at<float>(v, u) = 1.0f + 0.001f * u + 0.0001f * v;
  }
  depth.at<float>(100, 200) = 0.0f;                                     // No measurement.
  depth.at<float>(101, 200) = std::numeric_limits<float>::quiet_NaN();  // Invalid.
  depth.at<float>(102, 200) = -1.0f;                                    // Invalid.
  std::vector<Keypoint> keypoints(7);
  keypoints[0].pixel = {10.4f, 20.6f};  // Rounds to (10, 21).
  keypoints[1].pixel = {639.4f, 479.4f};
  keypoints[2].pixel = {200.0f, 100.0f};
  keypoints[3].pixel = {200.0f, 101.2f};
  keypoints[4].pixel = {199.6f, 102.0f};
  keypoints[5].pixel = {639.6f, 10.0f};  // Rounds outside the image.
  keypoints[6].pixel = {320.0f, 240.0f};
  FinishKeypoints(camera, depth, &keypoints);
  for (const Keypoint& k : keypoints) {
    const Eigen::Vector2d ideal = camera.UndistortPixel(k.pixel.cast<double>());
    EXPECT_NEAR(k.undistorted.x(), ideal.x(), 1e-3);
    EXPECT_NEAR(k.undistorted.y(), ideal.y(), 1e-3);
    // Consistent with the model: distorting the ideal pixel gives the pixel back.
    const Eigen::Vector2d back = camera.DistortPixel(k.undistorted.cast<double>());
    EXPECT_NEAR(back.x(), k.pixel.x(), 1e-2);
    EXPECT_NEAR(back.y(), k.pixel.y(), 1e-2);
  }
  EXPECT_FLOAT_EQ(keypoints[0].depth, 1.0f + 0.001f * 10 + 0.0001f * 21);
  EXPECT_FLOAT_EQ(keypoints[1].depth, 1.0f + 0.001f * 639 + 0.0001f * 479);
  EXPECT_EQ(keypoints[2].depth, 0.0f);
  EXPECT_EQ(keypoints[3].depth, 0.0f);
  EXPECT_EQ(keypoints[4].depth, 0.0f);
  EXPECT_EQ(keypoints[5].depth, 0.0f);
  EXPECT_FLOAT_EQ(keypoints[6].depth, 1.0f + 0.001f * 320 + 0.0001f * 240);
  // Distortion moves a pixel away from the centre noticeably with tum1's lens.
  EXPECT_GT((keypoints[0].undistorted.vec() - keypoints[0].pixel.vec()).norm(), 1.0f);

  // Without distortion the ideal pixel is the pixel; an empty depth image
  // leaves depth at 0; a depth image of the wrong type is refused.
  const PinholeCamera ideal_camera(500, 500, 320, 240, 640, 480);
  std::vector<Keypoint> more(1);
  more[0].pixel = {100.25f, 50.75f};
  more[0].depth = 3.0f;
  FinishKeypoints(ideal_camera, cv::Mat(), &more);
  EXPECT_EQ(more[0].undistorted, more[0].pixel);
  EXPECT_EQ(more[0].depth, 0.0f);
  EXPECT_THROW(FinishKeypoints(ideal_camera, cv::Mat(480, 640, CV_16UC1), &more),
               std::invalid_argument);
}

TEST(OrbExtractor, RealKitchenFrames) {
  RRSLAM_REQUIRE_SHARED_DATA(data);
  const std::filesystem::path dir = data / "7scenes-kitchen";
  if (!std::filesystem::exists(dir)) GTEST_SKIP() << "7scenes-kitchen not in shared data";
  const RgbdSequence sequence = RgbdSequence::Open(dir);
  const Settings settings = ReadSettings(data / "settings" / "7scenes.yaml");
  OrbExtractor extractor(settings.orb, 2);
  for (size_t i : {0u, 250u, 500u, 750u}) {
    const cv::Mat gray = sequence.LoadGray(i);
    const Extraction e = Extract(&extractor, gray);
    EXPECT_GE(e.keypoints.size(), 950u) << "frame " << i;
    EXPECT_LE(e.keypoints.size(), 1000u) << "frame " << i;
    std::vector<int> per_level(8, 0);
    for (const Keypoint& k : e.keypoints) ++per_level[k.octave];
    for (int l = 0; l < 8; ++l) EXPECT_GT(per_level[l], 0) << "frame " << i << " level " << l;
    EXPECT_GE(GridCoverage(e.keypoints, gray.cols, gray.rows, 8, 6), 0.8) << "frame " << i;
  }
  // Consecutive frames share most features: descriptors of frame 1 mostly
  // have a close neighbour in frame 0 (small motion between them).
  const Extraction f0 = Extract(&extractor, sequence.LoadGray(0));
  const Extraction f1 = Extract(&extractor, sequence.LoadGray(1));
  int close = 0;
  for (const OrbDescriptor& d : f1.descriptors) {
    int best = 256;
    for (const OrbDescriptor& o : f0.descriptors) best = std::min(best, HammingDistance(d, o));
    close += best <= 50 ? 1 : 0;
  }
  EXPECT_GE(close, 0.6 * f1.descriptors.size());
}

}  // namespace
}  // namespace rrslam
