// Nonlinear least-squares refinement with Ceres: the pose of a tracked frame
// (pose-only optimization) and the local window of the map around a new
// keyframe (local bundle adjustment), both as ORB-SLAM2 does them with g2o:
// Huber-robustified reprojection errors on (u, v, u_R) for keypoints with
// depth and (u, v) otherwise, information 1 / sigma^2 of the keypoint's
// octave, and rounds of outlier classification by chi-square thresholds.
//
// Both run Ceres on one thread, so results are bit-identical run to run.
#pragma once

#include <ceres/iteration_callback.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include <atomic>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "stages/track/data/frame.h"
#include "stages/track/data/keyframe.h"
#include "stages/track/data/map.h"
#include "stages/track/data/sensor_model.h"

namespace rrslam {

// 95% chi-square bounds for 2 and 3 degrees of freedom.
inline constexpr double kChi2TwoDof = 5.991;
inline constexpr double kChi2ThreeDof = 7.815;

// Iteration counts below are counted as g2o counts them: g2o's optimize(n)
// makes n Levenberg-Marquardt iterations, each of which retries a rejected
// step (with a larger damping) up to 10 times, while Ceres' max_num_iterations
// also counts the rejected steps. So a solve here stops after n *successful*
// steps, after n + 10 n iterations in all, or when Ceres' convergence
// tolerances are met (see SuccessfulStepLimit).
struct PoseOptimizationOptions {
  int rounds = 4;                 // Outlier classification rounds (ORB-SLAM2: 4).
  int iterations_per_round = 10;  // Successful LM steps per round (ORB-SLAM2: optimize(10)).
  int robust_rounds = 3;          // Rounds that use the Huber loss (the last runs without).
};

// What the solves of an optimizer did, added up over solves: whether the
// step limit ended them, and whether they needed more iterations in all
// (rejected steps included) than the limit, where counting every iteration as
// Ceres does would have stopped them early.
struct SolveCounts {
  size_t solves = 0;
  size_t successful_steps = 0;
  size_t at_step_limit = 0;      // Ended by the limit, not by convergence.
  size_t beyond_iterations = 0;  // Used more than `limit` iterations in all.
  void Add(const ceres::Solver::Summary& summary, int limit, int successful);
  SolveCounts& operator+=(const SolveCounts& other);
};

// A Ceres iteration callback that ends the solve after `limit` successful
// steps (g2o's iteration count; see above). Add it to the solver's callbacks
// and set max_num_iterations to MaxIterationsFor(limit).
class SuccessfulStepLimit final : public ceres::IterationCallback {
 public:
  explicit SuccessfulStepLimit(int limit) : limit_(limit) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override;
  int successful_steps() const { return successful_; }
  // Iterations allowed in all: `limit` steps with up to 10 rejections each.
  static int MaxIterationsFor(int limit) { return 11 * limit; }

 private:
  int limit_;
  int successful_ = 0;
};

// What keypoint `index` of a keyframe measures, as the bundle adjustments use
// it: the ideal pixel (u, v), the virtual right coordinate u_R (meaningful
// with depth), the whitening 1 / sigma of the keypoint's octave.
struct KeypointMeasurement {
  double observed[3];
  double inv_sigma;
  bool with_depth;
};
KeypointMeasurement MeasurementOf(const SensorModel& sensor, const KeyFrame& keyframe,
                                  uint32_t index);

// Stops a solve (keeping its current estimate) when `flag` (may be null) is
// raised; polled between iterations.
class AbortCallback final : public ceres::IterationCallback {
 public:
  explicit AbortCallback(const std::atomic<bool>* flag) : flag_(flag) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return flag_ != nullptr && flag_->load(std::memory_order_relaxed)
               ? ceres::SOLVER_TERMINATE_SUCCESSFULLY
               : ceres::SOLVER_CONTINUE;
  }

 private:
  const std::atomic<bool>* flag_;
};

// Problem options of every problem here: manifolds and losses are shared
// instances the problem must not own.
ceres::Problem::Options ProblemOptions();

// Refines frame->T_cam_world() from the frame's map-point matches (points
// held fixed). Each round restarts from the input pose, optimizes the matches
// currently classified as inliers, then reclassifies every match: an error
// above the chi-square bound makes it an outlier (frame->outlier[i] = 1), below
// an inlier again. Returns the number of inliers; with fewer than 3 matches
// returns 0 and leaves the pose unchanged.
// `counts` (may be null) gets the rounds' solves added.
int OptimizeFramePose(const SensorModel& sensor, Frame* frame,
                      const PoseOptimizationOptions& options = {}, SolveCounts* counts = nullptr);

