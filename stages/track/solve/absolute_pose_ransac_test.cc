#include "stages/track/solve/absolute_pose_ransac.h"

#include <gtest/gtest.h>

#include <random>

#include "stages/track/test_scene.h"

namespace rrslam {
namespace {

using testing::RandomScene;
using testing::SmallMotion;
using testing::TestSensor;
using testing::TranslationError;

// Correspondences of `scene` seen from T_true with exact pixels and depths,
// every `no_depth_every`-th without depth; a fraction `outliers` of them
// tied to a wrong, random world point.
std::vector<PoseCorrespondence> Correspondences(const SensorModel& sensor, const Rigid3d& T_true,
                                                int n, double outliers, int no_depth_every,
                                                std::mt19937& rng,
                                                std::vector<uint8_t>* is_outlier) {
  const std::vector<testing::ScenePoint> scene = RandomScene(n, rng, 2.0, 4.0);
  const std::vector<testing::ScenePoint> wrong = RandomScene(n, rng, 2.0, 4.0);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<PoseCorrespondence> matches;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d pc = T_true * scene[i].position;
    PoseCorrespondence m;
    m.pixel = sensor.Project(pc);
    if (no_depth_every == 0 || i % no_depth_every != 0) {
      m.depth = pc.z();
      m.u_right = m.pixel.x() - sensor.bf / pc.z();
    }
    const bool out = u(rng) < outliers;
    m.point_world = out ? wrong[i].position : scene[i].position;
    matches.push_back(m);
    is_outlier->push_back(out);
  }
  return matches;
}

TEST(AbsolutePoseRansacTest, RecoversAKnownPoseWithSixtyPercentOutliers) {
  std::mt19937 rng(8);
  const SensorModel sensor = TestSensor();
  const Rigid3d T_true = SmallMotion(0.4, 0.7);
  std::vector<uint8_t> is_outlier;
  const std::vector<PoseCorrespondence> matches =
      Correspondences(sensor, T_true, 300, 0.6, 4, rng, &is_outlier);
  const AbsolutePoseResult r = SolveAbsolutePoseRansac(matches, sensor, {}, 1);
  ASSERT_TRUE(r.ok);
  EXPECT_LT(TranslationError(r.T_cam_world, T_true), 1e-6);
  EXPECT_LT(RotationAngle(r.T_cam_world.rotation, T_true.rotation), 1e-6);
  int wrong_labels = 0;
  for (size_t i = 0; i < matches.size(); ++i) wrong_labels += r.inlier[i] == is_outlier[i];
  // A random wrong point can fall on its keypoint's ray by chance; rarely.
  EXPECT_LE(wrong_labels, 2);
  EXPECT_LT(r.iterations, 1000);
}

TEST(AbsolutePoseRansacTest, FindsNoPoseWhereNoneExplainsTheMatches) {
  std::mt19937 rng(9);
  const SensorModel sensor = TestSensor();
  std::vector<uint8_t> is_outlier;
  const std::vector<PoseCorrespondence> matches =
      Correspondences(sensor, SmallMotion(0.1, 0.2), 300, 1.0, 0, rng, &is_outlier);
  EXPECT_FALSE(SolveAbsolutePoseRansac(matches, sensor, {}, 1).ok);
}

TEST(AbsolutePoseRansacTest, NeedsThreeCorrespondencesWithDepth) {
  std::mt19937 rng(10);
  const SensorModel sensor = TestSensor();
  std::vector<uint8_t> is_outlier;
  const std::vector<PoseCorrespondence> matches =
      Correspondences(sensor, SmallMotion(0.1, 0.2), 100, 0.0, 1, rng, &is_outlier);
  EXPECT_FALSE(SolveAbsolutePoseRansac(matches, sensor, {}, 1).ok);
  EXPECT_FALSE(SolveAbsolutePoseRansac({}, sensor, {}, 1).ok);
}

TEST(AbsolutePoseRansacTest, ScoresKeypointsWithoutDepthByTheirPixelAlone) {
  const SensorModel sensor = TestSensor();
  PoseCorrespondence m;
  m.point_world = Eigen::Vector3d(0.1, -0.2, 3.0);
  m.pixel = sensor.Project(m.point_world);
  EXPECT_TRUE(IsPoseInlier(m, sensor, Rigid3d::Identity()));
  m.pixel.x() += 3;  // 9 px^2 > 5.991 at octave 0.
  EXPECT_FALSE(IsPoseInlier(m, sensor, Rigid3d::Identity()));
  m.pixel.x() -= 3;
  m.depth = 3.0;
  m.u_right = m.pixel.x() - sensor.bf / 2.0;  // The depth of a point at 2 m.
  EXPECT_FALSE(IsPoseInlier(m, sensor, Rigid3d::Identity()));
  m.u_right = m.pixel.x() - sensor.bf / 3.0;
  EXPECT_TRUE(IsPoseInlier(m, sensor, Rigid3d::Identity()));
}

}  // namespace
}  // namespace rrslam
