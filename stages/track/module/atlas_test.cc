#include "stages/track/module/atlas.h"

#include <gtest/gtest.h>

#include <limits>
#include <random>
#include <string>
#include <vector>

#include "stages/track/test_scene.h"

namespace rrslam {
namespace {

using testing::MakeFrame;
using testing::RandomScene;
using testing::RenderView;
using testing::ScenePoint;
using testing::SmallMotion;
using testing::TestSensor;
using testing::TranslationError;
using testing::ViewOptions;

// A synthetic map split in two: the loaded map A (world frame = the true
// one) and a new map B of the same place in a world frame of its own,
// `T_b_true` away (B's keyframes and points are where B's tracking would
// have put them). Random scenes of 300 points with descriptors, the test
// vocabulary of 100 words.
class AtlasTest : public ::testing::Test {
 protected:
  // A keyframe of `map` rendered from T_cam_true over `scene`, placed in a
  // world frame T_world_true, with a new map point per keypoint; 0.3 px of
  // pixel noise, exact depth, 4 bits flipped per descriptor; BoW computed.
  KeyFrame* AddKeyFrame(Map* map, const std::vector<ScenePoint>& scene, const Rigid3d& T_cam_true,
                        const Rigid3d& T_world_true) {
    ViewOptions options;
    options.pixel_noise = 0.3;
    options.flipped_bits = 4;
    const testing::SyntheticView view = RenderView(sensor_, scene, T_cam_true, rng_, options);
    KeyFrame* kf = map->CreateKeyFrame(MakeFrame(sensor_, view, map->num_created_keyframes(),
                                                 T_cam_true * T_world_true.Inverse()));
    map->AddKeyFrame(kf);
    for (size_t i = 0; i < view.point_of.size(); ++i) {
      MapPoint* point = map->CreateMapPoint(T_world_true * scene[view.point_of[i]].position, kf);
      map->AddMapPoint(point);
      map->AddObservation(point, kf, static_cast<uint32_t>(i));
      point->ComputeDistinctiveDescriptor();
      point->UpdateNormalAndDepth(sensor_.pyramid);
    }
    map->UpdateConnections(kf);
    kf->ComputeBow(vocabulary_, FeatureVectorLevelsUp(vocabulary_.levels(), false));
    return kf;
  }

  // Map A (two keyframes over scene_) loaded in map_, then set aside.
  void LoadAndSetAside() {
    AddKeyFrame(&map_, scene_, Rigid3d::Identity(), Rigid3d::Identity());
    AddKeyFrame(&map_, scene_, SmallMotion(0.03, 0.1), Rigid3d::Identity());
    database_.AddAll(map_.KeyFrames());
    atlas_.SetLoadedMapAside(&map_, &database_);
  }

