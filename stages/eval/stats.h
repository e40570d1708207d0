// Summary statistics of a set of errors, with numpy's definitions so that the
// figures equal those of TUM's evaluate_ate.py / evaluate_rpe.py.
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <span>

namespace rrslam {

// RMSE, mean, median, standard deviation, minimum and maximum of `count`
// values, all in the values' unit. Definitions (n = count):
//   rmse   = sqrt(sum(e_i^2) / n)
//   mean   = sum(e_i) / n
//   median = middle value; for even n the mean of the two middle values (numpy.median)
//   std    = sqrt(sum((e_i - mean)^2) / n), the population deviation (numpy.std, ddof = 0)
struct ErrorStats {
  size_t count = 0;
  double rmse = 0;
  double mean = 0;
  double median = 0;
  double std = 0;
  double min = 0;
  double max = 0;
};

// Statistics of `values`; all zero when `values` is empty.
ErrorStats ComputeErrorStats(std::span<const double> values);

// {"rmse": .., "mean": .., "median": .., "std": .., "min": .., "max": ..}.
nlohmann::ordered_json ErrorStatsToJson(const ErrorStats& stats);

}  // namespace rrslam
