#include "stages/track/optimize/loop_optimizer.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <set>

#include "stages/track/optimize/pose_graph_error.h"
#include "stages/track/optimize/reprojection_error.h"

namespace rrslam {
namespace {

// Whitened pixel error of a fixed camera-frame point mapped by a relative
// pose: with `inverse` false the point is in camera 2 and maps by T_12 into
// camera 1; with `inverse` true it is in camera 1 and maps by T_12^-1.
struct RelativeProjectionError {
  RelativeProjectionError(const ProjectionParameters& k, const Eigen::Vector2d& observed,
                          const Eigen::Vector3d& point, double inv_sigma, bool inverse)
      : k(k), observed(observed), point(point), inv_sigma(inv_sigma), inverse(inverse) {}

  template <typename T>
  bool operator()(const T* pose, T* residuals) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(pose);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(pose + 4);
    const Eigen::Matrix<T, 3, 1> p = point.cast<T>();
    const Eigen::Matrix<T, 3, 1> x = inverse ? Eigen::Matrix<T, 3, 1>(q.conjugate() * (p - t))
                                             : Eigen::Matrix<T, 3, 1>(q * p + t);
    if (x.z() <= T(1e-9)) return false;
    residuals[0] = (T(observed.x()) - (T(k.fx) * x.x() / x.z() + T(k.cx))) * T(inv_sigma);
    residuals[1] = (T(observed.y()) - (T(k.fy) * x.y() / x.z() + T(k.cy))) * T(inv_sigma);
    return true;
  }

  ProjectionParameters k;
  Eigen::Vector2d observed;
  Eigen::Vector3d point;
  double inv_sigma;
  bool inverse;
};

ceres::Solver::Options SolverOptions(int iterations) {
  ceres::Solver::Options options;
  options.max_num_iterations = SuccessfulStepLimit::MaxIterationsFor(iterations);
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  return options;
}

// Solves with at most `iterations` successful steps (SuccessfulStepLimit);
// adds the solve to `counts` (may be null).
ceres::Solver::Summary SolveCounted(ceres::Solver::Options options, ceres::Problem* problem,
                                    int iterations, SolveCounts* counts) {
  SuccessfulStepLimit step_limit(iterations);
  options.callbacks.push_back(&step_limit);
  ceres::Solver::Summary summary;
  ceres::Solve(options, problem, &summary);
  if (counts != nullptr) counts->Add(summary, iterations, step_limit.successful_steps());
  return summary;
}

// Poses before and after an optimization, by keyframe id: of the
// optimized keyframes (those not bad), and of the keyframes made since,
// each moved with its spanning-tree parent (its pose relative to it kept).
struct PoseChanges {
  std::vector<uint8_t> moved;
  std::vector<Rigid3d> before, after;
  // A world point that moves rigidly with keyframe `id`.
  Eigen::Vector3d Move(KeyFrameId id, const Eigen::Vector3d& p_world) const {
    return after[id].Inverse() * (before[id] * p_world);
  }
};

// Sets the poses `after` (per keyframe of `keyframes`, whose poses were
// `before`) and moves the keyframes made since with their parents.
PoseChanges ChangePoses(Map* map, const std::vector<KeyFrame*>& keyframes,
                        const std::vector<Rigid3d>& before, const std::vector<Rigid3d>& after) {
  const size_t n = map->num_created_keyframes();
  PoseChanges c{std::vector<uint8_t>(n, 0), std::vector<Rigid3d>(n), std::vector<Rigid3d>(n)};
  for (size_t i = 0; i < keyframes.size(); ++i) {
    const KeyFrame* kf = keyframes[i];
    if (kf->bad()) continue;
    c.moved[kf->id()] = 1;
    c.before[kf->id()] = before[i];
    c.after[kf->id()] = after[i];
  }
  if (map->root() != nullptr) {
    std::vector<KeyFrame*> stack = {map->root()};
    while (!stack.empty()) {
      KeyFrame* kf = stack.back();
      stack.pop_back();
      for (KeyFrame* child : kf->children()) {
        if (child->bad()) continue;
        if (!c.moved[child->id()] && c.moved[kf->id()]) {
          c.moved[child->id()] = 1;
          c.before[child->id()] = child->T_cam_world();
          c.after[child->id()] = child->T_cam_world() * kf->T_world_cam() * c.after[kf->id()];
        }
        stack.push_back(child);
      }
    }
  }
  for (KeyFrame* kf : map->KeyFrames()) {
    if (c.moved[kf->id()]) kf->SetPose(c.after[kf->id()]);
  }
  return c;
}

}  // namespace