  std::mt19937 rng_{5};
  SensorModel sensor_ = TestSensor();
  Vocabulary vocabulary_ = testing::HundredWordVocabulary();
  Map map_;
  KeyFrameDatabase database_{vocabulary_};
  Atlas atlas_{sensor_, vocabulary_};
  std::vector<ScenePoint> scene_ = RandomScene(300, rng_, 2.0, 4.0);
  // B's world frame: 40 degrees and 1.3 m from the true one.
  const Rigid3d T_b_true_{ExpSO3(Eigen::Vector3d(0.1, 0.7, -0.05)),
                          Eigen::Vector3d(1.0, -0.3, 0.8)};
};

TEST_F(AtlasTest, TheLoadedMapIsSetAsideAndTheNewMapsIdsFollowIt) {
  LoadAndSetAside();
  EXPECT_TRUE(atlas_.holds_loaded_map());
  EXPECT_EQ(atlas_.loaded_map().num_keyframes(), 2u);
  EXPECT_EQ(map_.num_keyframes(), 0u);
  EXPECT_EQ(database_.size(), 0u);
  KeyFrame* kf = AddKeyFrame(&map_, scene_, SmallMotion(0.02, 0.05), T_b_true_);
  EXPECT_EQ(kf->id(), 2u);
  EXPECT_EQ(map_.root(), kf);
}

TEST_F(AtlasTest, TwoAgreeingKeyFramesMergeTheNewMapIntoTheLoadedMapsFrame) {
  LoadAndSetAside();
  std::mt19937 other_rng(99);
  const std::vector<ScenePoint> elsewhere = RandomScene(300, other_rng, 2.0, 4.0);
  // B starts where A is not, then sees A's place twice.
  KeyFrame* b0 = AddKeyFrame(&map_, elsewhere, Rigid3d::Identity(), T_b_true_);
  const Rigid3d T_b1_true = SmallMotion(0.04, 0.08), T_b2_true = SmallMotion(-0.03, 0.12);
  KeyFrame* b1 = AddKeyFrame(&map_, scene_, T_b1_true, T_b_true_);
  KeyFrame* b2 = AddKeyFrame(&map_, scene_, T_b2_true, T_b_true_);
  const size_t points = map_.num_map_points() + atlas_.loaded_map().num_map_points();

  EXPECT_FALSE(atlas_.Check(b0));  // Another place: no match.
  EXPECT_FALSE(atlas_.Check(b1));  // A match, but alone.
  ASSERT_TRUE(atlas_.Check(b2));   // A second one that agrees.
  const AtlasMerge* merge = nullptr;
  {
    std::lock_guard<std::mutex> lock(map_.mutex());
    merge = atlas_.Merge(&map_, &database_);
  }
  ASSERT_NE(merge, nullptr);
  EXPECT_FALSE(atlas_.holds_loaded_map());
  EXPECT_EQ(merge->keyframes_checked, 3);
  EXPECT_EQ(merge->keyframes_matched, 2);
  // T_a_b undoes B's frame (A's world is the true one).
  EXPECT_LT(TranslationError(merge->overlap.T_a_b, T_b_true_.Inverse()), 0.01);

  // One map in A's frame: A's root, every keyframe, B's poses where they
  // truly are, B's points of A's place fused into A's.
  EXPECT_EQ(map_.root(), map_.keyframe_by_id(0));
  EXPECT_EQ(map_.num_keyframes(), 5u);
  EXPECT_EQ(database_.size(), 2u);  // A's keyframes join (B's are added by local mapping).
  EXPECT_TRUE(testing::MapIsConsistent(map_));
  EXPECT_LT(TranslationError(b1->T_cam_world(), T_b1_true), 0.01);
  EXPECT_LT(TranslationError(b2->T_cam_world(), T_b2_true), 0.01);
  EXPECT_GT(merge->weld.points_fused, 100);
  EXPECT_LT(map_.num_map_points(), points);
  // B's tree hangs from A's keyframe that matched (b0 shares no point with
  // b1 and b2: a part of its own, as the invariants allow).
  for (KeyFrame* k = b1; k != nullptr; k = k->parent()) {
    if (k->parent() == nullptr) EXPECT_EQ(k, map_.root());
  }
}

TEST_F(AtlasTest, AKeyFrameOfAnotherPlaceIsNeverMerged) {
  LoadAndSetAside();
  std::mt19937 other_rng(7);
  const std::vector<ScenePoint> elsewhere = RandomScene(300, other_rng, 2.0, 4.0);
  for (int i = 0; i < 4; ++i) {
    KeyFrame* kf = AddKeyFrame(&map_, elsewhere, SmallMotion(0.02 * i, 0.04 * i), T_b_true_);
    EXPECT_FALSE(atlas_.Check(kf));
  }
  std::lock_guard<std::mutex> lock(map_.mutex());
  EXPECT_EQ(atlas_.Merge(&map_, &database_), nullptr);
  EXPECT_TRUE(atlas_.holds_loaded_map());
}

TEST(AtlasOptions, NewMapAfterMustBeFinite) {
  AtlasOptions options;
  std::string why;
  EXPECT_TRUE(options.Check(&why));
  options.new_map_after_s = -1;  // Never: allowed.
  EXPECT_TRUE(options.Check(&why));
  options.new_map_after_s = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("new_map_after_s"), std::string::npos);
}

}  // namespace
}  // namespace rrslam
