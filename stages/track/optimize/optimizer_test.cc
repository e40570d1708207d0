#include "stages/track/optimize/optimizer.h"

#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "stages/track/optimize/reprojection_error.h"
#include "stages/track/test_scene.h"

namespace rrslam {
namespace {

using testing::MakeFrame;
using testing::RandomScene;
using testing::RenderView;
using testing::SmallMotion;
using testing::TestSensor;
using testing::TranslationError;
using testing::ViewOptions;

TEST(ReprojectionErrorTest, AnalyticJacobiansMatchNumericDifferentiation) {
  const ProjectionParameters k{500, 510, 320, 240, 40};
  const Rigid3d T = SmallMotion(0.4, 0.5);
  const std::array<double, 7> pose = ToPoseBlock(T);
  const Eigen::Vector3d point(0.3, -0.2, 2.5);
  const std::vector<const ceres::Manifold*> manifolds = {PoseManifold(), nullptr};
  const double* parameters[] = {pose.data(), point.data()};
  ceres::NumericDiffOptions numeric;

  ReprojectionError<3> stereo(k, Eigen::Vector3d(330, 250, 320), 1 / 1.2);
  ceres::GradientChecker::ProbeResults results;
  ceres::GradientChecker stereo_checker(&stereo, &manifolds, numeric);
  EXPECT_TRUE(stereo_checker.Probe(parameters, 1e-6, &results)) << results.error_log;

  ReprojectionError<2> mono(k, Eigen::Vector2d(330, 250), 1.0);
  ceres::GradientChecker mono_checker(&mono, &manifolds, numeric);
  EXPECT_TRUE(mono_checker.Probe(parameters, 1e-6, &results)) << results.error_log;

  const std::vector<const ceres::Manifold*> pose_only = {PoseManifold()};
  PoseOnlyReprojectionError<3> fixed_point(k, Eigen::Vector3d(330, 250, 320), 1.0, point);
  ceres::GradientChecker pose_checker(&fixed_point, &pose_only, numeric);
  EXPECT_TRUE(pose_checker.Probe(parameters, 1e-6, &results)) << results.error_log;

  // The disparity row of a sensor with a depth noise model. Its derivative
  // along a rotation about the optical axis is zero, where Ceres' relative
  // test fails on differentiation noise; compare with an absolute floor.
  ProjectionParameters kd = k;
  kd.inv_sigma_disparity = 1 / 0.2;
  auto expect_close = [&](const ceres::GradientChecker::ProbeResults& r) {
    for (size_t b = 0; b < r.local_jacobians.size(); ++b) {
      const ceres::Matrix& analytic = r.local_jacobians[b];
      const ceres::Matrix& numeric_jacobian = r.local_numeric_jacobians[b];
      for (Eigen::Index i = 0; i < analytic.size(); ++i) {
        const double a = analytic.data()[i], n = numeric_jacobian.data()[i];
        EXPECT_NEAR(a, n, 1e-6 * std::max({1.0, std::abs(a), std::abs(n)})) << b << " " << i;
      }
    }
  };
  ReprojectionError<3> disparity(kd, Eigen::Vector3d(330, 250, 320), 1 / 1.2);
  ceres::GradientChecker disparity_checker(&disparity, &manifolds, numeric);
  disparity_checker.Probe(parameters, 1e-6, &results);
  expect_close(results);
  PoseOnlyReprojectionError<3> disparity_pose(kd, Eigen::Vector3d(330, 250, 320), 1.0, point);
  ceres::GradientChecker disparity_pose_checker(&disparity_pose, &pose_only, numeric);
  disparity_pose_checker.Probe(parameters, 1e-6, &results);
  expect_close(results);
}

TEST(ReprojectionErrorTest, ResidualIsWhitenedProjectionError) {
  const ProjectionParameters k{500, 500, 320, 240, 40};
  const std::array<double, 7> identity = ToPoseBlock(Rigid3d::Identity());
  const Eigen::Vector3d point(0.2, -0.4, 2.0);  // Projects to (370, 140), u_R = 350.
  ReprojectionError<3> error(k, Eigen::Vector3d(371, 138, 352), 0.5);
  const double* parameters[] = {identity.data(), point.data()};
  double r[3];
  ASSERT_TRUE(error.Evaluate(parameters, r, nullptr));
  EXPECT_NEAR(r[0], 0.5, 1e-12);
  EXPECT_NEAR(r[1], -1.0, 1e-12);
  EXPECT_NEAR(r[2], 1.0, 1e-12);
  const Eigen::Vector3d behind(0, 0, -1);
  const double* behind_parameters[] = {identity.data(), behind.data()};
  EXPECT_FALSE(error.Evaluate(behind_parameters, r, nullptr));

  // With a disparity sigma the third row is the disparity error: observed
  // 371 - 352 = 19 px against bf / z = 20 px, over sigma 0.25 px.
  ProjectionParameters kd = k;
  kd.inv_sigma_disparity = 4;
  ReprojectionError<3> disparity(kd, Eigen::Vector3d(371, 138, 352), 0.5);
  ASSERT_TRUE(disparity.Evaluate(parameters, r, nullptr));
  EXPECT_NEAR(r[0], 0.5, 1e-12);
  EXPECT_NEAR(r[1], -1.0, 1e-12);
  EXPECT_NEAR(r[2], -4.0, 1e-12);
}

// The chi-square statistic the matchers gate on is the squared norm of the
// residual the optimizers minimize, with and without a depth noise model.
TEST(ReprojectionErrorTest, SquaredNormIsTheSensorsStereoChiSquare) {
  for (double disparity_sigma : {0.0, 0.25}) {
    Settings settings = testing::TestSettings();
    if (disparity_sigma > 0)
      settings.depth_noise = {DepthNoise::Model::kQuadratic, 0, disparity_sigma};
    const SensorModel sensor(settings, 640, 480);
    const ProjectionParameters k = ProjectionParametersOf(sensor);
    const int octave = 3;
    const double inv_sigma = std::sqrt(sensor.pyramid.inv_sigma2[octave]);
    const Eigen::Vector3d point(0.2, -0.4, 2.0);  // Projects to (370, 140), u_R = 350.
    const Eigen::Vector3d observed(371.5, 138, 352.25);
    const std::array<double, 7> identity = ToPoseBlock(Rigid3d::Identity());
    PoseOnlyReprojectionError<3> error(k, observed, inv_sigma, point);
    const double* parameters[] = {identity.data()};
    double r[3];
    ASSERT_TRUE(error.Evaluate(parameters, r, nullptr));
    const double chi2 = sensor.StereoChi2(370 - 371.5, 140 - 138, 350 - 352.25, octave);
    EXPECT_NEAR(r[0] * r[0] + r[1] * r[1] + r[2] * r[2], chi2, 1e-9) << disparity_sigma;
  }
}

// Parameter: the sensor's disparity sigma (0 = ORB-SLAM2's depth weighting).
class PoseOptimizationWithOutliersTest : public ::testing::TestWithParam<double> {};

TEST_P(PoseOptimizationWithOutliersTest, RecoversPoseWithThirtyPercentOutliers) {
  std::mt19937 rng(21);
  Settings settings = testing::TestSettings();
  if (GetParam() > 0) settings.depth_noise = {DepthNoise::Model::kQuadratic, 0, GetParam()};
  const SensorModel sensor(settings, 640, 480);
  const std::vector<testing::ScenePoint> scene = RandomScene(500, rng, 1.5, 4.0);
  const Rigid3d T_true = SmallMotion(0.1, 0.3);
  ViewOptions options;
  options.pixel_noise = 0.5;
  testing::SyntheticView view = RenderView(sensor, scene, T_true, rng, options);
  // Half of the keypoints without depth: both residual kinds are exercised.
  for (size_t i = 0; i < view.keypoints.size(); i += 2) view.keypoints[i].depth = 0;

  const Rigid3d T_start = SmallMotion(0.05, 0.1) * T_true;
  Frame frame = MakeFrame(sensor, view, 0, T_start);
  Map map;
  std::vector<MapPoint*> points;
  for (const testing::ScenePoint& p : scene)
    points.push_back(map.CreateMapPoint(p.position, nullptr));
  std::uniform_real_distribution<double> u(0, 1);
  std::uniform_int_distribution<size_t> any(0, scene.size() - 1);
  std::vector<uint8_t> wrong(frame.size(), 0);
  for (size_t i = 0; i < frame.size(); ++i) {
    size_t p = view.point_of[i];
    if (u(rng) < 0.3) {
      // A wrong point far from the right one (more than 20 px away).
      size_t q;
      do {
        q = any(rng);
      } while (
          (sensor.Project(T_true * scene[q].position) - sensor.Project(T_true * scene[p].position))
              .norm() < 20);
      p = q;
      wrong[i] = 1;
    }
    frame.map_points[i] = points[p];
  }
  ASSERT_GT(frame.size(), 200u);

  SolveCounts counts;
  const int inliers = OptimizeFramePose(sensor, &frame, {}, &counts);
  EXPECT_EQ(counts.solves, 4u);  // One per round.
  EXPECT_GT(counts.successful_steps, 4u);
  EXPECT_LE(counts.at_step_limit, counts.solves);
  EXPECT_LT(TranslationError(frame.T_cam_world(), T_true), 0.005);
  EXPECT_LT(RotationAngle(frame.T_cam_world().rotation, T_true.rotation), 0.1 * M_PI / 180);
  int flagged_wrong = 0, flagged_right = 0, num_wrong = 0;
  for (size_t i = 0; i < frame.size(); ++i) {
    num_wrong += wrong[i];
    if (frame.outlier[i]) (wrong[i] ? flagged_wrong : flagged_right)++;
  }
  EXPECT_GE(flagged_wrong, 0.97 * num_wrong);
  EXPECT_LE(flagged_right, 0.05 * (frame.size() - num_wrong));
  EXPECT_EQ(inliers, static_cast<int>(frame.size()) - flagged_wrong - flagged_right);
}

INSTANTIATE_TEST_SUITE_P(DepthWeighting, PoseOptimizationWithOutliersTest,
                         ::testing::Values(0.0, 0.1));

TEST(PoseOptimizationTest, NeedsThreeMatches) {
  std::mt19937 rng(2);
  const SensorModel sensor = TestSensor();
  const std::vector<testing::ScenePoint> scene = RandomScene(30, rng);
  const testing::SyntheticView view = RenderView(sensor, scene, Rigid3d::Identity(), rng);
  const Rigid3d T_start = SmallMotion(0.05, 0.1);
  Frame frame = MakeFrame(sensor, view, 0, T_start);
  Map map;
  for (int i = 0; i < 2; ++i) {
    frame.map_points[i] = map.CreateMapPoint(scene[view.point_of[i]].position, nullptr);
  }
  EXPECT_EQ(OptimizeFramePose(sensor, &frame), 0);
  EXPECT_EQ(frame.T_cam_world().translation, T_start.translation);
}

// Keyframes along a path seeing a shared scene, each keypoint tied to the
// map point of its scene point.
class LocalBundleAdjustmentTest : public ::testing::Test {
 protected:
  void SetUp() override {
    scene_ = RandomScene(300, rng_, 2.0, 4.0);
    for (int k = 0; k < 6; ++k) truth_.push_back(SmallMotion(0.02 * k, 0.08 * k));
    points_.assign(scene_.size(), nullptr);
    ViewOptions options;
    options.pixel_noise = 0.0;
    for (int k = 0; k < 6; ++k) {
      testing::SyntheticView view = RenderView(sensor_, scene_, truth_[k], rng_, options);
      // A third of the keypoints without depth.
      for (size_t i = 0; i < view.keypoints.size(); i += 3) view.keypoints[i].depth = 0;
      AdjustView(k, &view);
      keyframes_.push_back(
          testing::AddViewKeyFrame(sensor_, view, k, truth_[k], scene_, &map_, &points_));
    }
    for (KeyFrame* kf : keyframes_) map_.UpdateConnections(kf);
    for (MapPoint* p : points_) {
      if (p != nullptr) p->UpdateNormalAndDepth(sensor_.pyramid);
    }
  }

