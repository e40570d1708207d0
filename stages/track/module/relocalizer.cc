#include "stages/track/module/relocalizer.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <map>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <random>
#include <set>
#include <tuple>

#include "common/clock.h"
#include "stages/track/match/matcher.h"
#include "stages/track/solve/ransac.h"

namespace rrslam {
namespace {

// EPnP on the correspondences `indices`; false when OpenCV finds no pose.
bool Epnp(const std::vector<Eigen::Vector3d>& points_world,
          const std::vector<Eigen::Vector2d>& pixels, const std::vector<int>& indices,
          const cv::Mat& K, Rigid3d* T_cam_world) {
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  object.reserve(indices.size());
  image.reserve(indices.size());
  for (int i : indices) {
    object.emplace_back(points_world[i].x(), points_world[i].y(), points_world[i].z());
    image.emplace_back(pixels[i].x(), pixels[i].y());
  }
  cv::Mat rvec, tvec;
  if (!cv::solvePnP(object, image, K, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_EPNP)) {
    return false;
  }
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d R_eigen;
  Eigen::Vector3d t_eigen;
  cv::cv2eigen(R, R_eigen);
  cv::cv2eigen(tvec, t_eigen);
  if (!R_eigen.allFinite() || !t_eigen.allFinite()) return false;
  *T_cam_world = Rigid3d(Eigen::Quaterniond(R_eigen).normalized(), t_eigen);
  return true;
}

// Marks the correspondences within their chi-square bound at pose T.
int Score(const std::vector<Eigen::Vector3d>& points_world,
          const std::vector<Eigen::Vector2d>& pixels, const std::vector<double>& max_error2,
          const Eigen::Matrix3d& K, const Rigid3d& T, std::vector<uint8_t>* inlier) {
  int n = 0;
  for (size_t i = 0; i < points_world.size(); ++i) {
    const Eigen::Vector3d p = T * points_world[i];
    bool ok = p.z() > 0;
    if (ok) {
      const Eigen::Vector2d uv(K(0, 0) * p.x() / p.z() + K(0, 2),
                               K(1, 1) * p.y() / p.z() + K(1, 2));
      ok = (uv - pixels[i]).squaredNorm() < max_error2[i];
    }
    (*inlier)[i] = ok;
    n += ok;
  }
  return n;
}

}  // namespace

PnpResult SolvePnpRansac(const std::vector<Eigen::Vector3d>& points_world,
                         const std::vector<Eigen::Vector2d>& pixels,
                         const std::vector<double>& sigma2, const Eigen::Matrix3d& K,
                         const PnpRansacOptions& options, uint64_t seed) {
  constexpr int kMinimalSet = 4;
  PnpResult result;
  const int n = static_cast<int>(points_world.size());
  if (n < kMinimalSet || pixels.size() != points_world.size() ||
      sigma2.size() != points_world.size()) {
    return result;
  }
  // ORB-SLAM2: at least max(min_inliers, ratio * n, 4) inliers, and as many
  // iterations as find an all-inlier set with `probability` at that ratio.
  const int min_inliers =
      std::max({options.min_inliers, static_cast<int>(options.min_inlier_ratio * n), kMinimalSet});
  if (min_inliers > n) return result;
  const double ratio = std::max(options.min_inlier_ratio, static_cast<double>(min_inliers) / n);
  const int iterations = RansacIterations(options.probability, ratio, options.max_iterations);

  std::vector<double> max_error2(n);
  for (int i = 0; i < n; ++i) max_error2[i] = options.chi2 * sigma2[i];
  cv::Mat K_cv;
  cv::eigen2cv(K, K_cv);

  std::mt19937_64 rng(seed);
  std::vector<int> all(n);
  for (int i = 0; i < n; ++i) all[i] = i;
  std::vector<uint8_t> inlier(n), best_inlier(n);
  int best = -1;
  Rigid3d best_T;
  std::vector<int> sample(kMinimalSet);
  for (int it = 0; it < iterations; ++it) {
    ++result.iterations;
    DrawMinimalSet(rng, kMinimalSet, &all);
    std::copy(all.begin(), all.begin() + kMinimalSet, sample.begin());
    Rigid3d T;
    if (!Epnp(points_world, pixels, sample, K_cv, &T)) continue;
    const int count = Score(points_world, pixels, max_error2, K, T, &inlier);
    if (count > best) {
      best = count;
      best_T = T;
      best_inlier = inlier;
    }
  }
  if (best < min_inliers) return result;

  // Refit on the inliers and rescore (ORB-SLAM2's Refine).
  std::vector<int> inliers;
  for (int i = 0; i < n; ++i) {
    if (best_inlier[i]) inliers.push_back(i);
  }
  Rigid3d refined;
  if (Epnp(points_world, pixels, inliers, K_cv, &refined)) {
    const int count = Score(points_world, pixels, max_error2, K, refined, &inlier);
    if (count >= min_inliers) {
      best = count;
      best_T = refined;
      best_inlier = inlier;
    }
  }
  result.ok = true;
  result.T_cam_world = best_T;
  result.inlier = std::move(best_inlier);
  result.inliers = best;
  return result;
}

std::string ToString(RelocalizationMethod method) {
  switch (method) {
    case RelocalizationMethod::kBow:
      return "bow";
    case RelocalizationMethod::kBowDirect:
      return "bow+direct";
    case RelocalizationMethod::kDirect:
      return "direct";
  }
  return "bow";
}

namespace {
constexpr RelocalizationMethod kMethods[] = {
    RelocalizationMethod::kBow, RelocalizationMethod::kBowDirect, RelocalizationMethod::kDirect};
}  // namespace

std::vector<std::string> RelocalizationMethodNames() {
  std::vector<std::string> names;
  for (RelocalizationMethod m : kMethods) names.push_back(ToString(m));
  return names;
}

bool ParseRelocalizationMethod(const std::string& name, RelocalizationMethod* method) {
  for (RelocalizationMethod m : kMethods) {
    if (name == ToString(m)) {
      *method = m;
      return true;
    }
  }
  return false;
}

bool RelocalizationOptions::Check(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (bow_covisible < 0 || bow_covisible > 20) {
    return fail("bow_covisible = " + std::to_string(bow_covisible) + "; must be in [0, 20]");
  }
  const DirectMatchOptions& d = direct;
  if (d.max_distance < 0 || d.max_distance > 256) {
    return fail("direct.max_distance = " + std::to_string(d.max_distance) +
                "; must be in [0, 256]");
  }
  if (!(d.ratio > 0 && d.ratio <= 1)) {
    return fail("direct.ratio = " + std::to_string(d.ratio) + "; must be in (0, 1]");
  }
  if (!(d.same_point_radius >= 0)) {
    return fail("direct.same_point_radius = " + std::to_string(d.same_point_radius) +
                "; must be >= 0");
  }
  if (d.max_matches < 3) {
    return fail("direct.max_matches = " + std::to_string(d.max_matches) + "; must be >= 3");
  }
  if (d.first_queries < 0) {
    return fail("direct.first_queries = " + std::to_string(d.first_queries) + "; must be >= 0");
  }
  if (d.ransac.max_iterations < 1) {
    return fail("direct.ransac.max_iterations = " + std::to_string(d.ransac.max_iterations) +
                "; must be >= 1");
  }
  if (min_inliers < min_pose_inliers) {
    return fail("min_inliers = " + std::to_string(min_inliers) +
                "; must be >= min_pose_inliers = " + std::to_string(min_pose_inliers));
  }
  const LocalMapVerifyOptions& l = local_map;
  if (l.keyframes < 1) {
    return fail("local_map.keyframes = " + std::to_string(l.keyframes) + "; must be >= 1");
  }
  if (!(l.search_radius > 0)) {
    return fail("local_map.search_radius = " + std::to_string(l.search_radius) + "; must be > 0");
  }
  if (l.rounds < 1) {
    return fail("local_map.rounds = " + std::to_string(l.rounds) + "; must be >= 1");
  }
  return d.index.Check(why);
}

namespace {

// Each voter's best covisible keyframes in the direct stage's local map
// (as many as the tracker's local map takes).
constexpr size_t kCovisibleNeighbours = 10;

void ClearMatches(Frame* frame) {
  std::fill(frame->map_points.begin(), frame->map_points.end(), nullptr);
  std::fill(frame->outlier.begin(), frame->outlier.end(), 0);
}

std::vector<MapPointId> MatchedIds(const Frame& frame) {
  std::vector<MapPointId> ids;
  for (MapPoint* p : frame.map_points) {
    if (p != nullptr) ids.push_back(p->id());
  }
  std::sort(ids.begin(), ids.end());
  return ids;
}

// The keyframe that observes most of the frame's matched points (ties: the
// lowest id).
KeyFrame* MostObservingKeyFrame(const Frame& frame) {
  std::map<KeyFrameId, std::pair<int, KeyFrame*>> votes;
  for (MapPoint* p : frame.map_points) {
    if (p == nullptr || p->bad()) continue;
    for (const MapPoint::Observation& o : p->observations()) {
      auto& vote = votes[o.keyframe->id()];
      ++vote.first;
      vote.second = o.keyframe;
    }
  }
  KeyFrame* best = nullptr;
  int most = 0;
  for (const auto& [id, vote] : votes) {
    if (vote.first > most && !vote.second->bad()) {
      most = vote.first;
      best = vote.second;
    }
  }
  return best;
}

// `points` without the frame's matched points, each once, where it came
// first. Through a table of the points seen (open addressing, at most half
// full): a local map lists some 11 000 points of 2 300, and a std::set of
// them, or sorting them, cost a millisecond of each verification round.
std::vector<MapPoint*> UnmatchedOnce(const Frame& frame, std::vector<MapPoint*> points) {
  size_t capacity = 64;
  while (capacity < 2 * (points.size() + frame.map_points.size())) capacity *= 2;
  const int shift = 64 - std::countr_zero(capacity);
  std::vector<const MapPoint*> seen(capacity, nullptr);
  // True when `p` was not seen before (and now is).
  const auto insert = [&](const MapPoint* p) {
    const uint64_t hash = (reinterpret_cast<uintptr_t>(p) >> 4) * 0x9E3779B97F4A7C15ull;
    for (size_t i = hash >> shift;; i = (i + 1) & (capacity - 1)) {
      if (seen[i] == p) return false;
      if (seen[i] == nullptr) {
        seen[i] = p;
        return true;
      }
    }
  };
  for (const MapPoint* p : frame.map_points) {
    if (p != nullptr) insert(p);
  }
  size_t kept = 0;
  for (MapPoint* p : points) {
    if (insert(p)) points[kept++] = p;
  }
  points.resize(kept);
  return points;
}

// The map points near a frame's matched points, not yet matched: those of
// the keyframes observing the matched points and of each one's best
// covisible keyframes, up to `max_keyframes` keyframes (voters first, by id).
std::vector<MapPoint*> LocalMapPoints(const Frame& frame, int max_keyframes) {
  std::map<KeyFrameId, KeyFrame*> voters;
  for (MapPoint* p : frame.map_points) {
    if (p == nullptr || p->bad()) continue;
    for (const MapPoint::Observation& o : p->observations()) {
      if (!o.keyframe->bad()) voters.emplace(o.keyframe->id(), o.keyframe);
    }
  }
  std::vector<KeyFrame*> keyframes;
  std::set<KeyFrameId> taken;
  auto take = [&](KeyFrame* kf) {
    if (static_cast<int>(keyframes.size()) < max_keyframes && !kf->bad() &&
        taken.insert(kf->id()).second) {
      keyframes.push_back(kf);
    }
  };
  for (const auto& [id, kf] : voters) take(kf);
  for (const auto& [id, kf] : voters) {
    for (KeyFrame* n : kf->BestCovisible(kCovisibleNeighbours)) take(n);
  }
  // Each point once before any is read: reading a point (is it bad?) is a
  // cache miss on a big map, and the keyframes hold each some five times.
  std::vector<MapPoint*> points;
  for (KeyFrame* kf : keyframes) {
    for (MapPoint* p : kf->map_points()) {
      if (p != nullptr) points.push_back(p);
    }
  }
  points = UnmatchedOnce(frame, std::move(points));
  std::erase_if(points, [](const MapPoint* p) { return p->bad(); });
  return points;
}

}  // namespace

void Relocalizer::PrepareIndexInBackground() {
  if (options_.method == RelocalizationMethod::kBow) return;
  WaitForBackgroundIndex();
  const auto start = SteadyClock::now();
  index_.Snapshot(map_);
  background_index_ = std::async(std::launch::async, [this, start] {
    index_.BuildTables();
    return MillisecondsSince(start);
  });
}

double Relocalizer::WaitForBackgroundIndex() {
  if (background_index_.valid()) background_index_ms_ = background_index_.get();
  return background_index_ms_;
}

double Relocalizer::PrepareIndex() {
  const auto start = SteadyClock::now();
  const bool waiting = background_index_.valid();
  WaitForBackgroundIndex();
  if (options_.method == RelocalizationMethod::kBow || index_.IsCurrent(map_)) {
    return waiting ? MillisecondsSince(start) : 0;
  }
  index_.Build(map_);
  return MillisecondsSince(start);
}

KeyFrame* Relocalizer::Relocalize(Frame* frame, SolveCounts* solves, RelocalizationAttempt* attempt,
                                  bool has_pose) {
  RelocalizationAttempt local;
  RelocalizationAttempt* a = attempt != nullptr ? attempt : &local;
  *a = RelocalizationAttempt{};
  ClearMatches(frame);
  if (options_.method != RelocalizationMethod::kDirect) {
    const auto bow_start = SteadyClock::now();
    KeyFrame* kf = RelocalizeByBow(frame, solves, a);
    a->bow_stage_ms = MillisecondsSince(bow_start);
    if (kf != nullptr) {
      a->stage = "bow";
      return kf;
    }
  }
  const bool direct = options_.method == RelocalizationMethod::kDirect ||
                      (options_.method == RelocalizationMethod::kBowDirect && !has_pose);
  if (direct) {
    if (KeyFrame* kf = RelocalizeDirect(frame, solves, a)) {
      a->stage = "direct";
      return kf;
    }
  }
  ClearMatches(frame);
  return nullptr;
}

KeyFrame* Relocalizer::RelocalizeTimed(Frame* frame, const Vocabulary& vocabulary,
                                       int bow_levels_up, SolveCounts* solves,
                                       RelocalizationAttempt* attempt, bool has_pose) {
  const auto start = SteadyClock::now();
  if (options_.method != RelocalizationMethod::kDirect) {
    frame->ComputeBow(vocabulary, bow_levels_up);
  }
  KeyFrame* keyframe = Relocalize(frame, solves, attempt, has_pose);
  attempt->ms = MillisecondsSince(start);
  return keyframe;
}

int Relocalizer::OptimizeInliers(Frame* frame, SolveCounts* solves) const {
  const int good = OptimizeFramePose(sensor_, frame, {}, solves);
  for (size_t i = 0; i < frame->size(); ++i) {
    if (frame->map_points[i] != nullptr && frame->outlier[i]) {
      frame->map_points[i] = nullptr;
      frame->outlier[i] = 0;
    }
  }
  return good;
}

int Relocalizer::Verify(Frame* frame, const KeyFrame& kf, SolveCounts* solves) const {
  const Matcher projection_matcher(sensor_, 0.9, true);
  int good = OptimizeInliers(frame, solves);
  if (good < options_.min_pose_inliers) return 0;
  // Few inliers: more of the keyframe's points, by projection, in a coarse
  // window, then (when close) in a narrow one.
  if (good < options_.min_inliers) {
    const int added = projection_matcher.SearchByProjection(frame, kf, MatchedIds(*frame), 10, 100);
    if (added + good >= options_.min_inliers) {
      good = OptimizeInliers(frame, solves);
      if (good > 30 && good < options_.min_inliers) {
        const int more =
            projection_matcher.SearchByProjection(frame, kf, MatchedIds(*frame), 3, 64);
        if (good + more >= options_.min_inliers) good = OptimizeInliers(frame, solves);
      }
    }
  }
  return good;
}

int Relocalizer::VerifyByLocalMap(Frame* frame, SolveCounts* solves) const {
  const LocalMapVerifyOptions& o = options_.local_map;
  int good = OptimizeInliers(frame, solves);
  if (good < options_.min_pose_inliers) return 0;
  const Matcher matcher(sensor_, 0.8, false);
  for (int round = 0; round < o.rounds; ++round) {
    const Eigen::Matrix3d R = frame->R_cam_world();
    const Eigen::Vector3d t = frame->T_cam_world().translation;
    const Eigen::Vector3d centre = frame->camera_centre();
    std::vector<ProjectedPoint> predicted;
    for (MapPoint* point : LocalMapPoints(*frame, o.keyframes)) {
      ProjectedPoint pp;
      if (ProjectIntoView(sensor_, R, t, centre, point, 0.5, &pp)) predicted.push_back(pp);
    }
    const int added = matcher.SearchByProjection(frame, predicted, o.search_radius);
    spdlog::debug(
        "relocalization: frame {}: local map round {}: {} inliers, {} predicted, {} added",
        frame->id(), round, good, predicted.size(), added);
    good = OptimizeInliers(frame, solves);
  }
  return good;
}

int Relocalizer::BowMatches(const Matcher& matcher, const KeyFrame& kf, const Frame& frame,
                            std::vector<MapPoint*>* matches) const {
  int n = matcher.SearchByBow(kf, frame, matches);
  if (options_.bow_covisible <= 0) return n;
  std::set<const MapPoint*> taken(matches->begin(), matches->end());
  std::vector<MapPoint*> more;
  for (KeyFrame* c : kf.BestCovisible(static_cast<size_t>(options_.bow_covisible))) {
    if (c->bad()) continue;
    matcher.SearchByBow(*c, frame, &more);
    for (size_t i = 0; i < more.size(); ++i) {
      if ((*matches)[i] != nullptr || more[i] == nullptr || !taken.insert(more[i]).second) continue;
      (*matches)[i] = more[i];
      ++n;
    }
  }
  return n;
}

KeyFrame* Relocalizer::RelocalizeByBow(Frame* frame, SolveCounts* solves,
                                       RelocalizationAttempt* attempt) {
  const auto query_start = SteadyClock::now();
  const std::vector<KeyFrame*> candidates = database_.DetectRelocalizationCandidates(frame->bow());
  attempt->bow_query_ms = MillisecondsSince(query_start);
  attempt->bow_candidates = static_cast<int>(candidates.size());
  const FrameFeatures& f = frame->features();
  const Eigen::Matrix3d K = sensor_.camera.K();
  const Matcher bow_matcher(sensor_, options_.bow_ratio, true);
  for (KeyFrame* kf : candidates) {
    if (kf->bad()) continue;
    std::vector<MapPoint*> matches;
    if (BowMatches(bow_matcher, *kf, *frame, &matches) < options_.min_bow_matches) continue;

    std::vector<Eigen::Vector3d> points_world;
    std::vector<Eigen::Vector2d> pixels;
    std::vector<double> sigma2;
    std::vector<uint32_t> keypoint;
    for (size_t i = 0; i < matches.size(); ++i) {
      if (matches[i] == nullptr || matches[i]->bad()) continue;
      points_world.push_back(matches[i]->position_world());
      const Keypoint& kp = f.keypoints[i];
      pixels.emplace_back(kp.undistorted.x(), kp.undistorted.y());
      sigma2.push_back(sensor_.pyramid.sigma2[kp.octave]);
      keypoint.push_back(static_cast<uint32_t>(i));
    }
    const PnpResult pnp =
        SolvePnpRansac(points_world, pixels, sigma2, K, options_.ransac, frame->id() ^ kf->id());
    if (!pnp.ok) continue;

    ClearMatches(frame);
    for (size_t j = 0; j < keypoint.size(); ++j) {
      if (pnp.inlier[j]) frame->map_points[keypoint[j]] = matches[keypoint[j]];
    }
    frame->SetPose(pnp.T_cam_world);
    // A covisible window's matches are verified against its local map.
    const int good =
        options_.bow_covisible > 0 ? VerifyByLocalMap(frame, solves) : Verify(frame, *kf, solves);
    attempt->inliers = std::max(attempt->inliers, good);
    if (good >= options_.min_inliers) {
      attempt->inliers = good;
      return kf;
    }
  }
  ClearMatches(frame);
  return nullptr;
}

std::vector<uint32_t> Relocalizer::QueryOrder(const Frame& frame) {
  const FrameFeatures& f = frame.features();
  std::vector<uint32_t> order(f.size());
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&f](uint32_t a, uint32_t b) {
    const bool depth_a = f.HasDepth(a), depth_b = f.HasDepth(b);
    if (depth_a != depth_b) return depth_a;
    return f.keypoints[a].response > f.keypoints[b].response;
  });
  return order;
}

