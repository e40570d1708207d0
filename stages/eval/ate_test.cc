#include "stages/eval/ate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/errors.h"
#include "common/geometry.h"

namespace rrslam {
namespace {

// A smooth 3D camera path at 30 Hz with rotating orientation.
Trajectory MakeGroundTruth(int n, double t0 = 1000.0) {
  Trajectory gt;
  for (int i = 0; i < n; ++i) {
    const double s = i / 30.0;
    StampedPose pose;
    pose.timestamp = t0 + s;
    pose.T_world_cam.translation =
        Eigen::Vector3d(1.5 * std::cos(0.7 * s), 0.8 * std::sin(1.1 * s), 0.2 * s);
    pose.T_world_cam.rotation = ExpSO3(Eigen::Vector3d(0.1 * s, -0.3 * s, 0.05));
    gt.push_back(pose);
  }
  return gt;
}

// T * pose for every pose (a different world frame).
Trajectory Transformed(const Trajectory& trajectory, const Rigid3d& T) {
  Trajectory out = trajectory;
  for (StampedPose& pose : out) pose.T_world_cam = T * pose.T_world_cam;
  return out;
}

const Rigid3d kWorldChange(ExpSO3(Eigen::Vector3d(0.6, -0.4, 2.2)), Eigen::Vector3d(5, -3, 1.2));

TEST(ComputeAte, RigidlyMovedGroundTruthHasZeroError) {
  const Trajectory gt = MakeGroundTruth(200);
  const AteResult result = ComputeAte(gt, Transformed(gt, kWorldChange));
  EXPECT_EQ(result.pairs.size(), 200u);
  EXPECT_EQ(result.error.count, 200u);
  EXPECT_LT(result.error.rmse, 1e-9);
  EXPECT_LT(result.error.max, 1e-9);
  // T_gt_est undoes the world change.
  const Rigid3d identity = result.T_gt_est * kWorldChange;
  EXPECT_LT(identity.translation.norm(), 1e-9);
  EXPECT_LT(LogSO3(identity.rotation).norm(), 1e-9);
  // The aligned estimate is the ground truth again, orientation included.
  ASSERT_EQ(result.est_aligned.size(), gt.size());
  for (size_t i = 0; i < gt.size(); ++i) {
    EXPECT_LT(
        (result.est_aligned[i].T_world_cam.translation - gt[i].T_world_cam.translation).norm(),
        1e-9);
    EXPECT_LT(RotationAngle(result.est_aligned[i].T_world_cam.rotation, gt[i].T_world_cam.rotation),
              1e-9);
  }
}

TEST(ComputeAte, ConstantOffsetIsAbsorbedByTheAlignment) {
  const Trajectory gt = MakeGroundTruth(90);
  Trajectory est = gt;
  for (StampedPose& pose : est) pose.T_world_cam.translation.x() += 0.25;
  const AteResult result = ComputeAte(gt, est);
  EXPECT_LT(result.error.rmse, 1e-12);
  EXPECT_NEAR(result.T_gt_est.translation.x(), -0.25, 1e-12);
}

TEST(ComputeAte, AlternatingOffsetAlongOneAxisGivesItsSizeAsError) {
  // Square in the z = 0 plane; the estimate lifts the corners along z by
  // +d, -d, +d, -d around the square (a saddle x*y*d, orthogonal to every
  // rigid motion): the optimal alignment is the identity, every error is d.
  const double d = 0.04;
  const double xs[] = {1, -1, -1, 1}, ys[] = {1, 1, -1, -1};
  Trajectory gt, est;
  for (int i = 0; i < 4; ++i) {
    StampedPose pose;
    pose.timestamp = i;
    pose.T_world_cam.translation = Eigen::Vector3d(xs[i], ys[i], 0);
    gt.push_back(pose);
    pose.T_world_cam.translation.z() = d * xs[i] * ys[i];
    est.push_back(pose);
  }
  const AteResult result = ComputeAte(gt, Transformed(est, kWorldChange));
  for (const AtePair& pair : result.pairs) EXPECT_NEAR(pair.error, d, 1e-12);
  EXPECT_NEAR(result.error.rmse, d, 1e-12);
  EXPECT_NEAR(result.error.median, d, 1e-12);
  EXPECT_NEAR(result.error.std, 0, 1e-12);
  const Rigid3d identity = result.T_gt_est * kWorldChange;
  EXPECT_LT(identity.translation.norm(), 1e-12);
  EXPECT_LT(LogSO3(identity.rotation).norm(), 1e-12);
}

TEST(ComputeAte, FourPointsWithKnownOptimalAlignment) {
  // Tetrahedron P; the estimate is (I + S) P with S symmetric, in another
  // world frame. The optimal alignment is that frame change (alignment_test
  // shows why), the errors are |S P_i|: two of sqrt(0.0237) and two of
  // sqrt(0.0057).
  const double P[4][3] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  Eigen::Matrix3d S;
  S << 0.1, 0.03, 0,  //
      0.03, 0.05, 0,  //
      0, 0, 0.02;
  Trajectory gt, est;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d p(P[i][0], P[i][1], P[i][2]);
    StampedPose pose;
    pose.timestamp = 10 + i;
    pose.T_world_cam.translation = p;
    gt.push_back(pose);
    pose.timestamp += 0.004;  // Within max_difference.
    pose.T_world_cam.translation = p + S * p;
    est.push_back(pose);
  }
  const AteResult result = ComputeAte(gt, Transformed(est, kWorldChange));
  const double e1 = std::sqrt(0.0237), e2 = std::sqrt(0.0057);
  ASSERT_EQ(result.pairs.size(), 4u);
  EXPECT_NEAR(result.pairs[0].error, e1, 1e-12);
  EXPECT_NEAR(result.pairs[1].error, e2, 1e-12);
  EXPECT_NEAR(result.pairs[2].error, e2, 1e-12);
  EXPECT_NEAR(result.pairs[3].error, e1, 1e-12);
  EXPECT_NEAR(result.error.rmse, std::sqrt((0.0237 + 0.0057) / 2), 1e-12);
  EXPECT_NEAR(result.error.mean, (e1 + e2) / 2, 1e-12);
  EXPECT_NEAR(result.error.median, (e1 + e2) / 2, 1e-12);  // Even count: mean of middle two.
  EXPECT_NEAR(result.error.std, (e1 - e2) / 2, 1e-12);
  EXPECT_NEAR(result.error.min, e2, 1e-12);
  EXPECT_NEAR(result.error.max, e1, 1e-12);
  EXPECT_DOUBLE_EQ(result.pairs[0].gt_timestamp, 10);
  EXPECT_DOUBLE_EQ(result.pairs[0].est_timestamp, 10.004);
}

TEST(ComputeAte, MatchesAnIndependentUmeyamaComputationOnNoisyData) {
  const Trajectory gt = MakeGroundTruth(300);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0, 0.01);
  Trajectory est = Transformed(gt, kWorldChange);
  for (StampedPose& pose : est) {
    pose.timestamp += 0.003;
    pose.T_world_cam.translation += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  }
  const AteResult result = ComputeAte(gt, est);
  ASSERT_EQ(result.pairs.size(), gt.size());
  Eigen::Matrix3Xd model(3, gt.size()), data(3, gt.size());
  for (size_t i = 0; i < gt.size(); ++i) {
    model.col(i) = est[i].T_world_cam.translation;
    data.col(i) = gt[i].T_world_cam.translation;
  }
  const Eigen::Matrix4d T = Eigen::umeyama(model, data, false);
  double sum = 0;
  for (size_t i = 0; i < gt.size(); ++i) {
    const Eigen::Vector3d aligned =
        T.topLeftCorner<3, 3>() * model.col(i) + T.topRightCorner<3, 1>();
    sum += (aligned - data.col(i)).squaredNorm();
  }
  EXPECT_NEAR(result.error.rmse, std::sqrt(sum / gt.size()), 1e-12);
  EXPECT_GT(result.error.rmse, 0.01);  // sqrt(3) sigma, about 0.017.
  EXPECT_LT(result.error.rmse, 0.025);
}

