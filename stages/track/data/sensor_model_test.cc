#include "stages/track/data/sensor_model.h"

#include <gtest/gtest.h>

#include "stages/track/test_scene.h"

namespace rrslam {
namespace {

// The chi-square statistic of a keypoint whose depth reading is `dz` metres
// off a point at depth `z` (pixels exact, pyramid level 0).
double DepthChi2(const SensorModel& sensor, double z, double dz) {
  // u_R = u - bf / z: the observed and predicted right coordinates differ by
  // the disparities' difference.
  const double eur = sensor.bf / (z + dz) - sensor.bf / z;
  return sensor.StereoChi2(0, 0, eur, 0);
}

// The quadratic model: a depth error of one sigma_z = k2 z^2 weighs as one
// standard deviation at 1 m and at 4 m alike, so at 4 m a depth reading is
// trusted 16 times less in metres (256 times less in weight).
TEST(SensorModelTest, QuadraticDepthNoiseWeighsOneSigmaAsOneAtEveryDepth) {
  Settings settings = testing::TestSettings();  // bf = 40.
  settings.depth_noise = {DepthNoise::Model::kQuadratic, 1.5e-3, 0.0};
  const SensorModel sensor(settings, 640, 480);
  EXPECT_DOUBLE_EQ(sensor.disparity_sigma, 40 * 1.5e-3);
  // Errors of a tenth of sigma, where 1 / z is close to linear: chi2 = 0.01.
  for (double z : {1.0, 4.0}) {
    const double sigma_z = 1.5e-3 * z * z;  // 1.5 mm at 1 m, 24 mm at 4 m.
    EXPECT_NEAR(DepthChi2(sensor, z, 0.1 * sigma_z) / 0.01, 1.0, 0.01) << z;
    EXPECT_NEAR(DepthChi2(sensor, z, -0.1 * sigma_z) / 0.01, 1.0, 0.01) << z;
  }
}

// ORB-SLAM2's weighting is the same law with 1 px of disparity: sigma_z =
// z^2 / bf, 2.5 cm at 1 m and 40 cm at 4 m, 16.7 times the Kinect's.
TEST(SensorModelTest, OrbSlam2WeighsDepthAsOnePixelOfDisparity) {
  const SensorModel sensor(testing::TestSettings(), 640, 480);
  EXPECT_EQ(sensor.disparity_sigma, 0.0);
  for (double z : {1.0, 4.0}) {
    EXPECT_NEAR(DepthChi2(sensor, z, 0.1 * z * z / 40) / 0.01, 1.0, 0.025) << z;
    // The Kinect's one sigma is 0.06 of ORB-SLAM2's: chi2 0.0036.
    EXPECT_NEAR(DepthChi2(sensor, z, 1.5e-3 * z * z) / 0.0036, 1.0, 0.02) << z;
  }
}

}  // namespace
}  // namespace rrslam