void Relocalizer::SearchIndex(const Frame& frame, const std::vector<uint32_t>& order, size_t begin,
                              size_t end, std::vector<DescriptorNeighbours>* nearest) const {
  const FrameFeatures& f = frame.features();
  std::vector<OrbDescriptor> queries;
  queries.reserve(end - begin);
  for (size_t k = begin; k < end; ++k) queries.push_back(f.descriptors[order[k]]);
  const std::vector<DescriptorNeighbours> found = index_.Search(queries);
  for (size_t k = begin; k < end; ++k) (*nearest)[order[k]] = found[k - begin];
}

std::vector<PoseCorrespondence> Relocalizer::DirectMatches(
    const Frame& frame, const std::vector<DescriptorNeighbours>& nearest,
    std::vector<MapPoint*>* points, std::vector<uint32_t>* keypoints) const {
  const FrameFeatures& f = frame.features();
  const DirectMatchOptions& o = options_.direct;
  points->clear();
  keypoints->clear();
  struct Candidate {
    double ratio;  // Nearest / second nearest distance (0: no second).
    int distance;
    uint32_t keypoint;
    MapPoint* point;
  };
  std::vector<Candidate> candidates;
  for (size_t i = 0; i < nearest.size(); ++i) {
    const DescriptorNeighbours& n = nearest[i];
    if (n.first == nullptr || n.first_distance > o.max_distance) continue;
    double ratio = 0;
    if (n.second != nullptr &&
        (n.second->position_world() - n.first->position_world()).norm() > o.same_point_radius) {
      ratio = static_cast<double>(n.first_distance) / std::max(1, n.second_distance);
      if (ratio >= o.ratio) continue;
    }
    candidates.push_back({ratio, n.first_distance, static_cast<uint32_t>(i), n.first});
  }
  // One keypoint per point (the closest), then the most distinctive first.
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return std::tie(a.point, a.distance, a.keypoint) < std::tie(b.point, b.distance, b.keypoint);
  });
  candidates.erase(
      std::unique(candidates.begin(), candidates.end(),
                  [](const Candidate& a, const Candidate& b) { return a.point == b.point; }),
      candidates.end());
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return std::tie(a.ratio, a.distance, a.keypoint) < std::tie(b.ratio, b.distance, b.keypoint);
  });
  if (candidates.size() > static_cast<size_t>(o.max_matches)) candidates.resize(o.max_matches);

  std::vector<PoseCorrespondence> matches;
  for (const Candidate& c : candidates) {
    const Keypoint& kp = f.keypoints[c.keypoint];
    PoseCorrespondence m;
    m.point_world = c.point->position_world();
    m.pixel = f.Pixel(c.keypoint);
    m.octave = kp.octave;
    if (f.HasDepth(c.keypoint)) {
      m.u_right = f.u_right[c.keypoint];
      m.depth = f.Depth(c.keypoint);
    }
    matches.push_back(m);
    points->push_back(c.point);
    keypoints->push_back(c.keypoint);
  }
  return matches;
}