TEST(ComputeAte, ScaleMultipliesTheEstimatedPositions) {
  const Trajectory gt = MakeGroundTruth(60);
  Trajectory est = Transformed(gt, kWorldChange);
  for (StampedPose& pose : est) pose.T_world_cam.translation *= 0.5;  // Half-size estimate.
  AteOptions options;
  EXPECT_GT(ComputeAte(gt, est, options).error.rmse, 0.1);
  options.scale = 2.0;
  const AteResult result = ComputeAte(gt, est, options);
  EXPECT_LT(result.error.rmse, 1e-9);
  EXPECT_EQ(result.scale, 2.0);
  EXPECT_LT((result.pairs[3].est_position - 2.0 * est[3].T_world_cam.translation).norm(), 1e-12);
}

TEST(ComputeAte, CorrectScaleEstimatesTheScaleAndReportsIt) {
  const Trajectory gt = MakeGroundTruth(60);
  Trajectory est = Transformed(gt, kWorldChange);
  for (StampedPose& pose : est) pose.T_world_cam.translation *= 0.8;
  AteOptions options;
  options.correct_scale = true;
  const AteResult result = ComputeAte(gt, est, options);
  EXPECT_LT(result.error.rmse, 1e-9);
  EXPECT_NEAR(result.scale, 1.25, 1e-12);
  EXPECT_TRUE(result.scale_estimated);
  EXPECT_LT((result.pairs[3].est_position - 1.25 * est[3].T_world_cam.translation).norm(), 1e-12);
  EXPECT_LT((result.est_aligned[3].T_world_cam.translation - gt[3].T_world_cam.translation).norm(),
            1e-9);
  EXPECT_EQ(AteResultToJson(result)["scale"].get<double>(), result.scale);
  EXPECT_NE(FormatAteReport(result).find("\nestimated_scale 1.250000\n"), std::string::npos);
  // Without it the report stays TUM's, and the scale is the given one.
  const AteResult rigid = ComputeAte(gt, est);
  EXPECT_FALSE(rigid.scale_estimated);
  EXPECT_EQ(FormatAteReport(rigid).find("estimated_scale"), std::string::npos);
  EXPECT_GT(rigid.error.rmse, result.error.rmse + 0.01);
}

