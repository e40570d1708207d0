#include "stages/track/module/local_mapper.h"

#include <spdlog/spdlog.h>

#include <Eigen/SVD>
#include <chrono>
#include <cmath>

#include "common/clock.h"
#include "stages/track/match/matcher.h"

namespace rrslam {

bool LocalMapperOptions::Check(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (changed_point_min_views < 0) {
    return fail("changed_point_min_views = " + std::to_string(changed_point_min_views) +
                "; must be >= 0");
  }
  if (changed_point_min_absent < 0) {
    return fail("changed_point_min_absent = " + std::to_string(changed_point_min_absent) +
                "; must be >= 0");
  }
  if (restore_point_min_found < 0) {
    return fail("restore_point_min_found = " + std::to_string(restore_point_min_found) +
                "; must be >= 0");
  }
  if (!(changed_point_min_found_ratio >= 0 && changed_point_min_found_ratio <= 1)) {
    return fail("changed_point_min_found_ratio = " + std::to_string(changed_point_min_found_ratio) +
                "; must be in [0, 1]");
  }
  return true;
}

RecentPointDecision ClassifyRecentPoint(const MapPoint& point, KeyFrameId current_keyframe_id,
                                        int min_found) {
  if (point.bad()) return RecentPointDecision::kCull;
  if (point.FoundRatio() < 0.25) return RecentPointDecision::kCull;
  const KeyFrameId age = current_keyframe_id - point.first_keyframe_id();
  // Three weighted observations: one keyframe with depth plus one without, or
  // three without. After two more keyframes a point needs more to stay.
  if (age >= 2 && point.num_observations() <= 3) {
    return min_found > 0 && point.found() >= min_found ? RecentPointDecision::kConfirm
                                                       : RecentPointDecision::kCull;
  }
  if (age >= 3) return RecentPointDecision::kConfirm;
  return RecentPointDecision::kWatch;
}

bool IsRedundantKeyFrame(const KeyFrame& keyframe, const SensorModel& sensor, int min_observers,
                         double redundancy) {
  const FrameFeatures& f = keyframe.features();
  int points = 0;
  int redundant = 0;
  for (size_t i = 0; i < keyframe.size(); ++i) {
    const MapPoint* point = keyframe.map_point(i);
    if (point == nullptr || point->bad()) continue;
    // Only close points count: far ones are weakly constrained by depth anyway.
    const float depth = f.Depth(i);
    if (depth <= 0 || depth > sensor.th_depth) continue;
    ++points;
    if (point->num_observations() <= min_observers) continue;
    const int level = f.Octave(i);
    int observers = 0;
    for (const MapPoint::Observation& o : point->observations()) {
      if (o.keyframe == &keyframe) continue;
      if (o.keyframe->features().Octave(o.index) <= level + 1 && ++observers >= min_observers) {
        break;
      }
    }
    if (observers >= min_observers) ++redundant;
  }
  return redundant > redundancy * points;
}

LocalMapper::LocalMapper(const SensorModel& sensor, const Vocabulary& vocabulary, Map* map,
                         KeyFrameDatabase* database, const LocalMapperOptions& options)
    : sensor_(sensor),
      vocabulary_(vocabulary),
      map_(map),
      database_(database),
      options_(options),
      adjuster_(sensor, options.bundle_adjustment) {}

LocalMapper::~LocalMapper() {
  if (thread_.joinable()) Stop();
}

void LocalMapper::InsertKeyFrame(KeyFrame* keyframe) {
  keyframe->ComputeBow(vocabulary_, options_.bow_levels_up);
  for (size_t i = 0; i < keyframe->size(); ++i) {
    MapPoint* point = keyframe->map_point(i);
    if (point == nullptr) continue;
    if (point->bad()) {
      keyframe->SetMapPoint(i, nullptr);
      continue;
    }
    const int index = point->IndexIn(keyframe);
    if (index < 0) {
      map_->AddObservation(point, keyframe, static_cast<uint32_t>(i));
      point->UpdateNormalAndDepth(sensor_.pyramid);
      point->ComputeDistinctiveDescriptor();
    } else if (index == static_cast<int>(i)) {
      // Created by the tracker together with this keyframe: watch it.
      recent_points_.push_back(point);
    } else {
      keyframe->SetMapPoint(i, nullptr);  // The same point matched twice: keep one.
    }
  }
  map_->UpdateConnections(keyframe);
  map_->AddKeyFrame(keyframe);
  database_->Add(keyframe);
}

size_t LocalMapper::CullRecentPoints(const KeyFrame* keyframe) {
  size_t culled = 0;
  std::vector<MapPoint*> kept;
  kept.reserve(recent_points_.size());
  const int min_found = restore_mapping_ ? options_.restore_point_min_found : 0;
  for (MapPoint* point : recent_points_) {
    if (point->bad()) continue;
    switch (ClassifyRecentPoint(*point, keyframe->id(), min_found)) {
      case RecentPointDecision::kCull:
        map_->CullMapPoint(point);
        ++culled;
        break;
      case RecentPointDecision::kConfirm:
        break;
      case RecentPointDecision::kWatch:
        kept.push_back(point);
        break;
    }
  }
  recent_points_ = std::move(kept);
  counters_.culled_points += culled;
  return culled;
}

size_t LocalMapper::TriangulateNewPoints(KeyFrame* keyframe, bool check_queue) {
  const ScalePyramid& pyramid = sensor_.pyramid;
  const FrameFeatures& f1 = keyframe->features();
  const Eigen::Matrix<double, 3, 4> P1 = keyframe->T_cam_world().ToMatrix3x4();
  const Eigen::Matrix3d R_wc1 = keyframe->R_cam_world().transpose();
  const Eigen::Vector3d& c1 = keyframe->camera_centre();
  const double ratio_factor = 1.5 * pyramid.scale_factor;
  const Matcher matcher(sensor_, 0.6, false);
  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  size_t created = 0;

  const std::vector<KeyFrame*> neighbours =
      keyframe->BestCovisible(options_.triangulation_neighbours);
  for (size_t n = 0; n < neighbours.size(); ++n) {
    if (check_queue && n > 0 && HasQueued()) break;
    KeyFrame* kf2 = neighbours[n];
    const Eigen::Vector3d& c2 = kf2->camera_centre();
    // Too short a baseline gives nothing that depth does not give already.
    if ((c2 - c1).norm() < sensor_.baseline) continue;
    const Eigen::Matrix3d F12 = FundamentalMatrix(sensor_, *keyframe, *kf2);
    matcher.SearchForTriangulation(*keyframe, *kf2, F12, false, &pairs);

    const FrameFeatures& f2 = kf2->features();
    const Eigen::Matrix<double, 3, 4> P2 = kf2->T_cam_world().ToMatrix3x4();
    const Eigen::Matrix3d R_wc2 = kf2->R_cam_world().transpose();
    for (const auto& [i1, i2] : pairs) {
      const Keypoint& kp1 = f1.keypoints[i1];
      const Keypoint& kp2 = f2.keypoints[i2];
      const bool depth1 = f1.HasDepth(i1);
      const bool depth2 = f2.HasDepth(i2);
      const Eigen::Vector3d xn1((kp1.undistorted.x() - sensor_.cx) * sensor_.inv_fx,
                                (kp1.undistorted.y() - sensor_.cy) * sensor_.inv_fy, 1.0);
      const Eigen::Vector3d xn2((kp2.undistorted.x() - sensor_.cx) * sensor_.inv_fx,
                                (kp2.undistorted.y() - sensor_.cy) * sensor_.inv_fy, 1.0);
      const Eigen::Vector3d ray1 = R_wc1 * xn1;
      const Eigen::Vector3d ray2 = R_wc2 * xn2;
      const double cos_rays = ray1.dot(ray2) / (ray1.norm() * ray2.norm());
      // Parallax the depth measurement itself offers (the angle the virtual
      // baseline subtends at the point).
      double cos_stereo1 = cos_rays + 1;
      double cos_stereo2 = cos_rays + 1;
      if (depth1) cos_stereo1 = std::cos(2 * std::atan2(sensor_.baseline / 2, kp1.depth));
      if (depth2) cos_stereo2 = std::cos(2 * std::atan2(sensor_.baseline / 2, kp2.depth));
      const double cos_stereo = std::min(cos_stereo1, cos_stereo2);

      Eigen::Vector3d x;
      if (cos_rays < cos_stereo && cos_rays > 0 && (depth1 || depth2 || cos_rays < 0.9998)) {
        // The two views give more parallax than depth: linear triangulation.
        Eigen::Matrix4d A;
        A.row(0) = xn1.x() * P1.row(2) - P1.row(0);
        A.row(1) = xn1.y() * P1.row(2) - P1.row(1);
        A.row(2) = xn2.x() * P2.row(2) - P2.row(0);
        A.row(3) = xn2.y() * P2.row(2) - P2.row(1);
        const Eigen::JacobiSVD<Eigen::Matrix4d> svd(A, Eigen::ComputeFullV);
        const Eigen::Vector4d h = svd.matrixV().col(3);
        if (h(3) == 0) continue;
        x = h.head<3>() / h(3);
      } else if (depth1 && cos_stereo1 < cos_stereo2) {
        x = keyframe->UnprojectWorld(sensor_, i1);
      } else if (depth2 && cos_stereo2 < cos_stereo1) {
        x = kf2->UnprojectWorld(sensor_, i2);
      } else {
        continue;  // No depth and too little parallax.
      }

      // In front of both cameras, consistent with both observations.
      auto reprojects = [&](const KeyFrame& kf, const FrameFeatures& f, uint32_t i) {
        const Eigen::Vector3d pc = kf.ToCamera(x);
        if (pc.z() <= 0) return false;
        const Keypoint& kp = f.keypoints[i];
        const double inv_z = 1.0 / pc.z();
        const double u = sensor_.fx * pc.x() * inv_z + sensor_.cx;
        const double v = sensor_.fy * pc.y() * inv_z + sensor_.cy;
        const double ex = u - kp.undistorted.x();
        const double ey = v - kp.undistorted.y();
        if (!f.HasDepth(i)) return ex * ex + ey * ey <= kChi2TwoDof * pyramid.sigma2[kp.octave];
        const double er = u - sensor_.bf * inv_z - f.u_right[i];
        return sensor_.StereoChi2(ex, ey, er, kp.octave) <= 7.8;
      };
      if (!reprojects(*keyframe, f1, i1) || !reprojects(*kf2, f2, i2)) continue;

      // Scale consistency: the distance ratio must agree with the octave ratio.
      const double dist1 = (x - c1).norm();
      const double dist2 = (x - c2).norm();
      if (dist1 == 0 || dist2 == 0) continue;
      const double ratio_dist = dist2 / dist1;
      const double ratio_octave = pyramid.scale[kp1.octave] / pyramid.scale[kp2.octave];
      if (ratio_dist * ratio_factor < ratio_octave || ratio_dist > ratio_octave * ratio_factor) {
        continue;
      }

      MapPoint* point = map_->CreateMapPoint(x, keyframe);
      map_->AddObservation(point, keyframe, i1);
      map_->AddObservation(point, kf2, i2);
      point->ComputeDistinctiveDescriptor();
      point->UpdateNormalAndDepth(pyramid);
      map_->AddMapPoint(point);
      recent_points_.push_back(point);
      ++created;
    }
  }
  counters_.triangulated_points += created;
  return created;
}

size_t LocalMapper::FuseWithNeighbours(KeyFrame* keyframe) {
  std::vector<uint8_t> is_target(map_->num_created_keyframes(), 0);
  is_target[keyframe->id()] = 1;
  std::vector<KeyFrame*> targets;
  for (KeyFrame* n : keyframe->BestCovisible(options_.fusion_neighbours)) {
    if (n->bad() || is_target[n->id()]) continue;
    is_target[n->id()] = 1;
    targets.push_back(n);
    for (KeyFrame* n2 : n->BestCovisible(5)) {
      if (n2->bad() || is_target[n2->id()]) continue;
      is_target[n2->id()] = 1;
      targets.push_back(n2);
    }
  }

  const Matcher matcher(sensor_, 0.6, true);
  size_t fused = 0;
  const std::vector<MapPoint*> own_points = keyframe->map_points();
  for (KeyFrame* target : targets) fused += matcher.Fuse(target, own_points, map_);

  std::vector<uint8_t> is_candidate(map_->num_created_map_points(), 0);
  std::vector<MapPoint*> candidates;
  for (KeyFrame* target : targets) {
    for (MapPoint* point : target->map_points()) {
      if (point == nullptr || point->bad() || is_candidate[point->id()]) continue;
      is_candidate[point->id()] = 1;
      candidates.push_back(point);
    }
  }
  fused += matcher.Fuse(keyframe, candidates, map_);

  for (MapPoint* point : keyframe->map_points()) {
    if (point == nullptr || point->bad()) continue;
    point->ComputeDistinctiveDescriptor();
    point->UpdateNormalAndDepth(sensor_.pyramid);
  }
  map_->UpdateConnections(keyframe);
  counters_.fused_points += fused;
  return fused;
}

size_t LocalMapper::CullRedundantKeyFrames(const KeyFrame* keyframe) {
  size_t culled = 0;
  const std::vector<KeyFrame*> local = keyframe->covisible();
  for (KeyFrame* kf : local) {
    if (kf->bad() || kf == map_->root()) continue;
    if (!IsRedundantKeyFrame(*kf, sensor_, options_.culling_min_observers,
                             options_.culling_redundancy)) {
      continue;
    }
    if (map_->CullKeyFrame(kf)) {
      database_->Erase(kf);
      ++culled;
    }
  }
  counters_.culled_keyframes += culled;
  return culled;
}

bool LocalMapper::HasQueued() const {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  return !queue_.empty();
}

bool IsChangedPoint(const MapPoint& point, const LocalMapperOptions& options) {
  const int views = point.SessionVisible();
  return options.changed_point_min_views > 0 && views >= options.changed_point_min_views &&
         point.SessionFound() < options.changed_point_min_found_ratio * views &&
         point.evidence().seen_through_views >= options.changed_point_min_absent &&
         point.evidence().seen_through >= kSeenThroughPerPresent * point.evidence().present;
}

void LocalMapper::WatchLoadedPoints(const std::vector<MapPoint*>& points) {
  loaded_points_ = points;
  restore_mapping_ = true;
  for (MapPoint* point : loaded_points_) point->StartSession();
}

size_t LocalMapper::CullChangedPoints() {
  if (options_.changed_point_min_views <= 0) return 0;
  size_t culled = 0;
  std::vector<MapPoint*> kept;
  kept.reserve(loaded_points_.size());
  for (MapPoint* point : loaded_points_) {
    if (point->bad()) continue;
    if (IsChangedPoint(*point, options_)) {
      map_->CullMapPoint(point);
      ++culled;
    } else {
      kept.push_back(point);
    }
  }
  loaded_points_ = std::move(kept);
  counters_.culled_changed_points += culled;
  return culled;
}

size_t LocalMapper::QueueSize() const {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  return queue_.size();
}

void LocalMapper::Process(KeyFrame* keyframe, bool realtime) {
  const auto start = SteadyClock::now();
  {
    std::lock_guard<std::mutex> lock(map_->mutex());
    InsertKeyFrame(keyframe);
    CullRecentPoints(keyframe);
    CullChangedPoints();
  }
  {
    std::lock_guard<std::mutex> lock(map_->mutex());
    TriangulateNewPoints(keyframe, realtime);
  }
  if (!HasQueued()) {
    std::lock_guard<std::mutex> lock(map_->mutex());
    FuseWithNeighbours(keyframe);
  }
  abort_ba_.store(false);
  if (!HasQueued()) {
    bool run_ba;
    {
      std::lock_guard<std::mutex> lock(map_->mutex());
      run_ba = map_->num_keyframes() > 2 && !keyframe->bad();
      if (run_ba) adjuster_.Collect(keyframe, *map_);
    }
    if (run_ba) {
      adjuster_.Solve(realtime ? &abort_ba_ : nullptr);
      std::lock_guard<std::mutex> lock(map_->mutex());
      adjuster_.Apply(map_);
      ++counters_.bundle_adjustments;
      counters_.bundle_adjustment_solves += adjuster_.stats().solves;
      const LocalBundleAdjustmentStats& st = adjuster_.stats();
      spdlog::debug(
          "local BA at keyframe {}: {} free + {} fixed keyframes, {} points, {} observations, "
          "{} outliers, cost {:.1f} -> {:.1f}",
          keyframe->id(), st.local_keyframes, st.fixed_keyframes, st.points, st.observations,
          st.outliers, st.initial_cost, st.final_cost);
      if (adjuster_.stats().aborted) ++counters_.aborted_bundle_adjustments;
    }
    std::lock_guard<std::mutex> lock(map_->mutex());
    CullRedundantKeyFrames(keyframe);
  }
  ++counters_.keyframes;
  counters_.keyframe_ms.push_back(MillisecondsSince(start));
  if (sink_) sink_(keyframe);
}

void LocalMapper::ProcessKeyFrame(KeyFrame* keyframe) { Process(keyframe, false); }

void LocalMapper::ProcessQueued() {
  while (true) {
    KeyFrame* keyframe;
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      if (queue_.empty()) return;
      keyframe = queue_.front();
      queue_.pop_front();
    }
    Process(keyframe, false);
  }
}