bool Relocalizer::SolveDirectPose(const std::vector<PoseCorrespondence>& matches, uint64_t seed,
                                  std::vector<uint8_t>* inlier, Rigid3d* T) const {
  const AbsolutePoseRansacOptions& ransac = options_.direct.ransac;
  if (static_cast<int>(matches.size()) < ransac.min_inliers) return false;
  const int with_depth = static_cast<int>(std::count_if(
      matches.begin(), matches.end(), [](const PoseCorrespondence& m) { return m.depth > 0; }));
  if (with_depth >= ransac.min_inliers) {
    AbsolutePoseResult r = SolveAbsolutePoseRansac(matches, sensor_, ransac, seed);
    *inlier = std::move(r.inlier);
    *T = r.T_cam_world;
    return r.ok;
  }
  std::vector<Eigen::Vector3d> points_world;
  std::vector<Eigen::Vector2d> pixels;
  std::vector<double> sigma2;
  for (const PoseCorrespondence& m : matches) {
    points_world.push_back(m.point_world);
    pixels.push_back(m.pixel);
    sigma2.push_back(sensor_.pyramid.sigma2[m.octave]);
  }
  // A shortlist from the whole map holds more outliers than a keyframe's
  // BoW matches: no minimum inlier ratio, the direct stage's iterations.
  PnpRansacOptions pnp = options_.ransac;
  pnp.min_inlier_ratio = 0;
  pnp.min_inliers = ransac.min_inliers;
  pnp.max_iterations = ransac.max_iterations;
  PnpResult r = SolvePnpRansac(points_world, pixels, sigma2, sensor_.camera.K(), pnp, seed);
  *inlier = std::move(r.inlier);
  *T = r.T_cam_world;
  return r.ok;
}

