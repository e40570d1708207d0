#include "stages/track/optimize/loop_optimizer.h"

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

constexpr double kDeg = M_PI / 180;

// Rotation of `angle` radians about the camera's y axis (down): a yaw.
Eigen::Quaterniond Yaw(double angle) { return ExpSO3(Eigen::Vector3d(0, angle, 0)); }

// 40 camera poses (T_cam_world) around a square of side 4 m in the x-z
// plane, 10 per side, 0.4 m apart, each camera looking along the path and
// turning 90 degrees at the corners; the pose after the last is the first.
std::vector<Rigid3d> SquarePath() {
  const Eigen::Vector3d corners[] = {{0, 0, 0}, {0, 0, 4}, {4, 0, 4}, {4, 0, 0}};
  std::vector<Rigid3d> truth;
  for (int k = 0; k < 40; ++k) {
    const int side = k / 10;
    const Eigen::Quaterniond R_world_cam = Yaw(side * M_PI / 2);
    const Eigen::Vector3d centre =
        corners[side] + 0.4 * (k % 10) * (R_world_cam * Eigen::Vector3d::UnitZ());
    truth.push_back(Rigid3d(R_world_cam, centre).Inverse());
  }
  return truth;
}

// Measured T_jw * T_iw^-1.
Rigid3d Relative(const std::vector<Rigid3d>& T_cam_world, int i, int j) {
  return T_cam_world[j] * T_cam_world[i].Inverse();
}

// Poses chained from the first by the true odometry, each step with a drift
// of 0.5 degrees of yaw and 1 cm forward.
std::vector<Rigid3d> DriftedChain(const std::vector<Rigid3d>& truth) {
  const Rigid3d drift(Yaw(0.5 * kDeg), Eigen::Vector3d(0, 0, 0.01));
  std::vector<Rigid3d> chain = {truth[0]};
  for (size_t k = 1; k < truth.size(); ++k) {
    chain.push_back(drift * Relative(truth, k - 1, k) * chain.back());
  }
  return chain;
}

// A graph with the given vertices (vertex 0 fixed) and odometry edges
// k-1 -> k measured on `odometry`.
PoseGraph ChainGraph(const std::vector<Rigid3d>& vertices, const std::vector<Rigid3d>& odometry) {
  PoseGraph graph;
  for (size_t k = 0; k < vertices.size(); ++k) graph.AddVertex(vertices[k], k == 0);
  for (int k = 1; k < static_cast<int>(vertices.size()); ++k) {
    graph.edges.push_back({k - 1, k, Relative(odometry, k - 1, k)});
  }
  return graph;
}

double MaxCentreError(const std::vector<Rigid3d>& a, const std::vector<Rigid3d>& b) {
  double error = 0;
  for (size_t k = 0; k < a.size(); ++k) error = std::max(error, TranslationError(a[k], b[k]));
  return error;
}

// Every edge measured on the truth, vertices initialized by the drifted
// chain: the optimum is the truth, reached from ~20 degrees of accumulated
// drift within ORB-SLAM2's 20 steps.
TEST(PoseGraphTest, ClosesASquareLoopWithInjectedDriftToWithinAMillimetre) {
  const std::vector<Rigid3d> truth = SquarePath();
  ASSERT_LT(TranslationError(Relative(truth, 39, 0) * truth[39], truth[0]), 1e-12);
  const std::vector<Rigid3d> drifted = DriftedChain(truth);
  // 39 steps of drift: the end of the loop is ~0.9 m and ~20 degrees off.
  ASSERT_GT(TranslationError(drifted[39], truth[39]), 0.5);
  ASSERT_GT(RotationAngle(drifted[39].rotation, truth[39].rotation), 19 * kDeg);

  PoseGraph graph = ChainGraph(drifted, truth);
  graph.edges.push_back({39, 0, Relative(truth, 39, 0)});  // The loop edge.
  SolveCounts counts;
  const double cost = OptimizePoseGraph(&graph, 20, &counts);
  EXPECT_EQ(counts.solves, 1u);
  EXPECT_LT(cost, 1e-12);
  EXPECT_EQ(graph.poses[0].translation, truth[0].translation);  // Fixed.
  for (int k = 0; k < 40; ++k) {
    EXPECT_LT(TranslationError(graph.poses[k], truth[k]), 1e-3) << k;
    EXPECT_LT(RotationAngle(graph.poses[k].rotation, truth[k].rotation), 1e-4) << k;
  }
}

