#include "stages/track/module/loop_closer.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <unordered_map>

#include "common/clock.h"
#include "stages/track/match/matcher.h"

namespace rrslam {
namespace {

// The current point a fused one stands for.
MapPoint* Survivor(MapPoint* point) {
  while (point != nullptr && point->bad() && point->replaced_by() != nullptr) {
    point = point->replaced_by();
  }
  return point;
}

}  // namespace

LoopCloser::LoopCloser(const SensorModel& sensor, const Vocabulary& vocabulary, Map* map,
                       KeyFrameDatabase* database, LocalMapper* mapper,
                       const LoopClosingOptions& options)
    : sensor_(sensor),
      vocabulary_(vocabulary),
      map_(map),
      database_(database),
      mapper_(mapper),
      options_(options) {}

LoopCloser::~LoopCloser() {
  if (thread_.joinable()) Stop();
  StopGlobalBundleAdjustment();
}

void LoopCloser::Enqueue(KeyFrame* keyframe) {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    queue_.push_back(keyframe);
  }
  queue_cv_.notify_one();
}

void LoopCloser::ProcessQueued() {
  while (true) {
    KeyFrame* keyframe;
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      if (queue_.empty()) return;
      keyframe = queue_.front();
      queue_.pop_front();
    }
    Process(keyframe);
  }
}

void LoopCloser::Start() {
  realtime_ = true;
  stop_requested_ = false;
  thread_ = std::thread([this] { Run(); });
}

void LoopCloser::Run() {
  while (true) {
    KeyFrame* keyframe;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      queue_cv_.wait(lock, [this] { return stop_requested_ || !queue_.empty(); });
      if (queue_.empty()) return;
      keyframe = queue_.front();
      queue_.pop_front();
    }
    Process(keyframe);
  }
}

void LoopCloser::Stop() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stop_requested_ = true;
  }
  queue_cv_.notify_one();
  if (thread_.joinable()) thread_.join();
  // The last global BA is let finish (batch mode has none running).
  if (ba_thread_.joinable()) ba_thread_.join();
  realtime_ = false;
}

void LoopCloser::Reset() {
  const bool running = thread_.joinable();
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    queue_.clear();
  }
  // A global BA running now (or started by a correction in progress) is
  // aborted: its map is being discarded.
  abort_ba_.store(true);
  if (running) Stop();
  if (ba_thread_.joinable()) ba_thread_.join();
  abort_ba_.store(false);
  consistent_groups_.clear();
  accepted_candidates_.clear();
  last_loop_keyframe_.reset();
  loop_ = {};
  if (running) Start();
}

void LoopCloser::StopGlobalBundleAdjustment() {
  if (!ba_thread_.joinable()) return;
  abort_ba_.store(true);
  ba_thread_.join();
  abort_ba_.store(false);
}

void LoopCloser::Process(KeyFrame* keyframe) {
  const auto start = SteadyClock::now();
  {
    std::lock_guard<std::mutex> lock(map_->mutex());
    if (keyframe->bad()) return;
  }
  ++counters_.keyframes;
  const bool detected = DetectLoop(keyframe);
  const bool closes = detected && ComputeLoopTransform(keyframe);
  counters_.detection_ms.push_back(MillisecondsSince(start));
  if (detected) ++counters_.detections;
  if (detected && !closes) ++counters_.geometric_fails;
  if (closes) CorrectLoop(keyframe);
}

