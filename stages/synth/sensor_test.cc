#include "stages/synth/sensor.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>

namespace rrslam::synth {
namespace {

// Depth of a scene with a near box (1.5 m) in front of a far wall: a
// staircase of depth edges, plus a band beyond 4 m.
cv::Mat StepDepth() {
  cv::Mat depth(240, 320, CV_32FC1, cv::Scalar(3.0f));
  depth(cv::Rect(100, 60, 120, 120)).setTo(1.5f);
  depth(cv::Rect(0, 200, 320, 40)).setTo(4.8f);
  return depth;
}

cv::Mat Facing(const cv::Mat& depth) { return cv::Mat(depth.size(), CV_32FC1, cv::Scalar(1.0f)); }

TEST(DepthSensor, ExactWithoutNoiseAndHoles) {
  DepthSensorModel model;
  model.noise_coefficient = 0;
  model.hole_fraction = 0;
  cv::Mat depth = StepDepth();
  depth.at<float>(5, 5) = 0.0f;     // No surface.
  depth.at<float>(6, 6) = 1.2345f;  // Rounded to 1/5000 m.
  depth.at<float>(7, 7) = 20.0f;    // Beyond 16 bits: no depth.
  const cv::Mat out = SimulateDepthSensor(depth, Facing(depth), model, 0, 0);
  ASSERT_EQ(out.type(), CV_16UC1);
  EXPECT_EQ(out.at<uint16_t>(0, 0), 15000);
  EXPECT_EQ(out.at<uint16_t>(100, 150), 7500);
  EXPECT_EQ(out.at<uint16_t>(5, 5), 0);
  EXPECT_EQ(out.at<uint16_t>(6, 6), std::lround(1.2345f * 5000.0));
  EXPECT_EQ(out.at<uint16_t>(7, 7), 0);
}

TEST(DepthSensor, NoiseGrowsWithTheSquareOfDepth) {
  DepthSensorModel model;
  model.hole_fraction = 0;
  for (float z : {1.0f, 3.0f, 5.0f}) {
    const cv::Mat depth(400, 400, CV_32FC1, cv::Scalar(z));
    const cv::Mat out = SimulateDepthSensor(depth, Facing(depth), model, 7, 3);
    cv::Mat metres;
    out.convertTo(metres, CV_64F, 1.0 / 5000.0);
    cv::Scalar mean, stddev;
    cv::meanStdDev(metres, mean, stddev);
    const double sigma = 1.425e-3 * z * z;
    EXPECT_NEAR(mean[0], z, 0.01 * sigma + 1e-4) << z;
    // Quantization (0.2 mm steps) adds 0.058 mm rms.
    const double expected = std::sqrt(sigma * sigma + std::pow(0.0002, 2) / 12);
    EXPECT_NEAR(stddev[0], expected, 0.02 * expected) << z;
  }
}

TEST(DepthSensor, HolesHitEdgesAndFarRangeFirst) {
  DepthSensorModel model;
  model.noise_coefficient = 0;
  model.hole_fraction = 0.05;
  const cv::Mat depth = StepDepth();
  const cv::Mat out = SimulateDepthSensor(depth, Facing(depth), model, 1, 0);
  const double fraction = static_cast<double>(cv::countNonZero(out == 0)) / out.total();
  EXPECT_NEAR(fraction, 0.05, 0.01);
  // Rates: around the box outline, on the far band, on flat near areas.
  auto hole_rate = [&](const cv::Rect& r) {
    return static_cast<double>(cv::countNonZero(out(r) == 0)) / r.area();
  };
  const double edge = hole_rate(cv::Rect(98, 60, 5, 120));  // The box's left edge.
  const double far = hole_rate(cv::Rect(0, 205, 320, 35));
  const double flat = hole_rate(cv::Rect(130, 90, 60, 60));
  EXPECT_GT(edge, 5 * flat);
  EXPECT_GT(far, 1.5 * flat);
  EXPECT_GT(flat, 0.0);
  // Grazing incidence raises the rate too.
  cv::Mat cosine = Facing(depth);
  cosine(cv::Rect(0, 0, 320, 50)).setTo(0.05f);
  const cv::Mat grazing = SimulateDepthSensor(depth, cosine, model, 1, 0);
  EXPECT_GT(cv::countNonZero(grazing(cv::Rect(0, 0, 320, 50)) == 0),
            2 * cv::countNonZero(out(cv::Rect(0, 0, 320, 50)) == 0));
}

TEST(DepthSensor, DeterministicPerSeedAndFrame) {
  const DepthSensorModel model;
  const cv::Mat depth = StepDepth();
  const cv::Mat a = SimulateDepthSensor(depth, Facing(depth), model, 3, 10);
  const cv::Mat b = SimulateDepthSensor(depth, Facing(depth), model, 3, 10);
  const cv::Mat other_frame = SimulateDepthSensor(depth, Facing(depth), model, 3, 11);
  const cv::Mat other_seed = SimulateDepthSensor(depth, Facing(depth), model, 4, 10);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::countNonZero(a != other_frame), static_cast<int>(a.total() / 2));
  EXPECT_GT(cv::countNonZero(a != other_seed), static_cast<int>(a.total() / 2));
}

TEST(ExposureGain, StaysWithinTheAmplitudeAndVaries) {
  EXPECT_EQ(ExposureGain(0.0, 0.3, 10.0, 1), 1.0);
  double lo = 2, hi = 0;
  for (int i = 0; i <= 300; ++i) {
    const double g = ExposureGain(0.3, i / 300.0, 10.0, 1);
    EXPECT_LE(std::fabs(g - 1.0), 0.3 + 1e-12);
    lo = std::min(lo, g);
    hi = std::max(hi, g);
  }
  EXPECT_GT(hi - lo, 0.3);
  EXPECT_NE(ExposureGain(0.3, 0.2, 10.0, 1), ExposureGain(0.3, 0.2, 10.0, 2));
}

}  // namespace
}  // namespace rrslam::synth
