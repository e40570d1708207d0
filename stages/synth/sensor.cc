#include "stages/synth/sensor.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <vector>

#include "stages/synth/random.h"

namespace rrslam::synth {
namespace {

// Stream keys: independent random streams for the same (seed, frame).
constexpr uint64_t kHoleStream = 0x401e5;
constexpr uint64_t kNoiseStream = 0x9015e;
constexpr uint64_t kExposureStream = 0xe1905;

// Hole weights (see DepthSensorModel::hole_fraction).
constexpr double kEdgeWeight = 30.0;     // Within 2 px of a depth discontinuity.
constexpr double kFarStart = 3.5;        // Metres.
constexpr double kFarWeight = 3.0;       // Per metre beyond kFarStart.
constexpr double kGrazingCosine = 0.25;  // Below this incidence cosine...
constexpr double kGrazingWeight = 6.0;   // ...up to this much more.

}  // namespace

cv::Mat SimulateDepthSensor(const cv::Mat& depth, const cv::Mat& cos_incidence,
                            const DepthSensorModel& model, uint64_t seed, uint64_t frame) {
  assert(depth.type() == CV_32FC1 && cos_incidence.type() == CV_32FC1);
  assert(depth.size() == cos_incidence.size());
  const int width = depth.cols, height = depth.rows;
  // Depth as the miscalibrated sensor sees it, before noise and holes. With
  // scale_error = 0 this is the input exactly (x * 1.0 is exact), so the
  // output is bit-identical to a model without the bias.
  const double scale = 1.0 + model.scale_error;
  auto z_at = [&](int r, int c) { return scale * depth.ptr<float>(r)[c]; };

  // Probability of a hole per pixel.
  std::vector<float> hole_probability;
  if (model.hole_fraction > 0) {
    // Depth discontinuities: a jump to a 4-neighbour of more than 4% of the
    // depth (at least 2 cm), or a neighbour without depth.
    std::vector<uint8_t> edge(size_t(width) * height, 0);
    for (int r = 0; r < height; ++r) {
      for (int c = 0; c < width; ++c) {
        const float z = static_cast<float>(z_at(r, c));
        if (z <= 0) continue;
        const float threshold = std::max(0.02f, 0.04f * z);
        const int nbr[4][2] = {{r - 1, c}, {r + 1, c}, {r, c - 1}, {r, c + 1}};
        for (const auto& n : nbr) {
          if (n[0] < 0 || n[0] >= height || n[1] < 0 || n[1] >= width) continue;
          const float zn = static_cast<float>(z_at(n[0], n[1]));
          if (zn <= 0 || std::fabs(zn - z) > threshold) {
            edge[size_t(r) * width + c] = 1;
            break;
          }
        }
      }
    }
    // Edge zone: within 2 px (5 x 5 window) of a discontinuity.
    std::vector<uint8_t> zone(edge.size(), 0);
    for (int r = 0; r < height; ++r) {
      for (int c = 0; c < width; ++c) {
        if (!edge[size_t(r) * width + c]) continue;
        for (int rr = std::max(0, r - 2); rr <= std::min(height - 1, r + 2); ++rr) {
          for (int cc = std::max(0, c - 2); cc <= std::min(width - 1, c + 2); ++cc) {
            zone[size_t(rr) * width + cc] = 1;
          }
        }
      }
    }
    hole_probability.assign(edge.size(), 0.0f);
    double weight_sum = 0;
    size_t valid = 0;
    for (int r = 0; r < height; ++r) {
      const float* cosine = cos_incidence.ptr<float>(r);
      for (int c = 0; c < width; ++c) {
        const float z = static_cast<float>(z_at(r, c));
        if (z <= 0) continue;
        double w = 1.0;
        if (zone[size_t(r) * width + c]) w += kEdgeWeight;
        if (z > kFarStart) w += kFarWeight * (z - kFarStart);
        if (cosine[c] < kGrazingCosine) {
          w += kGrazingWeight * (kGrazingCosine - cosine[c]) / kGrazingCosine;
        }
        hole_probability[size_t(r) * width + c] = static_cast<float>(w);
        weight_sum += w;
        ++valid;
      }
    }
    const double scale = valid > 0 ? model.hole_fraction * valid / weight_sum : 0.0;
    for (float& p : hole_probability) p = static_cast<float>(std::min(1.0, p * scale));
  }

  cv::Mat out(height, width, CV_16UC1);
  const int blocks_per_row = (width + 1) / 2;
  for (int r = 0; r < height; ++r) {
    uint16_t* o = out.ptr<uint16_t>(r);
    double normals[2] = {0, 0};
    for (int c = 0; c < width; ++c) {
      // Standard normal deviates for pixel pairs (c, c + 1) from one
      // Box-Muller transform of a hash of the pair's index.
      if (model.noise_coefficient > 0 && c % 2 == 0) {
        const uint64_t key = HashKeys(seed, kNoiseStream, frame, uint64_t(r) * width + c);
        const double radius = std::sqrt(-2.0 * std::log(1.0 - UnitFromBits(Mix64(key))));
        const double angle = 6.283185307179586 * UnitFromBits(Mix64(key ^ 1));
        normals[0] = radius * std::cos(angle);
        normals[1] = radius * std::sin(angle);
      }
      const double z = z_at(r, c);
      o[c] = 0;
      if (z <= 0) continue;
      if (!hole_probability.empty()) {
        // One uniform per 2 x 2 block: holes come in small clumps.
        const uint64_t block = uint64_t(r / 2) * blocks_per_row + c / 2;
        if (UnitFromBits(HashKeys(seed, kHoleStream, frame, block)) <
            hole_probability[size_t(r) * width + c]) {
          continue;
        }
      }
      const double measured = z + model.noise_coefficient * z * z * normals[c % 2];
      const double units = std::round(measured * model.depth_map_factor);
      if (units >= 1.0 && units <= 65535.0) o[c] = static_cast<uint16_t>(units);
    }
  }
  return out;
}

double ExposureGain(double amplitude, double s, double duration, uint64_t seed) {
  if (amplitude == 0) return 1.0;
  const double two_pi = 2.0 * M_PI;
  const double m1 = std::max(1.0, std::round(duration / 8.0));
  const double m2 = std::max(2.0, std::round(duration / 2.5));
  const double p1 = two_pi * UnitFromBits(HashKeys(seed, kExposureStream, 1));
  const double p2 = two_pi * UnitFromBits(HashKeys(seed, kExposureStream, 2));
  return 1.0 +
         amplitude * (0.7 * std::sin(two_pi * m1 * s + p1) + 0.3 * std::sin(two_pi * m2 * s + p2));
}

}  // namespace rrslam::synth
