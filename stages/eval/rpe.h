// Relative pose error (RPE) over a fixed delta, as TUM's evaluate_rpe.py
// computes it with --fixed_delta and --max_pairs 0 (every pair, no sampling).
//
// For every estimated pose i (distinct stamps, sorted) the partner j is the
// pose whose index value is nearest to index_i + delta, where the index is the
// frame number (delta in frames) or the timestamp (delta in seconds); as in
// evaluate_rpe.py, a pair whose j is the estimate's last pose is not used, and
// (deviating from it) neither is a pose paired with itself, which happens only
// across a gap in the estimate longer than about twice a delta in seconds.
// Each estimated pose takes the ground-truth pose of nearest stamp (after
// adding `offset`); a pair is used only when both ground-truth stamps lie
// within max_difference (inclusive). With P = est_i^-1 est_j (translation times
// `scale`) and Q = gt_i^-1 gt_j the relative motions (poses T_world_cam),
//   kTumScript: E = P Q^-1          (what evaluate_rpe.py computes)
//   kPaper:     E = Q^-1 P          (eq. 3 of Sturm et al., IROS 2012)
// The translational error is |translation(E)| (metres) and the rotational
// error the angle of rotation(E) (degrees). The two forms give the same
// rotational error; their translational errors differ by the rotational error
// acting on the motion, |t_P - R_P R_Q^T t_Q| against |t_P - t_Q|.
// Thread-safe (no shared state).
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/trajectory.h"
#include "stages/eval/stats.h"

namespace rrslam {

enum class DeltaUnit {
  kFrames,   // Delta counts poses of the estimate (a whole number >= 1).
  kSeconds,  // Delta is a time difference in seconds.
};

enum class RpeErrorForm {
  kTumScript,  // E = P Q^-1, the figures of evaluate_rpe.py.
  kPaper,      // E = Q^-1 P, the definition printed in the benchmark's paper.
};

// "f" / "s" and "script" / "paper", as on the command line.
std::string ToString(DeltaUnit unit);
std::string ToString(RpeErrorForm form);

struct RpeOptions {
  // Distance between the two poses of a pair, in `delta_unit`. Must be > 0,
  // and a whole number for frames.
  double delta = 1.0;
  DeltaUnit delta_unit = DeltaUnit::kSeconds;
  // Largest |t_gt - (t_est + offset)|, seconds, for an estimated pose to take
  // a ground-truth pose (inclusive). 0: twice the median interval between
  // ground-truth stamps, as evaluate_rpe.py. Must be >= 0.
  double max_difference = 0.0;
  // Seconds added to every estimated stamp before the ground-truth lookup.
  double offset = 0.0;
  // Factor applied to the estimated relative translations. Must be > 0.
  double scale = 1.0;
  RpeErrorForm error_form = RpeErrorForm::kTumScript;

  bool Check(std::string* why) const;
  nlohmann::ordered_json ToJson() const;
};

struct RpePair {
  double est_timestamp_0 = 0, est_timestamp_1 = 0;  // Seconds, pair (i, j) of the estimate.
  double gt_timestamp_0 = 0, gt_timestamp_1 = 0;    // Their ground-truth stamps.
  double translational_error = 0;                   // Metres.
  double rotational_error_deg = 0;                  // Degrees, in [0, 180].
};

struct RpeResult {
  std::vector<RpePair> pairs;  // In the order of the estimate's first pose.
  ErrorStats translational;    // Metres.
  ErrorStats rotational;       // Degrees.
  double max_difference = 0;   // The ground-truth lookup bound used, seconds.
  size_t gt_poses = 0;         // Distinct ground-truth stamps.
  size_t est_poses = 0;        // Distinct estimated stamps.
  size_t skipped_pairs = 0;    // Pairs left out: no ground truth within max_difference.
};

// Computes the RPE of `est` against `gt` (any order; a repeated stamp keeps its
// last pose). Throws UsageError when `options` fail Check(), DataError when a
// trajectory has fewer than 2 poses or no pair has ground truth.
RpeResult ComputeRpe(const Trajectory& gt, const Trajectory& est, const RpeOptions& options = {});

// Counts and "translational_error_m" / "rotational_error_deg" statistics.
nlohmann::ordered_json RpeResultToJson(const RpeResult& result);

// evaluate_rpe.py's --verbose report ("translational_error.rmse 0.012 m", ...,
// "rotational_error.rmse 0.8 deg", ...), every rotational figure in degrees.
std::string FormatRpeReport(const RpeResult& result);

// One line per pair as evaluate_rpe.py's --save: `est_stamp_0 est_stamp_1
// gt_stamp_0 gt_stamp_1 translational_error_m rotational_error_deg`.
std::string FormatRpePairs(const RpeResult& result);

}  // namespace rrslam
