#include "stages/mapstore/map_join.h"

#include <algorithm>
#include <string>
#include <unordered_map>

#include "common/errors.h"

namespace rrslam {
namespace {

KeyFrameRecord* FindKeyFrame(MapData* map, uint64_t id) {
  auto it = std::lower_bound(map->keyframes.begin(), map->keyframes.end(), id,
                             [](const KeyFrameRecord& k, uint64_t v) { return k.id < v; });
  return it != map->keyframes.end() && it->id == id ? &*it : nullptr;
}

// Renumbers b's ids after a's and moves it by T_a_b.
void MoveIntoA(const Rigid3d& T_a_b, uint64_t kf_offset, uint64_t point_offset, MapData* b) {
  MoveMap(T_a_b, b);
  const auto kf_id = [&](uint64_t id) { return id == kNoId ? kNoId : id + kf_offset; };
  const auto point_id = [&](uint64_t id) { return id == kNoId ? kNoId : id + point_offset; };
  for (KeyFrameRecord& kf : b->keyframes) {
    kf.id = kf_id(kf.id);
    for (uint64_t& p : kf.map_point_ids) p = point_id(p);
    for (auto& [other, weight] : kf.connections) other = kf_id(other);
    kf.parent = kf_id(kf.parent);
    for (uint64_t& other : kf.loop_edges) other = kf_id(other);
  }
  for (MapPointRecord& p : b->map_points) {
    p.id = point_id(p.id);
    p.reference_keyframe = kf_id(p.reference_keyframe);
    p.first_keyframe = kf_id(p.first_keyframe);
    for (auto& [kf, index] : p.observations) kf = kf_id(kf);
  }
}

// Reverses the parent links from `new_root` up to b's root, then hangs
// `new_root` under `parent`.
void Reroot(MapData* b, KeyFrameRecord* new_root, uint64_t parent) {
  uint64_t child = parent;
  KeyFrameRecord* node = new_root;
  while (node != nullptr) {
    const uint64_t up = node->parent;
    node->parent = child;
    child = node->id;
    node = up == kNoId ? nullptr : FindKeyFrame(b, up);
  }
}

void AddLoopEdge(KeyFrameRecord* kf, uint64_t other) {
  auto it = std::lower_bound(kf->loop_edges.begin(), kf->loop_edges.end(), other);
  if (it == kf->loop_edges.end() || *it != other) kf->loop_edges.insert(it, other);
}

}  // namespace

Rigid3d RigidOf(const MapPose& p) {
  return Rigid3d(Eigen::Quaterniond(p.qw, p.qx, p.qy, p.qz), Eigen::Vector3d(p.tx, p.ty, p.tz));
}

MapPose MapPoseOf(const Rigid3d& T) {
  MapPose p;
  p.qw = T.rotation.w();
  p.qx = T.rotation.x();
  p.qy = T.rotation.y();
  p.qz = T.rotation.z();
  p.tx = T.translation.x();
  p.ty = T.translation.y();
  p.tz = T.translation.z();
  return p;
}

void MoveMap(const Rigid3d& T_new_old, MapData* map) {
  const Rigid3d T_old_new = T_new_old.Inverse();
  for (KeyFrameRecord& kf : map->keyframes) {
    kf.T_cam_world = MapPoseOf(RigidOf(kf.T_cam_world) * T_old_new);
  }
  const Eigen::Matrix3d R_new_old = T_new_old.RotationMatrix();
  for (MapPointRecord& p : map->map_points) {
    const Eigen::Vector3d position =
        T_new_old * Eigen::Vector3d(p.position[0], p.position[1], p.position[2]);
    const Eigen::Vector3d normal =
        R_new_old * Eigen::Vector3d(p.normal[0], p.normal[1], p.normal[2]);
    for (int i = 0; i < 3; ++i) {
      p.position[i] = position[i];
      p.normal[i] = normal[i];
    }
  }
}

MapData JoinMaps(MapData a, MapData b, const Rigid3d& T_a_b, uint64_t a_keyframe,
                 uint64_t b_keyframe, const std::string& source) {
  if (FindKeyFrame(&a, a_keyframe) == nullptr || FindKeyFrame(&b, b_keyframe) == nullptr) {
    throw DataError(source + ": keyframe " + std::to_string(a_keyframe) + " of the first map or " +
                    std::to_string(b_keyframe) + " of the second is not in it");
  }
  const uint64_t next_keyframe = a.next_keyframe_id + b.next_keyframe_id;
  const uint64_t next_point = a.next_map_point_id + b.next_map_point_id;
  if (next_keyframe < a.next_keyframe_id || next_point < a.next_map_point_id ||
      next_keyframe > MaxNextMapId(a.keyframes.size() + b.keyframes.size()) ||
      next_point > MaxNextMapId(a.map_points.size() + b.map_points.size())) {
    throw DataError(source + ": the joined map's ids would exceed the bound of its size");
  }
  const uint64_t b_root = b_keyframe + a.next_keyframe_id;
  MoveIntoA(T_a_b, a.next_keyframe_id, a.next_map_point_id, &b);
  Reroot(&b, FindKeyFrame(&b, b_root), a_keyframe);
  AddLoopEdge(FindKeyFrame(&b, b_root), a_keyframe);
  AddLoopEdge(FindKeyFrame(&a, a_keyframe), b_root);
  std::move(b.keyframes.begin(), b.keyframes.end(), std::back_inserter(a.keyframes));
  std::move(b.map_points.begin(), b.map_points.end(), std::back_inserter(a.map_points));
  a.next_keyframe_id = next_keyframe;
  a.next_map_point_id = next_point;
  // Maps kept beside b (since format 1.1) stay beside the joined map.
  std::move(b.other_maps.begin(), b.other_maps.end(), std::back_inserter(a.other_maps));
  if (a.other_maps.size() > kMaxOtherMaps) {
    throw DataError(source + ": the joined map would keep " + std::to_string(a.other_maps.size()) +
                    " other maps; at most " + std::to_string(kMaxOtherMaps));
  }
  return a;
}

}  // namespace rrslam
