// Absolute trajectory error (ATE), as TUM's evaluate_ate.py computes it.
//
// Sturm et al., "A Benchmark for the Evaluation of RGB-D SLAM Systems", IROS
// 2012, Sec. V-B. Ground-truth and estimated poses are paired by timestamp
// (greedy, each stamp used once, |t_gt - (t_est + offset)| < max_difference),
// the estimated camera centres (times `scale`) are aligned to the ground-truth
// ones by the rigid transform of least squared error (AlignRigid: rotation and
// translation, no scale), and the error of pair i is
//   e_i = |T_gt_est * (scale * p_est_i) - p_gt_i|   (metres)
// With `correct_scale` the scale is estimated too, by the similarity of least
// squared error (AlignSimilarity, Umeyama 1991, as evo's --correct_scale): a
// diagnostic for estimates whose scale is off, not TUM's figure.
// Only positions enter ATE; orientations are carried along for the aligned
// trajectory. Every function here is thread-safe (no shared state).
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "common/trajectory.h"
#include "stages/eval/alignment.h"
#include "stages/eval/stats.h"

namespace rrslam {

// The fewest pairs ATE accepts: with two, the rotation about their line is free.
inline constexpr size_t kMinAtePairs = 3;

struct AteOptions {
  // Largest time difference, in seconds, between a ground-truth stamp and an
  // (offset) estimated stamp for them to be paired; strictly smaller, as
  // associate.py. Must be > 0.
  double max_difference = 0.02;
  // Seconds added to every estimated stamp before pairing (the estimate's
  // clock lag). Any finite value.
  double offset = 0.0;
  // Factor applied to the estimated positions before alignment (for monocular
  // or otherwise scaled estimates). Must be > 0.
  double scale = 1.0;
  // Estimate the scale as part of the alignment; `scale` must then stay 1.
  bool correct_scale = false;

  // False, with the violated constraint in `why`, when an option is invalid.
  bool Check(std::string* why) const;
  nlohmann::ordered_json ToJson() const;
};

// One ground-truth pose paired with one estimated pose.
struct AtePair {
  double gt_timestamp = 0;   // Seconds, as in the ground-truth file.
  double est_timestamp = 0;  // Seconds, as in the estimate's file (without offset).
  Eigen::Vector3d gt_position = Eigen::Vector3d::Zero();   // Camera centre, gt world.
  Eigen::Vector3d est_position = Eigen::Vector3d::Zero();  // Camera centre, est world, scaled.
  Eigen::Vector3d est_position_aligned = Eigen::Vector3d::Zero();  // T_gt_est * est_position.
  double error = 0;  // |est_position_aligned - gt_position|, metres.
};

struct AteResult {
  // Maps the estimate's (scaled) world frame into the ground-truth world frame.
  Rigid3d T_gt_est;
  // The pairs, sorted by ground-truth stamp.
  std::vector<AtePair> pairs;
  // Statistics of the pairs' errors, metres.
  ErrorStats error;
  // The whole estimate (distinct stamps, sorted) with scale and alignment
  // applied: T_gt_est * (R_i, scale * t_i). For plots and --save-aligned.
  Trajectory est_aligned;
  size_t gt_poses = 0;       // Distinct ground-truth stamps.
  size_t est_poses = 0;      // Distinct estimated stamps.
  size_t gt_duplicates = 0;  // Ground-truth lines dropped for a repeated stamp.
  size_t est_duplicates = 0;
  // Factor applied to the estimated positions: AteOptions::scale, or the
  // estimated one when scale_estimated.
  double scale = 1.0;
  bool scale_estimated = false;  // AteOptions::correct_scale.
};

// The transform ATE applies to an estimate, computed once from one
// trajectory's pairs with the ground truth (ComputeAteAlignment) and applied to
// that or another trajectory in the same world frame (EvaluateAte): an
// estimated position t (in the estimate's world) becomes
//   T_gt_est * (scale * t)   (ground-truth world, metres).
struct AteAlignment {
  // Maps the estimate's (scaled) world frame into the ground-truth world
  // frame; the rigid part of the fit (its `scale` is 1).
  Alignment transform;
  // The same transform as a pose (normalized quaternion); for reports and
  // orientations. Positions go through `transform`, as evaluate_ate.py.
  Rigid3d T_gt_est;
  // Factor applied to the estimated positions before `transform`:
  // AteOptions::scale, or the estimated one when scale_estimated.
  double scale = 1.0;
  bool scale_estimated = false;  // AteOptions::correct_scale.
  size_t pairs = 0;              // Stamp pairs the alignment was computed from (>= kMinAtePairs).
  size_t gt_poses = 0;           // Distinct stamps of the ground truth it was computed with.
  size_t est_poses = 0;          // Distinct stamps of the trajectory it was computed from.
  size_t gt_duplicates = 0;      // Lines dropped for a repeated stamp, as in AteResult.
  size_t est_duplicates = 0;
};

// The alignment of `est` to `gt` exactly as ComputeAte finds it: the same
// pairing (max_difference, offset), the given scale, and Horn's rigid fit
// (AlignRigid) or, with correct_scale, Umeyama's similarity (AlignSimilarity).
// Same errors as ComputeAte: UsageError when `options` fail Check(),
// DataError when no stamps pair or fewer than kMinAtePairs do, or when
// correct_scale meets paired positions that are all equal.
AteAlignment ComputeAteAlignment(const Trajectory& gt, const Trajectory& est,
                                 const AteOptions& options = {});

// The ATE of `est` against `gt` under a given `alignment`, without fitting
// one: `est` is paired with `gt` by `options`' max_difference and offset,
// and its positions are mapped by alignment.scale and alignment.transform
// (options.scale and correct_scale are not used; the alignment carries the
// scale). For an estimate in the same world frame as the trajectory the
// alignment came from, e.g. a localization run on the map a mapping run
// built: a fresh alignment would absorb an offset of the whole run, this
// does not. Since no fit is made, one pair suffices. Throws UsageError when
// `options` fail Check(), DataError when either trajectory is empty or no
// stamps pair.
AteResult EvaluateAte(const Trajectory& gt, const Trajectory& est, const AteAlignment& alignment,
                      const AteOptions& options = {});

// Computes the ATE of `est` against `gt`. Neither needs to be sorted; a stamp
// that occurs more than once keeps its last pose (DistinctByTimestamp), as in
// TUM's tools. Throws UsageError when `options` fail Check(), DataError when
// no stamps pair within max_difference or fewer than kMinAtePairs do.
// The same as EvaluateAte(gt, est, ComputeAteAlignment(gt, est, options),
// options), bit for bit.
AteResult ComputeAte(const Trajectory& gt, const Trajectory& est, const AteOptions& options = {});

// Machine-readable result: pair and pose counts, "ate_m" statistics (metres)
// the alignment T_gt_est (quaternion x y z w, translation) and the scale.
nlohmann::ordered_json AteResultToJson(const AteResult& result);

// evaluate_ate.py's --verbose report: "compared_pose_pairs N pairs" then
// "absolute_translational_error.<stat> <value> m" lines (6 decimals).
std::string FormatAteReport(const AteResult& result);

// The pairs as TUM's --save_associations writes them, one line per pair:
// `gt_stamp gx gy gz est_stamp ex ey ez` with the aligned estimated position.
std::string FormatAteAssociations(const AteResult& result);

}  // namespace rrslam
