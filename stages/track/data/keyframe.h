// A keyframe: a frame kept in the map, with its map-point associations, its
// bag of words, its place in the covisibility graph and in the spanning tree.
//
// Created and owned by Map (map.h); operations that involve other objects
// (connections update, culling) are Map's. Ids are stable integers in creation
// order; neighbour lists are ordered by (weight desc, id asc) and child sets by
// id, never by pointer value. Fields are plain values and ids/pointers to other
// map objects so that a map can be written out and read back.
//
// Thread-safety: none of its own; see Map::mutex().
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "common/geometry.h"
#include "stages/track/data/frame.h"
#include "stages/track/data/map_point.h"

namespace rrslam {

class KeyFrame : public View {
 public:
  // A keyframe from a tracked frame: shares its features, copies its pose, its
  // bag of words (when computed) and its map-point associations.
  KeyFrame(KeyFrameId id, const Frame& frame);
  // The same, taking the frame's bag of words and associations over (a map
  // being loaded).
  KeyFrame(KeyFrameId id, Frame&& frame);

  KeyFrameId id() const { return id_; }
  uint64_t frame_id() const { return frame_id_; }
  // Features, timestamp, pose and bag of words: View.

  // Map point of each keypoint (nullptr = none). Only these setters change
  // one side of an association; Map keeps both sides consistent.
  const std::vector<MapPoint*>& map_points() const { return map_points_; }
  MapPoint* map_point(size_t i) const { return map_points_[i]; }
  void SetMapPoint(size_t i, MapPoint* point) { map_points_[i] = point; }
  // Number of good map points with at least `min_observations` (weighted) observations.
  int NumTrackedMapPoints(int min_observations) const;

  // Covisibility: keyframes sharing map points with this one, with the number
  // shared as weight. Edges are symmetric (Map::UpdateConnections).
  struct Connection {
    KeyFrame* keyframe;
    int weight;
  };
  // All connections, sorted by keyframe id.
  const std::vector<Connection>& connections() const { return connections_; }
  // Connected keyframes ordered by weight (desc), then id (asc).
  const std::vector<KeyFrame*>& covisible() const { return ordered_neighbours_; }
  // The first `n` of covisible().
  std::vector<KeyFrame*> BestCovisible(size_t n) const;
  // Those of covisible() with weight >= `min_weight`.
  std::vector<KeyFrame*> CovisibleWithWeight(int min_weight) const;
  // Weight of the edge to `other`, 0 when not connected.
  int Weight(const KeyFrame* other) const;
  // Adds or updates / removes one edge of this keyframe only (Map keeps both sides).
  void SetConnection(KeyFrame* other, int weight);
  void RemoveConnection(const KeyFrame* other);
  // Replaces all edges of this keyframe only (`connections` sorted by id).
  void SetConnections(std::vector<Connection> connections);
  void ClearConnections();

  // Spanning tree (rooted at the first keyframe). Children sorted by id.
  KeyFrame* parent() const { return parent_; }
  const std::vector<KeyFrame*>& children() const { return children_; }
  void SetParent(KeyFrame* parent);  // Also registers this as the parent's child.
  void RemoveChild(const KeyFrame* child);
  // False until the keyframe got its first covisibility connections (and its parent).
  bool connected() const { return connected_; }
  void set_connected() { connected_ = true; }

  // Loop edges (ORB-SLAM2's mspLoopEdges): keyframes this one closed a loop
  // with, by id. A keyframe with loop edges is never culled.
  const std::vector<KeyFrame*>& loop_edges() const { return loop_edges_; }
  void AddLoopEdge(KeyFrame* other);

  // Culling protection (ORB-SLAM2's mbNotErase / mbToBeErased): while loop
  // closing uses a keyframe it is not culled; a cull asked for meanwhile is
  // remembered and done when loop closing releases it (Map::CullKeyFrame,
  // Map::ReleaseKeyFrame).
  bool in_use() const { return in_use_; }
  void set_in_use(bool in_use) { in_use_ = in_use; }
  bool cull_pending() const { return cull_pending_; }
  void set_cull_pending(bool pending) { cull_pending_ = pending; }

  // A culled keyframe is bad: it left the map, but frames may still refer to
  // it. T_cam_parent() then holds its pose relative to its parent at culling
  // time, so its frames' poses can be resolved through the tree.
  bool bad() const { return bad_; }
  const Rigid3d& T_cam_parent() const { return T_cam_parent_; }
  void MarkBad(const Rigid3d& T_cam_parent) {
    bad_ = true;
    T_cam_parent_ = T_cam_parent;
  }

 private:
  void UpdateOrder();

  KeyFrameId id_;
  uint64_t frame_id_;
  std::vector<MapPoint*> map_points_;
  std::vector<Connection> connections_;
  std::vector<KeyFrame*> ordered_neighbours_;
  std::vector<int> ordered_weights_;
  KeyFrame* parent_ = nullptr;
  std::vector<KeyFrame*> children_;
  bool connected_ = false;
  std::vector<KeyFrame*> loop_edges_;
  bool in_use_ = false;
  bool cull_pending_ = false;
  bool bad_ = false;
  Rigid3d T_cam_parent_;
};

// Pose (T_cam_world) of a camera given relative to keyframe `reference`
// (T_cam_reference): when the reference was culled, the relative pose is
// carried through the culled keyframes' recorded T_cam_parent to the first
// keyframe still in the map, whose current pose is used.
Rigid3d ResolvePose(const KeyFrame* reference, const Rigid3d& T_cam_reference);

// Orders map objects by id (for ordered containers of pointers).
struct IdLess {
  template <typename T>
  bool operator()(const T* a, const T* b) const {
    return a->id() < b->id();
  }
};

}  // namespace rrslam
