#include "stages/track/run_report.h"

#include <gtest/gtest.h>

#include <random>

#include "stages/track/test_scene.h"

namespace rrslam {
namespace {

using testing::MakeGridKeyFrame;
using testing::MakeObservedPoint;
using testing::SmallMotion;
using testing::TestSensor;

TEST(SummarizeTimingsTest, MedianMeanPercentileMax) {
  std::vector<double> values;
  for (int i = 1; i <= 100; ++i) values.push_back(101 - i);  // 100 .. 1, unsorted.
  const TimingSummary s = SummarizeTimings(values);
  EXPECT_EQ(s.count, 100u);
  EXPECT_DOUBLE_EQ(s.median, 50.5);
  EXPECT_DOUBLE_EQ(s.mean, 50.5);
  EXPECT_DOUBLE_EQ(s.p95, 95);
  EXPECT_DOUBLE_EQ(s.max, 100);
  EXPECT_DOUBLE_EQ(s.total, 5050);
  const TimingSummary odd = SummarizeTimings({3, 1, 2});
  EXPECT_DOUBLE_EQ(odd.median, 2);
  EXPECT_DOUBLE_EQ(odd.p95, 3);
  EXPECT_EQ(SummarizeTimings({}).count, 0u);
  const nlohmann::json j = ToJson(odd);
  EXPECT_DOUBLE_EQ(j.at("median_ms").get<double>(), 2);
  EXPECT_DOUBLE_EQ(j.at("p95_ms").get<double>(), 3);
}

bool SamePose(const Rigid3d& a, const Rigid3d& b) {
  return (a.translation - b.translation).norm() < 1e-12 &&
         RotationAngle(a.rotation, b.rotation) < 1e-9;
}

TEST(ResolveCameraTrajectoryTest, FramesFollowTheirKeyFramesThroughCulledOnes) {
  std::mt19937 rng(1);
  const SensorModel sensor = TestSensor();
  Map map;
  // Keyframes 0 <- 1 <- 2 in the spanning tree.
  std::vector<KeyFrame*> kfs;
  for (int k = 0; k < 3; ++k) {
    kfs.push_back(MakeGridKeyFrame(&map, sensor, 60, SmallMotion(0.05 * k, 0.1 * k), rng));
  }
  for (uint32_t i = 0; i < 20; ++i) MakeObservedPoint(&map, {kfs[0], kfs[1]}, {i, i});
  for (uint32_t i = 20; i < 40; ++i) MakeObservedPoint(&map, {kfs[1], kfs[2]}, {i, i});
  for (KeyFrame* kf : kfs) map.UpdateConnections(kf);
  ASSERT_EQ(kfs[2]->parent(), kfs[1]);

  // Frame a relative to keyframe 2, frame b lost, frame c relative to 1.
  const Rigid3d T_a_2 = SmallMotion(0.01, 0.02);
  const Rigid3d T_c_1 = SmallMotion(-0.02, 0.03);
  std::vector<TrackedFrame> records(3);
  records[0] = {0, 10.0, true, kfs[2], T_a_2};
  records[1] = {1, 10.1, false, nullptr, Rigid3d()};
  records[2] = {2, 10.2, true, kfs[1], T_c_1};

  // Keyframe 1 moves (as after bundle adjustment), then keyframe 2 is culled
  // and then keyframe 1 is too: frames resolve through the recorded relative
  // poses to the root.
  kfs[1]->SetPose(SmallMotion(0.06, 0.12));
  const Rigid3d T_a_world = T_a_2 * kfs[2]->T_cam_world();
  const Rigid3d T_c_world = T_c_1 * kfs[1]->T_cam_world();
  for (uint32_t i = 20; i < 40; ++i) MakeObservedPoint(&map, {kfs[0], kfs[2]}, {i, 40 + i - 20});
  map.UpdateConnections(kfs[2]);
  ASSERT_TRUE(map.CullKeyFrame(kfs[2]));
  ASSERT_TRUE(map.CullKeyFrame(kfs[1]));

  const Trajectory t = ResolveCameraTrajectory(records);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].timestamp, 10.0);
  EXPECT_EQ(t[1].timestamp, 10.2);
  EXPECT_TRUE(SamePose(t[0].T_world_cam, T_a_world.Inverse()));
  EXPECT_TRUE(SamePose(t[1].T_world_cam, T_c_world.Inverse()));

  // The keyframe trajectory holds the keyframes left in the map.
  const Trajectory k = KeyFrameTrajectory(map);
  ASSERT_EQ(k.size(), 1u);
  EXPECT_TRUE(SamePose(k[0].T_world_cam, kfs[0]->T_world_cam()));
}

}  // namespace
}  // namespace rrslam
