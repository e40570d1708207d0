#include "stages/eval/association.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "common/errors.h"
#include "stages/eval/ate.h"

namespace rrslam {
namespace {

// A pose at `timestamp` whose position encodes `tag` (for identification) on
// a curve that never degenerates to a line.
StampedPose Pose(double timestamp, double tag) {
  StampedPose pose;
  pose.timestamp = timestamp;
  pose.T_world_cam.translation = Eigen::Vector3d(tag, tag * tag, 0.5 * tag * tag * tag);
  return pose;
}

Trajectory FromStamps(const std::vector<double>& stamps) {
  Trajectory t;
  for (size_t i = 0; i < stamps.size(); ++i) t.push_back(Pose(stamps[i], static_cast<double>(i)));
  return t;
}

// (gt stamp, est stamp) of every ATE pair.
std::vector<std::pair<double, double>> Pairs(const Trajectory& gt, const Trajectory& est,
                                             double max_difference, double offset = 0) {
  AteOptions options;
  options.max_difference = max_difference;
  options.offset = offset;
  std::vector<std::pair<double, double>> pairs;
  for (const AtePair& p : ComputeAte(gt, est, options).pairs) {
    pairs.emplace_back(p.gt_timestamp, p.est_timestamp);
  }
  return pairs;
}

using StampPairs = std::vector<std::pair<double, double>>;

// Far-away stamps that always pair exactly, so ATE has its 3 pairs.
const std::vector<double> kAnchors = {100, 200, 300};

std::vector<double> WithAnchors(std::vector<double> stamps) {
  stamps.insert(stamps.end(), kAnchors.begin(), kAnchors.end());
  return stamps;
}

TEST(Association, GreedyBySmallestDifferenceNotOptimalMatching) {
  // Candidates (|a - b| < 0.7): (1, 0.6) 0.4, (1, 1.5) 0.5, (0, 0.6) 0.6.
  // Greedy takes (1, 0.6) first; (1, 1.5) and (0, 0.6) then reuse a stamp, so
  // only one pair forms although a perfect matching of two exists.
  const auto pairs =
      Pairs(FromStamps(WithAnchors({0, 1})), FromStamps(WithAnchors({0.6, 1.5})), 0.7);
  EXPECT_EQ(pairs, (StampPairs{{1, 0.6}, {100, 100}, {200, 200}, {300, 300}}));
}

TEST(Association, NearestCandidateWinsOverEarlierStamp) {
  const auto pairs =
      Pairs(FromStamps(WithAnchors({0.0, 0.1})), FromStamps(WithAnchors({0.0625})), 0.1);
  ASSERT_EQ(pairs.size(), 4u);
  EXPECT_EQ(pairs[0], std::make_pair(0.1, 0.0625));
}

TEST(Association, MaxDifferenceIsStrict) {
  // |1.0 - 1.5| = 0.5 exactly (binary-exact numbers): not < 0.5.
  EXPECT_EQ(Pairs(FromStamps(WithAnchors({1.0})), FromStamps(WithAnchors({1.5})), 0.5).size(), 3u);
  EXPECT_EQ(Pairs(FromStamps(WithAnchors({1.0})), FromStamps(WithAnchors({1.5})), 0.5000001).size(),
            4u);
}

TEST(Association, OffsetIsAddedToTheEstimatedStamps) {
  const Trajectory gt = FromStamps({10, 11, 12, 13});
  const Trajectory est = FromStamps({0.005, 1.005, 2.005, 3.005});
  EXPECT_THROW(Pairs(gt, est, 0.02), DataError);
  const auto pairs = Pairs(gt, est, 0.02, 10.0);
  // The pairs report the estimate's own stamps, without the offset.
  EXPECT_EQ(pairs, (StampPairs{{10, 0.005}, {11, 1.005}, {12, 2.005}, {13, 3.005}}));
}

TEST(Association, EachStampIsUsedOnce) {
  // Three estimated stamps crowd one ground-truth stamp: only the nearest pairs.
  const auto pairs =
      Pairs(FromStamps(WithAnchors({5.0})), FromStamps(WithAnchors({4.99, 5.004, 5.01})), 0.02);
  EXPECT_EQ(pairs, (StampPairs{{5.0, 5.004}, {100, 100}, {200, 200}, {300, 300}}));
}

TEST(Association, ResultIsSortedByGroundTruthStamp) {
  Trajectory gt = FromStamps({3, 1, 2, 0});
  Trajectory est = FromStamps({2.001, 0.001, 3.001, 1.001});
  const auto pairs = Pairs(gt, est, 0.01);
  EXPECT_EQ(pairs, (StampPairs{{0, 0.001}, {1, 1.001}, {2, 2.001}, {3, 3.001}}));
}

TEST(Association, RepeatedStampKeepsItsLastPose) {
  Trajectory est = FromStamps({1, 2, 2, 3, 1});
  size_t dropped = 0;
  const Trajectory distinct = DistinctByTimestamp(est, &dropped);
  EXPECT_EQ(dropped, 2u);
  ASSERT_EQ(distinct.size(), 3u);
  EXPECT_EQ(distinct[0].timestamp, 1);
  EXPECT_EQ(distinct[0].T_world_cam.translation.x(), 4);  // The last line with stamp 1.
  EXPECT_EQ(distinct[1].T_world_cam.translation.x(), 2);  // The last line with stamp 2.
  EXPECT_EQ(distinct[2].T_world_cam.translation.x(), 3);

  // In ATE the duplicates count once and the later pose is the one compared.
  const Trajectory gt = FromStamps({1, 2, 3});
  AteOptions options;
  const AteResult result = ComputeAte(gt, est, options);
  EXPECT_EQ(result.est_poses, 3u);
  EXPECT_EQ(result.est_duplicates, 2u);
  ASSERT_EQ(result.pairs.size(), 3u);
  EXPECT_EQ(result.pairs[0].est_position.x(), 4);
}

TEST(FindClosestIndex, FindsTheNearestElement) {
  const std::vector<double> L = {0.0, 1.0, 2.5, 4.0, 10.0};
  EXPECT_EQ(FindClosestIndex(L, -5), 0u);
  EXPECT_EQ(FindClosestIndex(L, 0.4), 0u);
  EXPECT_EQ(FindClosestIndex(L, 0.6), 1u);
  EXPECT_EQ(FindClosestIndex(L, 2.5), 2u);
  EXPECT_EQ(FindClosestIndex(L, 3.3), 3u);
  EXPECT_EQ(FindClosestIndex(L, 6.9), 3u);
  EXPECT_EQ(FindClosestIndex(L, 7.1), 4u);
  EXPECT_EQ(FindClosestIndex(L, 99), 4u);
  // Every value agrees with a linear scan on a larger list.
  std::vector<double> M;
  for (int k = 0; k < 37; ++k) M.push_back(k * k * 0.1);
  for (double t = -1; t < 140; t += 0.173) {
    size_t best = 0;
    for (size_t k = 1; k < M.size(); ++k) {
      if (std::fabs(M[k] - t) < std::fabs(M[best] - t)) best = k;
    }
    EXPECT_DOUBLE_EQ(std::fabs(M[FindClosestIndex(M, t)] - t), std::fabs(M[best] - t)) << t;
  }
}

TEST(FindClosestIndex, TieGoesToTheFirstVisitedElement) {
  // Between two equally near elements the search keeps the one it visits
  // first, as evaluate_rpe.py's find_closest_index.
  const std::vector<double> L = {0.0, 1.0, 2.0, 3.0};
  EXPECT_EQ(FindClosestIndex(L, 1.5), 2u);  // Visits 2 first ((0 + 4) / 2), keeps it.
  const std::vector<double> K = {0.0, 1.0, 2.0};
  EXPECT_EQ(FindClosestIndex(K, 1.5), 1u);  // Visits 1 first ((0 + 3) / 2), keeps it.
}

}  // namespace
}  // namespace rrslam