bool LoopCloser::DetectLoop(KeyFrame* keyframe) {
  std::lock_guard<std::mutex> lock(map_->mutex());
  accepted_candidates_.clear();
  keyframe->set_in_use(true);
  auto release = [&] {
    if (map_->ReleaseKeyFrame(keyframe)) database_->Erase(keyframe);
    return false;
  };
  if (static_cast<int>(map_->num_keyframes()) <= options_.min_map_keyframes ||
      (last_loop_keyframe_ &&
       keyframe->id() <
           *last_loop_keyframe_ + static_cast<KeyFrameId>(options_.keyframes_after_loop))) {
    return release();
  }
  // The bar: the lowest similarity of the keyframe to its covisible keyframes.
  double min_score = 1;
  for (const KeyFrame* neighbour : keyframe->covisible()) {
    if (neighbour->bad()) continue;
    min_score = std::min(min_score, vocabulary_.Score(keyframe->bow(), neighbour->bow()));
  }
  const std::vector<KeyFrame*> candidates = database_->DetectLoopCandidates(*keyframe, min_score);
  spdlog::debug(
      "loop detection: keyframe {} (frame {}): {} covisible, min score {:.4f}, {} candidates{}",
      keyframe->id(), keyframe->frame_id(), keyframe->covisible().size(), min_score,
      candidates.size(),
      candidates.empty() ? "" : fmt::format(" (first {})", candidates.front()->id()));
  if (candidates.empty()) {
    consistent_groups_.clear();
    return release();
  }

  // Consistency with the groups of the previous keyframes' candidates.
  std::vector<Group> current_groups;
  std::vector<uint8_t> group_continued(consistent_groups_.size(), 0);
  for (KeyFrame* candidate : candidates) {
    Group group{{candidate->id()}, 0};
    for (const KeyFrame::Connection& c : candidate->connections()) {
      group.keyframes.insert(c.keyframe->id());
    }
    bool enough = false;
    bool consistent_with_any = false;
    for (size_t g = 0; g < consistent_groups_.size(); ++g) {
      const std::set<KeyFrameId>& previous = consistent_groups_[g].keyframes;
      const bool shares = std::any_of(group.keyframes.begin(), group.keyframes.end(),
                                      [&](KeyFrameId id) { return previous.count(id) > 0; });
      if (!shares) continue;
      consistent_with_any = true;
      const int consistency = consistent_groups_[g].consistency + 1;
      if (!group_continued[g]) {
        current_groups.push_back({group.keyframes, consistency});
        group_continued[g] = 1;
      }
      if (consistency >= options_.consistency && !enough) {
        accepted_candidates_.push_back(candidate);
        enough = true;
      }
    }
    if (!consistent_with_any) current_groups.push_back(group);
  }
  consistent_groups_ = std::move(current_groups);
  if (accepted_candidates_.empty()) return release();
  return true;
}

bool LoopCloser::CheckCandidate(KeyFrame* keyframe, KeyFrame* candidate,
                                LoopCandidateMatch* match) const {
  return CheckLoopCandidate(sensor_, options_, map_->num_created_map_points(), keyframe, candidate,
                            match);
}

bool CheckLoopCandidate(const SensorModel& sensor, const LoopClosingOptions& options,
                        size_t num_point_ids, KeyFrame* keyframe, KeyFrame* candidate,
                        LoopCandidateMatch* match) {
  *match = {};
  if (candidate->bad()) return false;
  const Matcher bow_matcher(sensor, options.bow_ratio, true);
  const Matcher guided_matcher(sensor, 0.75, true);
  std::vector<MapPoint*> matches;
  match->bow_matches = bow_matcher.SearchByBow(*keyframe, *candidate, &matches);
  if (match->bow_matches < options.min_bow_matches) return false;

  // Correspondences with both points observed where they were matched.
  std::vector<size_t> index;
  std::vector<Eigen::Vector3d> points1, points2;
  std::vector<double> sigma2_1, sigma2_2;
  for (size_t i = 0; i < matches.size(); ++i) {
    MapPoint* p2 = matches[i];
    const MapPoint* p1 = keyframe->map_point(i);
    if (p2 == nullptr || p1 == nullptr || p1->bad() || p2->bad()) continue;
    const int i2 = p2->IndexIn(candidate);
    if (i2 < 0 || p1->IndexIn(keyframe) < 0) continue;
    index.push_back(i);
    points1.push_back(keyframe->ToCamera(p1->position_world()));
    points2.push_back(candidate->ToCamera(p2->position_world()));
    sigma2_1.push_back(sensor.pyramid.sigma2[keyframe->features().Octave(i)]);
    sigma2_2.push_back(sensor.pyramid.sigma2[candidate->features().Octave(i2)]);
  }
  Eigen::Matrix3d K;
  K << sensor.fx, 0, sensor.cx, 0, sensor.fy, sensor.cy, 0, 0, 1;
  const uint64_t seed = (keyframe->id() << 20) ^ candidate->id();
  const RigidRansacResult ransac =
      SolveRigidRansac(points1, points2, sigma2_1, sigma2_2, K, options.ransac, seed);
  match->ransac_inliers = ransac.inliers;
  if (!ransac.ok) return false;

  std::vector<MapPoint*> inlier_matches(keyframe->size(), nullptr);
  for (size_t k = 0; k < index.size(); ++k) {
    if (ransac.inlier[k]) inlier_matches[index[k]] = matches[index[k]];
  }
  Rigid3d T_12 = ransac.T_12;
  guided_matcher.SearchByRelativePose(*keyframe, *candidate, T_12, options.guided_radius,
                                      &inlier_matches);
  match->inliers = OptimizeRelativePose(sensor, *keyframe, *candidate, &inlier_matches, &T_12,
                                        options.relative_pose_chi2);
  if (match->inliers < options.min_optimized_inliers) return false;

  match->matched = candidate;
  match->T_cam_world = T_12 * candidate->T_cam_world();
  // The map points around the candidate, projected with the corrected pose.
  std::vector<KeyFrame*> loop_keyframes = candidate->covisible();
  loop_keyframes.push_back(candidate);
  std::vector<uint8_t> taken(num_point_ids, 0);
  for (KeyFrame* kf : loop_keyframes) {
    if (kf->bad()) continue;
    for (MapPoint* point : kf->map_points()) {
      if (point == nullptr || point->bad() || taken[point->id()]) continue;
      taken[point->id()] = 1;
      match->loop_points.push_back(point);
    }
  }
  guided_matcher.SearchByProjection(*keyframe, match->T_cam_world, match->loop_points,
                                    options.projection_radius, &inlier_matches);
  match->matches = static_cast<int>(std::count_if(inlier_matches.begin(), inlier_matches.end(),
                                                  [](MapPoint* p) { return p != nullptr; }));
  match->matched_points = std::move(inlier_matches);
  return true;
}

