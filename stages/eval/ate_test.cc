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

// Every field of two results, compared exactly.
void ExpectSameResult(const AteResult& a, const AteResult& b) {
  EXPECT_EQ(a.T_gt_est.rotation.coeffs(), b.T_gt_est.rotation.coeffs());
  EXPECT_EQ(a.T_gt_est.translation, b.T_gt_est.translation);
  EXPECT_EQ(a.scale, b.scale);
  EXPECT_EQ(a.scale_estimated, b.scale_estimated);
  EXPECT_EQ(a.gt_poses, b.gt_poses);
  EXPECT_EQ(a.est_poses, b.est_poses);
  EXPECT_EQ(a.gt_duplicates, b.gt_duplicates);
  EXPECT_EQ(a.est_duplicates, b.est_duplicates);
  EXPECT_EQ(AteResultToJson(a).dump(), AteResultToJson(b).dump());
  EXPECT_EQ(FormatAteReport(a), FormatAteReport(b));
  EXPECT_EQ(FormatAteAssociations(a), FormatAteAssociations(b));
  ASSERT_EQ(a.pairs.size(), b.pairs.size());
  for (size_t k = 0; k < a.pairs.size(); ++k) {
    EXPECT_EQ(a.pairs[k].gt_timestamp, b.pairs[k].gt_timestamp) << k;
    EXPECT_EQ(a.pairs[k].est_timestamp, b.pairs[k].est_timestamp) << k;
    EXPECT_EQ(a.pairs[k].est_position, b.pairs[k].est_position) << k;
    EXPECT_EQ(a.pairs[k].est_position_aligned, b.pairs[k].est_position_aligned) << k;
    EXPECT_EQ(a.pairs[k].error, b.pairs[k].error) << k;
  }
  ASSERT_EQ(a.est_aligned.size(), b.est_aligned.size());
  for (size_t k = 0; k < a.est_aligned.size(); ++k) {
    EXPECT_EQ(a.est_aligned[k].timestamp, b.est_aligned[k].timestamp);
    EXPECT_EQ(a.est_aligned[k].T_world_cam.translation, b.est_aligned[k].T_world_cam.translation);
    EXPECT_EQ(a.est_aligned[k].T_world_cam.rotation.coeffs(),
              b.est_aligned[k].T_world_cam.rotation.coeffs());
  }
}

// `trajectory` with `offset` (map frame, metres) added to the camera centres
// of poses [begin, end); the others unchanged.
Trajectory ShiftedRange(Trajectory trajectory, size_t begin, size_t end,
                        const Eigen::Vector3d& offset) {
  for (size_t i = begin; i < end; ++i) {
    trajectory[i].T_world_cam =
        Rigid3d(Eigen::Quaterniond::Identity(), offset) * trajectory[i].T_world_cam;
  }
  return trajectory;
}

TEST(EvaluateAte, AlignedWithTheEstimateItselfIsPlainAteBitForBit) {
  const Trajectory gt = MakeGroundTruth(250);
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0, 0.02);
  Trajectory est = Transformed(gt, kWorldChange);
  for (StampedPose& pose : est) {
    pose.timestamp += 0.0041;
    pose.T_world_cam.translation =
        0.7 * pose.T_world_cam.translation + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  }
  est.push_back(est[17]);  // A repeated stamp.
  AteOptions rigid, scaled, similarity;
  rigid.max_difference = 0.01;
  rigid.offset = -0.001;
  scaled.scale = 1.4;
  similarity.correct_scale = true;
  for (const AteOptions& options : {AteOptions{}, rigid, scaled, similarity}) {
    const AteAlignment alignment = ComputeAteAlignment(gt, est, options);
    const AteResult plain = ComputeAte(gt, est, options);
    EXPECT_EQ(alignment.pairs, plain.pairs.size());
    EXPECT_EQ(alignment.est_duplicates, 1u);
    ExpectSameResult(EvaluateAte(gt, est, alignment, options), plain);
    EXPECT_GT(plain.error.rmse, 0.01);
  }
}

TEST(EvaluateAte, OffsetOfPartOfTheEstimateIsReportedExactly) {
  // Mapping run A: the ground truth in the map's world frame. Run B is A with
  // a rigid offset of 10 cm (map frame) on poses 100..199.
  const Trajectory gt = MakeGroundTruth(300);
  const Trajectory a = Transformed(gt, kWorldChange);
  const Eigen::Vector3d offset(0.06, 0, -0.08);  // 10 cm.
  const Trajectory b = ShiftedRange(a, 100, 200, offset);

  // A fresh alignment of B spreads the offset over all its poses.
  const AteResult plain = ComputeAte(gt, b);
  EXPECT_LT(plain.error.max, 0.09);
  EXPECT_GT(plain.pairs[0].error, 0.005);
  EXPECT_LT(plain.error.rmse, 0.1 * std::sqrt(1.0 / 3) - 0.005);

  const AteAlignment alignment = ComputeAteAlignment(gt, a);
  EXPECT_EQ(alignment.pairs, 300u);
  const AteResult result = EvaluateAte(gt, b, alignment);
  ASSERT_EQ(result.pairs.size(), 300u);
  for (size_t i = 0; i < 300; ++i) {
    EXPECT_NEAR(result.pairs[i].error, (i >= 100 && i < 200) ? 0.1 : 0.0, 1e-9) << i;
  }
  EXPECT_NEAR(result.error.max, 0.1, 1e-9);
  EXPECT_NEAR(result.error.min, 0.0, 1e-9);
  EXPECT_NEAR(result.error.rmse, 0.1 * std::sqrt(1.0 / 3), 1e-9);
  EXPECT_EQ(result.T_gt_est.translation, alignment.T_gt_est.translation);
  // The aligned estimate carries the offset, rotated into the ground truth's frame.
  EXPECT_LT((result.est_aligned[150].T_world_cam.translation - gt[150].T_world_cam.translation -
             kWorldChange.Inverse().rotation * offset)
                .norm(),
            1e-9);
}

