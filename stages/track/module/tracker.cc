#include "stages/track/module/tracker.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <map>

#include "stages/track/data/depth_evidence.h"
#include "stages/track/optimize/optimizer.h"

namespace rrslam {

bool TrackerOptions::Check(std::string* why) const {
  if (close_tracked < 0) {
    if (why != nullptr)
      *why = "close_tracked = " + std::to_string(close_tracked) + "; must be >= 0";
    return false;
  }
  if (!(new_view_fraction >= 0 && new_view_fraction < 1)) {
    if (why != nullptr)
      *why = "new_view_fraction = " + std::to_string(new_view_fraction) + "; must be in [0, 1)";
    return false;
  }
  if (new_view_min_age < 0) {
    if (why != nullptr)
      *why = "new_view_min_age = " + std::to_string(new_view_min_age) + "; must be >= 0";
    return false;
  }
  std::string reason;
  if (!relocalization.Check(&reason)) {
    if (why != nullptr) *why = "relocalization." + reason;
    return false;
  }
  return true;
}

Tracker::Tracker(const SensorModel& sensor, const Vocabulary& vocabulary, Map* map,
                 LocalMapper* mapper, const KeyFrameDatabase& database,
                 const TrackerOptions& options)
    : sensor_(sensor),
      vocabulary_(vocabulary),
      map_(map),
      mapper_(mapper),
      options_(options),
      relocalizer_(sensor, database, *map, options.relocalization) {}

bool Tracker::Track(Frame frame, bool* new_keyframe) {
  std::lock_guard<std::mutex> lock(map_->mutex());
  current_ = std::move(frame);
  SizeMarks();

  bool ok = false;
  bool made_keyframe = false;
  if (state_ == State::kNotInitialized) {
    ok = Initialize();
    made_keyframe = ok;
  } else {
    const bool was_lost = state_ == State::kLost;
    if (options_.localization_only) {
      ok = TrackLocalizationOnly();
    } else if (!was_lost) {
      ReplaceInLastFrame();
      if (velocity_ && !RecentlyRelocalized(2)) {
        ok = TrackWithMotionModel(*velocity_);
      }
      if (!ok) ok = TrackReferenceKeyFrame();
      if (!ok) ok = TrackLastFrameStill();
    } else {
      ok = Relocalize();
    }
    current_.reference_keyframe = reference_keyframe_;
    if (ok && !vo_) ok = TrackLocalMap();
    if (ok && !options_.localization_only && GatesKeyFramesByView()) {
      lacking_history_.push_back(CompareWithLocalMap());
      if (lacking_history_.size() > kLacksViewFrames) lacking_history_.pop_front();
      frames_lacking_view_ += LacksView();
    }
    if (ok && vo_) ++visual_odometry_frames_;
    if (ok && was_lost) ++relocalizations_;
    state_ = ok ? State::kOk : State::kLost;
    if (!ok) lacking_history_.clear();
    if (ok) {
      if (last_frame_tracked_) {
        velocity_ = current_.T_cam_world() * last_frame_.T_world_cam();
      } else {
        velocity_.reset();
      }
      if (options_.localization_only) {
        // Matches of temporary points do not outlive them (ORB-SLAM2's
        // "clean VO matches").
        for (size_t i = 0; i < current_.size(); ++i) {
          MapPoint* point = current_.map_points[i];
          if (point != nullptr && point->num_observations() < 1) {
            current_.map_points[i] = nullptr;
            current_.outlier[i] = 0;
          }
        }
      } else if (NeedNewKeyFrame()) {
        CreateNewKeyFrame();
        made_keyframe = true;
      }
      // Outliers stay out of the next frame's motion-model search.
      for (size_t i = 0; i < current_.size(); ++i) {
        if (current_.map_points[i] != nullptr && current_.outlier[i]) {
          current_.map_points[i] = nullptr;
        }
      }
    } else {
      velocity_.reset();
      // Lost soon after initialization: start again (ORB-SLAM2).
      if (options_.reset_max_keyframes >= 0 &&
          map_->num_keyframes() <= static_cast<size_t>(options_.reset_max_keyframes)) {
        reset_requested_ = true;
      }
    }
  }
  if (current_.reference_keyframe == nullptr) current_.reference_keyframe = reference_keyframe_;

  TrackedFrame record;
  record.frame_id = current_.id();
  record.timestamp = current_.timestamp();
  record.tracked = ok;
  if (ok) {
    record.reference = current_.reference_keyframe;
    record.T_cam_reference = current_.T_cam_world() * record.reference->T_world_cam();
  }
  records_.push_back(record);
  if (!temporary_points_.empty()) {
    for (MapPoint*& point : current_.map_points) {
      if (point != nullptr && point->num_observations() < 1) point = nullptr;
    }
    temporary_points_.clear();
  }
  last_frame_ = std::move(current_);
  last_frame_tracked_ = ok;
  if (new_keyframe != nullptr) *new_keyframe = made_keyframe;
  return ok;
}

void Tracker::Reset() {
  state_ = State::kNotInitialized;
  velocity_.reset();
  reference_keyframe_ = nullptr;
  local_keyframes_.clear();
  local_points_.clear();
  last_frame_tracked_ = false;
  for (TrackedFrame& r : records_) {
    r.tracked = false;
    r.reference = nullptr;
  }
  reset_requested_ = false;
  ++resets_;
}

void Tracker::SizeMarks() {
  keyframe_mark_.resize(map_->num_created_keyframes(), 0);
  point_mark_.resize(map_->num_created_map_points(), 0);
  seen_mark_.resize(map_->num_created_map_points(), 0);
}

void Tracker::StartOnLoadedMap() {
  {
    std::lock_guard<std::mutex> lock(map_->mutex());
    relocalizer_.PrepareIndexInBackground();
    // Here, on the loading thread: its heap has the load's huge pages, where
    // the frame loop's thread would fault the marks in 4 kB at a time (9 MB
    // at 10k keyframes: 0.25 s of the first frame on the bench's VM).
    SizeMarks();
  }
  state_ = State::kLost;
  velocity_.reset();
  reference_keyframe_ = nullptr;
  last_frame_tracked_ = false;
  options_.reset_max_keyframes = -1;
}

void Tracker::StartNewMap() {
  state_ = State::kNotInitialized;
  velocity_.reset();
  last_good_T_cam_world_.reset();
  reference_keyframe_ = nullptr;
  local_keyframes_.clear();
  local_points_.clear();
  last_frame_tracked_ = false;
  options_.reset_max_keyframes = given_reset_max_keyframes_;
}

void Tracker::MoveWorld(const Rigid3d& T_new_old) {
  const Rigid3d T_old_new = T_new_old.Inverse();
  if (last_frame_.has_pose()) last_frame_.SetPose(last_frame_.T_cam_world() * T_old_new);
  if (last_good_T_cam_world_) last_good_T_cam_world_ = *last_good_T_cam_world_ * T_old_new;
}

bool Tracker::CompareWithLocalMap() {
  const FrameFeatures& f = current_.features();
  const bool with_depth_image = !current_.depth_metres.empty();
  const uint64_t stamp = current_.id() + 1;
  for (const MapPoint* point : current_.map_points) {
    if (point != nullptr) MarkSeen(point, stamp);
  }
  const Eigen::Matrix3d& R = current_.R_cam_world();
  const Eigen::Vector3d& t = current_.T_cam_world().translation;
  const Eigen::Vector3d& centre = current_.camera_centre();
  const double th = options_.local_map_search_radius;
  std::vector<uint8_t> covered(f.size(), 0);
  std::vector<uint32_t> near;
  for (MapPoint* point : local_points_) {
    if (point->bad()) continue;
    ProjectedPoint pp;
    if (!ProjectIntoView(sensor_, R, t, centre, point, 0.5, &pp)) continue;
    const Eigen::Vector3d point_cam = R * point->position_world() + t;
    // The keypoints it accounts for: near its pixel, at its depth.
    const double gap = DepthCoverGap(point_cam.z());
    const double r = LocalMapSearchRadius(pp, th, sensor_.pyramid);
    near.clear();
    f.FeaturesInArea(sensor_, pp.u, pp.v, r, 0, -1, &near);
    for (uint32_t i : near) {
      if (f.HasDepth(i) && std::abs(f.Depth(i) - point_cam.z()) < gap) covered[i] = 1;
    }
    // Not matched: what the depth image says about it.
    if (!with_depth_image || seen_mark_[point->id()] == stamp) continue;
    const Eigen::Vector2d pixel = sensor_.camera.ProjectDistorted(point_cam);
    switch (DepthEvidenceAt(current_.depth_metres, pixel, point_cam.z())) {
      case DepthEvidence::kPresent:
        point->AddPresent();
        break;
      case DepthEvidence::kSeenThrough:
        point->AddSeenThrough(centre);
        break;
      case DepthEvidence::kNone:
        break;
    }
  }
  int uncovered = 0, close = 0;
  for (size_t i = 0; i < f.size(); ++i) {
    const float depth = f.Depth(i);
    if (depth <= 0 || depth >= sensor_.th_depth) continue;
    ++close;
    if (!covered[i]) uncovered += current_.map_points[i] == nullptr || current_.outlier[i];
  }
  return uncovered > options_.close_untracked && uncovered > options_.new_view_fraction * close;
}

bool Tracker::Revisits() const {
  const uint64_t age = map_->num_created_keyframes() - 1 - reference_keyframe_->id();
  return age >= static_cast<uint64_t>(options_.new_view_min_age);
}

bool Tracker::LacksView() const {
  if (lacking_history_.size() < kLacksViewFrames) return false;
  return std::all_of(lacking_history_.begin(), lacking_history_.end(),
                     [](bool lacking) { return lacking; });
}

bool Tracker::TrackLocalizationOnly() {
  if (state_ == State::kLost) {
    const bool ok = Relocalize();
    if (ok) vo_ = false;
    return ok;
  }
  if (!vo_) {
    if (velocity_) return TrackWithMotionModel(*velocity_);
    return TrackReferenceKeyFrame() || TrackLastFrameStill();
  }

  // The last frame was tracked mainly on temporary points: track with the
  // motion model and try relocalization too; relocalization wins.
  bool ok_motion = false;
  std::vector<MapPoint*> motion_points;
  std::vector<uint8_t> motion_outliers;
  Rigid3d motion_pose;
  if (velocity_) {
    ok_motion = TrackWithMotionModel(*velocity_);
    motion_points = current_.map_points;
    motion_outliers = current_.outlier;
    motion_pose = current_.T_cam_world();
  }
  const bool ok_relocalized = Relocalize(ok_motion);
  if (ok_motion && !ok_relocalized) {
    current_.SetPose(motion_pose);
    current_.map_points = std::move(motion_points);
    current_.outlier = std::move(motion_outliers);
    if (vo_) {
      for (size_t i = 0; i < current_.size(); ++i) {
        if (current_.map_points[i] != nullptr && !current_.outlier[i]) {
          current_.map_points[i]->IncreaseFound();
        }
      }
    }
  } else if (ok_relocalized) {
    vo_ = false;
  }
  return ok_relocalized || ok_motion;
}

void Tracker::AddTemporaryPoints() {
  constexpr MapPointId kTemporaryPointIdBase = MapPointId{1} << 62;
  const FrameFeatures& f = last_frame_.features();
  std::vector<std::pair<float, uint32_t>> by_depth;
  for (size_t i = 0; i < f.size(); ++i) {
    if (f.HasDepth(i)) by_depth.emplace_back(f.Depth(i), static_cast<uint32_t>(i));
  }
  std::sort(by_depth.begin(), by_depth.end());
  const ScalePyramid& pyramid = sensor_.pyramid;
  int points = 0;
  for (const auto& [depth, i] : by_depth) {
    MapPoint* existing = last_frame_.map_points[i];
    if (existing == nullptr || existing->num_observations() < 1) {
      // As ORB-SLAM2's MapPoint made from a frame: the keypoint's descriptor,
      // the viewing direction and the scale range from this one view.
      const Eigen::Vector3d position = last_frame_.UnprojectWorld(sensor_, i);
      auto point = std::make_unique<MapPoint>(kTemporaryPointIdBase + temporary_points_.size(),
                                              position, nullptr);
      const Eigen::Vector3d ray = position - last_frame_.camera_centre();
      const double distance = ray.norm();
      const double max_distance = distance * pyramid.scale[f.Octave(i)];
      point->SetNormalAndDistances(ray / distance, max_distance / pyramid.scale.back(),
                                   max_distance);
      point->SetDescriptor(f.descriptors[i]);
      last_frame_.map_points[i] = point.get();
      last_frame_.outlier[i] = 0;
      temporary_points_.push_back(std::move(point));
    }
    ++points;
    if (depth > sensor_.th_depth && points > 100) break;
  }
}

bool Tracker::Initialize() {
  const FrameFeatures& f = current_.features();
  if (f.size() <= static_cast<size_t>(options_.min_initial_keypoints)) return false;
  int with_depth = 0;
  for (size_t i = 0; i < f.size(); ++i) with_depth += f.HasDepth(i);
  if (with_depth < options_.min_initial_points) return false;

  // The first camera defines the world frame.
  current_.SetPose(Rigid3d::Identity());
  KeyFrame* keyframe = map_->CreateKeyFrame(current_);
  map_->AddKeyFrame(keyframe);
  for (size_t i = 0; i < f.size(); ++i) {
    if (!f.HasDepth(i)) continue;
    MapPoint* point = map_->CreateMapPoint(current_.UnprojectWorld(sensor_, i), keyframe);
    map_->AddObservation(point, keyframe, static_cast<uint32_t>(i));
    point->ComputeDistinctiveDescriptor();
    point->UpdateNormalAndDepth(sensor_.pyramid);
    map_->AddMapPoint(point);
    current_.map_points[i] = point;
  }
  mapper_->Enqueue(keyframe);

  last_keyframe_frame_id_ = current_.id();
  reference_keyframe_ = keyframe;
  current_.reference_keyframe = keyframe;
  local_keyframes_ = {keyframe};
  local_points_ = map_->MapPoints();
  velocity_.reset();
  relocalized_frame_id_ = current_.id();
  state_ = State::kOk;
  return true;
}

void Tracker::ReplaceInLastFrame() {
  for (MapPoint*& point : last_frame_.map_points) {
    if (point == nullptr) continue;
    while (point != nullptr && point->bad()) point = point->replaced_by();
  }
}

int Tracker::DiscardOutliers() {
  const uint64_t stamp = current_.id() + 1;
  int in_map = 0;
  for (size_t i = 0; i < current_.size(); ++i) {
    MapPoint* point = current_.map_points[i];
    if (point == nullptr) continue;
    if (current_.outlier[i]) {
      current_.map_points[i] = nullptr;
      current_.outlier[i] = 0;
      // Not searched again in this frame's local map.
      MarkSeen(point, stamp);
    } else if (point->num_observations() > 0) {
      ++in_map;
    }
  }
  return in_map;
}

bool Tracker::TrackLastFrameStill() {
  if (!options_.last_frame_fallback || !last_frame_tracked_) return false;
  const bool ok = TrackWithMotionModel(Rigid3d::Identity());
  last_frame_fallbacks_ += ok;
  return ok;
}

bool Tracker::TrackWithMotionModel(const Rigid3d& velocity) {
  // The last frame's pose follows its reference keyframe, which local bundle
  // adjustment may have moved since.
  const TrackedFrame& last_record = records_.back();
  last_frame_.SetPose(ResolvePose(last_record.reference, last_record.T_cam_reference));

  if (options_.localization_only) AddTemporaryPoints();

  current_.SetPose(velocity * last_frame_.T_cam_world());
  std::fill(current_.map_points.begin(), current_.map_points.end(), nullptr);
  const Matcher matcher(sensor_, 0.9, true);
  int matches = matcher.SearchByProjection(&current_, last_frame_, options_.motion_search_radius);
  if (matches < options_.min_motion_matches) {
    std::fill(current_.map_points.begin(), current_.map_points.end(), nullptr);
    matches = matcher.SearchByProjection(&current_, last_frame_, 2 * options_.motion_search_radius);
  }
  if (matches < options_.min_motion_matches) return false;
  OptimizeFramePose(sensor_, &current_, {}, &pose_solves_);
  const int in_map = DiscardOutliers();
  if (options_.localization_only) {
    int inliers = 0;
    for (const MapPoint* point : current_.map_points) inliers += point != nullptr;
    vo_ = in_map < options_.vo_min_map_matches;
    return inliers > options_.vo_min_matches;
  }
  return in_map >= options_.min_pose_inliers;
}

bool Tracker::TrackReferenceKeyFrame() {
  KeyFrame* keyframe = reference_keyframe_;
  if (keyframe == nullptr) return false;
  current_.ComputeBow(vocabulary_, options_.bow_levels_up);
  // A keyframe still queued for mapping has none yet.
  keyframe->ComputeBow(vocabulary_, options_.bow_levels_up);
  const Matcher matcher(sensor_, 0.7, true);
  std::vector<MapPoint*> matches;
  const int n = matcher.SearchByBow(*keyframe, current_, &matches);
  if (n < options_.min_bow_matches) return false;
  current_.map_points = std::move(matches);
  std::fill(current_.outlier.begin(), current_.outlier.end(), 0);
  current_.SetPose(last_frame_.T_cam_world());
  OptimizeFramePose(sensor_, &current_, {}, &pose_solves_);
  return DiscardOutliers() >= options_.min_pose_inliers;
}

bool Tracker::Relocalize(bool has_pose) {
  RelocalizationAttempt attempt;
  KeyFrame* keyframe = relocalizer_.RelocalizeTimed(&current_, vocabulary_, options_.bow_levels_up,
                                                    &pose_solves_, &attempt, has_pose);
  attempt.timestamp = current_.timestamp();
  relocalization_ms_.push_back(attempt.ms);
  relocalization_attempts_.push_back(attempt);
  if (keyframe == nullptr) return false;
  reference_keyframe_ = keyframe;
  relocalized_frame_id_ = current_.id();
  return true;
}

bool Tracker::TrackLocalMap() {
  UpdateLocalKeyFrames();
  UpdateLocalPoints();
  int before = 0;
  for (MapPoint* p : current_.map_points) before += p != nullptr;
  const int found = SearchLocalPoints();
  OptimizeFramePose(sensor_, &current_, {}, &pose_solves_);
  matches_inliers_ = 0;
  int map_inliers = 0;
  for (size_t i = 0; i < current_.size(); ++i) {
    MapPoint* point = current_.map_points[i];
    if (point == nullptr || current_.outlier[i]) continue;
    point->IncreaseFound();
    map_inliers += point->num_observations() > 0;
    // Localization only counts every inlier (ORB-SLAM2).
    if (point->num_observations() > 0 || options_.localization_only) ++matches_inliers_;
  }
  spdlog::debug(
      "frame {}: {} matched before local map, {} local keyframes, {} local points, {} found, "
      "{} inliers ({} of them map points)",
      current_.id(), before, local_keyframes_.size(), local_points_.size(), found, matches_inliers_,
      map_inliers);
  if (RecentlyRelocalized(options_.max_keyframe_gap) &&
      matches_inliers_ < options_.min_local_map_inliers_relocalized) {
    return false;
  }
  return matches_inliers_ >= options_.min_local_map_inliers;
}

void Tracker::UpdateLocalKeyFrames() {
  const uint64_t stamp = current_.id() + 1;
  // Votes: keyframes observing the frame's matched points, by id.
  std::map<KeyFrameId, std::pair<KeyFrame*, int>> votes;
  for (MapPoint*& point : current_.map_points) {
    if (point == nullptr) continue;
    if (point->bad()) {
      point = nullptr;
      continue;
    }
    for (const MapPoint::Observation& o : point->observations()) {
      auto [it, inserted] = votes.try_emplace(o.keyframe->id(), o.keyframe, 0);
      ++it->second.second;
    }
  }
  if (votes.empty()) return;

  // Every voter is a local keyframe, in id order (ORB-SLAM2 walks a map keyed
  // by keyframe pointer, i.e. allocation order); the reference keyframe is
  // the first with the most votes.
  local_keyframes_.clear();
  KeyFrame* best = nullptr;
  int best_votes = 0;
  for (const auto& [id, vote] : votes) {
    KeyFrame* kf = vote.first;
    if (kf->bad()) continue;
    if (vote.second > best_votes) {
      best_votes = vote.second;
      best = kf;
    }
    local_keyframes_.push_back(kf);
    keyframe_mark_[kf->id()] = stamp;
  }
  if (local_keyframes_.empty()) return;

  // Neighbours of the voters: one best covisible, one child and the parent of
  // each, up to 80 keyframes. ORB-SLAM2's loop ends at the first parent it
  // adds; expand_all_local_keyframes goes on through every voter.
  auto try_add = [&](KeyFrame* kf) {
    if (kf == nullptr || kf->bad() || keyframe_mark_[kf->id()] == stamp) return false;
    keyframe_mark_[kf->id()] = stamp;
    local_keyframes_.push_back(kf);
    return true;
  };
  const size_t voters = local_keyframes_.size();
  for (size_t k = 0; k < voters && local_keyframes_.size() <= 80; ++k) {
    KeyFrame* kf = local_keyframes_[k];
    for (KeyFrame* n : kf->BestCovisible(10)) {
      if (try_add(n)) break;
    }
    for (KeyFrame* c : kf->children()) {
      if (try_add(c)) break;
    }
    if (try_add(kf->parent()) && !options_.expand_all_local_keyframes) break;
  }
  reference_keyframe_ = best;
  current_.reference_keyframe = best;
}

void Tracker::UpdateLocalPoints() {
  const uint64_t stamp = current_.id() + 1;
  local_points_.clear();
  for (KeyFrame* kf : local_keyframes_) {
    for (MapPoint* point : kf->map_points()) {
      if (point == nullptr || point->bad() || point_mark_[point->id()] == stamp) continue;
      point_mark_[point->id()] = stamp;
      local_points_.push_back(point);
    }
  }
}

int Tracker::SearchLocalPoints() {
  const uint64_t stamp = current_.id() + 1;
  for (MapPoint*& point : current_.map_points) {
    if (point == nullptr) continue;
    if (point->bad()) {
      point = nullptr;
      continue;
    }
    point->IncreaseVisible();
    MarkSeen(point, stamp);
  }
  std::vector<ProjectedPoint> candidates;
  candidates.reserve(local_points_.size());
  const Eigen::Matrix3d& R = current_.R_cam_world();
  const Eigen::Vector3d& t = current_.T_cam_world().translation;
  const Eigen::Vector3d& centre = current_.camera_centre();
  for (MapPoint* point : local_points_) {
    if (seen_mark_[point->id()] == stamp || point->bad()) continue;
    ProjectedPoint pp;
    if (ProjectIntoView(sensor_, R, t, centre, point, 0.5, &pp)) {
      point->IncreaseVisible();
      candidates.push_back(pp);
    }
  }
  if (candidates.empty()) return 0;
  const Matcher matcher(sensor_, 0.8, false);
  return matcher.SearchByProjection(&current_, candidates,
                                    RecentlyRelocalized(2)
                                        ? options_.local_map_search_radius_relocalized
                                        : options_.local_map_search_radius);
}

bool Tracker::NeedNewKeyFrame() const {
  if (mapper_->Paused()) return false;  // Loop correction under way.
  const size_t keyframes = map_->num_keyframes();
  const uint64_t id = current_.id();
  const int max_gap = options_.max_keyframe_gap;
  if (RecentlyRelocalized(max_gap) && keyframes > static_cast<size_t>(max_gap)) {
    return false;
  }
  const int min_observations = keyframes <= 2 ? 2 : 3;
  const int reference_matches = reference_keyframe_->NumTrackedMapPoints(min_observations);
  const bool mapper_idle = mapper_->AcceptsKeyFrames();

  // Close points tracked, and close points that could become map points.
  const FrameFeatures& f = current_.features();
  int tracked_close = 0, untracked_close = 0;
  for (size_t i = 0; i < f.size(); ++i) {
    const float depth = f.Depth(i);
    if (depth <= 0 || depth >= sensor_.th_depth) continue;
    if (current_.map_points[i] != nullptr && !current_.outlier[i]) {
      ++tracked_close;
    } else {
      ++untracked_close;
    }
  }
  const bool need_close =
      tracked_close < options_.close_tracked && untracked_close > options_.close_untracked;
  const double ratio = keyframes < 2 ? 0.4 : options_.reference_ratio;

  const bool c1a = id >= last_keyframe_frame_id_ + max_gap;
  const bool c1b = mapper_idle;
  const bool c1c = matches_inliers_ < reference_matches * 0.25 || need_close;
  const bool c2 =
      (matches_inliers_ < reference_matches * ratio || need_close) && matches_inliers_ > 15;
  // Restore mapping, or new_view_fraction on a revisit: keyframes only
  // where the map lacks the view (the close keypoints no map point accounts
  // for, on kLacksViewFrames frames in a row); restore mapping then also
  // once per max_keyframe_gap frames.
  const bool gate = GatesKeyFramesByView() && (options_.restore_mapping || Revisits());
  const bool lacks_view = !gate || LacksView();
  const bool restore = options_.restore_mapping && c1a && lacks_view && matches_inliers_ > 15;
  if (!((c1a || c1b || c1c) && ((c2 && lacks_view) || restore))) return false;
  if (mapper_idle) return true;
  mapper_->InterruptBundleAdjustment();
  return mapper_->QueueSize() < 3;
}

void Tracker::CreateNewKeyFrame() {
  KeyFrame* keyframe = map_->CreateKeyFrame(current_);
  reference_keyframe_ = keyframe;
  current_.reference_keyframe = keyframe;

  // Close points first; at least new_keyframe_points points in all.
  const FrameFeatures& f = current_.features();
  std::vector<std::pair<float, uint32_t>> by_depth;
  for (size_t i = 0; i < f.size(); ++i) {
    if (f.HasDepth(i)) by_depth.emplace_back(f.Depth(i), static_cast<uint32_t>(i));
  }
  std::sort(by_depth.begin(), by_depth.end());
  int points = 0;
  for (const auto& [depth, i] : by_depth) {
    MapPoint* existing = current_.map_points[i];
    if (existing != nullptr && (existing->bad() || existing->num_observations() < 1)) {
      current_.map_points[i] = nullptr;
      keyframe->SetMapPoint(i, nullptr);
      existing = nullptr;
    }
    if (existing == nullptr) {
      MapPoint* point = map_->CreateMapPoint(current_.UnprojectWorld(sensor_, i), keyframe);
      map_->AddObservation(point, keyframe, i);
      point->ComputeDistinctiveDescriptor();
      point->UpdateNormalAndDepth(sensor_.pyramid);
      map_->AddMapPoint(point);
      current_.map_points[i] = point;
      current_.outlier[i] = 0;
    }
    ++points;
    if (depth > sensor_.th_depth && points > options_.new_keyframe_points) break;
  }
  mapper_->Enqueue(keyframe);
  last_keyframe_frame_id_ = current_.id();
}

}  // namespace rrslam
