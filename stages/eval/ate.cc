#include "stages/eval/ate.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "common/dataset.h"
#include "common/errors.h"
#include "common/text.h"
#include "stages/eval/alignment.h"
#include "stages/eval/association.h"

namespace rrslam {
namespace {

std::string Span(const Trajectory& trajectory) {
  return Format("%.6f", trajectory.front().timestamp) + " to " +
         Format("%.6f", trajectory.back().timestamp) + " s";
}

}  // namespace

bool AteOptions::Check(std::string* why) const {
  if (!(max_difference > 0) || !std::isfinite(max_difference)) {
    *why = "max_difference = " + Format("%g", max_difference) + " s; must be > 0";
    return false;
  }
  if (correct_scale && scale != 1.0) {
    *why = "scale = " + Format("%g", scale) + " with correct_scale, which estimates it; must be 1";
    return false;
  }
  return CheckOffsetAndScale(offset, scale, why);
}

nlohmann::ordered_json AteOptions::ToJson() const {
  return {{"max_difference_s", max_difference},
          {"offset_s", offset},
          {"scale", scale},
          {"correct_scale", correct_scale}};
}

namespace {

// Both trajectories with distinct stamps and their stamp pairs.
struct PairedTrajectories {
  Trajectory gt, est;
  size_t gt_duplicates = 0, est_duplicates = 0;
  std::vector<std::pair<size_t, size_t>> matches;  // (index into gt, index into est)
};

// Checks `options`, pairs the stamps and throws DataError for an empty
// trajectory, no pairs, or fewer than `min_pairs`.
PairedTrajectories Pair(const Trajectory& gt_input, const Trajectory& est_input,
                        const AteOptions& options, size_t min_pairs) {
  std::string why;
  if (!options.Check(&why)) throw UsageError("ATE options: " + why);
  PairedTrajectories paired;
  paired.gt = DistinctByTimestamp(gt_input, &paired.gt_duplicates);
  paired.est = DistinctByTimestamp(est_input, &paired.est_duplicates);
  const Trajectory& gt = paired.gt;
  const Trajectory& est = paired.est;
  if (gt.empty()) throw DataError("the ground truth has no poses");
  if (est.empty()) throw DataError("the estimate has no poses");

  paired.matches =
      AssociateTimestamps(Timestamps(gt), Timestamps(est), options.max_difference, options.offset);
  if (paired.matches.empty()) {
    throw DataError("no stamps matched: no estimated stamp (plus offset " +
                    Format("%g", options.offset) + " s) lies within max_difference " +
                    Format("%g", options.max_difference) +
                    " s of a ground-truth stamp (ground truth spans " + Span(gt) + ", estimate " +
                    Span(est) + "); check --offset and that both files are of the same sequence");
  }
  if (paired.matches.size() < min_pairs) {
    throw DataError("only " + std::to_string(paired.matches.size()) +
                    " stamp pair(s) matched within max_difference " +
                    Format("%g", options.max_difference) + " s; ATE needs at least " +
                    std::to_string(min_pairs));
  }
  return paired;
}

}  // namespace

AteAlignment ComputeAteAlignment(const Trajectory& gt_input, const Trajectory& est_input,
                                 const AteOptions& options) {
  const PairedTrajectories paired = Pair(gt_input, est_input, options, kMinAtePairs);
  const auto& matches = paired.matches;
  AteAlignment result;
  result.scale = options.scale;
  result.pairs = matches.size();
  result.gt_poses = paired.gt.size();
  result.est_poses = paired.est.size();
  result.gt_duplicates = paired.gt_duplicates;
  result.est_duplicates = paired.est_duplicates;

  const Eigen::Index n = static_cast<Eigen::Index>(matches.size());
  Eigen::Matrix3Xd gt_xyz(3, n), est_xyz(3, n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const auto [i, j] = matches[k];
    gt_xyz.col(k) = paired.gt[i].T_world_cam.translation;
    est_xyz.col(k) = options.scale * paired.est[j].T_world_cam.translation;
  }
  Alignment alignment;
  if (!options.correct_scale) {
    alignment = AlignRigid(est_xyz, gt_xyz);
  } else {
    try {
      alignment = AlignSimilarity(est_xyz, gt_xyz);
    } catch (const std::invalid_argument&) {
      throw DataError(
          "the paired estimated positions are all equal; the scale cannot be estimated");
    }
    // The scale goes with the estimate (options.scale is 1 here, so
    // scale * t is exact); the rest is the rigid alignment of the scaled points.
    result.scale = alignment.scale;
    result.scale_estimated = true;
    alignment.scale = 1.0;
  }
  result.transform = alignment;
  result.T_gt_est =
      Rigid3d(Eigen::Quaterniond(alignment.rotation).normalized(), alignment.translation);
  return result;
}

AteResult EvaluateAte(const Trajectory& gt_input, const Trajectory& est_input,
                      const AteAlignment& alignment, const AteOptions& options) {
  const PairedTrajectories paired = Pair(gt_input, est_input, options, /*min_pairs=*/1);
  const Trajectory& gt = paired.gt;
  const Trajectory& est = paired.est;
  const auto& matches = paired.matches;
  AteResult result;
  result.T_gt_est = alignment.T_gt_est;
  result.scale = alignment.scale;
  result.scale_estimated = alignment.scale_estimated;
  result.gt_poses = gt.size();
  result.est_poses = est.size();
  result.gt_duplicates = paired.gt_duplicates;
  result.est_duplicates = paired.est_duplicates;

  std::vector<double> errors(matches.size());
  result.pairs.resize(matches.size());
  for (size_t k = 0; k < matches.size(); ++k) {
    AtePair& pair = result.pairs[k];
    pair.gt_timestamp = gt[matches[k].first].timestamp;
    pair.est_timestamp = est[matches[k].second].timestamp;
    pair.gt_position = gt[matches[k].first].T_world_cam.translation;
    pair.est_position = alignment.scale * est[matches[k].second].T_world_cam.translation;
    // The rotation matrix itself (not its quaternion) so the figures follow
    // evaluate_ate.py's arithmetic as closely as possible.
    pair.est_position_aligned = alignment.transform * pair.est_position;
    pair.error = (pair.est_position_aligned - pair.gt_position).norm();
    errors[k] = pair.error;
  }
  result.error = ComputeErrorStats(errors);

  result.est_aligned.reserve(est.size());
  for (const StampedPose& pose : est) {
    StampedPose aligned;
    aligned.timestamp = pose.timestamp;
    aligned.T_world_cam =
        Rigid3d((result.T_gt_est.rotation * pose.T_world_cam.rotation).normalized(),
                alignment.transform * (alignment.scale * pose.T_world_cam.translation));
    result.est_aligned.push_back(aligned);
  }
  return result;
}

AteResult ComputeAte(const Trajectory& gt, const Trajectory& est, const AteOptions& options) {
  return EvaluateAte(gt, est, ComputeAteAlignment(gt, est, options), options);
}

nlohmann::ordered_json AteResultToJson(const AteResult& result) {
  const Eigen::Quaterniond& q = result.T_gt_est.rotation;
  const Eigen::Vector3d& t = result.T_gt_est.translation;
  return {
      {"pairs", result.pairs.size()},
      {"gt_poses", result.gt_poses},
      {"est_poses", result.est_poses},
      {"gt_duplicate_stamps", result.gt_duplicates},
      {"est_duplicate_stamps", result.est_duplicates},
      {"ate_m", ErrorStatsToJson(result.error)},
      {"T_gt_est",
       {{"quaternion_xyzw", {q.x(), q.y(), q.z(), q.w()}}, {"translation", {t.x(), t.y(), t.z()}}}},
      {"scale", result.scale},
      {"scale_estimated", result.scale_estimated},
  };
}

std::string FormatAteReport(const AteResult& result) {
  const ErrorStats& e = result.error;
  std::string out = "compared_pose_pairs " + std::to_string(result.pairs.size()) + " pairs\n";
  const std::pair<const char*, double> rows[] = {{"rmse", e.rmse},     {"mean", e.mean},
                                                 {"median", e.median}, {"std", e.std},
                                                 {"min", e.min},       {"max", e.max}};
  for (const auto& [name, value] : rows) {
    out += std::string("absolute_translational_error.") + name + " " + Format("%f", value) + " m\n";
  }
  if (result.scale_estimated) out += "estimated_scale " + Format("%f", result.scale) + "\n";
  return out;
}

std::string FormatAteAssociations(const AteResult& result) {
  std::string out;
  out.reserve(result.pairs.size() * 110);
  char line[320];
  for (const AtePair& p : result.pairs) {
    std::snprintf(line, sizeof(line), "%.6f %.9f %.9f %.9f %.6f %.9f %.9f %.9f\n", p.gt_timestamp,
                  p.gt_position.x(), p.gt_position.y(), p.gt_position.z(), p.est_timestamp,
                  p.est_position_aligned.x(), p.est_position_aligned.y(),
                  p.est_position_aligned.z());
    out += line;
  }
  return out;
}

}  // namespace rrslam
