#include "stages/track/optimize/loop_optimizer.h"

#include <ceres/ceres.h>

#include <cmath>
#include <memory>
#include <unordered_map>

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

// Residual of a pose-graph edge: T_j_i * T_iw * T_jw^-1 as (2 * quaternion
// vector part, translation).
struct PoseGraphEdgeError {
  explicit PoseGraphEdgeError(const Rigid3d& T_j_i) : T_j_i(T_j_i) {}

  template <typename T>
  bool operator()(const T* pose_i, const T* pose_j, T* residuals) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q_i(pose_i);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_i(pose_i + 4);
    const Eigen::Map<const Eigen::Quaternion<T>> q_j(pose_j);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_j(pose_j + 4);
    const Eigen::Quaternion<T> q_m = T_j_i.rotation.cast<T>();
    const Eigen::Matrix<T, 3, 1> t_m = T_j_i.translation.cast<T>();
    // T_jw^-1 = (q_j^-1, -q_j^-1 t_j); A = T_iw * T_jw^-1; E = T_m * A.
    const Eigen::Quaternion<T> q_j_inv = q_j.conjugate();
    const Eigen::Quaternion<T> q_a = q_i * q_j_inv;
    const Eigen::Matrix<T, 3, 1> t_a = t_i - q_a * t_j;
    Eigen::Quaternion<T> q_e = q_m * q_a;
    const Eigen::Matrix<T, 3, 1> t_e = q_m * t_a + t_m;
    const T sign = q_e.w() < T(0) ? T(-1) : T(1);
    residuals[0] = T(2) * sign * q_e.x();
    residuals[1] = T(2) * sign * q_e.y();
    residuals[2] = T(2) * sign * q_e.z();
    residuals[3] = t_e.x();
    residuals[4] = t_e.y();
    residuals[5] = t_e.z();
    return true;
  }

  Rigid3d T_j_i;
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
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<PoseGraphEdgeError, 6, 7, 7>(
                                 new PoseGraphEdgeError(e.T_j_i)),
                             nullptr, blocks[e.i].data(), blocks[e.j].data());
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
  std::unordered_map<KeyFrameId, uint32_t> keyframe_index;
  for (size_t i = 0; i < keyframes_.size(); ++i) {
    keyframe_index.emplace(keyframes_[i]->id(), static_cast<uint32_t>(i));
    keyframe_fixed_[i] = keyframes_[i] == map.root();
    poses_[i] = ToPoseBlock(keyframes_[i]->T_cam_world());
  }
  points_.clear();
  positions_.clear();
  observations_.clear();
  stats_ = {};
  for (MapPoint* point : map.MapPoints()) {
    const uint32_t p = static_cast<uint32_t>(points_.size());
    bool observed = false;
    for (const MapPoint::Observation& o : point->observations()) {
      auto it = keyframe_index.find(o.keyframe->id());
      if (it == keyframe_index.end()) continue;
      Observation obs;
      static_cast<KeypointMeasurement&>(obs) = MeasurementOf(sensor_, *o.keyframe, o.index);
      obs.point = p;
      obs.keyframe = it->second;
      observations_.push_back(obs);
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
    ceres::CostFunction* cost;
    double* pose = poses_[o.keyframe].data();
    double* point = positions_[o.point].data();
    // A point behind the camera has no defined residual: left out.
    double r[3];
    const double* parameters[] = {pose, point};
    if (o.with_depth) {
      cost = new ReprojectionError<3>(
          k, Eigen::Vector3d(o.observed[0], o.observed[1], o.observed[2]), o.inv_sigma);
    } else {
      cost =
          new ReprojectionError<2>(k, Eigen::Vector2d(o.observed[0], o.observed[1]), o.inv_sigma);
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
  // Poses before and after, by keyframe id, for the keyframes of the
  // snapshot and those moved with their parent.
  const size_t n = map->num_created_keyframes();
  std::vector<uint8_t> has_new(n, 0);
  std::vector<Rigid3d> before(n), after(n);
  for (size_t i = 0; i < keyframes_.size(); ++i) {
    KeyFrame* kf = keyframes_[i];
    if (kf->bad()) continue;
    has_new[kf->id()] = 1;
    before[kf->id()] = kf->T_cam_world();
    after[kf->id()] = FromPoseBlock(poses_[i]);
  }
  // Keyframes made during the solve: through the spanning tree from the root,
  // each keeps its pose relative to its parent.
  if (map->root() != nullptr) {
    std::vector<KeyFrame*> stack = {map->root()};
    while (!stack.empty()) {
      KeyFrame* kf = stack.back();
      stack.pop_back();
      for (KeyFrame* child : kf->children()) {
        if (child->bad()) continue;
        if (!has_new[child->id()] && has_new[kf->id()]) {
          has_new[child->id()] = 1;
          before[child->id()] = child->T_cam_world();
          after[child->id()] = child->T_cam_world() * kf->T_world_cam() * after[kf->id()];
        }
        stack.push_back(child);
      }
    }
  }
  for (KeyFrame* kf : map->KeyFrames()) {
    if (has_new[kf->id()]) kf->SetPose(after[kf->id()]);
  }
  std::vector<uint8_t> in_snapshot(map->num_created_map_points(), 0);
  for (size_t p = 0; p < points_.size(); ++p) {
    in_snapshot[points_[p]->id()] = 1;
    if (!points_[p]->bad()) points_[p]->SetPosition(positions_[p]);
  }
  for (MapPoint* point : map->MapPoints()) {
    if (in_snapshot[point->id()]) continue;
    const KeyFrame* ref = point->reference_keyframe();
    if (ref == nullptr || ref->bad() || !has_new[ref->id()]) continue;
    point->SetPosition(after[ref->id()].Inverse() * (before[ref->id()] * point->position_world()));
  }
}

}  // namespace rrslam
