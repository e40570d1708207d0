#include "stages/track/module/local_mapper.h"

#include <gtest/gtest.h>

#include <random>

#include "stages/track/test_scene.h"

namespace rrslam {
namespace {

using testing::MakeGridKeyFrame;
using testing::MakeObservedPoint;
using testing::TestSensor;

class CullingTest : public ::testing::Test {
 protected:
  KeyFrame* AddKeyFrame(float depth = 2.0f, int octave = 0, int n = 40) {
    keyframes_.push_back(
        MakeGridKeyFrame(&map_, sensor_, n, Rigid3d::Identity(), rng_, depth, octave));
    return keyframes_.back();
  }

  std::mt19937 rng_{9};
  SensorModel sensor_ = TestSensor();
  Map map_;
  std::vector<KeyFrame*> keyframes_;
};

TEST_F(CullingTest, RecentPointsRarelyFoundAreCulled) {
  KeyFrame* k0 = AddKeyFrame();
  KeyFrame* k1 = AddKeyFrame();
  MapPoint* point = MakeObservedPoint(&map_, {k0, k1}, {0, 0});
  point->IncreaseVisible(9);  // Visible 10, found 1: 10 %.
  EXPECT_EQ(ClassifyRecentPoint(*point, k1->id()), RecentPointDecision::kCull);
  point->IncreaseFound(2);  // 30 %.
  EXPECT_EQ(ClassifyRecentPoint(*point, k1->id()), RecentPointDecision::kWatch);
}

// Restore mapping: a loaded point is changed when this run predicted it
// visible often, rarely found it, and its depth images saw through it from
// distinct viewpoints more often than they measured a surface there; views
// and finds before the run (StartSession) do not count.
TEST_F(CullingTest, LoadedPointIsChangedOnlyWhenSeenThroughFromDistinctViews) {
  KeyFrame* k0 = AddKeyFrame();
  KeyFrame* k1 = AddKeyFrame();
  MapPoint* point = MakeObservedPoint(&map_, {k0, k1}, {0, 0});
  point->IncreaseVisible(50);
  point->IncreaseFound(50);  // Well found in the run that made the map.
  point->StartSession();
  LocalMapperOptions options;
  options.changed_point_min_views = 20;
  options.changed_point_min_found_ratio = 0.25;
  options.changed_point_min_absent = 3;
  point->IncreaseVisible(20);
  point->IncreaseFound(4);  // 20 % of this run's views.
  EXPECT_EQ(point->SessionVisible(), 20);
  EXPECT_EQ(point->SessionFound(), 4);
  // Not found but never seen through (blurred, occluded): kept.
  EXPECT_FALSE(IsChangedPoint(*point, options));
  // Seen through 6 times from 10 cm of travel (a depth error repeats
  // there): two viewpoints, kept.
  for (int i = 0; i < 6; ++i) point->AddSeenThrough({0.02 * i, 0, 0});
  EXPECT_EQ(point->evidence().seen_through, 6);
  EXPECT_EQ(point->evidence().seen_through_views, 2);  // At 0 and 6 cm.
  EXPECT_FALSE(IsChangedPoint(*point, options));
  point->AddSeenThrough({0.2, 0, 0});  // A third viewpoint: changed.
  EXPECT_EQ(point->evidence().seen_through_views, 3);
  EXPECT_TRUE(IsChangedPoint(*point, options));
  // Frames that measured a surface at its depth outweigh the see-through ones.
  for (int i = 0; i < 3; ++i) point->AddPresent();
  EXPECT_FALSE(IsChangedPoint(*point, options));  // 7 < 3 x 3.
  for (int i = 0; i < 2; ++i) point->AddSeenThrough({0.2, 0, 0});
  EXPECT_TRUE(IsChangedPoint(*point, options));  // 9 >= 3 x 3.
  point->IncreaseFound(2);                       // 30 %.
  EXPECT_FALSE(IsChangedPoint(*point, options));
  options.changed_point_min_found_ratio = 0.5;
  EXPECT_TRUE(IsChangedPoint(*point, options));
  options.changed_point_min_views = 21;  // Too few views yet.
  EXPECT_FALSE(IsChangedPoint(*point, options));
  options.changed_point_min_views = 0;  // Off.
  EXPECT_FALSE(IsChangedPoint(*point, options));
  point->StartSession();  // A new run forgets the evidence.
  EXPECT_EQ(point->evidence().seen_through, 0);
  EXPECT_EQ(point->evidence().present, 0);
}

TEST_F(CullingTest, RecentPointsNeedMoreThanThreeObservationsAfterTwoKeyFrames) {
  KeyFrame* k0 = AddKeyFrame();
  KeyFrame* mono = AddKeyFrame(/*depth=*/0.0f);
  // Observed with depth by k0 and without by `mono`: weight 3.
  MapPoint* weak = MakeObservedPoint(&map_, {k0, mono}, {0, 0});
  ASSERT_EQ(weak->num_observations(), 3);
  // Two keyframes with depth: weight 4.
  KeyFrame* k2 = AddKeyFrame();
  MapPoint* strong = MakeObservedPoint(&map_, {k0, k2}, {1, 1});
  ASSERT_EQ(strong->num_observations(), 4);

  // One keyframe after creation: both are watched.
  EXPECT_EQ(ClassifyRecentPoint(*weak, k0->id() + 1), RecentPointDecision::kWatch);
  // Two keyframes after: the weak one is culled, the strong one still watched.
  EXPECT_EQ(ClassifyRecentPoint(*weak, k0->id() + 2), RecentPointDecision::kCull);
  EXPECT_EQ(ClassifyRecentPoint(*strong, k0->id() + 2), RecentPointDecision::kWatch);
  // Three keyframes after: the strong one is confirmed.
  EXPECT_EQ(ClassifyRecentPoint(*strong, k0->id() + 3), RecentPointDecision::kConfirm);
  // A bad point is culled (from the watch list).
  map_.CullMapPoint(strong);
  EXPECT_EQ(ClassifyRecentPoint(*strong, k0->id() + 1), RecentPointDecision::kCull);
}

TEST_F(CullingTest, KeyFrameRedundantWhenNinetyPercentOfCloseMapPointsSeenByThreeOthers) {
  KeyFrame* target = AddKeyFrame(2.0f, /*octave=*/1);
  std::vector<KeyFrame*> others = {AddKeyFrame(2.0f, 0), AddKeyFrame(2.0f, 1),
                                   AddKeyFrame(2.0f, 2)};
  // 10 close points, all seen by the three others at octaves 0, 1, 2 (<= 1 + 1).
  for (uint32_t i = 0; i < 10; ++i) {
    MakeObservedPoint(&map_, {target, others[0], others[1], others[2]}, {i, i, i, i});
  }
  EXPECT_TRUE(IsRedundantKeyFrame(*target, sensor_));
  // 11 points, one seen by the target alone: 10 > 0.9 * 11 still.
  MakeObservedPoint(&map_, {target}, {10});
  EXPECT_TRUE(IsRedundantKeyFrame(*target, sensor_));
  // 12 points: 10 is not more than 0.9 * 12 = 10.8.
  MakeObservedPoint(&map_, {target, others[0]}, {11, 11});
  EXPECT_FALSE(IsRedundantKeyFrame(*target, sensor_));
}

TEST_F(CullingTest, KeyFrameRedundancyCountsOnlySameOrFinerScaleObservers) {
  KeyFrame* target = AddKeyFrame(2.0f, /*octave=*/0);
  // Two observers at octave 0 or 1, one at octave 2 (coarser than 0 + 1).
  std::vector<KeyFrame*> others = {AddKeyFrame(2.0f, 0), AddKeyFrame(2.0f, 1),
                                   AddKeyFrame(2.0f, 2)};
  for (uint32_t i = 0; i < 10; ++i) {
    MakeObservedPoint(&map_, {target, others[0], others[1], others[2]}, {i, i, i, i});
  }
  EXPECT_FALSE(IsRedundantKeyFrame(*target, sensor_));
  // A fourth observer at octave 0 makes three that count.
  KeyFrame* fourth = AddKeyFrame(2.0f, 0);
  for (uint32_t i = 0; i < 10; ++i) map_.AddObservation(target->map_point(i), fourth, i);
  EXPECT_TRUE(IsRedundantKeyFrame(*target, sensor_));
}

TEST_F(CullingTest, KeyFrameRedundancyIgnoresFarAndDepthlessPoints) {
  // ThDepth = 40 baselines of 8 cm = 3.2 m. The target's keypoints are far.
  KeyFrame* far = AddKeyFrame(5.0f);
  std::vector<KeyFrame*> others = {AddKeyFrame(), AddKeyFrame(), AddKeyFrame()};
  for (uint32_t i = 0; i < 10; ++i) {
    MakeObservedPoint(&map_, {far, others[0], others[1], others[2]}, {i, i, i, i});
  }
  // No close point at all: nothing to be redundant with.
  EXPECT_FALSE(IsRedundantKeyFrame(*far, sensor_));
  KeyFrame* no_depth = AddKeyFrame(0.0f);
  for (uint32_t i = 0; i < 10; ++i) map_.AddObservation(far->map_point(i), no_depth, 20 + i);
  EXPECT_FALSE(IsRedundantKeyFrame(*no_depth, sensor_));
}

TEST_F(CullingTest, AFrequentlyFoundPointSurvivesTooFewObserversOnlyWithMinFound) {
  KeyFrame* k0 = AddKeyFrame();
  MapPoint* point = MakeObservedPoint(&map_, {k0}, {0});  // One keyframe with depth: weight 2.
  point->IncreaseVisible(11);
  point->IncreaseFound(8);  // Found 9 of 12.
  EXPECT_EQ(ClassifyRecentPoint(*point, k0->id() + 1, 10), RecentPointDecision::kWatch);
  EXPECT_EQ(ClassifyRecentPoint(*point, k0->id() + 2, 10), RecentPointDecision::kCull);
  point->IncreaseFound(1);  // 10 of 12.
  EXPECT_EQ(ClassifyRecentPoint(*point, k0->id() + 2, 10), RecentPointDecision::kConfirm);
  EXPECT_EQ(ClassifyRecentPoint(*point, k0->id() + 2), RecentPointDecision::kCull);  // ORB-SLAM2.
  point->IncreaseVisible(40);  // 10 of 52: rarely found, culled whatever the count.
  EXPECT_EQ(ClassifyRecentPoint(*point, k0->id() + 2, 10), RecentPointDecision::kCull);
}

// Restore mapping (from WatchLoadedPoints until Reset) keeps a new point
// that tracking found often though no second keyframe observes it (a new
// object, where keyframes are made only where the loaded map lacks the
// view); a new map culls it as ORB-SLAM2 does.
TEST_F(CullingTest, RestoreMappingKeepsNewPointsThatTrackingFinds) {
  const Vocabulary vocabulary = testing::HundredWordVocabulary();
  KeyFrameDatabase database(vocabulary);
  LocalMapperOptions options;
  options.restore_point_min_found = 10;
  LocalMapper mapper(sensor_, vocabulary, &map_, &database, options);
  AddKeyFrame();
  // A keyframe the tracker made with two new points, found in 10 and 9 frames.
  auto new_points = [&] {
    KeyFrame* kf = testing::MakeGridKeyFrame(&map_, sensor_, 40, Rigid3d::Identity(), rng_, 2.0f, 0,
                                             /*add_to_map=*/false);
    std::vector<MapPoint*> points = {MakeObservedPoint(&map_, {kf}, {0}),
                                     MakeObservedPoint(&map_, {kf}, {1})};
    for (int i = 0; i < 2; ++i) {
      points[i]->IncreaseVisible(11);
      points[i]->IncreaseFound(9 - i);
    }
    mapper.InsertKeyFrame(kf);
    AddKeyFrame();
    mapper.CullRecentPoints(AddKeyFrame());  // Two keyframes on.
    return points;
  };
  mapper.WatchLoadedPoints({});
  const std::vector<MapPoint*> restored = new_points();
  EXPECT_FALSE(restored[0]->bad());
  EXPECT_TRUE(restored[1]->bad());
  mapper.Reset();  // A new map: ORB-SLAM2's rule.
  const std::vector<MapPoint*> fresh = new_points();
  EXPECT_TRUE(fresh[0]->bad());
  EXPECT_TRUE(fresh[1]->bad());
  EXPECT_TRUE(testing::MapIsConsistent(map_));
}

TEST_F(CullingTest, MapperCullsRedundantCovisibleKeyFramesButNeverTheRoot) {
  // Root, a redundant keyframe and three others seeing everything it sees.
  KeyFrame* root = AddKeyFrame();
  KeyFrame* redundant = AddKeyFrame();
  std::vector<KeyFrame*> others = {AddKeyFrame(), AddKeyFrame(), AddKeyFrame()};
  for (uint32_t i = 0; i < 20; ++i) {
    MakeObservedPoint(&map_, {root, redundant, others[0], others[1], others[2]}, {i, i, i, i, i});
  }
  for (KeyFrame* kf : keyframes_) map_.UpdateConnections(kf);
  const Vocabulary vocabulary;  // Unused by culling.
  KeyFrameDatabase database(vocabulary);
  LocalMapper mapper(sensor_, vocabulary, &map_, &database);
  const size_t culled = mapper.CullRedundantKeyFrames(others[2]);
  // Candidates in covisibility order (equal weights: by id). `redundant` has
  // four other observers of every point; after it goes, others[0] still has
  // three (root, others[1], others[2]); then others[1] has only two left.
  EXPECT_EQ(culled, 2u);
  EXPECT_FALSE(root->bad());
  EXPECT_TRUE(redundant->bad());
  EXPECT_TRUE(others[0]->bad());
  EXPECT_FALSE(others[1]->bad());
  EXPECT_FALSE(others[2]->bad());  // The keyframe being processed is not a candidate.
  EXPECT_EQ(map_.num_keyframes(), 3u);
  EXPECT_EQ(mapper.counters().culled_keyframes, 2u);
  for (KeyFrame* kf : map_.KeyFrames()) EXPECT_NE(kf, redundant);
  EXPECT_TRUE(testing::MapIsConsistent(map_));
}

}  // namespace
}  // namespace rrslam
