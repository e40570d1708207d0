#include "stages/mapstore/floor.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "stages/mapstore/map_join.h"

namespace rrslam {
namespace {

// A room in a frame with z up (the truth), seen by cameras 1.4 m above the
// floor looking 30 degrees down; the map's world is that frame moved by an
// arbitrary rigid transform, as a first camera's frame would be.
class FloorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    T_map_true_ = Rigid3d(
        Eigen::Quaterniond(Eigen::AngleAxisd(0.9, Eigen::Vector3d(0.3, -1.0, 0.4).normalized())),
        Eigen::Vector3d(0.4, 1.1, -0.2));
    const double c = std::cos(M_PI / 6), s = std::sin(M_PI / 6);
    Eigen::Matrix3d R_true_cam;
    R_true_cam.col(0) = Eigen::Vector3d(0, -1, 0);   // Right.
    R_true_cam.col(1) = Eigen::Vector3d(-s, 0, -c);  // Down.
    R_true_cam.col(2) = Eigen::Vector3d(c, 0, -s);   // Forward.
    for (int k = 0; k < 5; ++k) {
      const Rigid3d T_true_cam(Eigen::Quaterniond(R_true_cam), Eigen::Vector3d(0, 0.2 * k, 1.4));
      KeyFrameRecord kf;
      kf.id = static_cast<uint64_t>(k);
      kf.T_cam_world = MapPoseOf((T_map_true_ * T_true_cam).Inverse());
      map_.keyframes.push_back(kf);
    }
  }
  // `n` points of the plane z = height (true frame), x in [1, 3], y in [-1, 1].
  void AddPlane(double height, int n) {
    std::uniform_real_distribution<double> u(0, 1);
    std::normal_distribution<double> noise(0, 0.003);
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d x(1 + 2 * u(rng_), -1 + 2 * u(rng_), height + noise(rng_));
      points_.push_back(T_map_true_ * x);
    }
  }
  Rigid3d T_map_true_;
  MapData map_;
  std::vector<Eigen::Vector3d> points_;
  std::mt19937 rng_{4};
};

TEST_F(FloorTest, FindsTheLowestLargePlaneNotTheLargest) {
  AddPlane(0.0, 600);    // The floor.
  AddPlane(0.75, 2000);  // A table, with more points.
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 300; ++i) {  // A wall and clutter.
    points_.push_back(T_map_true_ * Eigen::Vector3d(3.0, u(rng_), 1 + u(rng_)));
  }
  const std::optional<Floor> floor = FindFloor(map_, points_);
  ASSERT_TRUE(floor);
  const Eigen::Vector3d true_up = T_map_true_.rotation * Eigen::Vector3d::UnitZ();
  EXPECT_LT(std::acos(std::min(1.0, floor->normal.dot(true_up))) * 180 / M_PI, 0.5);
  EXPECT_NEAR(floor->camera_height, 1.4, 0.01);
  EXPECT_NEAR(floor->tilt_deg, 30, 0.5);  // The cameras look 30 degrees down.
  // The floor frame: the floor at z = 0, z up, the origin under the first camera.
  const Rigid3d T_floor_true = floor->T_floor_map * T_map_true_;
  EXPECT_NEAR((T_floor_true * Eigen::Vector3d(2, 0.5, 0)).z(), 0, 0.01);
  EXPECT_NEAR((T_floor_true * Eigen::Vector3d(2, 0.5, 1)).z(), 1, 0.01);
  const Eigen::Vector3d origin_true = T_floor_true.Inverse().translation;
  EXPECT_LT((origin_true - Eigen::Vector3d(0, 0, 0)).norm(), 0.01);
  // x along the first camera's view (true +x).
  EXPECT_GT((T_floor_true.rotation * Eigen::Vector3d::UnitX()).x(), 0.999);
}

TEST_F(FloorTest, NoPlaneBelowTheCamerasIsNoFloor) {
  AddPlane(1.6, 1000);  // A ceiling-height plane, above the cameras.
  EXPECT_FALSE(FindFloor(map_, points_));
  EXPECT_FALSE(FindFloor(map_, {}));
}

TEST_F(FloorTest, MetadataRoundTrip) {
  AddPlane(0.0, 600);
  const std::optional<Floor> floor = FindFloor(map_, points_);
  ASSERT_TRUE(floor);
  const std::optional<Rigid3d> back =
      FloorFromMetadata("{\"producer\": \"x\", \"floor\": " + FloorToJson(*floor) + "}");
  ASSERT_TRUE(back);
  EXPECT_LT((back->translation - floor->T_floor_map.translation).norm(), 1e-12);
  EXPECT_FALSE(FloorFromMetadata("{\"producer\": \"x\"}"));
  EXPECT_FALSE(FloorFromMetadata("not json"));
  EXPECT_FALSE(FloorFromMetadata("{\"floor\": {\"T_floor_map\": [1, 2]}}"));
}

}  // namespace
}  // namespace rrslam
