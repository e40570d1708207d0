#include "stages/track/optimize/map_refinement.h"

#include <gtest/gtest.h>

#include "stages/track/test_scene.h"

namespace rrslam {
namespace {

using testing::TranslationError;

class MapRefinementTest : public ::testing::Test, public testing::KeyFrameChainScene {};

// Keyframes 1-4 moved by up to 3 cm and 0.6 degrees, points by 2 cm: the
// refinement brings every keyframe back to the truth within 1 mm and 0.006
// degrees and every point seen twice within 2 mm, and leaves the first
// keyframe (the gauge) where it was.
TEST_F(MapRefinementTest, MovesAPerturbedMapBackToTheTruth) {
  Perturb();
  const Rigid3d root_before = keyframes_[0]->T_cam_world();
  for (size_t k = 1; k < keyframes_.size(); ++k) {
    ASSERT_GT(TranslationError(keyframes_[k]->T_cam_world(), truth_[k]), 0.02) << k;
  }
  const MapRefinementStats stats = RefineMap(sensor_, &map_);
  EXPECT_EQ(stats.keyframes, 5);
  EXPECT_EQ(stats.points, static_cast<int>(map_.num_map_points()));
  EXPECT_GT(stats.initial_cost, 100 * stats.final_cost);
  // Converged: no pass was ended by its step cap.
  EXPECT_EQ(stats.solves.solves, 2u);
  EXPECT_EQ(stats.solves.at_step_limit, 0u);
  EXPECT_EQ(keyframes_[0]->T_cam_world().translation, root_before.translation);
  for (size_t k = 1; k < keyframes_.size(); ++k) {
    EXPECT_LT(TranslationError(keyframes_[k]->T_cam_world(), truth_[k]), 1e-3) << k;
    EXPECT_LT(RotationAngle(keyframes_[k]->T_cam_world().rotation, truth_[k].rotation), 1e-4) << k;
  }
  // Points seen more than once (a single observation without depth leaves
  // the point free along its ray).
  for (size_t p = 0; p < points_.size(); ++p) {
    if (points_[p] == nullptr || points_[p]->observations().size() < 2) continue;
    EXPECT_LT((points_[p]->position_world() - scene_[p].position).norm(), 2e-3) << p;
  }
}

// Observations tied to the wrong map point (a false match) do not pull the
// map: the robust pass discounts them, the classification erases them from
// the map, and the keyframes still return to the truth.
TEST_F(MapRefinementTest, ErasesFalseObservationsAndIgnoresThem) {
  Perturb();
  // Keyframe 3's observations of 10 points moved to other points' keypoints.
  KeyFrame* kf = keyframes_[3];
  std::vector<std::pair<MapPoint*, uint32_t>> swapped;
  const auto& seen = kf->map_points();
  std::vector<uint32_t> indices;
  for (uint32_t i = 0; i < seen.size(); ++i) {
    if (seen[i] != nullptr) indices.push_back(i);
  }
  ASSERT_GE(indices.size(), 40u);
  for (int n = 0; n < 10; ++n) {
    const uint32_t a = indices[2 * n], b = indices[2 * n + 20];
    MapPoint* point_a = seen[a];
    MapPoint* point_b = seen[b];
    map_.EraseObservation(point_a, kf);
    map_.EraseObservation(point_b, kf);
    map_.AddObservation(point_a, kf, b);  // Point a now claims keypoint b.
    swapped.emplace_back(point_a, b);
  }
  const MapRefinementStats stats = RefineMap(sensor_, &map_);
  EXPECT_GE(stats.outliers, 10);
  for (const auto& [point, index] : swapped) {
    EXPECT_NE(point->IndexIn(kf), static_cast<int>(index)) << "false observation kept";
  }
  EXPECT_TRUE(testing::MapIsConsistent(map_));
  for (size_t k = 1; k < keyframes_.size(); ++k) {
    EXPECT_LT(TranslationError(keyframes_[k]->T_cam_world(), truth_[k]), 1e-3) << k;
  }
}

TEST_F(MapRefinementTest, AMapOfOneKeyFrameIsLeftAsItIs) {
  Map map;
  testing::SyntheticView view = testing::RenderView(sensor_, scene_, truth_[0], rng_);
  KeyFrame* kf = map.CreateKeyFrame(testing::MakeFrame(sensor_, view, 0, truth_[0]));
  map.AddKeyFrame(kf);
  const MapRefinementStats stats = RefineMap(sensor_, &map);
  EXPECT_EQ(stats.solves.solves, 0u);
  EXPECT_EQ(kf->T_cam_world().translation, truth_[0].translation);
}

}  // namespace
}  // namespace rrslam
