#include "stages/eval/stats.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace rrslam {
namespace {

TEST(ErrorStats, EvenCountUsesMeanOfMiddleValuesAndPopulationStd) {
  // Unsorted on purpose. numpy: median 2.5, std (ddof=0) sqrt(1.25).
  const std::vector<double> values = {4, 1, 3, 2};
  const ErrorStats s = ComputeErrorStats(values);
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(30.0 / 4));
  EXPECT_DOUBLE_EQ(s.min, 1);
  EXPECT_DOUBLE_EQ(s.max, 4);
}

TEST(ErrorStats, OddCountTakesTheMiddleValue) {
  const std::vector<double> values = {0.5, 10, 0.25, 0.75, 0.1};
  const ErrorStats s = ComputeErrorStats(values);
  EXPECT_DOUBLE_EQ(s.median, 0.5);
  EXPECT_DOUBLE_EQ(s.mean, 11.6 / 5);
  const double mean = 11.6 / 5;
  double sum = 0;
  for (double v : values) sum += (v - mean) * (v - mean);
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(sum / 5));
  EXPECT_DOUBLE_EQ(s.min, 0.1);
  EXPECT_DOUBLE_EQ(s.max, 10);
}

TEST(ErrorStats, SingleValueAndConstantValues) {
  const std::vector<double> one = {0.3};
  const ErrorStats s = ComputeErrorStats(one);
  EXPECT_DOUBLE_EQ(s.rmse, 0.3);
  EXPECT_DOUBLE_EQ(s.median, 0.3);
  EXPECT_DOUBLE_EQ(s.std, 0);
  // A large common value must not leak into the deviation: a one-pass
  // sqrt(E[x^2] - mean^2) would be off by ~1e-2 here, two passes by ~1e-10.
  const std::vector<double> constant(7, 1e6 + 0.1);
  EXPECT_LT(ComputeErrorStats(constant).std, 1e-6);
}

TEST(ErrorStats, EmptyGivesZeros) {
  const ErrorStats s = ComputeErrorStats({});
  EXPECT_EQ(s.count, 0u);
  EXPECT_EQ(s.rmse, 0);
  EXPECT_EQ(s.max, 0);
}

TEST(ErrorStats, JsonHasTheSixFigures) {
  const std::vector<double> values = {1, 2, 4};
  const auto json = ErrorStatsToJson(ComputeErrorStats(values));
  EXPECT_EQ(json.size(), 6u);
  EXPECT_DOUBLE_EQ(json["median"].get<double>(), 2);
  EXPECT_DOUBLE_EQ(json["mean"].get<double>(), 7.0 / 3);
  EXPECT_DOUBLE_EQ(json["rmse"].get<double>(), std::sqrt(7.0));
  EXPECT_DOUBLE_EQ(json["min"].get<double>(), 1);
  EXPECT_DOUBLE_EQ(json["max"].get<double>(), 4);
  EXPECT_TRUE(json.contains("std"));
}

}  // namespace
}  // namespace rrslam
