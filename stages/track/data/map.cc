#include "stages/track/data/map.h"

#include <algorithm>
#include <map>
#include <stdexcept>
#include <string>

namespace rrslam {

KeyFrame* Map::CreateKeyFrame(const Frame& frame) { return CreateKeyFrame(Frame(frame)); }

KeyFrame* Map::CreateKeyFrame(Frame&& frame) {
  keyframes_.push_back(std::make_unique<KeyFrame>(keyframes_.size(), std::move(frame)));
  keyframe_in_map_.push_back(0);
  return keyframes_.back().get();
}

MapPoint* Map::CreateMapPoint(const Eigen::Vector3d& position_world, KeyFrame* reference_keyframe) {
  map_points_.push_back(
      std::make_unique<MapPoint>(map_points_.size(), position_world, reference_keyframe));
  map_point_in_map_.push_back(0);
  return map_points_.back().get();
}

KeyFrame* Map::CreateKeyFrameWithId(KeyFrameId id, Frame&& frame) {
  if (id < keyframes_.size()) {
    throw std::invalid_argument("keyframe id " + std::to_string(id) + " is taken");
  }
  ReserveIds(id, map_points_.size());
  return CreateKeyFrame(std::move(frame));
}

MapPoint* Map::CreateMapPointWithId(MapPointId id, const Eigen::Vector3d& position_world,
                                    KeyFrame* reference_keyframe) {
  if (id < map_points_.size()) {
    throw std::invalid_argument("map point id " + std::to_string(id) + " is taken");
  }
  ReserveIds(keyframes_.size(), id);
  return CreateMapPoint(position_world, reference_keyframe);
}

void Map::ReserveIds(KeyFrameId next_keyframe_id, MapPointId next_map_point_id) {
  if (next_keyframe_id > keyframes_.size()) {
    keyframes_.resize(next_keyframe_id);
    keyframe_in_map_.resize(next_keyframe_id, 0);
  }
  if (next_map_point_id > map_points_.size()) {
    map_points_.resize(next_map_point_id);
    map_point_in_map_.resize(next_map_point_id, 0);
  }
}

void Map::AddKeyFrame(KeyFrame* keyframe) {
  uint8_t& in = keyframe_in_map_.at(keyframe->id());
  if (in) return;
  in = 1;
  ++num_keyframes_;
  if (root_ == nullptr) root_ = keyframe;
}

void Map::AddMapPoint(MapPoint* point) {
  uint8_t& in = map_point_in_map_.at(point->id());
  if (in) return;
  in = 1;
  ++num_map_points_;
}

std::vector<KeyFrame*> Map::KeyFrames() const {
  std::vector<KeyFrame*> out;
  out.reserve(num_keyframes_);
  for (size_t i = 0; i < keyframes_.size(); ++i) {
    if (keyframe_in_map_[i]) out.push_back(keyframes_[i].get());
  }
  return out;
}

std::vector<MapPoint*> Map::MapPoints() const {
  std::vector<MapPoint*> out;
  out.reserve(num_map_points_);
  for (size_t i = 0; i < map_points_.size(); ++i) {
    if (map_point_in_map_[i]) out.push_back(map_points_[i].get());
  }
  return out;
}

void Map::Clear() {
  for (size_t i = 0; i < map_points_.size(); ++i) {
    if (!map_point_in_map_[i]) continue;
    map_points_[i]->MarkBad(nullptr);
    map_points_[i]->ClearObservations();
    map_point_in_map_[i] = 0;
  }
  for (size_t i = 0; i < keyframes_.size(); ++i) {
    KeyFrame* kf = keyframes_[i].get();
    if (kf == nullptr || kf->bad()) continue;  // Also those created but not yet added.
    for (size_t k = 0; k < kf->size(); ++k) kf->SetMapPoint(k, nullptr);
    kf->MarkBad(Rigid3d::Identity());
    keyframe_in_map_[i] = 0;
  }
  num_map_points_ = 0;
  num_keyframes_ = 0;
  root_ = nullptr;
}

void Map::MoveObjectsTo(Map* to) {
  if (!to->keyframes_.empty() || !to->map_points_.empty()) {
    throw std::invalid_argument("MoveObjectsTo: the receiving map has objects");
  }
  const size_t next_keyframe = keyframes_.size(), next_point = map_points_.size();
  std::swap(keyframes_, to->keyframes_);
  std::swap(map_points_, to->map_points_);
  std::swap(keyframe_in_map_, to->keyframe_in_map_);
  std::swap(map_point_in_map_, to->map_point_in_map_);
  std::swap(num_keyframes_, to->num_keyframes_);
  std::swap(num_map_points_, to->num_map_points_);
  std::swap(root_, to->root_);
  ReserveIds(next_keyframe, next_point);
}

namespace {

// Index of the first slot that both vectors fill, or -1.
template <typename T>
int64_t FirstTakenId(const std::vector<std::unique_ptr<T>>& here,
                     const std::vector<std::unique_ptr<T>>& from) {
  for (size_t i = 0; i < from.size(); ++i) {
    if (from[i] != nullptr && i < here.size() && here[i] != nullptr) return static_cast<int64_t>(i);
  }
  return -1;
}

// Moves every object of `from` into `here` at its index; `in` likewise.
template <typename T>
void MoveSlots(std::vector<std::unique_ptr<T>>* from, std::vector<uint8_t>* from_in,
               std::vector<std::unique_ptr<T>>* here, std::vector<uint8_t>* here_in) {
  if (here->size() < from->size()) {
    here->resize(from->size());
    here_in->resize(from->size(), 0);
  }
  for (size_t i = 0; i < from->size(); ++i) {
    if ((*from)[i] == nullptr) continue;
    (*here)[i] = std::move((*from)[i]);
    (*here_in)[i] = (*from_in)[i];
  }
  from->clear();
  from_in->clear();
}

}  // namespace

void Map::Absorb(Map* from) {
  const int64_t keyframe = FirstTakenId(keyframes_, from->keyframes_);
  const int64_t point = FirstTakenId(map_points_, from->map_points_);
  if (keyframe >= 0 || point >= 0) {
    throw std::invalid_argument(
        keyframe >= 0 ? "Absorb: keyframe id " + std::to_string(keyframe) + " is taken in both maps"
                      : "Absorb: map point id " + std::to_string(point) + " is taken in both maps");
  }
  MoveSlots(&from->keyframes_, &from->keyframe_in_map_, &keyframes_, &keyframe_in_map_);
  MoveSlots(&from->map_points_, &from->map_point_in_map_, &map_points_, &map_point_in_map_);
  num_keyframes_ += from->num_keyframes_;
  num_map_points_ += from->num_map_points_;
  if (from->root_ != nullptr) root_ = from->root_;
  from->num_keyframes_ = 0;
  from->num_map_points_ = 0;
  from->root_ = nullptr;
}

void Map::AddObservation(MapPoint* point, KeyFrame* keyframe, uint32_t index) {
  point->AddObservation(keyframe, index);
  keyframe->SetMapPoint(index, point);
}

void Map::EraseObservation(MapPoint* point, KeyFrame* keyframe) {
  const int index = point->IndexIn(keyframe);
  if (index < 0) return;
  point->RemoveObservation(keyframe);
  if (keyframe->map_point(index) == point) keyframe->SetMapPoint(index, nullptr);
  // A point measured by a single depth observation (weight 2) or two plain
  // ones no longer constrains anything: cull it (ORB-SLAM2's rule).
  if (point->num_observations() <= 2) CullMapPoint(point);
}

void Map::CullMapPoint(MapPoint* point) {
  if (point->bad()) return;
  point->MarkBad(nullptr);
  for (const MapPoint::Observation& o : point->observations()) {
    if (o.keyframe->map_point(o.index) == point) o.keyframe->SetMapPoint(o.index, nullptr);
  }
  point->ClearObservations();
  uint8_t& in = map_point_in_map_.at(point->id());
  if (in) {
    in = 0;
    --num_map_points_;
  }
}

void Map::ReplaceMapPoint(MapPoint* point, MapPoint* by) {
  if (point == by || point->bad()) return;
  const std::vector<MapPoint::Observation> observations = point->observations();
  point->ClearObservations();
  point->MarkBad(by);
  for (const MapPoint::Observation& o : observations) {
    if (!by->IsObservedBy(o.keyframe)) {
      o.keyframe->SetMapPoint(o.index, by);
      by->AddObservation(o.keyframe, o.index);
    } else {
      o.keyframe->SetMapPoint(o.index, nullptr);
    }
  }
  by->IncreaseFound(point->found());
  by->IncreaseVisible(point->visible());
  by->ComputeDistinctiveDescriptor();
  uint8_t& in = map_point_in_map_.at(point->id());
  if (in) {
    in = 0;
    --num_map_points_;
  }
}

void Map::UpdateConnections(KeyFrame* keyframe) {
  // Points shared with every other keyframe, counted in keyframe-id order.
  std::map<KeyFrameId, KeyFrame::Connection> counter;
  for (const MapPoint* point : keyframe->map_points()) {
    if (point == nullptr || point->bad()) continue;
    for (const MapPoint::Observation& o : point->observations()) {
      if (o.keyframe == keyframe || o.keyframe->bad()) continue;
      auto [it, inserted] =
          counter.try_emplace(o.keyframe->id(), KeyFrame::Connection{o.keyframe, 0});
      ++it->second.weight;
    }
  }
  if (counter.empty()) return;

  std::vector<KeyFrame::Connection> edges;
  KeyFrame::Connection best{nullptr, 0};
  for (const auto& [id, c] : counter) {
    if (c.weight > best.weight) best = c;  // Ties keep the lowest id.
    if (c.weight >= kCovisibilityMinWeight) edges.push_back(c);
  }
  if (edges.empty()) edges.push_back(best);

  // Edges that disappear are removed on the other side too.
  for (const KeyFrame::Connection& old : keyframe->connections()) {
    const bool kept = std::any_of(edges.begin(), edges.end(), [&](const KeyFrame::Connection& e) {
      return e.keyframe == old.keyframe;
    });
    if (!kept) old.keyframe->RemoveConnection(keyframe);
  }
  for (const KeyFrame::Connection& e : edges) e.keyframe->SetConnection(keyframe, e.weight);
  keyframe->SetConnections(std::move(edges));

  if (!keyframe->connected()) {
    if (keyframe == root_) {
      keyframe->set_connected();
      return;
    }
    // The strongest neighbour becomes the parent, as in ORB-SLAM2. A
    // keyframe that had no neighbours when it was made (the first of a new
    // session in the map) may first connect once keyframes hang below it,
    // typically when a loop closure fuses its points with the older part:
    // it then stays the root of its part (the tree is a forest; loop and
    // covisibility edges join the parts), since a tree edge to the older
    // part would carry the drift the loop corrects, and a descendant as
    // parent would close a cycle. In one session every keyframe is
    // connected before the next is made, so this never happens there.
    if (!keyframe->children().empty()) return;
    for (KeyFrame* candidate : keyframe->covisible()) {
      if (!IsDescendant(candidate, keyframe)) {
        keyframe->SetParent(candidate);
        keyframe->set_connected();
        return;
      }
    }
  }
}

bool Map::IsDescendant(const KeyFrame* keyframe, const KeyFrame* ancestor) const {
  // Bounded by the number of keyframes: a cycle elsewhere cannot hang it.
  const KeyFrame* node = keyframe;
  for (size_t steps = 0; node != nullptr && steps <= keyframes_.size(); ++steps) {
    if (node == ancestor) return true;
    node = node->parent();
  }
  return false;
}

bool Map::CullKeyFrame(KeyFrame* keyframe) {
  KeyFrame* parent = keyframe->parent();
  if (keyframe == root_ || parent == nullptr || keyframe->bad()) return false;
  if (!keyframe->loop_edges().empty()) return false;
  if (keyframe->in_use()) {
    keyframe->set_cull_pending(true);
    return false;
  }

  for (const KeyFrame::Connection& c : keyframe->connections()) {
    c.keyframe->RemoveConnection(keyframe);
  }
  keyframe->ClearConnections();
  for (size_t i = 0; i < keyframe->size(); ++i) {
    if (MapPoint* point = keyframe->map_point(i)) EraseObservation(point, keyframe);
  }

  // Re-attach the children: repeatedly pick the (child, candidate) pair with
  // the strongest covisibility, where candidates are the parent and the
  // children already re-attached; the rest go to the parent.
  std::vector<KeyFrame*> candidates = {parent};
  std::vector<KeyFrame*> children = keyframe->children();
  while (!children.empty()) {
    int best_weight = -1;
    KeyFrame* best_child = nullptr;
    KeyFrame* best_parent = nullptr;
    for (KeyFrame* child : children) {
      if (child->bad()) continue;
      for (KeyFrame* neighbour : child->covisible()) {
        if (std::find(candidates.begin(), candidates.end(), neighbour) == candidates.end())
          continue;
        const int w = child->Weight(neighbour);
        if (w > best_weight) {
          best_weight = w;
          best_child = child;
          best_parent = neighbour;
        }
      }
    }
    if (best_child == nullptr) break;
    best_child->SetParent(best_parent);
    candidates.push_back(best_child);
    children.erase(std::find(children.begin(), children.end(), best_child));
  }
  for (KeyFrame* child : children) child->SetParent(parent);
  parent->RemoveChild(keyframe);

  keyframe->MarkBad(keyframe->T_cam_world() * parent->T_world_cam());
  uint8_t& in = keyframe_in_map_.at(keyframe->id());
  if (in) {
    in = 0;
    --num_keyframes_;
  }
  return true;
}

bool Map::ReleaseKeyFrame(KeyFrame* keyframe) {
  keyframe->set_in_use(false);
  if (!keyframe->cull_pending()) return false;
  keyframe->set_cull_pending(false);
  return CullKeyFrame(keyframe);
}

}  // namespace rrslam