int OptimizeRelativePose(const SensorModel& sensor, const KeyFrame& kf1, const KeyFrame& kf2,
                         std::vector<MapPoint*>* matches12, Rigid3d* T_12, double chi2,
                         SolveCounts* counts) {
  const ProjectionParameters k = ProjectionParametersOf(sensor);
  struct Match {
    size_t index1;
    std::unique_ptr<ceres::CostFunction> e12, e21;
    bool outlier = false;
  };
  std::vector<Match> matches;
  for (size_t i = 0; i < matches12->size(); ++i) {
    MapPoint* p2 = (*matches12)[i];
    const MapPoint* p1 = kf1.map_point(i);
    if (p1 == nullptr || p2 == nullptr || p1->bad() || p2->bad()) continue;
    const int i2 = p2->IndexIn(&kf2);
    if (i2 < 0) continue;
    const Keypoint& kp1 = kf1.features().keypoints[i];
    const Keypoint& kp2 = kf2.features().keypoints[i2];
    Match m;
    m.index1 = i;
    m.e12 = std::make_unique<ceres::AutoDiffCostFunction<RelativeProjectionError, 2, 7>>(
        new RelativeProjectionError(k, kp1.undistorted.cast<double>(),
                                    kf2.ToCamera(p2->position_world()),
                                    std::sqrt(sensor.pyramid.inv_sigma2[kp1.octave]), false));
    m.e21 = std::make_unique<ceres::AutoDiffCostFunction<RelativeProjectionError, 2, 7>>(
        new RelativeProjectionError(k, kp2.undistorted.cast<double>(),
                                    kf1.ToCamera(p1->position_world()),
                                    std::sqrt(sensor.pyramid.inv_sigma2[kp2.octave]), true));
    matches.push_back(std::move(m));
  }

  std::array<double, 7> pose = ToPoseBlock(*T_12);
  ceres::HuberLoss loss(std::sqrt(chi2));
  auto chi2_of = [&](const ceres::CostFunction& cost) {
    const double* parameters[] = {pose.data()};
    double r[2];
    if (!cost.Evaluate(parameters, r, nullptr)) return std::numeric_limits<double>::infinity();
    return r[0] * r[0] + r[1] * r[1];
  };
  auto solve = [&](int iterations) {
    ceres::Problem::Options problem_options = ProblemOptions();
    problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    problem.AddParameterBlock(pose.data(), 7, PoseManifold());
    int residuals = 0;
    for (const Match& m : matches) {
      // A point behind a camera cannot enter the problem: it stays out.
      if (m.outlier || !std::isfinite(chi2_of(*m.e12)) || !std::isfinite(chi2_of(*m.e21))) {
        continue;
      }
      problem.AddResidualBlock(m.e12.get(), &loss, pose.data());
      problem.AddResidualBlock(m.e21.get(), &loss, pose.data());
      ++residuals;
    }
    if (residuals == 0) return;
    ceres::Solver::Options options = SolverOptions(iterations);
    options.linear_solver_type = ceres::DENSE_QR;
    SolveCounted(options, &problem, iterations, counts);
  };
  auto classify = [&]() {
    int bad = 0;
    for (Match& m : matches) {
      if (m.outlier) continue;
      if (chi2_of(*m.e12) > chi2 || chi2_of(*m.e21) > chi2) {
        m.outlier = true;
        (*matches12)[m.index1] = nullptr;
        ++bad;
      }
    }
    return bad;
  };

  solve(5);
  const int bad = classify();
  if (static_cast<int>(matches.size()) - bad < 10) return 0;
  solve(bad > 0 ? 10 : 5);
  const int more_bad = classify();
  *T_12 = FromPoseBlock(pose);
  return static_cast<int>(matches.size()) - bad - more_bad;
}