// Odometry measured on the drifted trajectory (as a SLAM system measures
// it): without a loop edge the drifted poses already satisfy every edge and
// stay where they are; the true loop edge pulls the loop end back.
TEST(PoseGraphTest, OnlyTheLoopEdgeCorrectsDriftedOdometry) {
  const std::vector<Rigid3d> truth = SquarePath();
  const std::vector<Rigid3d> drifted = DriftedChain(truth);

  PoseGraph open = ChainGraph(drifted, drifted);
  EXPECT_LT(OptimizePoseGraph(&open), 1e-20);
  for (int k = 0; k < 40; ++k) {
    EXPECT_LT(TranslationError(open.poses[k], drifted[k]), 1e-9) << k;
    EXPECT_LT(RotationAngle(open.poses[k].rotation, drifted[k].rotation), 1e-9) << k;
  }

  PoseGraph closed = ChainGraph(drifted, drifted);
  closed.edges.push_back({39, 0, Relative(truth, 39, 0)});
  const double cost = OptimizePoseGraph(&closed);
  EXPECT_GT(cost, 0.0);  // Drifted odometry and the loop edge disagree.
  // The loop end was off by the whole drift; now it is close to the truth.
  const double before = TranslationError(drifted[39], truth[39]);
  const double after = TranslationError(closed.poses[39], truth[39]);
  EXPECT_LT(after, 0.1 * before) << before << " -> " << after;
  EXPECT_LT(MaxCentreError(closed.poses, truth), 0.5 * MaxCentreError(drifted, truth));
}

// Two keyframes of a loop over one scene, each with its own map points:
// keyframe 2 and its points live in a drifted world frame (W), so T_12 is
// found from the points in the cameras' coordinates only. matches12 ties
// keyframe 1's keypoints to keyframe 2's points of the same scene point.
class RelativePoseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    scene_ = RandomScene(300, rng_, 2.0, 4.0);
    const Rigid3d T_1w = SmallMotion(0.02, 0.05);
    const Rigid3d T_2w(ExpSO3(Eigen::Vector3d(0.02, 0.1, -0.03)),
                       Eigen::Vector3d(-0.3, 0.02, 0.05));
    true_T_12_ = T_1w * T_2w.Inverse();
    const Rigid3d W(ExpSO3(Eigen::Vector3d(0.1, -0.2, 0.05)), Eigen::Vector3d(0.5, -0.3, 1.0));
    ViewOptions options;
    options.pixel_noise = 0.3;
    const testing::SyntheticView view1 = RenderView(sensor_, scene_, T_1w, rng_, options);
    const testing::SyntheticView view2 = RenderView(sensor_, scene_, T_2w, rng_, options);
    kf1_ = map_.CreateKeyFrame(MakeFrame(sensor_, view1, 0, T_1w));
    kf2_ = map_.CreateKeyFrame(MakeFrame(sensor_, view2, 1, T_2w * W.Inverse()));
    map_.AddKeyFrame(kf1_);
    map_.AddKeyFrame(kf2_);
    scene_of1_ = view1.point_of;
    for (size_t i = 0; i < view1.point_of.size(); ++i) {
      MapPoint* point = map_.CreateMapPoint(scene_[view1.point_of[i]].position, kf1_);
      map_.AddMapPoint(point);
      map_.AddObservation(point, kf1_, static_cast<uint32_t>(i));
    }
    points2_.assign(scene_.size(), nullptr);
    for (size_t i = 0; i < view2.point_of.size(); ++i) {
      const int p = view2.point_of[i];
      points2_[p] = map_.CreateMapPoint(W * scene_[p].position, kf2_);
      map_.AddMapPoint(points2_[p]);
      map_.AddObservation(points2_[p], kf2_, static_cast<uint32_t>(i));
    }
  }

  // The true matches of keyframe 1's keypoints, every `wrong_every`-th one
  // (0 = none) replaced by a point of keyframe 2 that the true T_12 projects
  // more than 20 px away from the keypoint.
  std::vector<MapPoint*> Matches(int wrong_every, std::vector<uint8_t>* wrong) {
    std::vector<MapPoint*> matches(kf1_->size(), nullptr);
    wrong->assign(kf1_->size(), 0);
    int n = 0;
    std::uniform_int_distribution<size_t> any(0, scene_.size() - 1);
    for (size_t i = 0; i < matches.size(); ++i) {
      MapPoint* right = points2_[scene_of1_[i]];
      if (right == nullptr) continue;
      matches[i] = right;
      if (wrong_every == 0 || ++n % wrong_every != 0) continue;
      const Eigen::Vector2d pixel = kf1_->features().keypoints[i].undistorted.cast<double>();
      MapPoint* other;
      do {
        other = points2_[any(rng_)];
      } while (
          other == nullptr ||
          (sensor_.Project(true_T_12_ * kf2_->ToCamera(other->position_world())) - pixel).norm() <
              20);
      matches[i] = other;
      (*wrong)[i] = 1;
    }
    return matches;
  }

  std::mt19937 rng_{41};
  SensorModel sensor_ = TestSensor();
  std::vector<testing::ScenePoint> scene_;
  Rigid3d true_T_12_;
  Map map_;
  KeyFrame* kf1_ = nullptr;
  KeyFrame* kf2_ = nullptr;
  std::vector<int> scene_of1_;      // Scene point of each keypoint of keyframe 1.
  std::vector<MapPoint*> points2_;  // Keyframe 2's point of each scene point.
};

