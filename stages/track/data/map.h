// The sparse map: keyframes and map points with the operations that keep
// their mutual references consistent (observations, covisibility graph,
// spanning tree, culling and fusion).
//
// Ownership: Map creates and owns every keyframe and map point for its whole
// lifetime, including culled ones (marked bad and removed from the map's
// sets), so a pointer held by a frame, a keyframe or a matcher stays valid
// until the Map is destroyed. Ids are dense integers in creation order.
//
// Determinism: every list returned and every internal iteration is ordered
// by id (or by weight, then id), so the same operations give the same map.
//
// Thread-safety: in realtime mode the tracker, the local mapper, the loop
// closer and the global bundle adjustment run in threads of their own; each
// holds mutex() for every access to map objects. (A map point's or
// keyframe's fields are only read or written under that lock.) In batch mode
// there is one thread and the lock is uncontended.
#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "stages/track/data/keyframe.h"
#include "stages/track/data/map_point.h"

namespace rrslam {

// Minimum number of shared map points for a covisibility edge (ORB-SLAM2: 15).
inline constexpr int kCovisibilityMinWeight = 15;

class Map {
 public:
  Map() = default;
  Map(const Map&) = delete;
  Map& operator=(const Map&) = delete;

  // Creates a keyframe from a frame (next keyframe id). It belongs to the
  // Map but is not in the map until AddKeyFrame.
  KeyFrame* CreateKeyFrame(const Frame& frame);
  // The same, taking the frame's features, bag of words and associations over.
  KeyFrame* CreateKeyFrame(Frame&& frame);
  // Creates a map point (next id) observed by nobody yet; not in the map
  // until AddMapPoint.
  MapPoint* CreateMapPoint(const Eigen::Vector3d& position_world, KeyFrame* reference_keyframe);
  void AddKeyFrame(KeyFrame* keyframe);
  void AddMapPoint(MapPoint* point);

  // Loading a saved map (map_io.h), whose ids have gaps (culled objects):
  // create a keyframe / map point with a given id, which must be at least
  // num_created_keyframes() / num_created_map_points() (objects are created in
  // id order); the ids skipped stay unused (keyframe_by_id gives nullptr).
  // Throws std::invalid_argument for an id already taken.
  KeyFrame* CreateKeyFrameWithId(KeyFrameId id, Frame&& frame);
  MapPoint* CreateMapPointWithId(MapPointId id, const Eigen::Vector3d& position_world,
                                 KeyFrame* reference_keyframe);
  // The next keyframe / map point created gets at least these ids.
  void ReserveIds(KeyFrameId next_keyframe_id, MapPointId next_map_point_id);

  // Keyframes / map points in the map (not bad), ordered by id.
  std::vector<KeyFrame*> KeyFrames() const;
  std::vector<MapPoint*> MapPoints() const;
  size_t num_keyframes() const { return num_keyframes_; }
  size_t num_map_points() const { return num_map_points_; }
  // Every keyframe ever created (including culled ones and those not yet
  // added), indexed by id: the next id. keyframe_by_id is nullptr for an id
  // skipped when a saved map was loaded.
  size_t num_created_keyframes() const { return keyframes_.size(); }
  KeyFrame* keyframe_by_id(KeyFrameId id) const { return keyframes_.at(id).get(); }
  size_t num_created_map_points() const { return map_points_.size(); }
  // The first keyframe added: origin of the map and root of the spanning tree.
  KeyFrame* root() const { return root_; }

  // Associates keypoint `index` of `keyframe` with `point` on both sides.
  void AddObservation(MapPoint* point, KeyFrame* keyframe, uint32_t index);
  // Removes the association of `point` with `keyframe` on both sides; culls the
  // point when fewer than three weighted observations remain (ORB-SLAM2).
  void EraseObservation(MapPoint* point, KeyFrame* keyframe);
  // Marks a point bad, removes all its observations and takes it out of the map.
  void CullMapPoint(MapPoint* point);
  // Fusion: every observation of `point` moves to `by` (dropped where `by` is
  // already observed), counters are added, `point` leaves the map as
  // replaced by `by`.
  void ReplaceMapPoint(MapPoint* point, MapPoint* by);