double OptimizePoseGraph(PoseGraph* graph, int iterations, SolveCounts* counts) {
  std::vector<std::array<double, 7>> blocks(graph->poses.size());
  for (size_t v = 0; v < blocks.size(); ++v) blocks[v] = ToPoseBlock(graph->poses[v]);
  ceres::Problem problem(ProblemOptions());
  for (size_t v = 0; v < blocks.size(); ++v) {
    problem.AddParameterBlock(blocks[v].data(), 7, PoseManifold());
    if (graph->fixed[v]) problem.SetParameterBlockConstant(blocks[v].data());
  }
  for (const PoseGraph::Edge& e : graph->edges) {
    problem.AddResidualBlock(new PoseGraphEdgeCost(e.T_j_i), nullptr, blocks[e.i].data(),
                             blocks[e.j].data());
  }
  if (graph->edges.empty()) return 0;
  ceres::Solver::Options options = SolverOptions(iterations);
  ChooseLinearSolver(ceres::SPARSE_NORMAL_CHOLESKY, ceres::DENSE_QR, &options);
  const ceres::Solver::Summary summary = SolveCounted(options, &problem, iterations, counts);
  for (size_t v = 0; v < blocks.size(); ++v) {
    if (!graph->fixed[v]) graph->poses[v] = FromPoseBlock(blocks[v]);
  }
  return summary.final_cost;
}

void GlobalBundleAdjuster::Collect(const Map& map) {
  keyframes_ = map.KeyFrames();
  keyframe_fixed_.assign(keyframes_.size(), 0);
  poses_.resize(keyframes_.size());
  std::vector<int32_t> keyframe_index(map.num_created_keyframes(), -1);
  for (size_t i = 0; i < keyframes_.size(); ++i) {
    keyframe_index[keyframes_[i]->id()] = static_cast<int32_t>(i);
    keyframe_fixed_[i] = keyframes_[i] == map.root();
    poses_[i] = ToPoseBlock(keyframes_[i]->T_cam_world());
  }
  // Sized first: on a big map, growing the arrays' fresh memory would cost
  // more than the copy itself (3k keyframes: 1.2 M observations).
  const std::vector<MapPoint*> map_points = map.MapPoints();
  size_t observations = 0;
  for (const MapPoint* point : map_points) observations += point->observations().size();
  points_.clear();
  positions_.clear();
  observations_.clear();
  points_.reserve(map_points.size());
  positions_.reserve(map_points.size());
  observations_.reserve(observations);
  stats_ = {};
  for (MapPoint* point : map_points) {
    const uint32_t p = static_cast<uint32_t>(points_.size());
    bool observed = false;
    for (const MapPoint::Observation& o : point->observations()) {
      const KeyFrameId id = o.keyframe->id();
      if (id >= keyframe_index.size() || keyframe_index[id] < 0) continue;
      observations_.push_back({p, static_cast<uint32_t>(keyframe_index[id]), o.index});
      observed = true;
    }
    if (!observed) continue;
    points_.push_back(point);
    positions_.push_back(point->position_world());
  }
  stats_.keyframes = static_cast<int>(keyframes_.size());
  stats_.points = static_cast<int>(points_.size());
  stats_.observations = static_cast<int>(observations_.size());
}

