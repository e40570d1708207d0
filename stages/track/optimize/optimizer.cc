#include "stages/track/optimize/optimizer.h"

#include <ceres/ceres.h>

#include <cmath>
#include <cstdlib>
#include <memory>

#include "stages/track/optimize/reprojection_error.h"

namespace rrslam {
KeypointMeasurement MeasurementOf(const SensorModel& sensor, const KeyFrame& keyframe,
                                  uint32_t index) {
  const FrameFeatures& f = keyframe.features();
  const Keypoint& kp = f.keypoints[index];
  KeypointMeasurement m;
  m.observed[0] = kp.undistorted.x();
  m.observed[1] = kp.undistorted.y();
  m.observed[2] = f.u_right[index];
  m.inv_sigma = std::sqrt(sensor.pyramid.inv_sigma2[kp.octave]);
  m.with_depth = f.HasDepth(index);
  return m;
}

ceres::Problem::Options ProblemOptions() {
  ceres::Problem::Options options;
  options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return options;
}

ceres::CallbackReturnType SuccessfulStepLimit::operator()(const ceres::IterationSummary& summary) {
  // Iteration 0 is the initial evaluation, not a step.
  if (summary.iteration > 0 && summary.step_is_successful) ++successful_;
  return successful_ >= limit_ ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
}

void SolveCounts::Add(const ceres::Solver::Summary& summary, int limit, int successful) {
  ++solves;
  successful_steps += successful;
  at_step_limit += successful >= limit;
  // summary.iterations holds iteration 0 (the initial evaluation) too.
  beyond_iterations += summary.iterations.size() > static_cast<size_t>(limit) + 1;
}

SolveCounts& SolveCounts::operator+=(const SolveCounts& other) {
  solves += other.solves;
  successful_steps += other.successful_steps;
  at_step_limit += other.at_step_limit;
  beyond_iterations += other.beyond_iterations;
  return *this;
}

ceres::Manifold* PoseManifold() {
  static PoseManifoldType manifold;
  return &manifold;
}

std::array<double, 7> ToPoseBlock(const Rigid3d& T) {
  const Eigen::Quaterniond q = T.rotation.normalized();
  return {q.x(), q.y(), q.z(), q.w(), T.translation.x(), T.translation.y(), T.translation.z()};
}

Rigid3d FromPoseBlock(const std::array<double, 7>& b) {
  return Rigid3d(Eigen::Quaterniond(b[3], b[0], b[1], b[2]).normalized(),
                 Eigen::Vector3d(b[4], b[5], b[6]));
}

int OptimizeFramePose(const SensorModel& sensor, Frame* frame,
                      const PoseOptimizationOptions& options, SolveCounts* counts) {
  const FrameFeatures& f = frame->features();
  const ProjectionParameters k = ProjectionParametersOf(sensor);
  struct Match {
    uint32_t index;
    bool with_depth;
    std::unique_ptr<ceres::CostFunction> cost;
  };
  std::vector<Match> matches;
  for (size_t i = 0; i < frame->size(); ++i) {
    MapPoint* point = frame->map_points[i];
    if (point == nullptr) continue;
    frame->outlier[i] = 0;
    const Keypoint& kp = f.keypoints[i];
    const double inv_sigma = std::sqrt(sensor.pyramid.inv_sigma2[kp.octave]);
    Match m{static_cast<uint32_t>(i), f.HasDepth(i), nullptr};
    if (m.with_depth) {
      const Eigen::Vector3d observed(kp.undistorted.x(), kp.undistorted.y(), f.u_right[i]);
      m.cost = std::make_unique<PoseOnlyReprojectionError<3>>(k, observed, inv_sigma,
                                                              point->position_world());
    } else {
      const Eigen::Vector2d observed(kp.undistorted.x(), kp.undistorted.y());
      m.cost = std::make_unique<PoseOnlyReprojectionError<2>>(k, observed, inv_sigma,
                                                              point->position_world());
    }
    matches.push_back(std::move(m));
  }
  if (matches.size() < 3) return 0;

  ceres::HuberLoss loss_mono(std::sqrt(kChi2TwoDof));
  ceres::HuberLoss loss_stereo(std::sqrt(kChi2ThreeDof));
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations =
      SuccessfulStepLimit::MaxIterationsFor(options.iterations_per_round);
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;

  const std::array<double, 7> initial = ToPoseBlock(frame->T_cam_world());
  std::array<double, 7> pose = initial;
  int bad = 0;
  for (int round = 0; round < options.rounds; ++round) {
    pose = initial;
    ceres::Problem::Options problem_options = ProblemOptions();
    problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    problem.AddParameterBlock(pose.data(), 7, PoseManifold());
    const bool robust = round < options.robust_rounds;
    int residuals = 0;
    for (const Match& m : matches) {
      if (frame->outlier[m.index]) continue;
      ceres::LossFunction* loss =
          robust ? (m.with_depth ? static_cast<ceres::LossFunction*>(&loss_stereo) : &loss_mono)
                 : nullptr;
      problem.AddResidualBlock(m.cost.get(), loss, pose.data());
      ++residuals;
    }
    if (residuals == 0) break;
    SuccessfulStepLimit step_limit(options.iterations_per_round);
    ceres::Solver::Options round_options = solver_options;
    round_options.callbacks.push_back(&step_limit);
    ceres::Solver::Summary summary;
    ceres::Solve(round_options, &problem, &summary);
    if (counts != nullptr) {
      counts->Add(summary, options.iterations_per_round, step_limit.successful_steps());
    }

    // Reclassify every match (also those left out of this round) at the new pose.
    bad = 0;
    const double* parameters[] = {pose.data()};
    for (Match& m : matches) {
      double r[3] = {0, 0, 0};
      const bool in_front = m.cost->Evaluate(parameters, r, nullptr);
      const double chi2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
      const bool is_outlier = !in_front || chi2 > (m.with_depth ? kChi2ThreeDof : kChi2TwoDof);
      frame->outlier[m.index] = is_outlier ? 1 : 0;
      if (is_outlier) ++bad;
    }
    // ORB-SLAM2 stops after the first round when the frame has under 10 matches.
    if (matches.size() < 10) break;
  }
  frame->SetPose(FromPoseBlock(pose));
  return static_cast<int>(matches.size()) - bad;
}

void ChooseLinearSolver(ceres::LinearSolverType sparse, ceres::LinearSolverType dense,
                        ceres::Solver::Options* options) {
  for (const auto library : {ceres::SUITE_SPARSE, ceres::EIGEN_SPARSE}) {
    if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(library)) {
      options->linear_solver_type = sparse;
      options->sparse_linear_algebra_library_type = library;
      return;
    }
  }
  options->linear_solver_type = dense;
}

