// A 3-D landmark of the sparse map.
//
// Map points are created and owned by Map (map.h), which also performs every
// operation that touches more than the point itself (culling, replacement,
// observation bookkeeping on both sides). Ids are stable integers assigned in
// creation order; every ordered container and every iteration over points is
// by id, never by pointer value, so batch runs are reproducible bit for bit.
//
// Thread-safety: none of its own. The modules access map objects only while
// holding Map::mutex() (see map.h).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "common/orb_descriptor.h"
#include "stages/track/data/sensor_model.h"

namespace rrslam {

class KeyFrame;
using KeyFrameId = uint64_t;
using MapPointId = uint64_t;

class MapPoint {
 public:
  // One keyframe keypoint that measures this point.
  struct Observation {
    KeyFrame* keyframe;
    uint32_t index;  // Keypoint index in that keyframe.
  };

  MapPoint(MapPointId id, const Eigen::Vector3d& position_world, KeyFrame* reference_keyframe);

  MapPointId id() const { return id_; }
  // Id of the keyframe the point was created with (ORB-SLAM2's mnFirstKFid).
  KeyFrameId first_keyframe_id() const { return first_keyframe_id_; }

  const Eigen::Vector3d& position_world() const { return position_world_; }
  void SetPosition(const Eigen::Vector3d& position_world) { position_world_ = position_world; }

  // Observations sorted by keyframe id (each keyframe at most once).
  const std::vector<Observation>& observations() const { return observations_; }
  // Weighted count as ORB-SLAM2's Observations(): an observation whose
  // keypoint has depth counts 2 (it constrains the point like a stereo pair).
  int num_observations() const { return num_observations_; }
  // Keypoint index of this point in `keyframe`, or -1.
  int IndexIn(const KeyFrame* keyframe) const;
  bool IsObservedBy(const KeyFrame* keyframe) const { return IndexIn(keyframe) >= 0; }
  // Adds an observation; no-op when the keyframe already observes the point.
  // Only updates this point: Map::AddObservation updates both sides.
  void AddObservation(KeyFrame* keyframe, uint32_t index);
  // Room for `count` observations (a point loaded from a file).
  void ReserveObservations(size_t count) { observations_.reserve(count); }
  // Removes the observation of `keyframe`; returns false when there was none.
  // When it was the reference keyframe, the first remaining observer becomes it.
  bool RemoveObservation(const KeyFrame* keyframe);
  void ClearObservations();

  // Mean unit viewing direction (from the observing cameras to the point).
  const Eigen::Vector3d& normal() const { return normal_; }
  // Representative descriptor: the observation descriptor with the least
  // median Hamming distance to the others.
  const OrbDescriptor& descriptor() const { return descriptor_; }
  // Scale-invariance distances (metres): the point keeps its ORB scale
  // between these distances from a camera.
  double min_distance() const { return min_distance_; }
  double max_distance() const { return max_distance_; }
  // The range used to accept a projection (ORB-SLAM2: 0.8 min, 1.2 max).
  double MinDistanceInvariance() const { return 0.8 * min_distance_; }
  double MaxDistanceInvariance() const { return 1.2 * max_distance_; }

  KeyFrame* reference_keyframe() const { return reference_keyframe_; }

  // Times the point was predicted in a tracked frame's view / actually matched
  // there; culling keeps points found in at least a quarter of their views.
  int visible() const { return visible_; }
  int found() const { return found_; }
  void IncreaseVisible(int n = 1) { visible_ += n; }
  void IncreaseFound(int n = 1) { found_ += n; }
  double FoundRatio() const { return static_cast<double>(found_) / visible_; }

  // Culled or replaced points are bad; replaced_by() names the survivor of a
  // fusion (follow it to the current point).
  bool bad() const { return bad_; }
  MapPoint* replaced_by() const { return replaced_by_; }

  // Recomputes descriptor() from the observations.
  void ComputeDistinctiveDescriptor();
  // Recomputes normal() and the scale-invariance distances from the
  // observations and the reference keyframe (ORB-SLAM2's UpdateNormalAndDepth).
  void UpdateNormalAndDepth(const ScalePyramid& pyramid);
  // Expected pyramid level when seen from `distance` metres.
  int PredictScale(const SensorModel& sensor, double distance) const {
    return sensor.PredictScaleLevel(max_distance_, distance);
  }

  // Direct setters for the map's bookkeeping (Map) and for tests.
  void SetDescriptor(const OrbDescriptor& descriptor) { descriptor_ = descriptor; }
  void SetNormalAndDistances(const Eigen::Vector3d& normal, double min_distance,
                             double max_distance) {
    normal_ = normal;
    min_distance_ = min_distance;
    max_distance_ = max_distance;
  }
  void MarkBad(MapPoint* replaced_by) {
    bad_ = true;
    replaced_by_ = replaced_by;
  }
  // Loading a saved map (map_io.h): the counters and creation keyframe it was
  // saved with.
  void RestoreSaved(int visible, int found, KeyFrameId first_keyframe_id) {
    visible_ = visible;
    found_ = found;
    first_keyframe_id_ = first_keyframe_id;
  }

  // Restore mapping (LocalMapperOptions::cull_changed_points): the counters
  // at the start of this run, so a loaded point is judged by this run's
  // views only (SessionVisible / SessionFound).
  void StartSession() {
    session_visible_base_ = visible_;
    session_found_base_ = found_;
    evidence_ = {};
  }
  int SessionVisible() const { return visible_ - session_visible_base_; }
  int SessionFound() const { return found_ - session_found_base_; }
  // What this run's depth images said where the point was predicted and
  // not matched (DepthEvidenceAt; Tracker::CompareWithLocalMap). Not saved.
  struct SessionEvidence {
    int present = 0;       // Frames that measured a surface at its depth.
    int seen_through = 0;  // Frames that measured only depths beyond it.
    // Of those, from camera centres at least kDistinctViewMetres from the
    // last one counted: the same view again repeats its errors (a mixed
    // pixel at an edge, a reflection), a distinct one does not.
    int seen_through_views = 0;
    Eigen::Vector3d last_view_centre = Eigen::Vector3d::Zero();
  };
  static constexpr double kDistinctViewMetres = 0.05;
  const SessionEvidence& evidence() const { return evidence_; }
  void AddPresent() { ++evidence_.present; }
  void AddSeenThrough(const Eigen::Vector3d& camera_centre);

 private:
  MapPointId id_;
  KeyFrameId first_keyframe_id_;
  Eigen::Vector3d position_world_;
  std::vector<Observation> observations_;
  int num_observations_ = 0;
  Eigen::Vector3d normal_ = Eigen::Vector3d::Zero();
  OrbDescriptor descriptor_;
  double min_distance_ = 0;
  double max_distance_ = 0;
  KeyFrame* reference_keyframe_;
  int visible_ = 1;
  int found_ = 1;
  int session_visible_base_ = 0;
  int session_found_base_ = 0;
  SessionEvidence evidence_;
  bool bad_ = false;
  MapPoint* replaced_by_ = nullptr;
};

}  // namespace rrslam
