#include "stages/track/data/frame.h"

#include <gtest/gtest.h>

#include <limits>
#include <memory>
#include <vector>

#include "stages/track/test_scene.h"

namespace rrslam {
namespace {

// Keypoints with depths 0 (none), 2 m and 4 m at octaves 0..2.
std::vector<Keypoint> GoodKeypoints() {
  std::vector<Keypoint> keypoints(3);
  for (int i = 0; i < 3; ++i) {
    keypoints[i].pixel = keypoints[i].undistorted = {100.0f + 10 * i, 50.0f};
    keypoints[i].octave = static_cast<uint8_t>(i);
    keypoints[i].depth = 2.0f * i;
  }
  return keypoints;
}

// A view of `keypoints` (as a map file's keypoints are), kept alive by `owner`.
RecordArray<Keypoint> ViewOf(const std::shared_ptr<const std::vector<Keypoint>>& owner) {
  return RecordArray<Keypoint>::View(owner->data(), owner->size(), owner);
}

TEST(BuildFrameFeaturesTest, ViewedKeypointsThatNeedNoFixStayAView) {
  const SensorModel sensor = testing::TestSensor();  // bf = 40.
  const auto owner = std::make_shared<const std::vector<Keypoint>>(GoodKeypoints());
  const auto features = BuildFrameFeatures(sensor, ViewOf(owner), {});
  EXPECT_TRUE(features->keypoints.is_view());
  EXPECT_EQ(features->keypoints.data(), owner->data());
  EXPECT_EQ(features->u_right, (std::vector<float>{-1.0f, 110.0f - 20.0f, 120.0f - 10.0f}));
  EXPECT_FALSE(features->HasDepth(0));
  EXPECT_TRUE(features->HasDepth(1));
}

// A depth that is not finite or negative becomes 0 (none) and an octave
// beyond the pyramid its last level: in a copy, the viewed keypoints unchanged.
TEST(BuildFrameFeaturesTest, KeypointsThatNeedAFixAreCopiedAndFixed) {
  const SensorModel sensor = testing::TestSensor();
  const int last_level = sensor.pyramid.n_levels - 1;
  for (const float depth :
       {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(), -1.0f}) {
    std::vector<Keypoint> keypoints = GoodKeypoints();
    keypoints[1].depth = depth;
    keypoints[2].octave = static_cast<uint8_t>(last_level + 1);
    const auto owner = std::make_shared<const std::vector<Keypoint>>(keypoints);
    const auto features = BuildFrameFeatures(sensor, ViewOf(owner), {});
    EXPECT_FALSE(features->keypoints.is_view());
    EXPECT_EQ(features->Depth(1), 0.0f) << depth;
    EXPECT_FALSE(features->HasDepth(1)) << depth;
    EXPECT_EQ(features->Octave(2), last_level);
    EXPECT_EQ(features->Depth(2), 4.0f);
    EXPECT_EQ(features->u_right[2], 120.0f - 10.0f);
    EXPECT_EQ((*owner)[2].octave, last_level + 1);
  }
}

}  // namespace
}  // namespace rrslam