struct LocalBundleAdjustmentOptions {
  int first_iterations = 5;    // Successful steps with Huber loss, on all observations.
  int second_iterations = 10;  // Successful steps without loss, on the first pass's inliers.
  // Departure from ORB-SLAM2 (option --ba-depth-fallback): an observation with
  // depth whose (u, v, u_R) error exceeds the three-dof bound but whose (u, v)
  // error is within the two-dof bound is kept as a (u, v) observation instead
  // of being an outlier. ORB-SLAM2 (false) removes it. Default true (lower
  // score under the rule for defaults, docs/track.md).
  bool depth_fallback = true;
};

struct LocalBundleAdjustmentStats {
  int local_keyframes = 0;  // Keyframes optimized.
  int fixed_keyframes = 0;  // Other observers of the local points, held fixed.
  int points = 0;
  int observations = 0;
  int outliers = 0;         // Observations removed from the map.
  bool aborted = false;     // Stopped early by the abort flag.
  double initial_cost = 0;  // Ceres cost (half the sum of squared robustified residuals).
  double final_cost = 0;
  SolveCounts solves;  // Both passes.
};

// Local bundle adjustment around a keyframe (ORB-SLAM2's
// Optimizer::LocalBundleAdjustment) in three phases, so that in realtime mode
// the map lock is held only while reading and writing the map:
//   Collect (map locked): the keyframe and its covisible keyframes are free;
//     every map point they see is free; the other keyframes observing those
//     points are fixed, as is the map's first keyframe (gauge freedom).
//   Solve (no map access): a first pass with Huber loss, then, unless aborted,
//     a second pass without loss on the observations that were inliers.
//   Apply (map locked): writes poses and points back and erases the
//     observations that remain outliers (error above the chi-square bound or
//     point behind the camera). Objects culled meanwhile are skipped.
// With options.depth_fallback, an observation with depth whose (u, v, u_R)
// error exceeds the three-dof bound but whose (u, v) error is within the
// two-dof bound is not an outlier: its depth is (a depth edge, a reflection),
// so the second pass and later classifications use its (u, v) only.
class LocalBundleAdjuster {
 public:
  LocalBundleAdjuster(const SensorModel& sensor, const LocalBundleAdjustmentOptions& options = {})
      : sensor_(sensor), options_(options) {}

  void Collect(KeyFrame* keyframe, const Map& map);
  // Collect for the whole map (the final refinement, map_refinement.h): every
  // keyframe free but the map's first (gauge freedom) and those with ids below
  // `first_free` (a merged map's loaded part, held fixed where it observes
  // points of the free keyframes), every point the free keyframes observe.
  void CollectAll(const Map& map, KeyFrameId first_free = 0);
  // `abort` (may be null) is polled between iterations; when it becomes true
  // the solver stops with the current estimate.
  void Solve(const std::atomic<bool>* abort = nullptr);
  void Apply(Map* map);

  const LocalBundleAdjustmentStats& stats() const { return stats_; }

 private:
  struct Observation : KeypointMeasurement {
    uint32_t point;              // Index into points_.
    uint32_t keyframe;           // Index into keyframes_.
    uint32_t keypoint;           // Keypoint index in that keyframe.
    bool depth_ignored = false;  // Depth inconsistent, (u, v) kept.
    bool outlier = false;
  };

  // `local` free, then every other observer of their points fixed.
  void CollectAround(const std::vector<KeyFrame*>& local, const Map& map);

  const SensorModel& sensor_;
  LocalBundleAdjustmentOptions options_;
  bool whole_map_ = false;            // CollectAll: a sparse Schur solver.
  std::vector<KeyFrame*> keyframes_;  // Local (free) first, then fixed.
  std::vector<uint8_t> keyframe_fixed_;
  std::vector<std::array<double, 7>> poses_;
  std::vector<MapPoint*> points_;
  std::vector<Eigen::Vector3d> positions_;
  std::vector<Observation> observations_;
  LocalBundleAdjustmentStats stats_;
};

// Uses `sparse` with the sparse linear algebra this Ceres build has
// (SuiteSparse, else Eigen's), or `dense` when it has none.
void ChooseLinearSolver(ceres::LinearSolverType sparse, ceres::LinearSolverType dense,
                        ceres::Solver::Options* options);

// Pose block [qx, qy, qz, qw, tx, ty, tz] of a transform and back.
std::array<double, 7> ToPoseBlock(const Rigid3d& T);
Rigid3d FromPoseBlock(const std::array<double, 7>& block);

}  // namespace rrslam