  // Recomputes `keyframe`'s covisibility edges from its map points: an edge to
  // every keyframe sharing at least kCovisibilityMinWeight points, or to the
  // one sharing most when none does; edges are kept symmetric. On the first
  // call the best neighbour that is not one of its descendants becomes the
  // spanning-tree parent (except for the first keyframe of the map, the
  // root, and a keyframe that already has children: the root of a part of
  // the tree made without neighbours, see map.cc).
  void UpdateConnections(KeyFrame* keyframe);

  // Culls a keyframe (ORB-SLAM2's KeyFrame::SetBadFlag): removes its edges and
  // its observations (which may cull points), re-attaches its children in the
  // spanning tree to the candidates with the strongest covisibility (its
  // parent first, then the already re-attached children), records its pose
  // relative to its parent and takes it out of the map. The root is never
  // culled: returns false for it. Nor is a keyframe with loop edges (false),
  // nor one in use by loop closing: that one is marked cull_pending (false)
  // and culled by ReleaseKeyFrame.
  bool CullKeyFrame(KeyFrame* keyframe);
  // Loop closing is done with `keyframe`: clears in_use and performs a cull
  // asked for meanwhile. Returns true when the keyframe was culled now.
  bool ReleaseKeyFrame(KeyFrame* keyframe);

  // Discards the whole map (ORB-SLAM2's reset): every keyframe and map point
  // in it is marked bad and leaves the map; the next keyframe added becomes
  // the root. The objects stay allocated (see Ownership), so pointers held
  // elsewhere stay valid.
  void Clear();

  // Atlas (module/atlas.h): every object of this map, culled ones too,
  // moves to `to` with its id, membership and root; `to` must have created
  // no object (throws std::invalid_argument otherwise). This map is left
  // empty, its next ids unchanged, so that objects created here afterwards
  // never share an id with those moved.
  void MoveObjectsTo(Map* to);
  // The reverse, for a merge: every object of `from` joins this map at its
  // id, which must be free here (throws std::invalid_argument naming the
  // first taken id, and moves nothing); `from`'s root becomes this map's
  // root (the merged map's world is `from`'s) and `from` is left empty.
  // The caller first moves this map's objects into `from`'s world and hangs
  // this map's spanning tree from one of `from`'s keyframes.
  void Absorb(Map* from);
  // The lock of realtime mode (see the file comment).
  std::mutex& mutex() const { return mutex_; }

  // Checks the graph's invariants (map_invariants.cc); false with the first
  // violated one in `why` (may be nullptr), e.g. "keyframe 12 keypoint 40:
  // map point 7 is not in the map (culled or replaced)":
  //   - membership: objects in the map are not bad, the counters match, the
  //     root is in the map;
  //   - observations both ways: a keyframe's keypoint points at a map point
  //     in the map that lists that keypoint, and a point's observations
  //     (sorted by keyframe id, weighted count right) are keyframes in the map
  //     pointing back; every point has one, and a reference keyframe in the map;
  //   - covisibility and loop edges: between keyframes in the map, symmetric,
  //     positive weights equal on both sides;
  //   - spanning tree: the root has no parent, every other connected
  //     keyframe a parent in the map listing it as a child, and following
  //     parents ends at the root or at an unconnected keyframe (the root of
  //     a part made without neighbours, see UpdateConnections): no cycle.
  // O(observations + edges + keyframes x tree depth). Call it where no
  // module is half-way through an operation (between keyframes, before a
  // save), holding mutex() in realtime mode.
  bool CheckInvariants(std::string* why) const;

 private:
  // True when following parents from `keyframe` reaches `ancestor`.
  bool IsDescendant(const KeyFrame* keyframe, const KeyFrame* ancestor) const;
  bool InMap(const KeyFrame* keyframe) const;
  bool InMap(const MapPoint* point) const;
  bool CheckMembership(std::string* why) const;
  bool CheckObservations(std::string* why) const;
  bool CheckEdges(std::string* why) const;
  bool CheckSpanningTree(std::string* why) const;

  std::vector<std::unique_ptr<KeyFrame>> keyframes_;   // Index = id; nullptr = id unused.
  std::vector<std::unique_ptr<MapPoint>> map_points_;  // Index = id; nullptr = id unused.
  std::vector<uint8_t> keyframe_in_map_;
  std::vector<uint8_t> map_point_in_map_;
  size_t num_keyframes_ = 0;
  size_t num_map_points_ = 0;
  KeyFrame* root_ = nullptr;
  mutable std::mutex mutex_;
};

}  // namespace rrslam
