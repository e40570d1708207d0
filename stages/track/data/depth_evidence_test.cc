#include "stages/track/data/depth_evidence.h"

#include <gtest/gtest.h>

#include <limits>
#include <opencv2/core.hpp>

namespace rrslam {
namespace {

constexpr double kZ = 1.0;  // The point's depth; the gap there is 15 cm.

cv::Mat Wall(float depth) { return cv::Mat(48, 64, CV_32F, cv::Scalar(depth)); }

TEST(DepthEvidenceTest, GapIsTenCentimetresOrFifteenPercent) {
  EXPECT_NEAR(DepthEvidenceGap(0.5), 0.1, 1e-12);
  EXPECT_NEAR(DepthEvidenceGap(1.0), 0.15, 1e-12);
  EXPECT_NEAR(DepthEvidenceGap(4.0), 0.6, 1e-12);
}

TEST(DepthEvidenceTest, CoverGapIsThreeCentimetresOrThreePercentAndTighter) {
  EXPECT_NEAR(DepthCoverGap(0.5), 0.03, 1e-12);
  EXPECT_NEAR(DepthCoverGap(4.0), 0.12, 1e-12);
  for (double z : {0.3, 1.0, 2.5, 6.0}) EXPECT_LT(DepthCoverGap(z), DepthEvidenceGap(z));
}

TEST(DepthEvidenceTest, SurfaceAtThePointsDepthIsPresent) {
  EXPECT_EQ(DepthEvidenceAt(Wall(1.1f), {30, 20}, kZ), DepthEvidence::kPresent);
  EXPECT_EQ(DepthEvidenceAt(Wall(0.9f), {30, 20}, kZ), DepthEvidence::kPresent);
}

TEST(DepthEvidenceTest, WallBehindThePointIsSeenThrough) {
  EXPECT_EQ(DepthEvidenceAt(Wall(1.2f), {30, 20}, kZ), DepthEvidence::kSeenThrough);
  // 30 cm beyond a point at 3 m is within its gap (45 cm): still present.
  EXPECT_EQ(DepthEvidenceAt(Wall(3.3f), {30, 20}, 3.0), DepthEvidence::kPresent);
}

TEST(DepthEvidenceTest, OccludedPointSaysNothing) {
  EXPECT_EQ(DepthEvidenceAt(Wall(0.5f), {30, 20}, kZ), DepthEvidence::kNone);
}

// A point on the near side of a depth edge: most of its window sees the
// background, but the near side in it keeps it from being seen through.
TEST(DepthEvidenceTest, DepthEdgeIsNotSeenThrough) {
  cv::Mat depth = Wall(3.0f);
  depth.colRange(0, 29).setTo(kZ);  // Columns 0-28 at the point's depth.
  EXPECT_EQ(DepthEvidenceAt(depth, {30, 20}, kZ), DepthEvidence::kPresent);
  depth.colRange(0, 29).setTo(0.5f);  // An occluder's edge beside a seen-through pixel.
  EXPECT_EQ(DepthEvidenceAt(depth, {30, 20}, kZ), DepthEvidence::kNone);
}

TEST(DepthEvidenceTest, HolesAndImageBorderSayNothing) {
  cv::Mat depth = Wall(3.0f);
  const cv::Rect window(28, 18, 5, 5);
  depth(window).setTo(0.0f);
  depth(cv::Rect(28, 18, 5, 2)).setTo(3.0f);  // 10 of 25 valid.
  EXPECT_EQ(DepthEvidenceAt(depth, {30, 20}, kZ), DepthEvidence::kNone);
  depth(cv::Rect(28, 20, 5, 1)).setTo(3.0f);  // 15 of 25.
  EXPECT_EQ(DepthEvidenceAt(depth, {30, 20}, kZ), DepthEvidence::kSeenThrough);
  depth(cv::Rect(28, 21, 5, 1)).setTo(std::numeric_limits<float>::quiet_NaN());
  EXPECT_EQ(DepthEvidenceAt(depth, {30, 20}, kZ), DepthEvidence::kSeenThrough);  // NaN = none.
  EXPECT_EQ(DepthEvidenceAt(Wall(3.0f), {1, 20}, kZ), DepthEvidence::kNone);
  EXPECT_EQ(DepthEvidenceAt(Wall(3.0f), {30, 46.6}, kZ), DepthEvidence::kNone);
  EXPECT_EQ(DepthEvidenceAt(cv::Mat(), {30, 20}, kZ), DepthEvidence::kNone);
}

}  // namespace
}  // namespace rrslam