TEST(EvaluateAte, LocalizationRunOffsetFromTheMapIsNotHidden) {
  // B localizes on A's map later in the sequence (poses 200..299 only), 10 cm
  // off. Aligned by itself B looks perfect; aligned as the map, every pose is
  // 10 cm off.
  const Trajectory gt = MakeGroundTruth(300);
  const Trajectory map_frame = Transformed(gt, kWorldChange);
  const Trajectory a(map_frame.begin(), map_frame.begin() + 200);
  const Trajectory later(map_frame.begin() + 200, map_frame.end());
  const Trajectory b = ShiftedRange(later, 0, later.size(), Eigen::Vector3d(0, 0.1, 0));
  EXPECT_LT(ComputeAte(gt, b).error.max, 1e-9);
  const AteResult result = EvaluateAte(gt, b, ComputeAteAlignment(gt, a));
  ASSERT_EQ(result.pairs.size(), 100u);
  for (double value : {result.error.rmse, result.error.mean, result.error.median, result.error.min,
                       result.error.max}) {
    EXPECT_NEAR(value, 0.1, 1e-9);
  }
  EXPECT_EQ(result.est_aligned.size(), 100u);

  // With --correct-scale the estimated scale goes with the alignment: a map at
  // 0.8 of the true size, B off by 8 cm of map units, is 10 cm off.
  Trajectory small_map = map_frame;
  for (StampedPose& pose : small_map) pose.T_world_cam.translation *= 0.8;
  const Trajectory small_a(small_map.begin(), small_map.begin() + 200);
  const Trajectory small_b = ShiftedRange(Trajectory(small_map.begin() + 200, small_map.end()), 0,
                                          100, Eigen::Vector3d(0.08, 0, 0));
  AteOptions options;
  options.correct_scale = true;
  const AteResult scaled = EvaluateAte(gt, small_b, ComputeAteAlignment(gt, small_a, options));
  EXPECT_TRUE(scaled.scale_estimated);
  EXPECT_NEAR(scaled.scale, 1.25, 1e-12);
  EXPECT_NEAR(scaled.error.min, 0.1, 1e-9);
  EXPECT_NEAR(scaled.error.max, 0.1, 1e-9);
}

TEST(EvaluateAte, Errors) {
  const Trajectory gt = MakeGroundTruth(20);
  // The alignment needs kMinAtePairs pairs, as ComputeAte.
  try {
    ComputeAteAlignment(gt, Trajectory(gt.begin(), gt.begin() + 2));
    FAIL() << "two pairs cannot fix an alignment";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("only 2 stamp pair(s)"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("at least 3"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ComputeAteAlignment(gt, Trajectory{}), DataError);
  EXPECT_THROW(ComputeAteAlignment(Trajectory{}, gt), DataError);
  AteOptions correct_scale;
  correct_scale.correct_scale = true;
  Trajectory still = gt;
  for (StampedPose& pose : still) pose.T_world_cam.translation = Eigen::Vector3d(1, 2, 3);
  EXPECT_THROW(ComputeAteAlignment(gt, still, correct_scale), DataError);

  // Under a given alignment one pair suffices, none does not.
  const AteAlignment alignment = ComputeAteAlignment(gt, gt);
  EXPECT_EQ(EvaluateAte(gt, Trajectory(gt.begin() + 5, gt.begin() + 6), alignment).pairs.size(),
            1u);
  Trajectory far = gt;
  for (StampedPose& pose : far) pose.timestamp += 100;
  try {
    EvaluateAte(gt, far, alignment);
    FAIL() << "no pair should match";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("no stamps matched"), std::string::npos) << e.what();
  }
  EXPECT_THROW(EvaluateAte(gt, Trajectory{}, alignment), DataError);
  EXPECT_THROW(EvaluateAte(Trajectory{}, gt, alignment), DataError);

  AteOptions bad;
  bad.max_difference = -1;
  EXPECT_THROW(ComputeAteAlignment(gt, gt, bad), UsageError);
  EXPECT_THROW(EvaluateAte(gt, gt, alignment, bad), UsageError);
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