void GlobalBundleAdjuster::Solve(const std::atomic<bool>* abort) {
  if (observations_.empty()) return;
  const ProjectionParameters k = ProjectionParametersOf(sensor_);
  ceres::Problem problem(ProblemOptions());
  auto* ordering = new ceres::ParameterBlockOrdering;
  std::vector<uint8_t> keyframe_used(keyframes_.size(), 0);
  for (const Observation& o : observations_) {
    // From the keyframe's features, which never change: read here rather
    // than in Collect, as the map's lock is not needed for them.
    const KeypointMeasurement m = MeasurementOf(sensor_, *keyframes_[o.keyframe], o.keypoint);
    ceres::CostFunction* cost;
    double* pose = poses_[o.keyframe].data();
    double* point = positions_[o.point].data();
    // A point behind the camera has no defined residual: left out.
    double r[3];
    const double* parameters[] = {pose, point};
    if (m.with_depth) {
      cost = new ReprojectionError<3>(
          k, Eigen::Vector3d(m.observed[0], m.observed[1], m.observed[2]), m.inv_sigma);
    } else {
      cost =
          new ReprojectionError<2>(k, Eigen::Vector2d(m.observed[0], m.observed[1]), m.inv_sigma);
    }
    if (!cost->Evaluate(parameters, r, nullptr)) {
      delete cost;
      continue;
    }
    if (!keyframe_used[o.keyframe]) {
      keyframe_used[o.keyframe] = 1;
      problem.AddParameterBlock(pose, 7, PoseManifold());
      if (keyframe_fixed_[o.keyframe]) problem.SetParameterBlockConstant(pose);
      ordering->AddElementToGroup(pose, 1);
    }
    if (!problem.HasParameterBlock(point)) {
      problem.AddParameterBlock(point, 3);
      ordering->AddElementToGroup(point, 0);
    }
    problem.AddResidualBlock(cost, nullptr, pose, point);
  }
  if (problem.NumResidualBlocks() == 0) {
    delete ordering;
    return;
  }
  ceres::Solver::Options options = SolverOptions(iterations_);
  ChooseLinearSolver(ceres::SPARSE_SCHUR, ceres::DENSE_SCHUR, &options);
  options.linear_solver_ordering.reset(ordering);
  AbortCallback abort_callback(abort);
  options.callbacks.push_back(&abort_callback);
  const ceres::Solver::Summary summary =
      SolveCounted(options, &problem, iterations_, &stats_.solves);
  stats_.initial_cost = summary.initial_cost;
  stats_.final_cost = summary.final_cost;
  stats_.aborted = abort != nullptr && abort->load();
}

void GlobalBundleAdjuster::Apply(Map* map) {
  std::vector<Rigid3d> before(keyframes_.size()), after(keyframes_.size());
  for (size_t i = 0; i < keyframes_.size(); ++i) {
    before[i] = keyframes_[i]->T_cam_world();
    after[i] = FromPoseBlock(poses_[i]);
  }
  const PoseChanges change = ChangePoses(map, keyframes_, before, after);
  std::vector<uint8_t> in_snapshot(map->num_created_map_points(), 0);
  for (size_t p = 0; p < points_.size(); ++p) {
    in_snapshot[points_[p]->id()] = 1;
    if (!points_[p]->bad()) points_[p]->SetPosition(positions_[p]);
  }
  for (MapPoint* point : map->MapPoints()) {
    if (in_snapshot[point->id()]) continue;
    const KeyFrame* ref = point->reference_keyframe();
    if (ref == nullptr || ref->bad() || !change.moved[ref->id()]) continue;
    point->SetPosition(change.Move(ref->id(), point->position_world()));
  }
}

LoopCorrection MoveLoopNeighbourhood(const SensorModel& sensor, Map* map, KeyFrame* keyframe,
                                     const KeyFrame* matched, const Rigid3d& T_cam_world) {
  map->UpdateConnections(keyframe);
  LoopCorrection c;
  c.keyframe = keyframe;
  c.matched = matched;
  c.moved = keyframe->covisible();
  c.moved.push_back(keyframe);
  std::sort(c.moved.begin(), c.moved.end(), IdLess());
  std::vector<Rigid3d> corrected(c.moved.size());
  c.non_corrected.resize(c.moved.size());
  const Rigid3d T_world_cam = keyframe->T_world_cam();
  for (size_t k = 0; k < c.moved.size(); ++k) {
    c.non_corrected[k] = c.moved[k]->T_cam_world();
    corrected[k] = c.moved[k] == keyframe ? T_cam_world
                                          : c.moved[k]->T_cam_world() * T_world_cam * T_cam_world;
  }
  // Their points move with them (each once, with the first keyframe seeing it).
  c.corrected_reference.assign(map->num_created_map_points(), kNoKeyFrameId);
  for (size_t k = 0; k < c.moved.size(); ++k) {
    const Rigid3d T_world_corrected = corrected[k].Inverse();
    for (MapPoint* point : c.moved[k]->map_points()) {
      if (point == nullptr || point->bad() || c.corrected_reference[point->id()] != kNoKeyFrameId) {
        continue;
      }
      point->SetPosition(T_world_corrected * (c.non_corrected[k] * point->position_world()));
      c.corrected_reference[point->id()] = c.moved[k]->id();
      point->UpdateNormalAndDepth(sensor.pyramid);
    }
    c.moved[k]->SetPose(corrected[k]);
    map->UpdateConnections(c.moved[k]);
  }
  c.loop_connections.resize(c.moved.size());
  return c;
}