void LocalBundleAdjuster::Collect(KeyFrame* keyframe, const Map& map) {
  std::vector<KeyFrame*> local = {keyframe};
  for (KeyFrame* kf : keyframe->covisible()) {
    if (!kf->bad()) local.push_back(kf);
  }
  whole_map_ = false;
  CollectAround(local, map);
}

void LocalBundleAdjuster::CollectAll(const Map& map, KeyFrameId first_free) {
  std::vector<KeyFrame*> all;
  for (KeyFrame* kf : map.KeyFrames()) {
    if (!kf->bad() && kf->id() >= first_free) all.push_back(kf);
  }
  whole_map_ = true;
  CollectAround(all, map);
}

void LocalBundleAdjuster::CollectAround(const std::vector<KeyFrame*>& local, const Map& map) {
  keyframes_.clear();
  keyframe_fixed_.clear();
  poses_.clear();
  points_.clear();
  positions_.clear();
  observations_.clear();
  stats_ = {};

  std::unordered_map<KeyFrameId, uint32_t> keyframe_index;
  auto add_keyframe = [&](KeyFrame* kf, bool fixed) {
    keyframe_index.emplace(kf->id(), static_cast<uint32_t>(keyframes_.size()));
    keyframes_.push_back(kf);
    keyframe_fixed_.push_back(fixed || kf == map.root());
    poses_.push_back(ToPoseBlock(kf->T_cam_world()));
  };
  for (KeyFrame* kf : local) add_keyframe(kf, false);
  const size_t num_local = keyframes_.size();  // Free keyframes come first.

  // Points seen by the local keyframes, in keyframe then keypoint order.
  std::unordered_map<MapPointId, uint32_t> point_index;
  for (size_t i = 0; i < num_local; ++i) {
    for (MapPoint* point : keyframes_[i]->map_points()) {
      if (point == nullptr || point->bad()) continue;
      if (point_index.emplace(point->id(), static_cast<uint32_t>(points_.size())).second) {
        points_.push_back(point);
        positions_.push_back(point->position_world());
      }
    }
  }
  // Their other observers are fixed.
  for (MapPoint* point : points_) {
    for (const MapPoint::Observation& o : point->observations()) {
      if (o.keyframe->bad() || keyframe_index.count(o.keyframe->id())) continue;
      add_keyframe(o.keyframe, true);
    }
  }

  for (size_t p = 0; p < points_.size(); ++p) {
    for (const MapPoint::Observation& o : points_[p]->observations()) {
      auto it = keyframe_index.find(o.keyframe->id());
      if (it == keyframe_index.end()) continue;
      Observation obs;
      static_cast<KeypointMeasurement&>(obs) = MeasurementOf(sensor_, *o.keyframe, o.index);
      obs.point = static_cast<uint32_t>(p);
      obs.keyframe = it->second;
      obs.keypoint = o.index;
      observations_.push_back(obs);
    }
  }
  for (size_t i = 0; i < keyframes_.size(); ++i) {
    if (keyframe_fixed_[i]) {
      ++stats_.fixed_keyframes;
    } else {
      ++stats_.local_keyframes;
    }
  }
  stats_.points = static_cast<int>(points_.size());
  stats_.observations = static_cast<int>(observations_.size());
}

