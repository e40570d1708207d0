#include "stages/track/data/map.h"

#include <gtest/gtest.h>

#include <random>

#include "stages/track/test_scene.h"

namespace rrslam {
namespace {

using testing::MakeGridKeyFrame;
using testing::MakeObservedPoint;
using testing::TestSensor;

class MapTest : public ::testing::Test {
 protected:
  // Keyframes 0..n-1, 200 keypoints each, at x = 0.1 * id.
  void MakeKeyFrames(int n, float depth = 2.0f) {
    for (int k = 0; k < n; ++k) {
      keyframes_.push_back(MakeGridKeyFrame(
          &map_, sensor_, 200,
          Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.1 * k, 0, 0)), rng_, depth));
    }
  }
  // `count` points seen by keyframes a and b (next unused keypoints of each).
  void Share(int a, int b, int count) {
    for (int i = 0; i < count; ++i) {
      MakeObservedPoint(&map_, {keyframes_[a], keyframes_[b]}, {next_[a]++, next_[b]++});
    }
  }

  // The map's invariants hold (Map::CheckInvariants); else the violated one.
  ::testing::AssertionResult Consistent() const {
    std::string why;
    if (map_.CheckInvariants(&why)) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << why;
  }
  // The first violated invariant ("" when none).
  std::string Violation() const {
    std::string why;
    return map_.CheckInvariants(&why) ? "" : why;
  }

  std::mt19937 rng_{1};
  SensorModel sensor_ = TestSensor();
  Map map_;
  std::vector<KeyFrame*> keyframes_;
  std::map<int, uint32_t> next_;
};

TEST_F(MapTest, CovisibilityEdgesNeedFifteenSharedPointsOrAreTheBestOne) {
  MakeKeyFrames(4);
  Share(0, 1, 20);
  Share(1, 2, 16);
  Share(2, 3, 5);
  Share(0, 3, 3);
  for (KeyFrame* kf : keyframes_) map_.UpdateConnections(kf);
  KeyFrame *k0 = keyframes_[0], *k1 = keyframes_[1], *k2 = keyframes_[2], *k3 = keyframes_[3];

  EXPECT_EQ(k0->covisible(), (std::vector<KeyFrame*>{k1}));
  EXPECT_EQ(k1->covisible(), (std::vector<KeyFrame*>{k0, k2}));
  EXPECT_EQ(k1->Weight(k0), 20);
  EXPECT_EQ(k0->Weight(k1), 20);
  EXPECT_EQ(k1->Weight(k2), 16);
  // Keyframe 3 shares fewer than 15 with anyone: connected to its best (2).
  EXPECT_EQ(k3->covisible(), (std::vector<KeyFrame*>{k2}));
  EXPECT_EQ(k2->covisible(), (std::vector<KeyFrame*>{k1, k3}));
  EXPECT_EQ(k2->Weight(k3), 5);
  EXPECT_EQ(k0->Weight(k3), 0);
  EXPECT_EQ(k1->BestCovisible(1), (std::vector<KeyFrame*>{k0}));
  EXPECT_EQ(k1->CovisibleWithWeight(17), (std::vector<KeyFrame*>{k0}));
  // Spanning tree: the first connection's best neighbour is the parent.
  EXPECT_EQ(k0->parent(), nullptr);
  EXPECT_EQ(k1->parent(), k0);
  EXPECT_EQ(k2->parent(), k1);
  EXPECT_EQ(k3->parent(), k2);
  EXPECT_EQ(k0->children(), (std::vector<KeyFrame*>{k1}));
  EXPECT_EQ(k2->children(), (std::vector<KeyFrame*>{k3}));
}

TEST_F(MapTest, EqualWeightsAreOrderedById) {
  MakeKeyFrames(4);
  Share(3, 2, 15);
  Share(3, 0, 15);
  Share(3, 1, 15);
  map_.UpdateConnections(keyframes_[3]);
  EXPECT_EQ(keyframes_[3]->covisible(),
            (std::vector<KeyFrame*>{keyframes_[0], keyframes_[1], keyframes_[2]}));
  EXPECT_EQ(keyframes_[3]->parent(), keyframes_[0]);
}