void EssentialGraphAdjuster::Collect(const Map& map, LoopCorrection correction) {
  keyframes_ = map.KeyFrames();
  const size_t n = map.num_created_keyframes();
  std::vector<int> vertex(n, -1), moved_index(n, -1);
  const std::vector<KeyFrame*>& moved = correction.moved;
  for (size_t k = 0; k < moved.size(); ++k) moved_index[moved[k]->id()] = static_cast<int>(k);
  graph_ = {};
  // Initial estimates: the corrected poses of the moved keyframes (already
  // set), the current ones elsewhere.
  for (KeyFrame* kf : keyframes_) {
    vertex[kf->id()] = graph_.AddVertex(kf->T_cam_world(), kf == correction.matched);
  }
  initial_ = graph_.poses;
  // Pose of a keyframe before the correction.
  auto before = [&](const KeyFrame* kf) {
    const int m = moved_index[kf->id()];
    return m >= 0 ? correction.non_corrected[m] : initial_[vertex[kf->id()]];
  };
  std::set<std::pair<KeyFrameId, KeyFrameId>> inserted;
  auto pair_of = [](const KeyFrame* a, const KeyFrame* b) {
    return std::make_pair(std::min(a->id(), b->id()), std::max(a->id(), b->id()));
  };
  // Loop connections, from the corrected estimates.
  for (size_t k = 0; k < moved.size(); ++k) {
    KeyFrame* ki = moved[k];
    if (ki->bad() || vertex[ki->id()] < 0) continue;
    for (KeyFrame* kj : correction.loop_connections[k]) {
      if (kj->bad() || vertex[kj->id()] < 0) continue;
      const bool loop_pair = ki == correction.keyframe && kj == correction.matched;
      if (!loop_pair && ki->Weight(kj) < min_weight_) continue;
      const int i = vertex[ki->id()], j = vertex[kj->id()];
      graph_.edges.push_back({i, j, initial_[j] * initial_[i].Inverse()});
      inserted.insert(pair_of(ki, kj));
    }
  }
  // Spanning tree, earlier loop edges, strong covisibility: from the poses
  // before the correction.
  for (KeyFrame* ki : keyframes_) {
    const int i = vertex[ki->id()];
    const Rigid3d T_world_i = before(ki).Inverse();
    auto add = [&](KeyFrame* kj) {
      graph_.edges.push_back({i, vertex[kj->id()], before(kj) * T_world_i});
    };
    KeyFrame* parent = ki->parent();
    if (parent != nullptr && !parent->bad() && vertex[parent->id()] >= 0) add(parent);
    for (KeyFrame* l : ki->loop_edges()) {
      if (!l->bad() && vertex[l->id()] >= 0 && l->id() < ki->id()) add(l);
    }
    for (KeyFrame* kn : ki->CovisibleWithWeight(min_weight_)) {
      if (kn == parent || kn->bad() || vertex[kn->id()] < 0 || kn->id() >= ki->id()) continue;
      if (kn->parent() == ki) continue;  // A child: its tree edge is there.
      const auto& loops = ki->loop_edges();
      if (std::find(loops.begin(), loops.end(), kn) != loops.end()) continue;
      if (inserted.count(pair_of(ki, kn))) continue;
      add(kn);
    }
  }
  corrected_reference_ = std::move(correction.corrected_reference);
  solves_ = {};
}

void EssentialGraphAdjuster::Solve() { OptimizePoseGraph(&graph_, iterations_, &solves_); }

void EssentialGraphAdjuster::Apply(Map* map) {
  const PoseChanges change = ChangePoses(map, keyframes_, initial_, graph_.poses);
  // Points move with the keyframe that corrected them, or their reference.
  for (MapPoint* point : map->MapPoints()) {
    KeyFrameId ref = point->id() < corrected_reference_.size() ? corrected_reference_[point->id()]
                                                               : kNoKeyFrameId;
    if (ref == kNoKeyFrameId) {
      const KeyFrame* reference = point->reference_keyframe();
      if (reference == nullptr) continue;
      ref = reference->id();
    }
    if (!change.moved[ref]) continue;
    point->SetPosition(change.Move(ref, point->position_world()));
    point->UpdateNormalAndDepth(sensor_.pyramid);
  }
}

}  // namespace rrslam
