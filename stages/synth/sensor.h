// Sensor effects of rrslam-synth: Kinect-like depth noise and holes, a depth
// scale bias, and a global exposure (brightness) change. Pure functions of
// their inputs and keys: a pixel's value depends only on (seed, frame index,
// pixel), never on threads.
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>

namespace rrslam::synth {

struct DepthSensorModel {
  // Depth scale error E, dimensionless (a fraction, not a percentage): the
  // sensor is miscalibrated by the factor 1 + E and reports (1 + E) * z for
  // a surface at true depth z, so E = 0.01 reads 1% long (2.02 m at 2 m) and
  // E = -0.01 1% short. Applied first: the axial noise and the hole model
  // below see the biased depth (their z is (1 + E) times the true depth).
  // 0 = calibrated (bit-identical to a model without this term).
  // rrslam-synth accepts (-0.5, 0.5).
  double scale_error = 0.0;
  // Axial noise: Gaussian with sigma = noise_coefficient * z^2 (metres, z in
  // metres), the Kinect v1 model of Khoshelham and Elberink (2012). 0 = exact.
  double noise_coefficient = 1.425e-3;
  // Expected fraction of pixels without depth (0 = none). Holes are placed
  // with a probability proportional to a weight that is high near depth
  // discontinuities (the sensor's shadows and mixed pixels), rises beyond
  // 3.5 m and at grazing incidence, and is 1 elsewhere; they come in 2 x 2
  // clumps.
  double hole_fraction = 0.02;
  // Depth image units per metre (16-bit PNG); values beyond 65535 units are
  // stored as 0 (no depth).
  double depth_map_factor = 5000.0;
};

// The 16-bit depth image (CV_16UC1) a Kinect-like sensor would give for exact
// depth `depth` (CV_32FC1, metres, 0 = no surface) with incidence cosines
// `cos_incidence` (CV_32FC1, same size): scaled by 1 + model.scale_error,
// then noisy and with holes. Deterministic in (seed, frame).
cv::Mat SimulateDepthSensor(const cv::Mat& depth, const cv::Mat& cos_incidence,
                            const DepthSensorModel& model, uint64_t seed, uint64_t frame);

// Exposure gain of frame phase s in [0, 1] (s = t / duration): 1 + amplitude *
// (0.7 sin(2 pi m1 s + p1) + 0.3 sin(2 pi m2 s + p2)), so |gain - 1| <=
// amplitude; m1 = max(1, round(duration / 8 s)) slow cycles and
// m2 = max(2, round(duration / 2.5 s)) faster ones, phases from the seed.
double ExposureGain(double amplitude, double s, double duration, uint64_t seed);

}  // namespace rrslam::synth
