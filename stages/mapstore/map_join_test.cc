#include "stages/mapstore/map_join.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "common/errors.h"
#include "stages/mapstore/map_file.h"
#include "stages/mapstore/map_test_util.h"

namespace rrslam {
namespace {

using testing::MakeTestMap;

Rigid3d TestTransform() {
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())),
                 Eigen::Vector3d(0.5, -1.0, 2.0));
}

Eigen::Vector3d Position(const MapPointRecord& p) {
  return {p.position[0], p.position[1], p.position[2]};
}

TEST(JoinMapsTest, MovesAndRenumbersTheSecondMapAndHangsItUnderTheFirst) {
  const MapData a = MakeTestMap(1), b = MakeTestMap(2);
  const Rigid3d T_a_b = TestTransform();
  const uint64_t a_kf = a.keyframes[3].id, b_kf = b.keyframes.back().id;
  const MapData j = JoinMaps(a, b, T_a_b, a_kf, b_kf, "test");
  ValidateMapData(j, "joined");  // One root (a's), every relation consistent.
  ASSERT_EQ(j.keyframes.size(), a.keyframes.size() + b.keyframes.size());
  ASSERT_EQ(j.map_points.size(), a.map_points.size() + b.map_points.size());
  EXPECT_EQ(j.next_keyframe_id, a.next_keyframe_id + b.next_keyframe_id);
  // a's records keep their ids and place.
  EXPECT_EQ(j.keyframes[0].T_cam_world, a.keyframes[0].T_cam_world);
  EXPECT_EQ(j.map_points[0].id, a.map_points[0].id);
  // b's: ids after a's, the same points seen from the same cameras.
  const size_t n = a.keyframes.size(), m = a.map_points.size();
  for (size_t i = 0; i < b.map_points.size(); ++i) {
    const MapPointRecord& moved = j.map_points[m + i];
    EXPECT_EQ(moved.id, b.map_points[i].id + a.next_map_point_id);
    EXPECT_LT((Position(moved) - T_a_b * Position(b.map_points[i])).norm(), 1e-9);
  }
  const Eigen::Vector3d x_b = Position(b.map_points[0]);
  const Eigen::Vector3d x_cam = RigidOf(b.keyframes[0].T_cam_world) * x_b;
  EXPECT_LT((RigidOf(j.keyframes[n].T_cam_world) * (T_a_b * x_b) - x_cam).norm(), 1e-9);
  // b's tree hangs from the joined keyframe, itself a child of a's.
  const KeyFrameRecord& joined = j.keyframes.back();
  EXPECT_EQ(joined.id, b_kf + a.next_keyframe_id);
  EXPECT_EQ(joined.parent, a_kf);
  for (size_t i = n; i < j.keyframes.size(); ++i) EXPECT_NE(j.keyframes[i].parent, kNoId);
  EXPECT_NE(std::find(joined.loop_edges.begin(), joined.loop_edges.end(), a_kf),
            joined.loop_edges.end());
  EXPECT_NE(
      std::find(j.keyframes[3].loop_edges.begin(), j.keyframes[3].loop_edges.end(), joined.id),
      j.keyframes[3].loop_edges.end());
}

TEST(JoinMapsTest, MapsKeptBesideEitherStayBesideTheJoinedMap) {
  MapData a = MakeTestMap(1), b = MakeTestMap(2);
  a.other_maps.push_back(MakeTestMap(3));
  b.other_maps.push_back(MakeTestMap(4));
  const size_t b_other_keyframes = b.other_maps[0].keyframes.size();
  const MapData j = JoinMaps(a, b, Rigid3d(), a.keyframes[0].id, b.keyframes[0].id, "test");
  ASSERT_EQ(j.other_maps.size(), 2u);
  EXPECT_EQ(j.other_maps[0].keyframes.size(), a.other_maps[0].keyframes.size());
  EXPECT_EQ(j.other_maps[1].keyframes.size(), b_other_keyframes);
  EXPECT_EQ(j.other_maps[1].keyframes[0].id, b.other_maps[0].keyframes[0].id);  // Not moved.
  EXPECT_NO_THROW(ValidateMapData(j, "joined"));
}

TEST(JoinMapsTest, KeyFrameNotInItsMapIsADataError) {
  const MapData a = MakeTestMap(1), b = MakeTestMap(2);
  EXPECT_THROW(JoinMaps(a, b, Rigid3d(), 999999, b.keyframes[0].id, "test"), DataError);
  EXPECT_THROW(JoinMaps(a, b, Rigid3d(), a.keyframes[0].id, 999999, "test"), DataError);
}

TEST(MapPoseTest, RoundTrip) {
  const Rigid3d T = TestTransform();
  const Rigid3d back = RigidOf(MapPoseOf(T));
  EXPECT_LT((back.translation - T.translation).norm(), 1e-12);
  EXPECT_LT(back.rotation.angularDistance(T.rotation), 1e-12);
}

}  // namespace
}  // namespace rrslam
