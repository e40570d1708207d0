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

TEST(DepthSensor, ScaleErrorBiasesEveryDepth) {
  DepthSensorModel model;
  model.noise_coefficient = 0;
  model.hole_fraction = 0;
  const cv::Mat depth(60, 80, CV_32FC1, cv::Scalar(2.0f));
  const cv::Mat facing = Facing(depth);
  auto metres = [](const cv::Mat& out) {
    cv::Mat m;
    out.convertTo(m, CV_64F, 1.0 / 5000.0);
    return m;
  };
  // Calibrated: the exact depth.
  const cv::Mat exact = SimulateDepthSensor(depth, facing, model, 0, 0);
  EXPECT_EQ(cv::countNonZero(exact != 10000), 0);
  // 1% too far, 1% too near: every pixel, within the 1/5000 m quantization.
  const double step = 1.0 / model.depth_map_factor;
  for (double e : {0.01, -0.01}) {
    model.scale_error = e;
    const cv::Mat out = SimulateDepthSensor(depth, facing, model, 0, 0);
    double lo = 0, hi = 0;
    cv::minMaxLoc(metres(out), &lo, &hi);
    EXPECT_NEAR(lo, 2.0 * (1 + e), 0.5 * step + 1e-12) << e;
    EXPECT_NEAR(hi, 2.0 * (1 + e), 0.5 * step + 1e-12) << e;
  }
  // Back to 0: bit-identical to the default model.
  model.scale_error = 0;
  EXPECT_EQ(cv::norm(SimulateDepthSensor(depth, facing, model, 0, 0), exact, cv::NORM_INF), 0.0);
  // A depth pushed beyond 16 bits by the bias is reported as no depth.
  model.scale_error = 0.2;
  const cv::Mat far(4, 4, CV_32FC1, cv::Scalar(12.0f));  // 14.4 m > 13.107 m.
  EXPECT_EQ(cv::countNonZero(SimulateDepthSensor(far, Facing(far), model, 0, 0)), 0);
}

TEST(DepthSensor, ScaleErrorKeepsTheRandomDraws) {
  // With noise and holes on, E = 0 gives the default model's image exactly,
  // and E != 0 keeps the same holes (on a flat scene, where the hole weights
  // do not change) and the same noise deviates, scaled with the depth.
  DepthSensorModel model;
  model.hole_fraction = 0.1;
  const cv::Mat depth(120, 160, CV_32FC1, cv::Scalar(2.0f));
  const cv::Mat facing = Facing(depth);
  const cv::Mat base = SimulateDepthSensor(depth, facing, model, 5, 2);
  model.scale_error = 0.0;
  EXPECT_EQ(cv::norm(SimulateDepthSensor(depth, facing, model, 5, 2), base, cv::NORM_INF), 0.0);
  model.scale_error = 0.01;
  const cv::Mat biased = SimulateDepthSensor(depth, facing, model, 5, 2);
  EXPECT_EQ(cv::countNonZero((base == 0) != (biased == 0)), 0);
  EXPECT_GT(cv::countNonZero(base == 0), 0);
  // measured = z' + k z'^2 n with z' = 1.01 z: the noise-free part moves by
  // 2 cm and the deviation by a factor 1.01^2.
  const double k = model.noise_coefficient, z = 2.0, zb = 2.02;
  for (int r = 0; r < depth.rows; ++r) {
    for (int c = 0; c < depth.cols; ++c) {
      if (base.at<uint16_t>(r, c) == 0) continue;
      const double n = (base.at<uint16_t>(r, c) / 5000.0 - z) / (k * z * z);
      EXPECT_NEAR(biased.at<uint16_t>(r, c) / 5000.0, zb + k * zb * zb * n, 1.1 / 5000.0)
          << r << " " << c;
    }
  }
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