TEST_F(RelativePoseTest, RecoversTheTransformAndDropsWrongMatches) {
  std::vector<uint8_t> wrong;
  std::vector<MapPoint*> matches12 = Matches(8, &wrong);
  int num_right = 0, num_wrong = 0;
  for (size_t i = 0; i < matches12.size(); ++i) {
    if (matches12[i] != nullptr) (wrong[i] ? num_wrong : num_right)++;
  }
  ASSERT_GT(num_right, 100);
  ASSERT_GT(num_wrong, 10);
  Rigid3d T_12 = SmallMotion(2 * kDeg, 0.03) * true_T_12_;
  ASSERT_GT(RotationAngle(T_12.rotation, true_T_12_.rotation), 1.9 * kDeg);

  SolveCounts counts;
  const int inliers = OptimizeRelativePose(sensor_, *kf1_, *kf2_, &matches12, &T_12, 10.0, &counts);
  EXPECT_EQ(counts.solves, 2u);
  EXPECT_GE(inliers, num_right - 3);
  int kept = 0;
  for (size_t i = 0; i < matches12.size(); ++i) {
    if (wrong[i]) {
      EXPECT_EQ(matches12[i], nullptr) << i;
    }
    kept += matches12[i] != nullptr;
  }
  EXPECT_EQ(inliers, kept);
  EXPECT_LT(RotationAngle(T_12.rotation, true_T_12_.rotation), 0.1 * kDeg);
  EXPECT_LT((T_12.translation - true_T_12_.translation).norm(), 0.002);
}

TEST_F(RelativePoseTest, FewerThanTenMatchesLeaveTheTransformUnchanged) {
  std::vector<uint8_t> wrong;
  std::vector<MapPoint*> matches12 = Matches(0, &wrong);
  int kept = 0;
  for (MapPoint*& m : matches12) {
    if (m == nullptr) continue;
    if (kept == 9) {
      m = nullptr;
    } else {
      ++kept;
    }
  }
  ASSERT_EQ(kept, 9);
  const Rigid3d start = SmallMotion(2 * kDeg, 0.03) * true_T_12_;
  Rigid3d T_12 = start;
  EXPECT_EQ(OptimizeRelativePose(sensor_, *kf1_, *kf2_, &matches12, &T_12), 0);
  EXPECT_EQ(T_12.rotation.coeffs(), start.rotation.coeffs());
  EXPECT_EQ(T_12.translation, start.translation);
}

// Five keyframes along a path over a random scene (test_scene.h).
class GlobalBundleAdjustmentTest : public ::testing::Test, public testing::KeyFrameChainScene {};

TEST_F(GlobalBundleAdjustmentTest, LowersTheCostAndReturnsPosesTowardsTheTruth) {
  Perturb();
  ASSERT_EQ(map_.root(), keyframes_[0]);
  const Rigid3d root_before = keyframes_[0]->T_cam_world();
  std::vector<double> error_before;
  for (size_t k = 0; k < keyframes_.size(); ++k) {
    error_before.push_back(TranslationError(keyframes_[k]->T_cam_world(), truth_[k]));
  }
  GlobalBundleAdjuster adjuster(sensor_);
  adjuster.Collect(map_);
  EXPECT_EQ(adjuster.stats().keyframes, 5);
  EXPECT_EQ(adjuster.stats().points, static_cast<int>(map_.num_map_points()));
  EXPECT_GT(adjuster.stats().observations, adjuster.stats().points);
  adjuster.Solve();
  adjuster.Apply(&map_);
  EXPECT_FALSE(adjuster.stats().aborted);
  EXPECT_GT(adjuster.stats().initial_cost, 10 * adjuster.stats().final_cost);
  EXPECT_EQ(keyframes_[0]->T_cam_world().rotation.coeffs(), root_before.rotation.coeffs());
  EXPECT_EQ(keyframes_[0]->T_cam_world().translation, root_before.translation);
  for (size_t k = 1; k < keyframes_.size(); ++k) {
    ASSERT_GT(error_before[k], 0.02) << k;
    EXPECT_LT(TranslationError(keyframes_[k]->T_cam_world(), truth_[k]), 1e-3) << k;
    EXPECT_LT(RotationAngle(keyframes_[k]->T_cam_world().rotation, truth_[k].rotation), 1e-4) << k;
  }
}