bool LoopCloser::ComputeLoopTransform(KeyFrame* keyframe) {
  std::lock_guard<std::mutex> lock(map_->mutex());
  for (KeyFrame* candidate : accepted_candidates_) candidate->set_in_use(true);
  // The first candidate that passes the relative-pose optimization decides.
  loop_ = {};
  for (KeyFrame* candidate : accepted_candidates_) {
    const bool passed = CheckCandidate(keyframe, candidate, &loop_);
    spdlog::debug(
        "loop check: keyframe {} (frame {}) with {} (frame {}): {} BoW matches, {} RANSAC "
        "inliers, {} optimized inliers, {} matches",
        keyframe->id(), keyframe->frame_id(), candidate->id(), candidate->frame_id(),
        loop_.bow_matches, loop_.ransac_inliers, loop_.inliers, loop_.matches);
    if (passed) break;
  }
  if (loop_.matched == nullptr || loop_.matches < options_.min_loop_matches) {
    loop_ = {};
    ReleaseCandidates(nullptr);
    if (map_->ReleaseKeyFrame(keyframe)) database_->Erase(keyframe);
    return false;
  }
  ReleaseCandidates(loop_.matched);
  return true;
}

void LoopCloser::ReleaseCandidates(const KeyFrame* keep) {
  for (KeyFrame* candidate : accepted_candidates_) {
    if (candidate == keep) continue;
    if (map_->ReleaseKeyFrame(candidate)) database_->Erase(candidate);
  }
}

