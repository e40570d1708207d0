#include "stages/eval/rpe.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/errors.h"
#include "common/geometry.h"

namespace rrslam {
namespace {

constexpr double kDeg = 180.0 / M_PI;

// A camera moving and turning about all axes, `rate` poses per second.
Trajectory MakeGroundTruth(int n, double rate = 30.0, double t0 = 500.0) {
  Trajectory gt;
  for (int i = 0; i < n; ++i) {
    const double s = i / rate;
    StampedPose pose;
    pose.timestamp = t0 + s;
    pose.T_world_cam.translation =
        Eigen::Vector3d(1.5 * std::cos(0.7 * s), 0.8 * std::sin(1.1 * s), 0.2 * s);
    pose.T_world_cam.rotation = ExpSO3(Eigen::Vector3d(0.3 * s, -0.5 * s, 0.1 + 0.2 * s));
    gt.push_back(pose);
  }
  return gt;
}

Eigen::Matrix4d M(const Rigid3d& T) { return T.ToMatrix(); }

TEST(ComputeRpe, TranslationalDriftPerFrameGivesDeltaTimesDrift) {
  // est_i = gt_i moved by i * d in the world: every relative motion over k
  // frames is off by k d, in both error forms; rotations are exact.
  const Trajectory gt = MakeGroundTruth(100);
  const Eigen::Vector3d d(0.002, -0.001, 0.0005);
  Trajectory est = gt;
  for (size_t i = 0; i < est.size(); ++i) est[i].T_world_cam.translation += double(i) * d;
  for (const RpeErrorForm form : {RpeErrorForm::kTumScript, RpeErrorForm::kPaper}) {
    for (const int k : {1, 3, 10}) {
      RpeOptions options;
      options.delta = k;
      options.delta_unit = DeltaUnit::kFrames;
      options.error_form = form;
      const RpeResult result = ComputeRpe(gt, est, options);
      // Pairs (i, i + k) for i + k <= n - 2: the last pose is never a partner.
      EXPECT_EQ(result.pairs.size(), 100u - 1 - k) << k;
      EXPECT_NEAR(result.translational.rmse, k * d.norm(), 1e-12) << k;
      EXPECT_NEAR(result.translational.min, k * d.norm(), 1e-12) << k;
      EXPECT_NEAR(result.translational.std, 0, 1e-12) << k;
      EXPECT_NEAR(result.rotational.max, 0, 1e-6) << k;
      EXPECT_DOUBLE_EQ(result.pairs[0].est_timestamp_1, gt[k].timestamp);
    }
  }
}

TEST(ComputeRpe, RotationalDriftPerFrameGivesDeltaTimesDrift) {
  // A camera turning about z at a fixed position; the estimate turns w more
  // per frame (about the same axis): relative rotations are off by k w.
  const double w = 0.002;  // Radians per frame.
  Trajectory gt, est;
  for (int i = 0; i < 50; ++i) {
    StampedPose pose;
    pose.timestamp = i * 0.05;
    pose.T_world_cam.translation = Eigen::Vector3d(0.3, -0.2, 1.0);
    pose.T_world_cam.rotation = ExpSO3(Eigen::Vector3d(0, 0, 0.03 * i));
    gt.push_back(pose);
    pose.T_world_cam.rotation = ExpSO3(Eigen::Vector3d(0, 0, (0.03 + w) * i));
    est.push_back(pose);
  }
  RpeOptions options;
  options.delta = 4;
  options.delta_unit = DeltaUnit::kFrames;
  const RpeResult result = ComputeRpe(gt, est, options);
  EXPECT_EQ(result.pairs.size(), 50u - 1 - 4);
  EXPECT_NEAR(result.rotational.rmse, 4 * w * kDeg, 1e-9);
  EXPECT_NEAR(result.rotational.median, 4 * w * kDeg, 1e-9);
  EXPECT_NEAR(result.translational.max, 0, 1e-12);
}

TEST(ComputeRpe, DeltaInSecondsPairsByTime) {
  // Estimate at 10 Hz with small stamp jitter, ground truth at 100 Hz shifted
  // by 3 ms. delta 0.5 s pairs pose i with pose i + 5.
  const Trajectory gt = MakeGroundTruth(1200, 100.0, 20.0);
  Trajectory est;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> jitter(-0.004, 0.004);
  for (int i = 0; i < 100; ++i) {
    StampedPose pose = gt[10 * i + 1];  // 10 ms after a 10 Hz tick.
    pose.timestamp = gt[10 * i].timestamp + jitter(rng);
    est.push_back(pose);
  }
  RpeOptions options;
  options.delta = 0.5;
  options.delta_unit = DeltaUnit::kSeconds;
  const RpeResult result = ComputeRpe(gt, est, options);
  EXPECT_NEAR(result.max_difference, 0.02, 1e-9);  // Twice the 10 ms median interval.
  EXPECT_EQ(result.pairs.size(), 100u - 1 - 5);
  for (size_t k = 0; k < result.pairs.size(); ++k) {
    const RpePair& p = result.pairs[k];
    EXPECT_EQ(p.est_timestamp_0, est[k].timestamp);
    EXPECT_EQ(p.est_timestamp_1, est[k + 5].timestamp);
    // Nearest ground truth: the 10 Hz tick itself (jitter < 5 ms).
    EXPECT_EQ(p.gt_timestamp_0, gt[10 * k].timestamp);
    EXPECT_EQ(p.gt_timestamp_1, gt[10 * (k + 5)].timestamp);
  }
  // The estimate holds the ground truth 10 ms later: its errors are the
  // motion differences; with the offset that undoes the shift they are zero.
  EXPECT_GT(result.translational.mean, 1e-4);
  Trajectory shifted = est;
  for (int i = 0; i < 100; ++i) shifted[i].timestamp = gt[10 * i + 1].timestamp - 0.25;
  options.offset = 0.25;
  const RpeResult exact = ComputeRpe(gt, shifted, options);
  EXPECT_EQ(exact.pairs.size(), 100u - 1 - 5);
  EXPECT_LT(exact.translational.max, 1e-12);
  EXPECT_LT(exact.rotational.max, 1e-6);
}

TEST(ComputeRpe, ErrorFormsFollowTheirMatrixDefinitions) {
  // Random poses and a random estimate: each pair's errors equal those of the
  // 4x4 matrix products, computed independently here.
  std::mt19937 rng(9);
  std::normal_distribution<double> n(0, 1);
  Trajectory gt, est;
  for (int i = 0; i < 30; ++i) {
    StampedPose a, b;
    a.timestamp = b.timestamp = i;
    a.T_world_cam = Rigid3d(ExpSO3(Eigen::Vector3d(n(rng), n(rng), n(rng))),
                            Eigen::Vector3d(n(rng), n(rng), n(rng)));
    b.T_world_cam = Rigid3d(ExpSO3(Eigen::Vector3d(n(rng), n(rng), n(rng))),
                            Eigen::Vector3d(n(rng), n(rng), n(rng)));
    gt.push_back(a);
    est.push_back(b);
  }
  const double scale = 1.7;
  for (const RpeErrorForm form : {RpeErrorForm::kTumScript, RpeErrorForm::kPaper}) {
    RpeOptions options;
    options.delta = 2;
    options.delta_unit = DeltaUnit::kFrames;
    options.error_form = form;
    options.scale = scale;
    const RpeResult result = ComputeRpe(gt, est, options);
    ASSERT_EQ(result.pairs.size(), 30u - 1 - 2);
    for (size_t i = 0; i < result.pairs.size(); ++i) {
      Eigen::Matrix4d P = M(est[i].T_world_cam).inverse() * M(est[i + 2].T_world_cam);
      P.topRightCorner<3, 1>() *= scale;
      const Eigen::Matrix4d Q = M(gt[i].T_world_cam).inverse() * M(gt[i + 2].T_world_cam);
      const Eigen::Matrix4d E = form == RpeErrorForm::kTumScript ? Eigen::Matrix4d(P * Q.inverse())
                                                                 : Eigen::Matrix4d(Q.inverse() * P);
      const double angle =
          std::acos(std::clamp((E.topLeftCorner<3, 3>().trace() - 1) / 2, -1.0, 1.0));
      const double translation = E.topRightCorner<3, 1>().norm();
      EXPECT_NEAR(result.pairs[i].translational_error, translation, 1e-9);
      EXPECT_NEAR(result.pairs[i].rotational_error_deg, angle * kDeg, 1e-6);
    }
  }
  // The forms differ in translation, agree in rotation.
  RpeOptions script, paper;
  script.delta = paper.delta = 2;
  script.delta_unit = paper.delta_unit = DeltaUnit::kFrames;
  paper.error_form = RpeErrorForm::kPaper;
  const RpeResult a = ComputeRpe(gt, est, script), b = ComputeRpe(gt, est, paper);
  EXPECT_GT(std::fabs(a.translational.rmse - b.translational.rmse), 1e-3);
  EXPECT_NEAR(a.rotational.rmse, b.rotational.rmse, 1e-9);
}

TEST(ComputeRpe, PoseIsNeverPairedWithItselfOrTheLastPose) {
  // A gap in the estimate: for pose 2 the pose nearest to t + 0.1 s is pose 2
  // itself; that pair is left out, and so are those whose partner is the last.
  const std::vector<double> stamps = {0, 0.1, 0.2, 5.0, 5.1, 5.2};
  Trajectory gt, est;
  for (int i = 0; i <= 52; ++i) {
    StampedPose pose;
    pose.timestamp = i * 0.1;
    pose.T_world_cam.translation = Eigen::Vector3d(i * 0.01, 0, 0);
    gt.push_back(pose);
  }
  for (double t : stamps) {
    StampedPose pose;
    pose.timestamp = t;
    pose.T_world_cam.translation = Eigen::Vector3d(t * 0.1, 0, 0.01);
    est.push_back(pose);
  }
  RpeOptions options;
  options.delta = 0.1;
  const RpeResult result = ComputeRpe(gt, est, options);
  ASSERT_EQ(result.pairs.size(), 3u);
  EXPECT_EQ(result.pairs[0].est_timestamp_0, 0.0);
  EXPECT_EQ(result.pairs[1].est_timestamp_0, 0.1);
  EXPECT_EQ(result.pairs[2].est_timestamp_0, 5.0);
  EXPECT_EQ(result.pairs[2].est_timestamp_1, 5.1);
}

TEST(ComputeRpe, GroundTruthLookupBound) {
  // Ground truth with a 1 s hole; pairs touching the hole have no ground truth
  // within twice the median interval (inclusive bound) and are skipped.
  Trajectory gt = MakeGroundTruth(300, 30.0, 0.0);
  gt.erase(
      std::remove_if(gt.begin(), gt.end(),
                     [](const StampedPose& p) { return p.timestamp > 3.0 && p.timestamp < 4.0; }),
      gt.end());
  const Trajectory est = MakeGroundTruth(300, 30.0, 0.0);
  RpeOptions options;
  options.delta = 1;
  options.delta_unit = DeltaUnit::kFrames;
  const RpeResult automatic = ComputeRpe(gt, est, options);
  EXPECT_NEAR(automatic.max_difference, 2.0 / 30, 1e-9);
  EXPECT_GT(automatic.skipped_pairs, 0u);
  EXPECT_EQ(automatic.pairs.size() + automatic.skipped_pairs, 300u - 2);
  for (const RpePair& p : automatic.pairs) {
    EXPECT_LE(std::fabs(p.gt_timestamp_0 - p.est_timestamp_0), automatic.max_difference);
  }
  options.max_difference = 10;  // Accept any nearest ground truth.
  const RpeResult loose = ComputeRpe(gt, est, options);
  EXPECT_EQ(loose.skipped_pairs, 0u);
  EXPECT_EQ(loose.max_difference, 10);
}

// Unmatched files are bad data (65); a delta that leaves no pair in a valid
// estimate computes nothing (75, issue 36: it exited 0).
TEST(ComputeRpe, FailuresAreDataOrAlgorithmErrors) {
  const Trajectory gt = MakeGroundTruth(60);
  Trajectory far = gt;
  for (StampedPose& pose : far) pose.timestamp += 1000;
  try {
    ComputeRpe(gt, far);
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("no stamps matched"), std::string::npos) << e.what();
  }
  RpeOptions options;
  options.delta = 100;
  options.delta_unit = DeltaUnit::kFrames;
  try {
    ComputeRpe(gt, gt, options);
    FAIL();
  } catch (const AlgorithmError& e) {
    EXPECT_NE(std::string(e.what()).find("leaves no pose pair"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ComputeRpe(gt, Trajectory(gt.begin(), gt.begin() + 1)), DataError);
  EXPECT_THROW(ComputeRpe(Trajectory(gt.begin(), gt.begin() + 1), gt), DataError);
}

TEST(RpeOptions, DefaultsPassAndEachConstraintFails) {
  std::string why;
  EXPECT_TRUE(RpeOptions{}.Check(&why));
  const auto fails = [&](const RpeOptions& o, const char* word) {
    std::string reason;
    EXPECT_FALSE(o.Check(&reason)) << word;
    EXPECT_NE(reason.find(word), std::string::npos) << reason;
  };
  RpeOptions o;
  o.delta = 0;
  fails(o, "delta");
  o.delta = -1;
  fails(o, "delta");
  o.delta = std::nan("");
  fails(o, "delta");
  o = RpeOptions{};
  o.delta_unit = DeltaUnit::kFrames;
  o.delta = 1.5;
  fails(o, "whole number");
  o.delta = 2;
  EXPECT_TRUE(o.Check(&why));
  o = RpeOptions{};
  o.max_difference = -0.1;
  fails(o, "max_difference");
  o = RpeOptions{};
  o.offset = NAN;
  fails(o, "offset");
  o = RpeOptions{};
  o.scale = 0;
  fails(o, "scale");
  EXPECT_THROW(ComputeRpe(MakeGroundTruth(5), MakeGroundTruth(5), o), UsageError);
}

TEST(RpeOutput, ReportAndJson) {
  const Trajectory gt = MakeGroundTruth(40);
  Trajectory est = gt;
  for (size_t i = 0; i < est.size(); ++i) est[i].T_world_cam.translation.x() += 0.001 * i;
  RpeOptions options;
  options.delta = 1;
  options.delta_unit = DeltaUnit::kFrames;
  const RpeResult result = ComputeRpe(gt, est, options);
  const std::string report = FormatRpeReport(result);
  EXPECT_EQ(report.rfind("compared_pose_pairs 38 pairs\n", 0), 0u) << report;
  EXPECT_NE(report.find("translational_error.rmse 0.001000 m\n"), std::string::npos) << report;
  EXPECT_NE(report.find("rotational_error.median 0.000000 deg\n"), std::string::npos) << report;
  const auto json = RpeResultToJson(result);
  EXPECT_EQ(json["pairs"].get<size_t>(), 38u);
  EXPECT_NEAR(json["translational_error_m"]["mean"].get<double>(), 0.001, 1e-12);
  EXPECT_TRUE(json["rotational_error_deg"].contains("std"));
  const std::string lines = FormatRpePairs(result);
  EXPECT_EQ(std::count(lines.begin(), lines.end(), '\n'), 38);
  EXPECT_NE(lines.find(" 0.001000000 "), std::string::npos);
}

}  // namespace
}  // namespace rrslam