void LocalBundleAdjuster::Solve(const std::atomic<bool>* abort) {
  if (observations_.empty() || stats_.local_keyframes == 0) return;
  const ProjectionParameters k = ProjectionParametersOf(sensor_);
  ceres::HuberLoss loss_mono(std::sqrt(kChi2TwoDof));
  ceres::HuberLoss loss_stereo(std::sqrt(kChi2ThreeDof));

  std::vector<std::unique_ptr<ceres::CostFunction>> costs(observations_.size());
  std::vector<std::unique_ptr<ceres::CostFunction>> mono_costs(observations_.size());
  for (size_t i = 0; i < observations_.size(); ++i) {
    const Observation& o = observations_[i];
    if (o.with_depth) {
      costs[i] = std::make_unique<ReprojectionError<3>>(
          k, Eigen::Vector3d(o.observed[0], o.observed[1], o.observed[2]), o.inv_sigma);
      // Used when the depth disagrees with the map but (u, v) agrees.
      mono_costs[i] = std::make_unique<ReprojectionError<2>>(
          k, Eigen::Vector2d(o.observed[0], o.observed[1]), o.inv_sigma);
    } else {
      costs[i] = std::make_unique<ReprojectionError<2>>(
          k, Eigen::Vector2d(o.observed[0], o.observed[1]), o.inv_sigma);
    }
  }
  auto residual = [&](size_t i, double* r) {
    const Observation& o = observations_[i];
    const double* parameters[] = {poses_[o.keyframe].data(), positions_[o.point].data()};
    r[2] = 0;
    return costs[i]->Evaluate(parameters, r, nullptr);
  };
  // Observations whose point is behind the camera cannot enter Ceres (their
  // residual is undefined): they start as outliers.
  for (size_t i = 0; i < observations_.size(); ++i) {
    double r[3];
    observations_[i].outlier = !residual(i, r);
  }

  AbortCallback abort_callback(abort);
  auto run_pass = [&](bool robust, int iterations) {
    ceres::Problem::Options problem_options = ProblemOptions();
    problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    auto* ordering = new ceres::ParameterBlockOrdering;
    std::vector<uint8_t> point_used(points_.size(), 0), keyframe_used(keyframes_.size(), 0);
    int residuals = 0;
    for (size_t i = 0; i < observations_.size(); ++i) {
      const Observation& o = observations_[i];
      if (o.outlier) continue;
      if (!keyframe_used[o.keyframe]) {
        keyframe_used[o.keyframe] = 1;
        problem.AddParameterBlock(poses_[o.keyframe].data(), 7, PoseManifold());
        if (keyframe_fixed_[o.keyframe])
          problem.SetParameterBlockConstant(poses_[o.keyframe].data());
        ordering->AddElementToGroup(poses_[o.keyframe].data(), 1);
      }
      if (!point_used[o.point]) {
        point_used[o.point] = 1;
        problem.AddParameterBlock(positions_[o.point].data(), 3);
        ordering->AddElementToGroup(positions_[o.point].data(), 0);
      }
      const bool stereo = o.with_depth && !o.depth_ignored;
      ceres::LossFunction* loss = nullptr;
      if (robust) loss = stereo ? &loss_stereo : &loss_mono;
      problem.AddResidualBlock(stereo || !o.with_depth ? costs[i].get() : mono_costs[i].get(), loss,
                               poses_[o.keyframe].data(), positions_[o.point].data());
      ++residuals;
    }
    if (residuals == 0) {
      delete ordering;
      return;
    }
    ceres::Solver::Options options;
    options.linear_solver_type = ceres::DENSE_SCHUR;
    // The whole map's reduced camera system is sparse (a keyframe shares
    // points with its covisible keyframes only).
    if (whole_map_) ChooseLinearSolver(ceres::SPARSE_SCHUR, ceres::DENSE_SCHUR, &options);
    options.linear_solver_ordering.reset(ordering);
    options.max_num_iterations = SuccessfulStepLimit::MaxIterationsFor(iterations);
    options.num_threads = 1;
    options.logging_type = ceres::SILENT;
    SuccessfulStepLimit step_limit(iterations);
    options.callbacks.push_back(&step_limit);
    if (abort != nullptr) options.callbacks.push_back(&abort_callback);
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem, &summary);
    stats_.solves.Add(summary, iterations, step_limit.successful_steps());
    if (robust) stats_.initial_cost = summary.initial_cost;
    stats_.final_cost = summary.final_cost;
  };
  auto classify = [&]() {
    int outliers = 0;
    for (size_t i = 0; i < observations_.size(); ++i) {
      double r[3];
      const bool in_front = residual(i, r);
      const double chi2_uv = r[0] * r[0] + r[1] * r[1];
      const double chi2 = chi2_uv + r[2] * r[2];
      Observation& o = observations_[i];
      o.depth_ignored = false;
      if (!in_front) {
        o.outlier = true;
      } else if (!o.with_depth) {
        o.outlier = chi2 > kChi2TwoDof;
      } else if (chi2 <= kChi2ThreeDof) {
        o.outlier = false;
      } else if (options_.depth_fallback && chi2_uv <= kChi2TwoDof) {
        o.outlier = false;
        o.depth_ignored = true;
      } else {
        o.outlier = true;
      }
      outliers += o.outlier;
    }
    return outliers;
  };

  run_pass(/*robust=*/true, options_.first_iterations);
  stats_.aborted = abort != nullptr && abort->load();
  if (!stats_.aborted) {
    classify();
    run_pass(/*robust=*/false, options_.second_iterations);
  }
  stats_.outliers = classify();
}

void LocalBundleAdjuster::Apply(Map* map) {
  for (const Observation& o : observations_) {
    if (!o.outlier) continue;
    MapPoint* point = points_[o.point];
    KeyFrame* kf = keyframes_[o.keyframe];
    if (point->bad() || kf->bad()) continue;
    if (point->IndexIn(kf) != static_cast<int>(o.keypoint)) continue;
    map->EraseObservation(point, kf);
  }
  for (size_t i = 0; i < keyframes_.size(); ++i) {
    if (!keyframe_fixed_[i] && !keyframes_[i]->bad())
      keyframes_[i]->SetPose(FromPoseBlock(poses_[i]));
  }
  for (size_t p = 0; p < points_.size(); ++p) {
    MapPoint* point = points_[p];
    if (point->bad()) continue;
    point->SetPosition(positions_[p]);
    point->UpdateNormalAndDepth(sensor_.pyramid);
  }
}

}  // namespace rrslam