// ORB-SLAM2's loop closing runs its global BA without a robust kernel
// (bRobust = false): the cost is half the plain sum of squared whitened
// residuals, however large they are. With 2 cm of point noise most residuals
// lie beyond the Huber width, where a robust loss would grow only linearly.
TEST_F(GlobalBundleAdjustmentTest, CostIsThePlainSumOfSquaresWithoutARobustLoss) {
  Perturb();
  const ProjectionParameters k = ProjectionParametersOf(sensor_);
  double expected = 0;
  int beyond_huber = 0;
  int observations = 0;
  for (MapPoint* point : map_.MapPoints()) {
    const Eigen::Vector3d position = point->position_world();
    for (const MapPoint::Observation& o : point->observations()) {
      const KeypointMeasurement m = MeasurementOf(sensor_, *o.keyframe, o.index);
      const std::array<double, 7> pose = ToPoseBlock(o.keyframe->T_cam_world());
      double r[3] = {0, 0, 0};
      const bool ok =
          m.with_depth ? internal::EvaluateReprojection<3>(k, m.observed, m.inv_sigma, pose.data(),
                                                           position.data(), r, nullptr, nullptr)
                       : internal::EvaluateReprojection<2>(k, m.observed, m.inv_sigma, pose.data(),
                                                           position.data(), r, nullptr, nullptr);
      ASSERT_TRUE(ok);
      const double squared = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
      expected += 0.5 * squared;
      beyond_huber += squared > (m.with_depth ? kChi2ThreeDof : kChi2TwoDof);
      ++observations;
    }
  }
  ASSERT_GT(beyond_huber, observations / 2);
  GlobalBundleAdjuster adjuster(sensor_);
  adjuster.Collect(map_);
  ASSERT_EQ(adjuster.stats().observations, observations);
  adjuster.Solve();
  EXPECT_NEAR(adjuster.stats().initial_cost, expected, 1e-9 * expected);
}

// A keyframe made while the adjustment solves is not in its snapshot: it
// moves with its spanning-tree parent, keeping its pose relative to it.
TEST_F(GlobalBundleAdjustmentTest, KeyFramesMadeDuringTheSolveMoveWithTheirParent) {
  Perturb();
  GlobalBundleAdjuster adjuster(sensor_);
  adjuster.Collect(map_);
  const Rigid3d T_true = SmallMotion(0.09, 0.36);
  const Rigid3d T_tracked = SmallMotion(0.01, 0.03) * T_true;  // Where the tracker put it.
  KeyFrame* late = AddKeyFrame(T_true, &T_tracked);
  map_.UpdateConnections(late);
  // Here every keyframe's best covisible is the root (it sees the most
  // points), which never moves: put the late one under keyframe 4.
  KeyFrame* parent = keyframes_[4];
  late->SetParent(parent);
  ASSERT_EQ(parent->parent(), map_.root());
  const Rigid3d T_late_parent = late->T_cam_world() * parent->T_world_cam();
  adjuster.Solve();
  adjuster.Apply(&map_);
  EXPECT_EQ(adjuster.stats().keyframes, 5);
  const Rigid3d T_after = late->T_cam_world() * parent->T_world_cam();
  EXPECT_LT(TranslationError(T_after, T_late_parent), 1e-9);
  EXPECT_LT(RotationAngle(T_after.rotation, T_late_parent.rotation), 1e-9);
  EXPECT_GT(TranslationError(late->T_cam_world(), T_tracked), 1e-3);  // It did move.
}

// The same five keyframes, for the loop correction and its essential graph.
class LoopCorrectionTest : public ::testing::Test, public testing::KeyFrameChainScene {};

