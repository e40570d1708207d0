#include "stages/eval/rpe.h"

#include <cmath>
#include <cstdio>

#include "common/errors.h"
#include "common/geometry.h"
#include "common/text.h"
#include "stages/eval/association.h"

namespace rrslam {
namespace {

constexpr double kDegreesPerRadian = 180.0 / M_PI;

double MedianInterval(const std::vector<double>& sorted_stamps) {
  std::vector<double> intervals(sorted_stamps.size() - 1);
  for (size_t k = 0; k + 1 < sorted_stamps.size(); ++k) {
    intervals[k] = sorted_stamps[k + 1] - sorted_stamps[k];
  }
  return ComputeErrorStats(intervals).median;
}

}  // namespace

std::string ToString(DeltaUnit unit) { return unit == DeltaUnit::kFrames ? "f" : "s"; }

std::string ToString(RpeErrorForm form) {
  return form == RpeErrorForm::kTumScript ? "script" : "paper";
}

bool RpeOptions::Check(std::string* why) const {
  if (!(delta > 0) || !std::isfinite(delta)) {
    *why = "delta = " + Format("%g", delta) + "; must be > 0";
    return false;
  }
  if (delta_unit == DeltaUnit::kFrames && delta != std::floor(delta)) {
    *why = "delta = " + Format("%g", delta) + " frames; must be a whole number of frames";
    return false;
  }
  if (!(max_difference >= 0) || !std::isfinite(max_difference)) {
    *why = "max_difference = " + Format("%g", max_difference) +
           " s; must be >= 0 (0: twice the median ground-truth interval)";
    return false;
  }
  return CheckOffsetAndScale(offset, scale, why);
}

nlohmann::ordered_json RpeOptions::ToJson() const {
  return {{"delta", delta},
          {"delta_unit", ToString(delta_unit)},
          {"max_difference_s", max_difference},
          {"offset_s", offset},
          {"scale", scale},
          {"error_form", ToString(error_form)}};
}

RpeResult ComputeRpe(const Trajectory& gt_input, const Trajectory& est_input,
                     const RpeOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError("RPE options: " + why);
  const Trajectory gt = DistinctByTimestamp(gt_input);
  const Trajectory est = DistinctByTimestamp(est_input);
  if (gt.size() < 2) {
    throw DataError("the ground truth has " + std::to_string(gt.size()) +
                    " distinct pose(s); RPE needs at least 2");
  }
  if (est.size() < 2) {
    throw DataError("the estimate has " + std::to_string(est.size()) +
                    " distinct pose(s); RPE needs at least 2");
  }
  RpeResult result;
  result.gt_poses = gt.size();
  result.est_poses = est.size();
  const std::vector<double> gt_stamps = Timestamps(gt);
  const std::vector<double> est_stamps = Timestamps(est);
  result.max_difference =
      options.max_difference > 0 ? options.max_difference : 2.0 * MedianInterval(gt_stamps);

  std::vector<double> index(est.size());
  for (size_t i = 0; i < est.size(); ++i) {
    index[i] = options.delta_unit == DeltaUnit::kFrames ? static_cast<double>(i) : est_stamps[i];
  }

  std::vector<double> translational, rotational;
  const size_t last = est.size() - 1;
  for (size_t i = 0; i < est.size(); ++i) {
    const size_t j = FindClosestIndex(index, index[i] + options.delta);
    // evaluate_rpe.py drops j == last: for i near the end every target beyond
    // the estimate clamps to the last pose.
    if (j == last || j == i) continue;
    const double t0 = est_stamps[i] + options.offset;
    const double t1 = est_stamps[j] + options.offset;
    const size_t g0 = FindClosestIndex(gt_stamps, t0);
    const size_t g1 = FindClosestIndex(gt_stamps, t1);
    if (std::fabs(gt_stamps[g0] - t0) > result.max_difference ||
        std::fabs(gt_stamps[g1] - t1) > result.max_difference) {
      ++result.skipped_pairs;
      continue;
    }
    Rigid3d motion_est = est[i].T_world_cam.Inverse() * est[j].T_world_cam;  // P
    motion_est.translation *= options.scale;
    const Rigid3d motion_gt = gt[g0].T_world_cam.Inverse() * gt[g1].T_world_cam;  // Q
    const Rigid3d error = options.error_form == RpeErrorForm::kTumScript
                              ? motion_est * motion_gt.Inverse()
                              : motion_gt.Inverse() * motion_est;
    RpePair pair;
    pair.est_timestamp_0 = est_stamps[i];
    pair.est_timestamp_1 = est_stamps[j];
    pair.gt_timestamp_0 = gt_stamps[g0];
    pair.gt_timestamp_1 = gt_stamps[g1];
    pair.translational_error = error.translation.norm();
    // From the quaternion (atan2): accurate for small angles, where
    // evaluate_rpe.py's arccos((trace - 1) / 2) loses up to ~1e-8 rad.
    pair.rotational_error_deg = LogSO3(error.rotation).norm() * kDegreesPerRadian;
    translational.push_back(pair.translational_error);
    rotational.push_back(pair.rotational_error_deg);
    result.pairs.push_back(pair);
  }
  if (result.pairs.empty()) {
    if (result.skipped_pairs == 0) {
      // The files are fine; the evaluation asked for has nothing to measure.
      throw AlgorithmError("a delta of " + Format("%g", options.delta) + " " +
                           (options.delta_unit == DeltaUnit::kFrames ? "frame(s)" : "s") +
                           " leaves no pose pair in an estimate of " + std::to_string(est.size()) +
                           " poses spanning " +
                           Format("%.6f", est_stamps.back() - est_stamps.front()) + " s");
    }
    throw DataError("no stamps matched: no pose pair of the estimate (plus offset " +
                    Format("%g", options.offset) + " s) has ground truth within max_difference " +
                    Format("%g", result.max_difference) + " s (ground truth spans " +
                    Format("%.6f", gt_stamps.front()) + " to " + Format("%.6f", gt_stamps.back()) +
                    " s, estimate " + Format("%.6f", est_stamps.front()) + " to " +
                    Format("%.6f", est_stamps.back()) +
                    " s); check --offset and that both files are of the same sequence");
  }
  result.translational = ComputeErrorStats(translational);
  result.rotational = ComputeErrorStats(rotational);
  return result;
}

nlohmann::ordered_json RpeResultToJson(const RpeResult& result) {
  return {{"pairs", result.pairs.size()},
          {"skipped_pairs", result.skipped_pairs},
          {"gt_poses", result.gt_poses},
          {"est_poses", result.est_poses},
          {"max_difference_used_s", result.max_difference},
          {"translational_error_m", ErrorStatsToJson(result.translational)},
          {"rotational_error_deg", ErrorStatsToJson(result.rotational)}};
}

std::string FormatRpeReport(const RpeResult& result) {
  std::string out = "compared_pose_pairs " + std::to_string(result.pairs.size()) + " pairs\n";
  const auto rows = [&](const char* prefix, const ErrorStats& e, const char* unit) {
    const std::pair<const char*, double> values[] = {{"rmse", e.rmse},     {"mean", e.mean},
                                                     {"median", e.median}, {"std", e.std},
                                                     {"min", e.min},       {"max", e.max}};
    for (const auto& [name, value] : values) {
      out += std::string(prefix) + "." + name + " " + Format("%f", value) + " " + unit + "\n";
    }
  };
  rows("translational_error", result.translational, "m");
  rows("rotational_error", result.rotational, "deg");
  return out;
}

std::string FormatRpePairs(const RpeResult& result) {
  std::string out;
  out.reserve(result.pairs.size() * 90);
  char line[256];
  for (const RpePair& p : result.pairs) {
    std::snprintf(line, sizeof(line), "%.6f %.6f %.6f %.6f %.9f %.9f\n", p.est_timestamp_0,
                  p.est_timestamp_1, p.gt_timestamp_0, p.gt_timestamp_1, p.translational_error,
                  p.rotational_error_deg);
    out += line;
  }
  return out;
}

}  // namespace rrslam
