#include "stages/track/data/map_point.h"

#include <algorithm>
#include <limits>

#include "stages/track/data/keyframe.h"

namespace rrslam {

MapPoint::MapPoint(MapPointId id, const Eigen::Vector3d& position_world,
                   KeyFrame* reference_keyframe)
    : id_(id),
      first_keyframe_id_(reference_keyframe != nullptr ? reference_keyframe->id() : 0),
      position_world_(position_world),
      reference_keyframe_(reference_keyframe) {}

int MapPoint::IndexIn(const KeyFrame* keyframe) const {
  for (const Observation& o : observations_) {
    if (o.keyframe == keyframe) return static_cast<int>(o.index);
  }
  return -1;
}

void MapPoint::AddSeenThrough(const Eigen::Vector3d& camera_centre) {
  if (evidence_.seen_through_views == 0 ||
      (camera_centre - evidence_.last_view_centre).norm() >= kDistinctViewMetres) {
    ++evidence_.seen_through_views;
    evidence_.last_view_centre = camera_centre;
  }
  ++evidence_.seen_through;
}

void MapPoint::AddObservation(KeyFrame* keyframe, uint32_t index) {
  auto it =
      std::lower_bound(observations_.begin(), observations_.end(), keyframe->id(),
                       [](const Observation& o, KeyFrameId id) { return o.keyframe->id() < id; });
  if (it != observations_.end() && it->keyframe == keyframe) return;
  observations_.insert(it, {keyframe, index});
  num_observations_ += keyframe->features().HasDepth(index) ? 2 : 1;
}

bool MapPoint::RemoveObservation(const KeyFrame* keyframe) {
  for (auto it = observations_.begin(); it != observations_.end(); ++it) {
    if (it->keyframe != keyframe) continue;
    num_observations_ -= keyframe->features().HasDepth(it->index) ? 2 : 1;
    observations_.erase(it);
    if (reference_keyframe_ == keyframe) {
      reference_keyframe_ = observations_.empty() ? nullptr : observations_.front().keyframe;
    }
    return true;
  }
  return false;
}

void MapPoint::ClearObservations() {
  observations_.clear();
  num_observations_ = 0;
}

void MapPoint::ComputeDistinctiveDescriptor() {
  if (bad_) return;
  std::vector<const OrbDescriptor*> descriptors;
  descriptors.reserve(observations_.size());
  for (const Observation& o : observations_) {
    if (!o.keyframe->bad()) descriptors.push_back(&o.keyframe->features().descriptors[o.index]);
  }
  const size_t n = descriptors.size();
  if (n == 0) return;
  std::vector<int> distances(n * n, 0);
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = i + 1; j < n; ++j) {
      const int d = HammingDistance(*descriptors[i], *descriptors[j]);
      distances[i * n + j] = d;
      distances[j * n + i] = d;
    }
  }
  // The descriptor whose median distance to the others is least (ties: the
  // observation of the lowest keyframe id).
  int best_median = std::numeric_limits<int>::max();
  size_t best = 0;
  std::vector<int> row(n);
  for (size_t i = 0; i < n; ++i) {
    std::copy(distances.begin() + i * n, distances.begin() + (i + 1) * n, row.begin());
    const size_t mid = (n - 1) / 2;
    std::nth_element(row.begin(), row.begin() + mid, row.end());
    if (row[mid] < best_median) {
      best_median = row[mid];
      best = i;
    }
  }
  descriptor_ = *descriptors[best];
}

void MapPoint::UpdateNormalAndDepth(const ScalePyramid& pyramid) {
  if (bad_ || observations_.empty() || reference_keyframe_ == nullptr) return;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  int n = 0;
  for (const Observation& o : observations_) {
    const Eigen::Vector3d ray = position_world_ - o.keyframe->camera_centre();
    const double norm = ray.norm();
    if (norm > 0) {
      normal += ray / norm;
      ++n;
    }
  }
  const int ref_index = IndexIn(reference_keyframe_);
  if (ref_index < 0 || n == 0) return;
  const double distance = (position_world_ - reference_keyframe_->camera_centre()).norm();
  const int level = reference_keyframe_->features().Octave(ref_index);
  max_distance_ = distance * pyramid.scale[level];
  min_distance_ = max_distance_ / pyramid.scale[pyramid.n_levels - 1];
  normal_ = normal / n;
}

}  // namespace rrslam
