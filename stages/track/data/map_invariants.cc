// Map::CheckInvariants: the graph's invariants, checked one family at a time.
#include <algorithm>
#include <string>

#include "stages/track/data/map.h"

namespace rrslam {
namespace {

std::string Kf(const KeyFrame* keyframe) { return "keyframe " + std::to_string(keyframe->id()); }
std::string Mp(const MapPoint* point) { return "map point " + std::to_string(point->id()); }

// Fails with `what` when `condition` is false; returns the condition.
bool Holds(bool condition, const std::string& what, std::string* why) {
  if (!condition && why != nullptr) *why = what;
  return condition;
}

}  // namespace

bool Map::InMap(const KeyFrame* keyframe) const {
  return keyframe != nullptr && keyframe->id() < keyframe_in_map_.size() &&
         keyframe_in_map_[keyframe->id()] && keyframes_[keyframe->id()].get() == keyframe;
}

bool Map::InMap(const MapPoint* point) const {
  return point != nullptr && point->id() < map_point_in_map_.size() &&
         map_point_in_map_[point->id()] && map_points_[point->id()].get() == point;
}

// Counts and flags: what is in the map is not bad, the counters are right,
// the root is in the map.
bool Map::CheckMembership(std::string* why) const {
  size_t keyframes = 0, points = 0;
  for (size_t i = 0; i < keyframes_.size(); ++i) {
    if (!keyframe_in_map_[i]) continue;
    ++keyframes;
    if (!Holds(!keyframes_[i]->bad(), Kf(keyframes_[i].get()) + " is in the map but bad", why))
      return false;
  }
  for (size_t i = 0; i < map_points_.size(); ++i) {
    if (!map_point_in_map_[i]) continue;
    ++points;
    if (!Holds(!map_points_[i]->bad(), Mp(map_points_[i].get()) + " is in the map but bad", why))
      return false;
  }
  return Holds(keyframes == num_keyframes_ && points == num_map_points_,
               "the map counts " + std::to_string(num_keyframes_) + " keyframes and " +
                   std::to_string(num_map_points_) + " map points but holds " +
                   std::to_string(keyframes) + " and " + std::to_string(points),
               why) &&
         Holds(keyframes == 0 || InMap(root_), "the root keyframe is not in the map", why);
}

// Every observation both ways: a keyframe's keypoint points at a map point
// in the map that lists it, and a map point's observations (sorted, one per
// keyframe, weighted count right) are keyframes in the map pointing back.
bool Map::CheckObservations(std::string* why) const {
  for (const KeyFrame* kf : KeyFrames()) {
    for (size_t i = 0; i < kf->size(); ++i) {
      const MapPoint* p = kf->map_point(i);
      if (p == nullptr) continue;
      const std::string at = Kf(kf) + " keypoint " + std::to_string(i) + ": ";
      if (!Holds(InMap(p), at + Mp(p) + " is not in the map (culled or replaced)", why) ||
          !Holds(p->IndexIn(kf) == static_cast<int>(i), at + Mp(p) + " does not list it", why))
        return false;
    }
  }
  for (const MapPoint* p : MapPoints()) {
    int weighted = 0;
    const KeyFrame* previous = nullptr;
    for (const MapPoint::Observation& o : p->observations()) {
      const std::string at = Mp(p) + ": observation by " + Kf(o.keyframe) + ": ";
      if (!Holds(InMap(o.keyframe), at + "not in the map", why) ||
          !Holds(previous == nullptr || previous->id() < o.keyframe->id(),
                 at + "not in keyframe-id order", why) ||
          !Holds(o.index < o.keyframe->size() && o.keyframe->map_point(o.index) == p,
                 at + "its keypoint " + std::to_string(o.index) + " does not point back", why))
        return false;
      weighted += o.keyframe->features().HasDepth(o.index) ? 2 : 1;
      previous = o.keyframe;
    }
    if (!Holds(!p->observations().empty(), Mp(p) + " has no observation", why) ||
        !Holds(weighted == p->num_observations(),
               Mp(p) + " counts " + std::to_string(p->num_observations()) +
                   " weighted observations, has " + std::to_string(weighted),
               why) ||
        !Holds(InMap(p->reference_keyframe()), Mp(p) + ": its reference keyframe is culled", why))
      return false;
  }
  return true;
}

// Covisibility and loop edges join keyframes in the map, both ways, with the
// same positive weight on both sides. (A weight is the number of shared
// points when either end last ran UpdateConnections, as in ORB-SLAM2; later
// observations change the count without an update, so it is not compared
// with today's count here.)
bool Map::CheckEdges(std::string* why) const {
  for (const KeyFrame* kf : KeyFrames()) {
    for (const KeyFrame::Connection& c : kf->connections()) {
      const std::string at = Kf(kf) + ": covisibility edge to " + Kf(c.keyframe) + ": ";
      if (!Holds(InMap(c.keyframe), at + "not in the map", why) ||
          !Holds(c.keyframe != kf, at + "an edge to itself", why) ||
          !Holds(c.weight > 0, at + "weight " + std::to_string(c.weight), why) ||
          !Holds(c.keyframe->Weight(kf) == c.weight,
                 at + "weight " + std::to_string(c.weight) + " here, " +
                     std::to_string(c.keyframe->Weight(kf)) + " there",
                 why))
        return false;
    }
    for (const KeyFrame* other : kf->loop_edges()) {
      const std::string at = Kf(kf) + ": loop edge to " + Kf(other) + ": ";
      const auto& back = other->loop_edges();
      if (!Holds(InMap(other), at + "not in the map", why) ||
          !Holds(std::find(back.begin(), back.end(), kf) != back.end(), at + "one-way", why))
        return false;
    }
  }
  return true;
}

// The spanning tree: the root has no parent; every other keyframe with
// connections has a parent in the map that lists it as a child; children
// are keyframes in the map whose parent this is; following parents from any
// keyframe reaches the root (connected, no cycle).
bool Map::CheckSpanningTree(std::string* why) const {
  for (const KeyFrame* kf : KeyFrames()) {
    const KeyFrame* parent = kf->parent();
    if (kf == root_) {
      if (!Holds(parent == nullptr, "the root " + Kf(kf) + " has a parent", why)) return false;
    } else if (kf->connected()) {
      const auto& siblings = parent != nullptr ? parent->children() : kf->children();
      if (!Holds(InMap(parent), Kf(kf) + " has no parent in the map", why) ||
          !Holds(std::find(siblings.begin(), siblings.end(), kf) != siblings.end(),
                 Kf(kf) + " is not a child of its parent " + Kf(parent), why))
        return false;
    }
    for (const KeyFrame* child : kf->children()) {
      if (!Holds(InMap(child) && child->parent() == kf,
                 Kf(kf) + " lists child " + Kf(child) + " whose parent it is not or culled", why))
        return false;
    }
    const KeyFrame* node = kf;
    for (size_t steps = 0; node != nullptr && node != root_; ++steps) {
      if (!Holds(steps <= num_keyframes_, Kf(kf) + ": its parents form a cycle", why)) return false;
      if (!node->connected()) break;  // Not yet in the tree (no connections).
      node = node->parent();
    }
    if (!Holds(node != nullptr, Kf(kf) + ": its parents do not reach the root", why)) return false;
  }
  return true;
}

bool Map::CheckInvariants(std::string* why) const {
  return CheckMembership(why) && CheckObservations(why) && CheckEdges(why) &&
         CheckSpanningTree(why);
}

}  // namespace rrslam
