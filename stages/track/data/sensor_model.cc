#include "stages/track/data/sensor_model.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "common/errors.h"

namespace rrslam {

ScalePyramid::ScalePyramid(const OrbSettings& orb)
    : n_levels(orb.n_levels),
      scale_factor(orb.scale_factor),
      log_scale_factor(std::log(orb.scale_factor)) {
  scale.resize(n_levels);
  inv_scale.resize(n_levels);
  sigma2.resize(n_levels);
  inv_sigma2.resize(n_levels);
  double s = 1.0;
  for (int l = 0; l < n_levels; ++l) {
    scale[l] = s;
    inv_scale[l] = 1.0 / s;
    sigma2[l] = s * s;
    inv_sigma2[l] = 1.0 / (s * s);
    s *= scale_factor;
  }
}

SensorModel::SensorModel(const Settings& settings, int image_width, int image_height) {
  const int width = settings.width > 0 ? settings.width : image_width;
  const int height = settings.height > 0 ? settings.height : image_height;
  if (width <= 0 || height <= 0) {
    throw DataError("image size " + std::to_string(width) + "x" + std::to_string(height) +
                    " is not positive");
  }
  camera = PinholeCamera(settings.fx, settings.fy, settings.cx, settings.cy, width, height,
                         settings.distortion);
  fx = settings.fx;
  fy = settings.fy;
  cx = settings.cx;
  cy = settings.cy;
  inv_fx = 1.0 / fx;
  inv_fy = 1.0 / fy;
  bf = settings.bf;
  baseline = settings.Baseline();
  th_depth = settings.ThDepthMetres();
  disparity_sigma = settings.depth_noise.DisparitySigma(settings.bf);
  bounds = camera.UndistortedBounds();
  grid_inv_cell_width = kGridCols / (bounds.max_x - bounds.min_x);
  grid_inv_cell_height = kGridRows / (bounds.max_y - bounds.min_y);
  pyramid = ScalePyramid(settings.orb);
}

double SensorModel::StereoChi2(double eu, double ev, double eur, int octave) const {
  const double inv_sigma2 = pyramid.inv_sigma2[octave];
  if (disparity_sigma <= 0) return (eu * eu + ev * ev + eur * eur) * inv_sigma2;
  const double ed = (eu - eur) / disparity_sigma;
  return (eu * eu + ev * ev) * inv_sigma2 + ed * ed;
}

bool SensorModel::GridCell(double u, double v, int* col, int* row) const {
  // Cell [c, c + 1) holds the pixels that fall in it. (ORB-SLAM2 rounds to
  // the nearest cell instead, which drops keypoints in the last half cell.)
  const double fc = std::floor((u - bounds.min_x) * grid_inv_cell_width);
  const double fr = std::floor((v - bounds.min_y) * grid_inv_cell_height);
  if (!(fc >= 0 && fc < kGridCols && fr >= 0 && fr < kGridRows)) return false;
  const long c = static_cast<long>(fc);
  const long r = static_cast<long>(fr);
  if (c < 0 || c >= kGridCols || r < 0 || r >= kGridRows) return false;
  *col = static_cast<int>(c);
  *row = static_cast<int>(r);
  return true;
}

int SensorModel::PredictScaleLevel(double max_distance, double distance) const {
  const double ratio = max_distance / distance;
  const int level = static_cast<int>(std::ceil(std::log(ratio) / pyramid.log_scale_factor));
  return std::clamp(level, 0, pyramid.n_levels - 1);
}

}  // namespace rrslam
