#include "stages/track/data/keyframe.h"

#include <algorithm>
#include <utility>

namespace rrslam {

KeyFrame::KeyFrame(KeyFrameId id, const Frame& frame)
    : View(frame), id_(id), frame_id_(frame.id()), map_points_(frame.map_points) {}

// Only the View base and map_points are moved from; id() is Frame's own.
KeyFrame::KeyFrame(KeyFrameId id, Frame&& frame)
    : View(std::move(static_cast<View&>(frame))),
      id_(id),
      frame_id_(frame.id()),
      map_points_(std::move(frame.map_points)) {}

int KeyFrame::NumTrackedMapPoints(int min_observations) const {
  int n = 0;
  for (const MapPoint* p : map_points_) {
    if (p != nullptr && !p->bad() && p->num_observations() >= min_observations) ++n;
  }
  return n;
}

std::vector<KeyFrame*> KeyFrame::BestCovisible(size_t n) const {
  return {ordered_neighbours_.begin(),
          ordered_neighbours_.begin() + std::min(n, ordered_neighbours_.size())};
}

std::vector<KeyFrame*> KeyFrame::CovisibleWithWeight(int min_weight) const {
  std::vector<KeyFrame*> out;
  for (size_t i = 0; i < ordered_neighbours_.size() && ordered_weights_[i] >= min_weight; ++i) {
    out.push_back(ordered_neighbours_[i]);
  }
  return out;
}

int KeyFrame::Weight(const KeyFrame* other) const {
  auto it =
      std::lower_bound(connections_.begin(), connections_.end(), other->id(),
                       [](const Connection& c, KeyFrameId id) { return c.keyframe->id() < id; });
  return it != connections_.end() && it->keyframe == other ? it->weight : 0;
}

void KeyFrame::SetConnection(KeyFrame* other, int weight) {
  auto it =
      std::lower_bound(connections_.begin(), connections_.end(), other->id(),
                       [](const Connection& c, KeyFrameId id) { return c.keyframe->id() < id; });
  if (it != connections_.end() && it->keyframe == other) {
    if (it->weight == weight) return;
    it->weight = weight;
  } else {
    connections_.insert(it, {other, weight});
  }
  UpdateOrder();
}

void KeyFrame::RemoveConnection(const KeyFrame* other) {
  auto it =
      std::lower_bound(connections_.begin(), connections_.end(), other->id(),
                       [](const Connection& c, KeyFrameId id) { return c.keyframe->id() < id; });
  if (it == connections_.end() || it->keyframe != other) return;
  connections_.erase(it);
  UpdateOrder();
}

void KeyFrame::SetConnections(std::vector<Connection> connections) {
  connections_ = std::move(connections);
  UpdateOrder();
}

void KeyFrame::ClearConnections() {
  connections_.clear();
  ordered_neighbours_.clear();
  ordered_weights_.clear();
}

void KeyFrame::AddLoopEdge(KeyFrame* other) {
  auto it = std::lower_bound(loop_edges_.begin(), loop_edges_.end(), other, IdLess());
  if (it == loop_edges_.end() || *it != other) loop_edges_.insert(it, other);
}

void KeyFrame::UpdateOrder() {
  std::vector<Connection> sorted = connections_;
  std::stable_sort(sorted.begin(), sorted.end(), [](const Connection& a, const Connection& b) {
    return a.weight > b.weight;  // connections_ is by id: ties stay by id.
  });
  ordered_neighbours_.resize(sorted.size());
  ordered_weights_.resize(sorted.size());
  for (size_t i = 0; i < sorted.size(); ++i) {
    ordered_neighbours_[i] = sorted[i].keyframe;
    ordered_weights_[i] = sorted[i].weight;
  }
}

void KeyFrame::SetParent(KeyFrame* parent) {
  if (parent_ != nullptr) parent_->RemoveChild(this);
  parent_ = parent;
  if (parent == nullptr) return;
  auto it = std::lower_bound(parent->children_.begin(), parent->children_.end(), this, IdLess());
  if (it == parent->children_.end() || *it != this) parent->children_.insert(it, this);
}

void KeyFrame::RemoveChild(const KeyFrame* child) {
  auto it = std::find(children_.begin(), children_.end(), child);
  if (it != children_.end()) children_.erase(it);
}

Rigid3d ResolvePose(const KeyFrame* reference, const Rigid3d& T_cam_reference) {
  Rigid3d T_cam_ref = T_cam_reference;
  while (reference->bad() && reference->parent() != nullptr) {
    T_cam_ref = T_cam_ref * reference->T_cam_parent();
    reference = reference->parent();
  }
  return T_cam_ref * reference->T_cam_world();
}

}  // namespace rrslam