void LoopCloser::CorrectLoop(KeyFrame* keyframe) {
  const auto start = SteadyClock::now();
  // A global BA of an earlier loop still running is outdated by this one: it
  // is aborted (and records so itself).
  StopGlobalBundleAdjustment();
  mapper_->Pause();
  size_t loop_index;
  LoopClosure record;
  Rigid3d T_before;
  EssentialGraphAdjuster essential_graph(sensor_, options_.essential_graph_min_weight,
                                         options_.essential_graph_iterations);
  {
    std::lock_guard<std::mutex> lock(map_->mutex());
    T_before = keyframe->T_cam_world();
    // The keyframe and its neighbours, moved by the loop correction.
    LoopCorrection correction =
        MoveLoopNeighbourhood(sensor_, map_, keyframe, loop_.matched, loop_.T_cam_world);
    const std::vector<KeyFrame*>& moved = correction.moved;

    // The loop's matched points replace the keyframe's own.
    for (size_t i = 0; i < loop_.matched_points.size(); ++i) {
      MapPoint* loop_point = Survivor(loop_.matched_points[i]);
      if (loop_point == nullptr || loop_point->bad()) continue;
      MapPoint* current = keyframe->map_point(i);
      if (current != nullptr && !current->bad()) {
        map_->ReplaceMapPoint(current, loop_point);
      } else if (!loop_point->IsObservedBy(keyframe)) {
        map_->AddObservation(loop_point, keyframe, static_cast<uint32_t>(i));
        loop_point->ComputeDistinctiveDescriptor();
      }
    }
    // The loop points fused into the moved keyframes.
    const Matcher matcher(sensor_, 0.8, true);
    std::vector<MapPoint*> replace;
    for (KeyFrame* kf : moved) {
      if (kf->bad()) continue;
      matcher.FuseForLoop(kf, loop_.loop_points, map_, options_.fuse_radius, &replace);
      for (size_t p = 0; p < replace.size(); ++p) {
        MapPoint* survivor = Survivor(loop_.loop_points[p]);
        if (replace[p] == nullptr || replace[p]->bad() || survivor == nullptr || survivor->bad()) {
          continue;
        }
        map_->ReplaceMapPoint(replace[p], survivor);
      }
    }

    // The links the fusion made are the loop connections.
    for (size_t k = 0; k < moved.size(); ++k) {
      if (moved[k]->bad()) continue;
      const std::vector<KeyFrame*> previous = moved[k]->covisible();
      map_->UpdateConnections(moved[k]);
      for (const KeyFrame::Connection& c : moved[k]->connections()) {
        const bool old = std::find(previous.begin(), previous.end(), c.keyframe) != previous.end();
        const bool neighbour = std::binary_search(moved.begin(), moved.end(), c.keyframe, IdLess());
        if (!old && !neighbour) correction.loop_connections[k].push_back(c.keyframe);
      }
    }
    essential_graph.Collect(*map_, std::move(correction));
  }
  // Solved without the map's lock, as ORB-SLAM2 does: tracking goes on.
  essential_graph.Solve();
  {
    std::lock_guard<std::mutex> lock(map_->mutex());
    essential_graph.Apply(map_);
    loop_.matched->AddLoopEdge(keyframe);
    keyframe->AddLoopEdge(loop_.matched);
    map_->ReleaseKeyFrame(loop_.matched);
    map_->ReleaseKeyFrame(keyframe);
    last_loop_keyframe_ = keyframe->id();

    record.bow_matches = loop_.bow_matches;
    record.ransac_inliers = loop_.ransac_inliers;
    record.optimized_inliers = loop_.inliers;
    record.matches = loop_.matches;
    record.keyframe = keyframe->id();
    record.matched = loop_.matched->id();
    record.timestamp = keyframe->timestamp();
    record.matched_timestamp = loop_.matched->timestamp();
    const Rigid3d& T_after = keyframe->T_cam_world();
    record.correction_m = (T_after.Inverse().translation - T_before.Inverse().translation).norm();
    record.correction_deg = RotationAngle(T_after.rotation, T_before.rotation) * 180.0 / M_PI;
    record.correction_ms = MillisecondsSince(start);
    std::lock_guard<std::mutex> counters_lock(counters_mutex_);
    counters_.essential_graph += essential_graph.solves();
    counters_.loops.push_back(record);
    loop_index = counters_.loops.size() - 1;
  }
  mapper_->Resume();
  spdlog::info(
      "loop closing: keyframe {} ({:.3f} s) closes a loop with keyframe {} ({:.3f} s): "
      "{} matches, correction {:.3f} m, {:.2f} deg",
      record.keyframe, record.timestamp, record.matched, record.matched_timestamp, record.matches,
      record.correction_m, record.correction_deg);
  loop_ = {};

  if (!options_.global_bundle_adjustment) return;
  if (realtime_) {
    ba_thread_ = std::thread([this, loop_index] { RunGlobalBundleAdjustment(loop_index, true); });
  } else {
    RunGlobalBundleAdjustment(loop_index, false);
  }
}

void LoopCloser::RunGlobalBundleAdjustment(size_t loop_index, bool realtime) {
  const auto start = SteadyClock::now();
  GlobalBundleAdjuster adjuster(sensor_, options_.global_ba_iterations);
  {
    std::lock_guard<std::mutex> lock(map_->mutex());
    adjuster.Collect(*map_);
  }
  adjuster.Solve(realtime ? &abort_ba_ : nullptr);
  if (!adjuster.stats().aborted) {
    mapper_->Pause();
    {
      std::lock_guard<std::mutex> lock(map_->mutex());
      adjuster.Apply(map_);
    }
    mapper_->Resume();
  }
  std::lock_guard<std::mutex> counters_lock(counters_mutex_);
  counters_.global_ba += adjuster.stats().solves;
  counters_.loops[loop_index].global_ba_ms = MillisecondsSince(start);
  counters_.loops[loop_index].global_ba_aborted = adjuster.stats().aborted;
}

}  // namespace rrslam