TEST_F(MapTest, UpdatingConnectionsDropsWeakenedEdgesOnBothSides) {
  MakeKeyFrames(3);
  Share(0, 1, 20);
  Share(1, 2, 16);
  for (KeyFrame* kf : keyframes_) map_.UpdateConnections(kf);
  // Keyframe 1 loses 10 of its points shared with keyframe 0.
  for (uint32_t i = 0; i < 10; ++i) {
    map_.EraseObservation(keyframes_[1]->map_point(i), keyframes_[1]);
  }
  map_.UpdateConnections(keyframes_[1]);
  EXPECT_EQ(keyframes_[1]->covisible(), (std::vector<KeyFrame*>{keyframes_[2]}));
  EXPECT_EQ(keyframes_[0]->Weight(keyframes_[1]), 0);
  EXPECT_TRUE(keyframes_[0]->covisible().empty());
  // The spanning tree does not change with the graph.
  EXPECT_EQ(keyframes_[1]->parent(), keyframes_[0]);
  EXPECT_TRUE(Consistent());
}

TEST_F(MapTest, CullingAKeyFrameReattachesItsChildrenByCovisibility) {
  MakeKeyFrames(4);
  KeyFrame *k0 = keyframes_[0], *k1 = keyframes_[1], *k2 = keyframes_[2], *k3 = keyframes_[3];
  // Keyframes come one after the other, each connected when it arrives.
  Share(0, 1, 40);
  map_.UpdateConnections(k1);
  Share(1, 2, 50);
  Share(2, 0, 20);
  map_.UpdateConnections(k2);
  Share(1, 3, 45);
  Share(3, 0, 16);
  Share(2, 3, 30);
  map_.UpdateConnections(k3);
  ASSERT_EQ(k1->parent(), k0);
  ASSERT_EQ(k2->parent(), k1);
  ASSERT_EQ(k3->parent(), k1);
  const Rigid3d expected_T_cam_parent = k1->T_cam_world() * k0->T_world_cam();

  EXPECT_FALSE(map_.CullKeyFrame(k0));  // The root stays.
  ASSERT_TRUE(map_.CullKeyFrame(k1));
  EXPECT_TRUE(k1->bad());
  EXPECT_EQ(map_.num_keyframes(), 3u);
  EXPECT_EQ(map_.KeyFrames(), (std::vector<KeyFrame*>{k0, k2, k3}));
  // Keyframe 2 shares more with the candidate 0 (20) than 3 does (16): it goes
  // first under 0; then 3 goes under 2, its strongest candidate (30).
  EXPECT_EQ(k2->parent(), k0);
  EXPECT_EQ(k3->parent(), k2);
  EXPECT_EQ(k0->children(), (std::vector<KeyFrame*>{k2}));
  EXPECT_EQ(k2->children(), (std::vector<KeyFrame*>{k3}));
  // Its edges and observations are gone; its pose relative to its parent is kept.
  EXPECT_EQ(k0->Weight(k1), 0);
  EXPECT_EQ(k2->Weight(k1), 0);
  for (MapPoint* point : map_.MapPoints()) EXPECT_FALSE(point->IsObservedBy(k1));
  EXPECT_EQ(k1->parent(), k0);
  EXPECT_TRUE(k1->T_cam_parent().translation.isApprox(expected_T_cam_parent.translation));
  // Points it shared with one other keyframe lost their second observation.
  EXPECT_EQ(map_.num_map_points(), static_cast<size_t>(20 + 16 + 30));
  EXPECT_TRUE(Consistent());
}

