#include "stages/eval/association.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <numeric>

#include "common/text.h"

namespace rrslam {

Trajectory DistinctByTimestamp(const Trajectory& trajectory, size_t* dropped) {
  std::vector<size_t> order(trajectory.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return trajectory[a].timestamp < trajectory[b].timestamp;
  });
  Trajectory distinct;
  distinct.reserve(trajectory.size());
  for (size_t k = 0; k < order.size(); ++k) {
    // Stable order: the last of a run of equal stamps is the latest line.
    const bool last_of_run = k + 1 == order.size() ||
                             trajectory[order[k + 1]].timestamp != trajectory[order[k]].timestamp;
    if (last_of_run) distinct.push_back(trajectory[order[k]]);
  }
  if (dropped != nullptr) *dropped = trajectory.size() - distinct.size();
  return distinct;
}

size_t FindClosestIndex(std::span<const double> sorted, double value) {
  assert(!sorted.empty());
  size_t begin = 0, end = sorted.size(), best = 0;
  double best_difference = std::fabs(sorted[0] - value);
  while (begin < end) {
    const size_t middle = (begin + end) / 2;
    const double difference = std::fabs(sorted[middle] - value);
    if (difference < best_difference) {
      best_difference = difference;
      best = middle;
    }
    if (sorted[middle] == value) return middle;
    if (sorted[middle] > value) {
      end = middle;
    } else {
      begin = middle + 1;
    }
  }
  return best;
}

std::vector<double> Timestamps(const Trajectory& trajectory) {
  std::vector<double> stamps(trajectory.size());
  for (size_t i = 0; i < trajectory.size(); ++i) stamps[i] = trajectory[i].timestamp;
  return stamps;
}

bool CheckOffsetAndScale(double offset, double scale, std::string* why) {
  if (!std::isfinite(offset)) {
    *why = "offset = " + Format("%g", offset) + " s; must be finite";
    return false;
  }
  if (!(scale > 0) || !std::isfinite(scale)) {
    *why = "scale = " + Format("%g", scale) + "; must be > 0";
    return false;
  }
  return true;
}

}  // namespace rrslam
