#include "stages/track/data/frame.h"

#include <algorithm>
#include <cmath>

namespace rrslam {

void FrameFeatures::FeaturesInArea(const SensorModel& sensor, double x, double y, double r,
                                   int min_level, int max_level, std::vector<uint32_t>* out) const {
  const ImageBounds& b = sensor.bounds;
  const int min_col =
      std::max(0, static_cast<int>(std::floor((x - b.min_x - r) * sensor.grid_inv_cell_width)));
  const int max_col =
      std::min(SensorModel::kGridCols - 1,
               static_cast<int>(std::floor((x - b.min_x + r) * sensor.grid_inv_cell_width)));
  const int min_row =
      std::max(0, static_cast<int>(std::floor((y - b.min_y - r) * sensor.grid_inv_cell_height)));
  const int max_row =
      std::min(SensorModel::kGridRows - 1,
               static_cast<int>(std::floor((y - b.min_y + r) * sensor.grid_inv_cell_height)));
  if (min_col > max_col || min_row > max_row) return;
  const Grid& grid = GridFor(sensor);
  const bool check_levels = min_level > 0 || max_level >= 0;
  for (int row = min_row; row <= max_row; ++row) {
    for (int col = min_col; col <= max_col; ++col) {
      const int cell = row * SensorModel::kGridCols + col;
      for (uint32_t k = grid.begin[cell]; k < grid.begin[cell + 1]; ++k) {
        const uint32_t i = grid.indices[k];
        const Keypoint& kp = keypoints[i];
        if (check_levels) {
          if (kp.octave < min_level) continue;
          if (max_level >= 0 && kp.octave > max_level) continue;
        }
        if (std::abs(kp.undistorted.x() - x) < r && std::abs(kp.undistorted.y() - y) < r) {
          out->push_back(i);
        }
      }
    }
  }
}

// The grid, on the first call: a counting sort of the keypoints into cells.
const FrameFeatures::Grid& FrameFeatures::GridFor(const SensorModel& sensor) const {
  std::call_once(grid_built_, [&] {
    constexpr int kCells = SensorModel::kGridCols * SensorModel::kGridRows;
    const size_t n = keypoints.size();
    std::vector<int> cell_of(n, -1);
    std::vector<uint32_t> count(kCells + 1, 0);
    for (size_t i = 0; i < n; ++i) {
      int col, row;
      if (sensor.GridCell(keypoints[i].undistorted.x(), keypoints[i].undistorted.y(), &col, &row)) {
        cell_of[i] = row * SensorModel::kGridCols + col;
        ++count[cell_of[i] + 1];
      }
    }
    for (int c = 0; c < kCells; ++c) count[c + 1] += count[c];
    grid_.begin = count;
    grid_.indices.resize(count[kCells]);
    for (size_t i = 0; i < n; ++i) {
      if (cell_of[i] >= 0) grid_.indices[count[cell_of[i]]++] = static_cast<uint32_t>(i);
    }
  });
  return grid_;
}

std::shared_ptr<const FrameFeatures> BuildFrameFeatures(const SensorModel& sensor,
                                                        RecordArray<Keypoint> keypoints,
                                                        RecordArray<OrbDescriptor> descriptors) {
  const int n_levels = sensor.pyramid.n_levels;
  const auto bad_depth = [](float depth) { return !(std::isfinite(depth) && depth >= 0); };
  // Levels beyond the pyramid cannot come from these settings; they are
  // clamped so a lookup in the pyramid tables stays in range (the caller
  // checks the settings of a features file or map against the tracking
  // settings). Checked through const access first: writing to a view (a
  // map file's keypoints) copies it.
  const RecordArray<Keypoint>& read = keypoints;
  if (std::any_of(read.begin(), read.end(), [&](const Keypoint& kp) {
        return bad_depth(kp.depth) || kp.octave >= n_levels;
      })) {
    for (Keypoint& kp : keypoints) {
      if (bad_depth(kp.depth)) kp.depth = 0;
      if (kp.octave >= n_levels) kp.octave = uint8_t(n_levels - 1);
    }
  }
  auto features = std::make_shared<FrameFeatures>();
  features->u_right.resize(read.size());
  for (size_t i = 0; i < read.size(); ++i) {
    const Keypoint& kp = read[i];
    features->u_right[i] =
        kp.depth > 0 ? static_cast<float>(kp.undistorted.x() - sensor.bf / kp.depth) : -1.0f;
  }
  features->keypoints = std::move(keypoints);
  features->descriptors = std::move(descriptors);
  return features;
}

Frame::Frame(uint64_t id, double timestamp, std::shared_ptr<const FrameFeatures> features)
    : View(timestamp, features),
      map_points(features->size(), nullptr),
      outlier(features->size(), 0),
      id_(id) {}

void View::SetPose(const Rigid3d& T_cam_world) {
  T_cam_world_ = T_cam_world;
  T_world_cam_ = T_cam_world.Inverse();
  R_cam_world_ = T_cam_world.RotationMatrix();
  has_pose_ = true;
}

int FeatureVectorLevelsUp(int vocabulary_levels, bool small_vocabulary_groups) {
  if (!small_vocabulary_groups) return 4;
  const int depth = std::max(vocabulary_levels - 4, std::min(2, vocabulary_levels - 1));
  return vocabulary_levels - depth;
}

void View::ComputeBow(const Vocabulary& vocabulary, int levels_up) {
  if (has_bow_) return;
  vocabulary.Transform(features_->descriptors, &bow_, &feature_vector_, levels_up);
  has_bow_ = true;
}

Eigen::Vector3d View::UnprojectWorld(const SensorModel& sensor, size_t i) const {
  const Keypoint& kp = features_->keypoints[i];
  return T_world_cam_ * sensor.Unproject(kp.undistorted.x(), kp.undistorted.y(), kp.depth);
}

}  // namespace rrslam