KeyFrame* Relocalizer::RelocalizeDirect(Frame* frame, SolveCounts* solves,
                                        RelocalizationAttempt* attempt) {
  ClearMatches(frame);
  attempt->index_ms = PrepareIndex();
  const std::vector<uint32_t> order = QueryOrder(*frame);
  const size_t first =
      options_.direct.first_queries > 0
          ? std::min(order.size(), static_cast<size_t>(options_.direct.first_queries))
          : order.size();
  std::vector<DescriptorNeighbours> nearest(order.size());
  size_t searched = 0;
  for (size_t end : {first, order.size()}) {
    if (end <= searched) continue;
    const auto search_start = SteadyClock::now();
    SearchIndex(*frame, order, searched, end, &nearest);
    spdlog::debug("relocalization: frame {}: keypoints {}-{} searched in {:.1f} ms", frame->id(),
                  searched, end, MillisecondsSince(search_start));
    searched = end;
    attempt->direct_queries = static_cast<int>(searched);
    if (KeyFrame* kf = DirectPose(frame, nearest, solves, attempt)) return kf;
  }
  return nullptr;
}

KeyFrame* Relocalizer::DirectPose(Frame* frame, const std::vector<DescriptorNeighbours>& nearest,
                                  SolveCounts* solves, RelocalizationAttempt* attempt) {
  std::vector<MapPoint*> points;
  std::vector<uint32_t> keypoints;
  const std::vector<PoseCorrespondence> matches =
      DirectMatches(*frame, nearest, &points, &keypoints);
  attempt->direct_matches = static_cast<int>(matches.size());
  const auto ransac_start = SteadyClock::now();
  std::vector<uint8_t> inlier;
  Rigid3d T;
  if (!SolveDirectPose(matches, frame->id(), &inlier, &T)) return nullptr;
  int ransac_inliers = 0;
  for (size_t j = 0; j < keypoints.size(); ++j) {
    if (inlier[j]) frame->map_points[keypoints[j]] = points[j];
    ransac_inliers += inlier[j];
  }
  spdlog::debug("relocalization: frame {}: {} direct matches, RANSAC {} inliers in {:.1f} ms",
                frame->id(), matches.size(), ransac_inliers, MillisecondsSince(ransac_start));
  frame->SetPose(T);
  const int good = VerifyByLocalMap(frame, solves);
  KeyFrame* kf = MostObservingKeyFrame(*frame);
  if (good < options_.min_inliers || kf == nullptr) {
    attempt->inliers = std::max(attempt->inliers, good);
    ClearMatches(frame);
    return nullptr;
  }
  attempt->inliers = good;
  return kf;
}

}  // namespace rrslam