TEST_F(MapTest, PointsWithTooFewObservationsAreCulled) {
  MakeKeyFrames(3);
  MakeKeyFrames(2, /*depth=*/0.0f);  // Keyframes 3, 4 without depth.
  KeyFrame *k0 = keyframes_[0], *k1 = keyframes_[1], *k2 = keyframes_[2], *k3 = keyframes_[3],
           *k4 = keyframes_[4];
  MapPoint* mono = MakeObservedPoint(&map_, {k3, k4}, {0, 0});
  EXPECT_EQ(mono->num_observations(), 2);
  map_.EraseObservation(mono, k3);
  EXPECT_TRUE(mono->bad());
  EXPECT_EQ(k4->map_point(0), nullptr);

  MapPoint* pair = MakeObservedPoint(&map_, {k0, k1}, {0, 0});
  EXPECT_EQ(pair->num_observations(), 4);
  map_.EraseObservation(pair, k0);
  EXPECT_TRUE(pair->bad());  // One observation with depth left: weight 2.

  MapPoint* triple = MakeObservedPoint(&map_, {k0, k1, k2}, {1, 1, 1});
  map_.EraseObservation(triple, k0);
  EXPECT_FALSE(triple->bad());
  EXPECT_EQ(triple->num_observations(), 4);
  EXPECT_EQ(triple->reference_keyframe(), k1);  // The reference moved on.
  EXPECT_EQ(k0->map_point(1), nullptr);
  EXPECT_EQ(map_.num_map_points(), 1u);
  EXPECT_TRUE(Consistent());
}

TEST_F(MapTest, ReplacingAPointMovesItsObservations) {
  MakeKeyFrames(3);
  MapPoint* a = MakeObservedPoint(&map_, {keyframes_[0], keyframes_[1]}, {5, 6});
  MapPoint* b = MakeObservedPoint(&map_, {keyframes_[1], keyframes_[2]}, {7, 8});
  a->IncreaseVisible(4);
  a->IncreaseFound(2);
  map_.ReplaceMapPoint(a, b);
  EXPECT_TRUE(a->bad());
  EXPECT_EQ(a->replaced_by(), b);
  EXPECT_EQ(keyframes_[0]->map_point(5), b);
  EXPECT_EQ(keyframes_[1]->map_point(6), nullptr);  // Keyframe 1 already saw b.
  EXPECT_EQ(keyframes_[1]->map_point(7), b);
  EXPECT_EQ(b->IndexIn(keyframes_[0]), 5);
  EXPECT_EQ(b->observations().size(), 3u);
  EXPECT_EQ(b->visible(), 1 + 5);
  EXPECT_EQ(b->found(), 1 + 3);
  EXPECT_EQ(map_.MapPoints(), (std::vector<MapPoint*>{b}));
  EXPECT_TRUE(Consistent());
}

TEST_F(MapTest, RepresentativeDescriptorHasTheLeastMedianDistance) {
  MakeKeyFrames(3);
  MapPoint* point = MakeObservedPoint(&map_, keyframes_, {0, 0, 0});
  // Distances: d0-d1 2, d0-d2 40, d1-d2 42 (or 38): medians 2, 2, 40; the
  // tie goes to the lowest keyframe id.
  const OrbDescriptor d0 = keyframes_[0]->features().descriptors[0];
  std::mt19937 rng(4);
  const OrbDescriptor d1 = testing::FlipBits(d0, 2, rng);
  const OrbDescriptor d2 = testing::FlipBits(d0, 40, rng);
  auto set_descriptor = [&](int k, const OrbDescriptor& d) {
    const_cast<FrameFeatures&>(keyframes_[k]->features()).descriptors[0] = d;
  };
  set_descriptor(1, d1);
  set_descriptor(2, d2);
  point->ComputeDistinctiveDescriptor();
  EXPECT_EQ(point->descriptor(), d0);
  // A far one and two close ones: the first close one wins.
  set_descriptor(0, testing::FlipBits(d1, 60, rng));
  set_descriptor(2, testing::FlipBits(d1, 1, rng));
  point->ComputeDistinctiveDescriptor();
  EXPECT_EQ(point->descriptor(), d1);
}