  // Lets a test change keyframe k's view before the map is made.
  virtual void AdjustView(int /*k*/, testing::SyntheticView* /*view*/) {}

  std::mt19937 rng_{31};
  SensorModel sensor_ = TestSensor();
  std::vector<testing::ScenePoint> scene_;
  std::vector<Rigid3d> truth_;
  Map map_;
  std::vector<KeyFrame*> keyframes_;
  std::vector<MapPoint*> points_;
};

TEST_F(LocalBundleAdjustmentTest, ReturnsPerturbedProblemToTheTruth) {
  std::normal_distribution<double> noise(0.0, 0.02);
  for (size_t k = 1; k < keyframes_.size(); ++k) {
    keyframes_[k]->SetPose(SmallMotion(0.01, 0.03) * truth_[k]);
  }
  for (size_t p = 0; p < points_.size(); ++p) {
    if (points_[p] == nullptr) continue;
    points_[p]->SetPosition(scene_[p].position +
                            Eigen::Vector3d(noise(rng_), noise(rng_), noise(rng_)));
  }
  LocalBundleAdjuster adjuster(sensor_);
  adjuster.Collect(keyframes_.back(), map_);
  EXPECT_EQ(adjuster.stats().local_keyframes, 5);  // All but the root.
  EXPECT_EQ(adjuster.stats().fixed_keyframes, 1);
  adjuster.Solve();
  adjuster.Apply(&map_);
  EXPECT_EQ(adjuster.stats().outliers, 0);
  for (size_t k = 0; k < keyframes_.size(); ++k) {
    EXPECT_LT(TranslationError(keyframes_[k]->T_cam_world(), truth_[k]), 1e-4) << k;
    EXPECT_LT(RotationAngle(keyframes_[k]->T_cam_world().rotation, truth_[k].rotation), 1e-5) << k;
  }
  // Every point measured by depth or by two views is back in place (a point
  // seen once without depth is free along its ray).
  for (size_t p = 0; p < points_.size(); ++p) {
    if (points_[p] == nullptr || points_[p]->num_observations() < 2) continue;
    EXPECT_LT((points_[p]->position_world() - scene_[p].position).norm(), 1e-3) << p;
  }
}

TEST_F(LocalBundleAdjustmentTest, RemovesOutlierObservations) {
  // Keyframe 3 observes a wrong point at 10 keypoints: its slot is re-tied to
  // the point of a keypoint elsewhere in the image.
  KeyFrame* kf = keyframes_[3];
  std::vector<std::pair<MapPoint*, uint32_t>> wrong;
  for (uint32_t i = 0; i < 10; ++i) {
    MapPoint* right = kf->map_point(i);
    MapPoint* other = kf->map_point(i + 100);
    map_.EraseObservation(right, kf);
    map_.EraseObservation(other, kf);
    map_.AddObservation(other, kf, i);
    wrong.emplace_back(other, i);
  }
  LocalBundleAdjuster adjuster(sensor_);
  adjuster.Collect(keyframes_.back(), map_);
  adjuster.Solve();
  adjuster.Apply(&map_);
  EXPECT_GE(adjuster.stats().outliers, 10);
  for (const auto& [point, index] : wrong) {
    EXPECT_EQ(kf->map_point(index), nullptr);
    EXPECT_NE(point->IndexIn(kf), static_cast<int>(index));
  }
  for (size_t k = 0; k < keyframes_.size(); ++k) {
    EXPECT_LT(TranslationError(keyframes_[k]->T_cam_world(), truth_[k]), 1e-3) << k;
  }
}

// Keyframe 3 measures 10 finest-octave keypoints (with depth) 50% too deep:
// their (u, v) is right, their u_R is off by 3 to 7 px.
class WrongDepthTest : public LocalBundleAdjustmentTest {
 protected:
  void AdjustView(int k, testing::SyntheticView* view) override {
    if (k != 3) return;
    for (size_t i = 0; i < view->keypoints.size() && wrong_.size() < 10; ++i) {
      if (view->keypoints[i].depth <= 0 || view->keypoints[i].octave != 0) continue;
      view->keypoints[i].depth *= 1.5f;
      wrong_.push_back(static_cast<uint32_t>(i));
    }
  }
  std::vector<uint32_t> wrong_;
};

TEST_F(WrongDepthTest, OrbSlam2RemovesObservationsWithWrongDepth) {
  ASSERT_EQ(wrong_.size(), 10u);
  LocalBundleAdjustmentOptions options;
  options.depth_fallback = false;  // ORB-SLAM2.
  LocalBundleAdjuster adjuster(sensor_, options);
  adjuster.Collect(keyframes_.back(), map_);
  adjuster.Solve();
  adjuster.Apply(&map_);
  for (uint32_t i : wrong_) EXPECT_EQ(keyframes_[3]->map_point(i), nullptr) << i;
}

TEST_F(WrongDepthTest, DepthFallbackKeepsThemAsPixelObservations) {
  LocalBundleAdjuster adjuster(sensor_);  // depth_fallback = true: the default.
  adjuster.Collect(keyframes_.back(), map_);
  adjuster.Solve();
  adjuster.Apply(&map_);
  for (uint32_t i : wrong_) EXPECT_NE(keyframes_[3]->map_point(i), nullptr) << i;
}

TEST_F(LocalBundleAdjustmentTest, AbortStopsAfterTheFirstPass) {
  std::atomic<bool> abort{true};
  LocalBundleAdjuster adjuster(sensor_);
  adjuster.Collect(keyframes_.back(), map_);
  adjuster.Solve(&abort);
  EXPECT_TRUE(adjuster.stats().aborted);
}

}  // namespace
// g2o's optimize(n) makes n successful steps; Ceres' iteration count also
// counts rejected ones. The limit counts only successful steps, so rejected
// steps do not end a solve early.
TEST(SuccessfulStepLimitTest, CountsOnlySuccessfulStepsAfterIterationZero) {
  SuccessfulStepLimit limit(3);
  ceres::IterationSummary s;
  s.iteration = 0;
  s.step_is_successful = true;  // The initial evaluation is not a step.
  EXPECT_EQ(limit(s), ceres::SOLVER_CONTINUE);
  const bool steps[] = {false, true, false, false, true};
  for (int i = 0; i < 5; ++i) {
    s.iteration = i + 1;
    s.step_is_successful = steps[i];
    EXPECT_EQ(limit(s), ceres::SOLVER_CONTINUE) << "iteration " << s.iteration;
  }
  EXPECT_EQ(limit.successful_steps(), 2);
  s.iteration = 6;
  s.step_is_successful = true;
  EXPECT_EQ(limit(s), ceres::SOLVER_TERMINATE_SUCCESSFULLY);
  EXPECT_EQ(SuccessfulStepLimit::MaxIterationsFor(10), 110);
}

}  // namespace rrslam
