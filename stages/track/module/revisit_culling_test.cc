#include "stages/track/module/revisit_culling.h"

#include <gtest/gtest.h>

#include "stages/track/test_scene.h"

namespace rrslam {
namespace {

using testing::SmallMotion;
using testing::TranslationError;

// A first pass of 10 keyframes along a path (8 cm and 1.1 degrees apart) over
// a random scene, every keypoint tied to its scene point's map point, then a
// second pass: keyframes back at the poses of keyframes 1 and 2.
class RevisitCullingTest : public ::testing::Test {
 protected:
  RevisitCullingTest() {
    scene_ = testing::RandomScene(300, rng_, 2.0, 4.0);
    points_.assign(scene_.size(), nullptr);
    for (int k = 0; k < 10; ++k) Add(Pass(k));
  }

  static Rigid3d Pass(int k) { return SmallMotion(0.02 * k, 0.08 * k); }

  KeyFrame* Add(const Rigid3d& T_cam_world) {
    testing::SyntheticView view = testing::RenderView(sensor_, scene_, T_cam_world, rng_);
    KeyFrame* kf = testing::AddViewKeyFrame(sensor_, view, map_.num_created_keyframes(),
                                            T_cam_world, scene_, &map_, &points_);
    if (kf->id() > 0) kf->SetParent(keyframes_.back());
    keyframes_.push_back(kf);
    for (KeyFrame* k : keyframes_) map_.UpdateConnections(k);
    return kf;
  }

  std::mt19937 rng_{7};
  SensorModel sensor_ = testing::TestSensor();
  Vocabulary vocabulary_ = testing::HundredWordVocabulary();
  std::vector<testing::ScenePoint> scene_;
  Map map_;
  KeyFrameDatabase database_{vocabulary_};
  std::vector<KeyFrame*> keyframes_;
  std::vector<MapPoint*> points_;
};

// The second pass's keyframes stand where keyframes 1 and 2 stood and see
// what they saw: both culled, the first pass kept (its keyframes within 8 cm
// of each other are not 8 keyframes older), the map's invariants hold, and
// a frame given relative to a culled keyframe keeps its pose.
TEST_F(RevisitCullingTest, CullsTheSecondPassAndKeepsTheFirst) {
  KeyFrame* again_1 = Add(Pass(1));
  KeyFrame* again_2 = Add(Pass(2));
  const Rigid3d T_frame_world = SmallMotion(0.01, 0.02) * Pass(2);
  const Rigid3d T_frame_again_2 = T_frame_world * again_2->T_cam_world().Inverse();
  EXPECT_TRUE(OlderKeyFrameHoldsView(*again_1, {}));
  EXPECT_FALSE(OlderKeyFrameHoldsView(*keyframes_[9], {}));

  const RevisitCullingStats stats = CullRevisitKeyFrames(sensor_, 0, &map_, &database_);
  EXPECT_EQ(stats.revisits, 2u);
  EXPECT_EQ(stats.culled, 2u);
  EXPECT_TRUE(again_1->bad());
  EXPECT_TRUE(again_2->bad());
  for (int k = 0; k < 10; ++k) EXPECT_FALSE(keyframes_[k]->bad()) << k;
  EXPECT_EQ(map_.num_keyframes(), 10u);
  EXPECT_TRUE(testing::MapIsConsistent(map_));
  EXPECT_LT(TranslationError(ResolvePose(again_2, T_frame_again_2), T_frame_world), 1e-9);
}

// A keyframe at a view no older keyframe holds (30 degrees off) and one
// whose points the map does not hold (half the scene moved) stay, as does a
// keyframe that came with a loaded map (below `first_id`), and everything
// when the culling is off.
TEST_F(RevisitCullingTest, KeepsNewViewsNewPointsAndLoadedKeyFrames) {
  KeyFrame* turned = Add(SmallMotion(0.52, 0.08));
  EXPECT_FALSE(OlderKeyFrameHoldsView(*turned, {}));
  KeyFrame* again = Add(Pass(2));
  RevisitCullingOptions off;
  off.enabled = false;
  EXPECT_EQ(CullRevisitKeyFrames(sensor_, 0, &map_, &database_, off).culled, 0u);
  // As if every keyframe so far had been loaded: nothing culled.
  EXPECT_EQ(CullRevisitKeyFrames(sensor_, again->id() + 1, &map_, &database_).culled, 0u);
  EXPECT_FALSE(again->bad());

  // Keyframe 1's view again, half its points moved by 30 cm: new map points.
  for (size_t p = 0; p < scene_.size(); p += 2) {
    scene_[p].position += Eigen::Vector3d(0.3, 0, 0);
    points_[p] = nullptr;
  }
  KeyFrame* changed = Add(Pass(1));
  EXPECT_TRUE(OlderKeyFrameHoldsView(*changed, {}));

  const RevisitCullingStats stats = CullRevisitKeyFrames(sensor_, 0, &map_, &database_);
  EXPECT_EQ(stats.revisits, 2u);
  EXPECT_EQ(stats.culled, 1u);
  EXPECT_TRUE(again->bad());
  EXPECT_FALSE(turned->bad());
  EXPECT_FALSE(changed->bad());
  EXPECT_TRUE(testing::MapIsConsistent(map_));
}

TEST(RevisitCullingOptionsTest, OutOfRangeIsNamed) {
  std::string why;
  EXPECT_TRUE(RevisitCullingOptions{}.Check(&why));
  RevisitCullingOptions o;
  o.max_distance = -1;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_EQ(why, "revisit_distance = -1.000000; must be >= 0 (metres)");
  o = {};
  o.max_angle_deg = 200;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_EQ(why, "revisit_angle = 200.000000; must be in [0, 180] (degrees)");
}

}  // namespace
}  // namespace rrslam