TEST_F(MapTest, NormalAndScaleDistancesFollowTheObservations) {
  // A point 2 m in front of keyframe 0 (at the origin) and seen by keyframe 2
  // (at x = 0.2), observed on octave 2 by its reference keyframe 0.
  keyframes_.push_back(MakeGridKeyFrame(&map_, sensor_, 10, Rigid3d::Identity(), rng_, 2.0f, 2));
  keyframes_.push_back(
      MakeGridKeyFrame(&map_, sensor_, 10,
                       Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.2, 0, 0)), rng_));
  const Eigen::Vector3d position(0, 0, 2);
  MapPoint* point = MakeObservedPoint(&map_, keyframes_, {0, 0}, position);
  point->UpdateNormalAndDepth(sensor_.pyramid);
  const Eigen::Vector3d expected =
      (position.normalized() + (position - Eigen::Vector3d(0.2, 0, 0)).normalized()) / 2;
  EXPECT_TRUE(point->normal().isApprox(expected, 1e-12));
  EXPECT_NEAR(point->max_distance(), 2.0 * 1.44, 1e-12);
  EXPECT_NEAR(point->min_distance(), 2.0 * 1.44 / std::pow(1.2, 7), 1e-12);
  // Seen from the distance it was measured at, on octave 2.
  EXPECT_EQ(point->PredictScale(sensor_, 2.01), 2);
  EXPECT_EQ(point->PredictScale(sensor_, 2.4), 1);
  EXPECT_EQ(point->PredictScale(sensor_, 2.0 * 1.44), 0);
  EXPECT_EQ(point->PredictScale(sensor_, 0.1), 7);
}

}  // namespace
TEST_F(MapTest, ClearDiscardsEverythingAndTheNextKeyFrameIsTheRoot) {
  MakeKeyFrames(3);
  Share(0, 1, 20);
  Share(1, 2, 20);
  ASSERT_EQ(map_.num_map_points(), 40u);
  const std::vector<MapPoint*> points = map_.MapPoints();
  map_.Clear();
  EXPECT_EQ(map_.num_keyframes(), 0u);
  EXPECT_EQ(map_.num_map_points(), 0u);
  EXPECT_TRUE(map_.KeyFrames().empty());
  EXPECT_EQ(map_.root(), nullptr);
  for (KeyFrame* kf : keyframes_) EXPECT_TRUE(kf->bad());
  for (MapPoint* p : points) EXPECT_TRUE(p->bad());
  EXPECT_EQ(keyframes_[1]->map_point(0), nullptr);
  EXPECT_TRUE(Consistent());
  MakeKeyFrames(1);
  EXPECT_EQ(map_.root(), keyframes_.back());
  EXPECT_EQ(map_.num_keyframes(), 1u);
  EXPECT_TRUE(Consistent());
}

TEST_F(MapTest, ObjectsMovedAsideKeepTheirIdsAndNewOnesFollowThem) {
  MakeKeyFrames(3);
  Share(0, 1, 20);
  Share(1, 2, 20);
  const std::vector<MapPoint*> points = map_.MapPoints();
  Map aside;
  map_.MoveObjectsTo(&aside);
  EXPECT_EQ(map_.num_keyframes(), 0u);
  EXPECT_EQ(map_.num_map_points(), 0u);
  EXPECT_EQ(map_.root(), nullptr);
  EXPECT_EQ(map_.num_created_keyframes(), 3u);  // Ids stay reserved.
  EXPECT_EQ(map_.keyframe_by_id(1), nullptr);
  EXPECT_EQ(aside.num_keyframes(), 3u);
  EXPECT_EQ(aside.num_map_points(), 40u);
  EXPECT_EQ(aside.root(), keyframes_[0]);
  EXPECT_EQ(aside.keyframe_by_id(2), keyframes_[2]);
  for (const MapPoint* p : points) EXPECT_FALSE(p->bad());  // Moved, not discarded.
  EXPECT_TRUE(testing::MapIsConsistent(aside));
  EXPECT_TRUE(Consistent());
  // A new map grows after the reserved ids.
  MakeKeyFrames(1);
  EXPECT_EQ(keyframes_.back()->id(), 3u);
  EXPECT_EQ(map_.root(), keyframes_.back());
  EXPECT_THROW(map_.MoveObjectsTo(&aside), std::invalid_argument);  // aside has objects.
}