void LocalMapper::Enqueue(KeyFrame* keyframe) {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    queue_.push_back(keyframe);
    counters_.max_queue = std::max(counters_.max_queue, queue_.size());
  }
  abort_ba_.store(true);
  queue_cv_.notify_one();
}

void LocalMapper::Start() {
  stop_requested_ = false;
  running_.store(true);
  thread_ = std::thread([this] { Run(); });
}

void LocalMapper::Run() {
  while (true) {
    KeyFrame* keyframe;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      queue_cv_.wait(lock, [this] { return pauses_ == 0 && (stop_requested_ || !queue_.empty()); });
      if (queue_.empty()) return;  // Stop requested and nothing left.
      keyframe = queue_.front();
      queue_.pop_front();
      busy_ = true;
    }
    accepting_.store(false);
    Process(keyframe, true);
    accepting_.store(true);
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      busy_ = false;
    }
    idle_cv_.notify_all();
  }
}

void LocalMapper::Pause() {
  if (!running_.load()) return;
  std::unique_lock<std::mutex> lock(queue_mutex_);
  ++pauses_;
  abort_ba_.store(true);
  idle_cv_.wait(lock, [this] { return !busy_; });
}

void LocalMapper::Resume() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    if (pauses_ > 0) --pauses_;
  }
  queue_cv_.notify_one();
}

bool LocalMapper::Paused() const {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  return pauses_ > 0;
}

void LocalMapper::Reset() {
  const bool running = thread_.joinable();
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    queue_.clear();  // Not processed: their map is being discarded.
  }
  if (running) Stop();  // Finishes the keyframe in progress.
  recent_points_.clear();
  loaded_points_.clear();
  restore_mapping_ = false;
  if (running) Start();
}

void LocalMapper::Stop() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stop_requested_ = true;
  }
  queue_cv_.notify_one();
  if (thread_.joinable()) thread_.join();
  running_.store(false);
}

}  // namespace rrslam
