#include "stages/track/module/tracker.h"

#include <gtest/gtest.h>

namespace rrslam {
namespace {

// The searches and thresholds default to ORB-SLAM2's values for RGB-D
// (Tracking.cc), but for the departures the rule for defaults chose.
TEST(TrackerOptionsTest, DefaultsAreOrbSlam2RgbdValues) {
  const TrackerOptions o;
  EXPECT_EQ(o.motion_search_radius, 15.0);    // TrackWithMotionModel: th = 15 (7 is stereo).
  EXPECT_EQ(o.local_map_search_radius, 3.0);  // SearchLocalPoints: th = 3 for RGB-D (1 mono).
  EXPECT_EQ(o.local_map_search_radius_relocalized, 5.0);
  EXPECT_EQ(o.min_initial_keypoints, 500);  // StereoInitialization: N > 500.
  EXPECT_EQ(o.close_tracked, 300);          // Departure; ORB-SLAM2's NeedNewKeyFrame: < 100.
  EXPECT_EQ(o.close_untracked, 70);
  EXPECT_FALSE(o.expand_all_local_keyframes);
  EXPECT_EQ(o.bow_levels_up, 4);
  EXPECT_EQ(o.reset_max_keyframes, 5);  // Reset when lost with <= 5 keyframes.
  EXPECT_EQ(o.min_local_map_inliers, 30);
  EXPECT_EQ(o.min_local_map_inliers_relocalized, 50);
}

TEST(TrackerOptionsTest, DefaultsPassAndEachConstraintFails) {
  std::string why;
  EXPECT_TRUE(TrackerOptions{}.Check(&why)) << why;
  TrackerOptions o;
  o.close_tracked = -1;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_EQ(why, "close_tracked = -1; must be >= 0");
}

}  // namespace
}  // namespace rrslam