TEST_F(MapTest, AbsorbingTakesEveryObjectAndTheOtherMapsRoot) {
  MakeKeyFrames(2);
  Share(0, 1, 20);
  Map loaded;
  map_.MoveObjectsTo(&loaded);
  MakeKeyFrames(2);  // Ids 2 and 3: the new map.
  Share(2, 3, 20);
  map_.Absorb(&loaded);
  EXPECT_EQ(map_.num_keyframes(), 4u);
  EXPECT_EQ(map_.num_map_points(), 40u);
  EXPECT_EQ(map_.root(), keyframes_[0]);  // The loaded map's world.
  EXPECT_EQ(map_.keyframe_by_id(1), keyframes_[1]);
  EXPECT_EQ(loaded.num_keyframes(), 0u);
  EXPECT_EQ(loaded.num_created_keyframes(), 0u);
  // Two parts: the new map's root (2) has no parent yet, which the
  // invariants allow (a part made without neighbours).
  EXPECT_TRUE(Consistent()) << Violation();

  Map clash;
  testing::MakeGridKeyFrame(&clash, sensor_, 10, Rigid3d::Identity(), rng_);  // Id 0: taken.
  EXPECT_THROW(map_.Absorb(&clash), std::invalid_argument);
  EXPECT_EQ(clash.num_created_keyframes(), 1u);  // Nothing moved.
  EXPECT_EQ(map_.num_keyframes(), 4u);
}

// Keyframes 0 <- 1 <- 2 in the spanning tree, each sharing 20 points with
// the one before.
class CullingProtectionTest : public MapTest {
 protected:
  void SetUp() override {
    MakeKeyFrames(3);
    Share(0, 1, 20);
    map_.UpdateConnections(keyframes_[1]);
    Share(1, 2, 20);
    map_.UpdateConnections(keyframes_[2]);
    ASSERT_EQ(keyframes_[2]->parent(), keyframes_[1]);
  }
};

TEST_F(CullingProtectionTest, AKeyFrameInUseIsCulledWhenReleased) {
  KeyFrame *k0 = keyframes_[0], *k1 = keyframes_[1], *k2 = keyframes_[2];
  k1->set_in_use(true);
  EXPECT_FALSE(map_.CullKeyFrame(k1));
  EXPECT_TRUE(k1->cull_pending());
  EXPECT_FALSE(k1->bad());
  EXPECT_EQ(map_.KeyFrames(), (std::vector<KeyFrame*>{k0, k1, k2}));
  EXPECT_EQ(k1->Weight(k2), 20);  // Untouched.
  EXPECT_EQ(k2->parent(), k1);

  EXPECT_TRUE(map_.ReleaseKeyFrame(k1));
  EXPECT_TRUE(k1->bad());
  EXPECT_FALSE(k1->in_use());
  EXPECT_FALSE(k1->cull_pending());
  EXPECT_EQ(map_.KeyFrames(), (std::vector<KeyFrame*>{k0, k2}));
  EXPECT_EQ(k2->parent(), k0);
  EXPECT_EQ(k2->Weight(k1), 0);
  EXPECT_TRUE(Consistent());
}

TEST_F(CullingProtectionTest, AKeyFrameWithALoopEdgeIsNeverCulled) {
  KeyFrame *k0 = keyframes_[0], *k1 = keyframes_[1], *k2 = keyframes_[2];
  k2->AddLoopEdge(k0);
  k0->AddLoopEdge(k2);
  EXPECT_EQ(k2->loop_edges(), (std::vector<KeyFrame*>{k0}));
  EXPECT_FALSE(map_.CullKeyFrame(k2));
  EXPECT_FALSE(k2->bad());
  // Not even after loop closing used and released it.
  k2->set_in_use(true);
  EXPECT_FALSE(map_.CullKeyFrame(k2));
  EXPECT_FALSE(map_.ReleaseKeyFrame(k2));
  EXPECT_FALSE(k2->bad());
  EXPECT_EQ(map_.KeyFrames(), (std::vector<KeyFrame*>{k0, k1, k2}));
  EXPECT_EQ(k1->Weight(k2), 20);
  // A keyframe without loop edges is culled as usual.
  EXPECT_TRUE(map_.CullKeyFrame(k1));
  EXPECT_TRUE(Consistent());
}

