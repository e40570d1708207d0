#include "stages/eval/stats.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace rrslam {

ErrorStats ComputeErrorStats(std::span<const double> values) {
  ErrorStats stats;
  stats.count = values.size();
  if (values.empty()) return stats;
  const double n = static_cast<double>(values.size());
  double sum = 0, sum_squares = 0;
  for (const double v : values) {
    sum += v;
    sum_squares += v * v;
  }
  stats.rmse = std::sqrt(sum_squares / n);
  stats.mean = sum / n;
  // Two-pass deviation (as numpy): no cancellation when the spread is small
  // against the mean.
  double sum_deviation = 0;
  for (const double v : values) sum_deviation += (v - stats.mean) * (v - stats.mean);
  stats.std = std::sqrt(sum_deviation / n);

  std::vector<double> sorted(values.begin(), values.end());
  std::sort(sorted.begin(), sorted.end());
  stats.min = sorted.front();
  stats.max = sorted.back();
  const size_t half = sorted.size() / 2;
  stats.median = sorted.size() % 2 == 1 ? sorted[half] : 0.5 * (sorted[half - 1] + sorted[half]);
  return stats;
}

nlohmann::ordered_json ErrorStatsToJson(const ErrorStats& stats) {
  return {{"rmse", stats.rmse}, {"mean", stats.mean}, {"median", stats.median},
          {"std", stats.std},   {"min", stats.min},   {"max", stats.max}};
}

}  // namespace rrslam
