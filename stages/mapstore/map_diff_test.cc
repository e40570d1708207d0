#include "stages/mapstore/map_diff.h"

#include <gtest/gtest.h>

#include <stdexcept>

#include "stages/mapstore/map_file.h"
#include "stages/mapstore/map_test_util.h"

namespace rrslam {
namespace {

using testing::MakeTestMap;

TEST(MapDiff, IdenticalMapsHaveNoDifference) {
  const MapData a = MakeTestMap(1);
  const MapDiff d = DiffMaps(a, a, 0.05);
  EXPECT_EQ(d.a_map_points, a.map_points.size());
  EXPECT_EQ(d.b_map_points, a.map_points.size());
  EXPECT_TRUE(d.added_points.empty());
  EXPECT_TRUE(d.removed_points.empty());
  EXPECT_TRUE(d.added_keyframes.empty());
  EXPECT_TRUE(d.removed_keyframes.empty());
}

TEST(MapDiff, KnownAddedAndRemoved) {
  const MapData a = MakeTestMap(2);
  MapData b = a;
  // Removed: three points of A. Added: four points far from every point, and
  // one point within the radius of a point of A (not added).
  const uint64_t r1 = a.map_points[3].id, r2 = a.map_points[40].id, r3 = a.map_points[99].id;
  for (uint64_t id : {r1, r2, r3}) testing::RemoveTestPoint(&b, id);
  std::vector<uint64_t> added;
  for (int i = 0; i < 4; ++i) {
    const double p[3] = {20.0 + i, -30.0, 1.0};
    added.push_back(testing::AddTestPoint(&b, p));
  }
  const double* near = a.map_points[10].position;
  const double moved[3] = {near[0] + 0.03, near[1], near[2] - 0.02};  // 0.036 m away.
  testing::AddTestPoint(&b, moved);
  const uint64_t new_kf = testing::AddTestKeyframe(&b);
  b.keyframes.erase(b.keyframes.begin() + 5);  // Removing keyframe 16 (index 5).
  const MapDiff d = DiffMaps(a, b, 0.05);
  ASSERT_EQ(d.removed_points.size(), 3u);
  EXPECT_EQ(d.removed_points[0].id, r1);
  EXPECT_EQ(d.removed_points[1].id, r2);
  EXPECT_EQ(d.removed_points[2].id, r3);
  EXPECT_EQ(d.removed_points[1].position[2], a.map_points[40].position[2]);
  ASSERT_EQ(d.added_points.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(d.added_points[i].id, added[i]);
    EXPECT_EQ(d.added_points[i].position[0], 20.0 + i);
  }
  EXPECT_EQ(d.added_keyframes, std::vector<uint64_t>{new_kf});
  EXPECT_EQ(d.removed_keyframes, std::vector<uint64_t>{16});
  // A radius below 0.036 m: the nearby point counts as added too.
  const MapDiff tight = DiffMaps(a, b, 0.02);
  EXPECT_EQ(tight.added_points.size(), 5u);
  EXPECT_EQ(tight.removed_points.size(), 3u);
}

TEST(MapDiff, EmptyMaps) {
  const MapData a = MakeTestMap(3);
  const MapData empty;
  const MapDiff added = DiffMaps(empty, a, 0.05);
  EXPECT_EQ(added.added_points.size(), a.map_points.size());
  EXPECT_TRUE(added.removed_points.empty());
  EXPECT_EQ(added.added_keyframes.size(), a.keyframes.size());
  const MapDiff removed = DiffMaps(a, empty, 0.05);
  EXPECT_EQ(removed.removed_points.size(), a.map_points.size());
  EXPECT_EQ(removed.removed_keyframes.size(), a.keyframes.size());
  EXPECT_TRUE(DiffMaps(empty, empty, 1).added_points.empty());
}

TEST(MapDiff, RejectsBadRadius) {
  const MapData a;
  EXPECT_THROW(DiffMaps(a, a, 0), std::invalid_argument);
  EXPECT_THROW(DiffMaps(a, a, -1), std::invalid_argument);
}

}  // namespace
}  // namespace rrslam