// Each invariant, broken behind Map's back, is reported by name.
TEST_F(CullingProtectionTest, EachBrokenInvariantIsReported) {
  KeyFrame *k0 = keyframes_[0], *k1 = keyframes_[1], *k2 = keyframes_[2];
  ASSERT_TRUE(Consistent());
  MapPoint* p = k1->map_point(0);  // Shared by keyframes 0 and 1.
  ASSERT_NE(p, nullptr);
  const uint32_t index = static_cast<uint32_t>(p->IndexIn(k0));
  // An observation one way only.
  k0->SetMapPoint(index, nullptr);
  EXPECT_EQ(Violation(), "map point " + std::to_string(p->id()) + ": observation by keyframe 0: " +
                             "its keypoint " + std::to_string(index) + " does not point back");
  k0->SetMapPoint(index, p);
  k2->SetMapPoint(199, p);
  EXPECT_EQ(Violation(),
            "keyframe 2 keypoint 199: map point " + std::to_string(p->id()) + " does not list it");
  k2->SetMapPoint(199, nullptr);
  // A culled point still referenced by a keyframe.
  map_.CullMapPoint(p);
  ASSERT_TRUE(Consistent());
  k0->SetMapPoint(index, p);
  EXPECT_EQ(Violation(), "keyframe 0 keypoint " + std::to_string(index) + ": map point " +
                             std::to_string(p->id()) + " is not in the map (culled or replaced)");
  k0->SetMapPoint(index, nullptr);
  // In the map but marked bad behind its back.
  MapPoint* q = k1->map_point(1);
  q->MarkBad(nullptr);
  EXPECT_EQ(Violation(), "map point " + std::to_string(q->id()) + " is in the map but bad");
}

TEST_F(CullingProtectionTest, BrokenEdgesAndTreeAreReported) {
  KeyFrame *k0 = keyframes_[0], *k1 = keyframes_[1], *k2 = keyframes_[2];
  // A covisibility weight that differs between the two ends.
  k2->SetConnection(k1, 7);
  EXPECT_EQ(Violation(), "keyframe 1: covisibility edge to keyframe 2: weight 20 here, 7 there");
  k2->SetConnection(k1, 20);
  ASSERT_TRUE(Consistent());
  // A one-way loop edge.
  k2->AddLoopEdge(k0);
  EXPECT_EQ(Violation(), "keyframe 2: loop edge to keyframe 0: one-way");
  k0->AddLoopEdge(k2);
  ASSERT_TRUE(Consistent());
  // A cycle in the spanning tree: 1's parent becomes 2, whose parent is 1.
  k0->RemoveChild(k1);
  k1->SetParent(k2);
  EXPECT_NE(Violation().find("its parents form a cycle"), std::string::npos) << Violation();
}

TEST_F(MapTest, BrokenCountsAndPointsAreReported) {
  MakeKeyFrames(2);
  Share(0, 1, 20);
  map_.UpdateConnections(keyframes_[1]);
  ASSERT_TRUE(Consistent());
  // A point without observations.
  MapPoint* lonely = map_.CreateMapPoint(Eigen::Vector3d(0, 0, 2), keyframes_[0]);
  map_.AddMapPoint(lonely);
  EXPECT_EQ(Violation(), "map point 20 has no observation");
  map_.CullMapPoint(lonely);
  ASSERT_TRUE(Consistent());
  // A keyframe in the map marked bad behind the map's back.
  keyframes_[1]->MarkBad(Rigid3d::Identity());
  EXPECT_EQ(Violation(), "keyframe 1 is in the map but bad");
}

TEST_F(CullingProtectionTest, ReleasingWithoutAPendingCullKeepsTheKeyFrame) {
  KeyFrame* k1 = keyframes_[1];
  k1->set_in_use(true);
  EXPECT_FALSE(map_.ReleaseKeyFrame(k1));
  EXPECT_FALSE(k1->in_use());
  EXPECT_FALSE(k1->bad());
  EXPECT_EQ(map_.num_keyframes(), 3u);
  // Never in use either.
  EXPECT_FALSE(map_.ReleaseKeyFrame(keyframes_[2]));
  EXPECT_FALSE(keyframes_[2]->bad());
  EXPECT_EQ(map_.KeyFrames(), keyframes_);
}

}  // namespace rrslam