TEST(ComputeAte, CorrectScaleNeedsAMovingEstimate) {
  const Trajectory gt = MakeGroundTruth(10);
  Trajectory still = gt;
  for (StampedPose& pose : still) pose.T_world_cam.translation = Eigen::Vector3d(1, 2, 3);
  AteOptions options;
  options.correct_scale = true;
  EXPECT_THROW(ComputeAte(gt, still, options), DataError);
  EXPECT_NO_THROW(ComputeAte(gt, still));  // Rigid alignment is defined.
}

TEST(ComputeAte, TooFewPairsAreDataErrors) {
  const Trajectory gt = MakeGroundTruth(10);
  Trajectory far = gt;
  for (StampedPose& pose : far) pose.timestamp += 100;
  try {
    ComputeAte(gt, far);
    FAIL() << "no pair should match";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("no stamps matched"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("max_difference 0.02"), std::string::npos) << e.what();
  }
  const Trajectory two(gt.begin(), gt.begin() + 2);
  EXPECT_THROW(ComputeAte(gt, two), DataError);
  const Trajectory three(gt.begin(), gt.begin() + 3);
  EXPECT_EQ(ComputeAte(gt, three).pairs.size(), 3u);
  EXPECT_THROW(ComputeAte(gt, Trajectory{}), DataError);
  EXPECT_THROW(ComputeAte(Trajectory{}, gt), DataError);
}

TEST(AteOptions, DefaultsPassAndEachConstraintFails) {
  std::string why;
  EXPECT_TRUE(AteOptions{}.Check(&why));
  AteOptions o;
  o.max_difference = 0;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("max_difference"), std::string::npos);
  o = AteOptions{};
  o.max_difference = std::nan("");
  EXPECT_FALSE(o.Check(&why));
  o = AteOptions{};
  o.offset = INFINITY;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("offset"), std::string::npos);
  o = AteOptions{};
  o.scale = -1;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("scale"), std::string::npos);
  o = AteOptions{};
  o.correct_scale = true;
  EXPECT_TRUE(o.Check(&why));
  o.scale = 2;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("correct_scale"), std::string::npos);
  const Trajectory gt = MakeGroundTruth(10);
  EXPECT_THROW(ComputeAte(gt, gt, o), UsageError);
}

TEST(AteOutput, JsonReportAndAssociations) {
  const Trajectory gt = MakeGroundTruth(30);
  const AteResult result = ComputeAte(gt, Transformed(gt, kWorldChange));
  const auto json = AteResultToJson(result);
  EXPECT_EQ(json["pairs"].get<size_t>(), 30u);
  EXPECT_EQ(json["gt_poses"].get<size_t>(), 30u);
  for (const char* key : {"rmse", "mean", "median", "std", "min", "max"}) {
    EXPECT_TRUE(json["ate_m"].contains(key)) << key;
  }
  EXPECT_EQ(json["T_gt_est"]["quaternion_xyzw"].size(), 4u);
  EXPECT_EQ(json["T_gt_est"]["translation"].size(), 3u);

  const std::string report = FormatAteReport(result);
  EXPECT_EQ(report.rfind("compared_pose_pairs 30 pairs\n", 0), 0u) << report;
  EXPECT_NE(report.find("absolute_translational_error.rmse 0.000000 m\n"), std::string::npos);
  EXPECT_NE(report.find("absolute_translational_error.max "), std::string::npos);

  const std::string lines = FormatAteAssociations(result);
  EXPECT_EQ(std::count(lines.begin(), lines.end(), '\n'), 30);
  // First line: gt stamp, gt position, est stamp, aligned est position (= gt).
  char expected[200];
  const Eigen::Vector3d& p = gt[0].T_world_cam.translation;
  std::snprintf(expected, sizeof(expected), "%.6f %.9f %.9f %.9f %.6f", gt[0].timestamp, p.x(),
                p.y(), p.z(), gt[0].timestamp);
  EXPECT_EQ(lines.rfind(expected, 0), 0u) << lines.substr(0, 120);
}

}  // namespace
}  // namespace rrslam
