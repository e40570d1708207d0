// Test helper: a small map whose geometry is known, consistent enough for
// ValidateMapData: keyframes at given poses, points at given positions, each
// point observed by every keyframe that sees it (in front, inside the image)
// at the keypoint where it projects.
#pragma once

#include <algorithm>
#include <cmath>
#include <map>
#include <vector>

#include "common/geometry.h"
#include "stages/mapstore/map_data.h"

namespace rrslam::testing {

inline MapCamera RenderTestCamera() {
  MapCamera camera;
  camera.fx = camera.fy = 500;
  camera.cx = 320;
  camera.cy = 240;
  camera.width = 640;
  camera.height = 480;
  camera.bf = 40;
  camera.th_depth = 40;
  camera.depth_map_factor = 5000;
  camera.orb_features = 1000;
  camera.orb_scale_factor = 1.2;
  camera.orb_levels = 8;
  camera.orb_ini_th_fast = 20;
  camera.orb_min_th_fast = 7;
  return camera;
}

// Keyframe i has id 10 * i + 1, timestamp 100 + i, pose T_world_cam[i].
// With max_observations > 0 a point keeps at most that many of the
// keyframes that see it, spread evenly over them.
inline MapData MakeKnownMap(const std::vector<Rigid3d>& T_world_cam,
                            const std::vector<Eigen::Vector3d>& points,
                            const MapCamera& camera = RenderTestCamera(),
                            size_t max_observations = 0) {
  MapData map;
  map.camera = camera;
  map.vocabulary = {0x1234, 10, 6, 0, 0, 1000000, "voc.rrv"};
  map.metadata = R"({"producer":"render test"})";
  const size_t n_kf = T_world_cam.size();
  map.keyframes.resize(n_kf);
  for (size_t i = 0; i < n_kf; ++i) {
    KeyFrameRecord& kf = map.keyframes[i];
    kf.id = 10 * i + 1;
    kf.frame_id = i;
    kf.timestamp = 100.0 + static_cast<double>(i);
    const Rigid3d T_cam_world = T_world_cam[i].Inverse();
    kf.T_cam_world = {T_cam_world.rotation.w(),    T_cam_world.rotation.x(),
                      T_cam_world.rotation.y(),    T_cam_world.rotation.z(),
                      T_cam_world.translation.x(), T_cam_world.translation.y(),
                      T_cam_world.translation.z()};
    kf.parent = i == 0 ? kNoId : map.keyframes[i - 1].id;
  }
  std::map<std::pair<size_t, size_t>, int> shared;
  for (size_t j = 0; j < points.size(); ++j) {
    MapPointRecord mp;
    mp.id = 7 * j + 3;
    for (int k = 0; k < 3; ++k) mp.position[k] = points[j][k];
    const auto project = [&](size_t i, Eigen::Vector3d* p, double* u, double* v) {
      *p = T_world_cam[i].Inverse() * points[j];
      if (p->z() <= 0.05) return false;
      *u = camera.fx * p->x() / p->z() + camera.cx;
      *v = camera.fy * p->y() / p->z() + camera.cy;
      return *u >= 0 && *v >= 0 && *u < camera.width && *v < camera.height;
    };
    std::vector<size_t> seeing;
    for (size_t i = 0; i < n_kf; ++i) {
      Eigen::Vector3d p;
      double u = 0, v = 0;
      if (project(i, &p, &u, &v)) seeing.push_back(i);
    }
    if (max_observations > 0 && seeing.size() > max_observations) {
      std::vector<size_t> kept;
      for (size_t k = 0; k < max_observations; ++k) {
        kept.push_back(seeing[k * seeing.size() / max_observations]);
      }
      seeing = kept;
    }
    std::vector<size_t> seen;
    Eigen::Vector3d mean_direction = Eigen::Vector3d::Zero();
    for (size_t i : seeing) {
      Eigen::Vector3d p;
      double u = 0, v = 0;
      project(i, &p, &u, &v);
      KeyFrameRecord& kf = map.keyframes[i];
      Keypoint keypoint;
      keypoint.pixel = keypoint.undistorted = {static_cast<float>(u), static_cast<float>(v)};
      keypoint.depth = static_cast<float>(p.z());
      mp.observations.push_back({kf.id, static_cast<uint32_t>(kf.keypoints.size())});
      kf.keypoints.push_back(keypoint);
      kf.descriptors.emplace_back();
      kf.map_point_ids.push_back(mp.id);
      mean_direction += (points[j] - T_world_cam[i].translation).normalized();
      seen.push_back(i);
    }
    if (seen.empty()) continue;  // Seen by no keyframe: not part of the map.
    const Eigen::Vector3d normal = mean_direction.normalized();
    for (int k = 0; k < 3; ++k) mp.normal[k] = normal[k];
    mp.min_distance = 0.1;
    mp.max_distance = 10;
    mp.visible = mp.found = static_cast<int32_t>(seen.size());
    mp.reference_keyframe = mp.first_keyframe = map.keyframes[seen.front()].id;
    for (size_t a : seen)
      for (size_t b : seen)
        if (a != b) ++shared[{a, b}];
    map.map_points.push_back(mp);
  }
  for (const auto& [pair, count] : shared) {
    map.keyframes[pair.first].connections.push_back({map.keyframes[pair.second].id, count});
  }
  map.next_keyframe_id = 10 * n_kf + 1;
  map.next_map_point_id = 7 * points.size() + 3;
  return map;
}

}  // namespace rrslam::testing
