// Timestamp handling shared by ATE and RPE, with the semantics of TUM's
// RGB-D benchmark tools (associate.py, evaluate_ate.py, evaluate_rpe.py).
#pragma once

#include <cstddef>
#include <span>
#include <string>

#include "common/trajectory.h"

namespace rrslam {

// TUM's tools read a trajectory file into a dictionary keyed by timestamp, so
// a stamp listed more than once keeps only its last pose. Returns the poses
// with distinct stamps, sorted by time; `dropped` (optional) receives the
// number of poses left out because a later line had the same stamp.
Trajectory DistinctByTimestamp(const Trajectory& trajectory, size_t* dropped = nullptr);

// Index of the element of `sorted` (ascending, non-empty) nearest to `value`,
// found as evaluate_rpe.py's find_closest_index does: a binary search that
// keeps the nearest element it visits (the first visited wins a tie) and stops
// at an exact hit. The search visits both neighbours of `value`, so the result
// is always a nearest element.
size_t FindClosestIndex(std::span<const double> sorted, double value);

// Timestamps of a trajectory, in order.
std::vector<double> Timestamps(const Trajectory& trajectory);

// Checks the estimate's time offset (s, finite) and scale (> 0, finite) that
// both ATE and RPE apply before pairing; names the first violation in `why`.
bool CheckOffsetAndScale(double offset, double scale, std::string* why);

}  // namespace rrslam