// The loop correction moves the keyframe and its covisible keyframes rigidly,
// each point with the first of them (by id) that observes it.
TEST_F(LoopCorrectionTest, NeighbourhoodMovesRigidlyWithItsPoints) {
  KeyFrame* keyframe = keyframes_[4];
  std::vector<Rigid3d> before;
  for (KeyFrame* kf : keyframes_) before.push_back(kf->T_cam_world());
  std::vector<Eigen::Vector3d> points_before;
  for (MapPoint* p : map_.MapPoints()) points_before.push_back(p->position_world());
  const Rigid3d T_corrected = SmallMotion(0.03, 0.1) * keyframe->T_cam_world();
  const LoopCorrection c =
      MoveLoopNeighbourhood(sensor_, &map_, keyframe, keyframes_[0], T_corrected);
  ASSERT_EQ(c.moved.size(), 5u);  // All see the same scene.
  ASSERT_EQ(c.loop_connections.size(), 5u);
  const Rigid3d T_move = T_corrected.Inverse() * before[4];  // World before -> world after.
  for (size_t k = 0; k < 5; ++k) {
    EXPECT_EQ(c.moved[k], keyframes_[k]);
    EXPECT_EQ(c.non_corrected[k].translation, before[k].translation);
    const Rigid3d expected = (T_move * before[k].Inverse()).Inverse();
    EXPECT_LT(TranslationError(keyframes_[k]->T_cam_world(), expected), 1e-9) << k;
  }
  const std::vector<MapPoint*> points = map_.MapPoints();
  for (size_t i = 0; i < points.size(); ++i) {
    const KeyFrameId ref = c.corrected_reference[points[i]->id()];
    ASSERT_NE(ref, kNoKeyFrameId);
    EXPECT_EQ(ref, points[i]->observations().front().keyframe->id());
    EXPECT_LT((points[i]->position_world() - T_move * points_before[i]).norm(), 1e-9);
  }
}

// The essential graph after a loop that moved keyframe 4 alone: the matched
// keyframe 0 stays fixed, the others spread the correction, a keyframe made
// while the graph solves moves with its parent, and points keep their
// place in their reference keyframe's camera.
TEST_F(LoopCorrectionTest, EssentialGraphSpreadsTheCorrection) {
  KeyFrame* keyframe = keyframes_[4];
  LoopCorrection c;
  c.keyframe = keyframe;
  c.matched = keyframes_[0];
  c.moved = {keyframe};
  c.non_corrected = {keyframe->T_cam_world()};
  c.loop_connections = {{keyframes_[0]}};
  c.corrected_reference.assign(map_.num_created_map_points(), kNoKeyFrameId);
  keyframe->SetPose(SmallMotion(0.03, 0.1) * keyframe->T_cam_world());
  std::vector<Rigid3d> collected;
  for (KeyFrame* kf : keyframes_) collected.push_back(kf->T_cam_world());
  std::vector<std::pair<MapPoint*, Eigen::Vector3d>> in_reference;
  for (MapPoint* p : map_.MapPoints()) {
    in_reference.emplace_back(p, p->reference_keyframe()->ToCamera(p->position_world()));
  }
  EssentialGraphAdjuster adjuster(sensor_, 100, 20);
  adjuster.Collect(map_, c);
  EXPECT_EQ(adjuster.vertices(), 5);
  EXPECT_GE(adjuster.edges(), 5);  // The loop pair and the spanning tree at least.
  KeyFrame* late = AddKeyFrame(SmallMotion(0.09, 0.36));
  map_.UpdateConnections(late);
  late->SetParent(keyframe);
  const Rigid3d T_late_parent = late->T_cam_world() * keyframe->T_world_cam();
  adjuster.Solve();
  adjuster.Apply(&map_);
  EXPECT_GT(adjuster.solves().successful_steps, 0);
  EXPECT_EQ(keyframes_[0]->T_cam_world().translation, collected[0].translation);
  for (size_t k = 1; k < 5; ++k) {
    EXPECT_GT(TranslationError(keyframes_[k]->T_cam_world(), collected[k]), 1e-4) << k;
  }
  const Rigid3d T_after = late->T_cam_world() * keyframe->T_world_cam();
  EXPECT_LT(TranslationError(T_after, T_late_parent), 1e-9);
  EXPECT_LT(RotationAngle(T_after.rotation, T_late_parent.rotation), 1e-9);
  for (const auto& [p, x] : in_reference) {
    EXPECT_LT((p->reference_keyframe()->ToCamera(p->position_world()) - x).norm(), 1e-9);
  }
}

}  // namespace
}  // namespace rrslam
