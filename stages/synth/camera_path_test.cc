#include "stages/synth/camera_path.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "stages/synth/scene.h"

namespace rrslam::synth {
namespace {

constexpr double kDeg = M_PI / 180.0;
// The kinds within the hand-held speed bounds; shake is the fast exception.
const TrajectoryKind kKinds[] = {TrajectoryKind::kLoop, TrajectoryKind::kSweep,
                                 TrajectoryKind::kRotation, TrajectoryKind::kTurn};
const TrajectoryKind kAllKinds[] = {TrajectoryKind::kLoop, TrajectoryKind::kSweep,
                                    TrajectoryKind::kRotation, TrajectoryKind::kShake,
                                    TrajectoryKind::kTurn};
// Short (tests), default, the benchmark's 600, and long sequences.
const int kFrameCounts[] = {2, 10, 60, 120, 300, 539, 540, 600, 1000, 1500, 3000};

Eigen::Vector3d Forward(const Rigid3d& T_world_cam) {
  return T_world_cam.rotation * Eigen::Vector3d::UnitZ();
}

TEST(CameraPath, PoseFromAnglesUsesCameraAxesRightDownForward) {
  const Rigid3d T = CameraPath::PoseFromAngles(Eigen::Vector3d(1, 2, 3), 0, 0, 0);
  const Eigen::Matrix3d R = T.RotationMatrix();
  EXPECT_TRUE(R.col(2).isApprox(Eigen::Vector3d::UnitX(), 1e-12)) << R;   // z forward = +x.
  EXPECT_TRUE(R.col(1).isApprox(-Eigen::Vector3d::UnitZ(), 1e-12)) << R;  // y down = -z.
  EXPECT_TRUE(R.col(0).isApprox(-Eigen::Vector3d::UnitY(), 1e-12)) << R;  // x right = -y.
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  EXPECT_TRUE(T.translation.isApprox(Eigen::Vector3d(1, 2, 3)));

  // Yaw 90 deg looks along +y; pitch up raises the optical axis.
  EXPECT_TRUE(Forward(CameraPath::PoseFromAngles({0, 0, 0}, 90 * kDeg, 0, 0))
                  .isApprox(Eigen::Vector3d::UnitY(), 1e-12));
  EXPECT_GT(Forward(CameraPath::PoseFromAngles({0, 0, 0}, 0, 10 * kDeg, 0)).z(), 0.17);
  // Roll turns about the optical axis only.
  const Rigid3d rolled = CameraPath::PoseFromAngles({0, 0, 0}, 0, 0, 20 * kDeg);
  EXPECT_TRUE(Forward(rolled).isApprox(Eigen::Vector3d::UnitX(), 1e-12));
  EXPECT_NEAR(RotationAngle(rolled.rotation, T.rotation), 20 * kDeg, 1e-12);
}

TEST(CameraPath, TimestampsAndSamplesFollowTheContinuousPath) {
  const Trajectory trajectory = MakeTrajectory(TrajectoryKind::kSweep, 90, 30.0, 5.0);
  ASSERT_EQ(trajectory.size(), 90u);
  const CameraPath path(TrajectoryKind::kSweep, 89 / 30.0);
  for (size_t i = 0; i < trajectory.size(); ++i) {
    EXPECT_DOUBLE_EQ(trajectory[i].timestamp, 5.0 + i / 30.0);
    const Rigid3d expected = path.T_world_cam(i / 30.0);
    EXPECT_TRUE(trajectory[i].T_world_cam.translation.isApprox(expected.translation, 1e-15));
    EXPECT_LT(RotationAngle(trajectory[i].T_world_cam.rotation, expected.rotation), 1e-12);
  }
  EXPECT_TRUE(MakeTrajectory(TrajectoryKind::kLoop, 0, 30.0).empty());
  EXPECT_EQ(MakeTrajectory(TrajectoryKind::kLoop, 1, 30.0).size(), 1u);
}

TEST(CameraPath, TurnStartsLookingAwayFromTheSweepAndEndsLookingAtIt) {
  for (int frames : {720, 1500}) {
    const Trajectory turn = MakeTrajectory(TrajectoryKind::kTurn, frames, 30.0);
    const Eigen::Vector3d north = Eigen::Vector3d::UnitY();
    // Looking south for the first 15% (within the hand's swings).
    for (size_t i = 0; i < turn.size() * 15 / 100; ++i) {
      EXPECT_LT(Forward(turn[i].T_world_cam).dot(north), -0.85) << frames << " frame " << i;
    }
    // Looking north over the last quarter, as the sweep does.
    for (size_t i = turn.size() * 3 / 4 + 1; i < turn.size(); ++i) {
      EXPECT_GT(Forward(turn[i].T_world_cam).dot(north), 0.85) << frames << " frame " << i;
    }
  }
}

TEST(CameraPath, QuaternionsKeepTheirSign) {
  for (TrajectoryKind kind : kAllKinds) {
    const Trajectory t = MakeTrajectory(kind, 600, 30.0);
    for (size_t i = 1; i < t.size(); ++i) {
      ASSERT_GE(t[i].T_world_cam.rotation.dot(t[i - 1].T_world_cam.rotation), 0.0)
          << TrajectoryKindName(kind) << " " << i;
    }
  }
}

TEST(CameraPath, LoopEndsWhereItBegan) {
  for (int frames : kFrameCounts) {
    const Trajectory t = MakeTrajectory(TrajectoryKind::kLoop, frames, 30.0);
    EXPECT_LT((t.front().T_world_cam.translation - t.back().T_world_cam.translation).norm(), 1e-9)
        << frames;
    EXPECT_LT(RotationAngle(t.front().T_world_cam.rotation, t.back().T_world_cam.rotation), 1e-9)
        << frames;
  }
}

TEST(CameraPath, LoopTravelsAndLongLoopsTurnAllTheWayAround) {
  // The 600-frame loop (20 s) goes once around the room looking outward: its
  // optical axis points into every quadrant; the default 300-frame loop keeps
  // looking east (+x) within +-60 deg.
  const Trajectory long_loop = MakeTrajectory(TrajectoryKind::kLoop, 600, 30.0);
  bool quadrant[4] = {false, false, false, false};
  double path_length = 0;
  for (size_t i = 0; i < long_loop.size(); ++i) {
    const Eigen::Vector3d f = Forward(long_loop[i].T_world_cam);
    quadrant[(f.x() >= 0 ? 0 : 1) + (f.y() >= 0 ? 0 : 2)] = true;
    if (i > 0) {
      path_length +=
          (long_loop[i].T_world_cam.translation - long_loop[i - 1].T_world_cam.translation).norm();
    }
  }
  EXPECT_TRUE(quadrant[0] && quadrant[1] && quadrant[2] && quadrant[3]);
  EXPECT_GT(path_length, 4.0);  // About 0.3 m/s over 20 s.

  const Trajectory short_loop = MakeTrajectory(TrajectoryKind::kLoop, 300, 30.0);
  double max_offset = 0;
  for (const auto& pose : short_loop) {
    const Eigen::Vector3d f = Forward(pose.T_world_cam);
    EXPECT_LT(std::acos(std::clamp(f.normalized().x(), -1.0, 1.0)), 60 * kDeg);
    max_offset = std::max(max_offset, pose.T_world_cam.translation.head<2>().norm());
  }
  EXPECT_GT(max_offset, 0.3);  // It does move: a loop of about 3 m.
}

TEST(CameraPath, RotationHasNoTranslation) {
  for (int frames : kFrameCounts) {
    const Trajectory t = MakeTrajectory(TrajectoryKind::kRotation, frames, 30.0);
    double max_angle = 0;
    for (const auto& pose : t) {
      EXPECT_EQ(pose.T_world_cam.translation, t.front().T_world_cam.translation) << frames;
      max_angle = std::max(
          max_angle, RotationAngle(pose.T_world_cam.rotation, t.front().T_world_cam.rotation));
    }
    // A real pan.
    if (frames >= 300) {
      EXPECT_GT(max_angle, 25 * kDeg) << frames;
    }
    if (frames >= 600) {
      EXPECT_GT(max_angle, 55 * kDeg) << frames;
    }
  }
}

TEST(CameraPath, SweepGoesThereAndBack) {
  for (int frames : {60, 300, 600}) {
    const Trajectory t = MakeTrajectory(TrajectoryKind::kSweep, frames, 30.0);
    double max_distance = 0;
    for (const auto& pose : t) {
      max_distance = std::max(
          max_distance, (pose.T_world_cam.translation - t.front().T_world_cam.translation).norm());
    }
    EXPECT_LT((t.back().T_world_cam.translation - t.front().T_world_cam.translation).norm(), 1e-9);
    EXPECT_GT(max_distance, frames >= 300 ? 1.0 : 0.2) << frames;
  }
}

TEST(CameraPath, SpeedsAreHandHeld) {
  // Between consecutive frames at 30 fps: at most 0.45 m/s and 30 deg/s, and
  // sequences of 10 s or more do move at a walking pace.
  for (TrajectoryKind kind : kKinds) {
    for (int frames : kFrameCounts) {
      const Trajectory t = MakeTrajectory(kind, frames, 30.0);
      double max_speed = 0, max_turn_rate = 0;
      for (size_t i = 1; i < t.size(); ++i) {
        const double dt = t[i].timestamp - t[i - 1].timestamp;
        max_speed =
            std::max(max_speed,
                     (t[i].T_world_cam.translation - t[i - 1].T_world_cam.translation).norm() / dt);
        max_turn_rate =
            std::max(max_turn_rate,
                     RotationAngle(t[i].T_world_cam.rotation, t[i - 1].T_world_cam.rotation) / dt);
      }
      EXPECT_LE(max_speed, 0.45) << TrajectoryKindName(kind) << " " << frames;
      EXPECT_LE(max_turn_rate, 30 * kDeg) << TrajectoryKindName(kind) << " " << frames;
      // Rotation and turn stand in place (but for the hand's bob).
      if (frames >= 300 && kind != TrajectoryKind::kRotation && kind != TrajectoryKind::kTurn) {
        EXPECT_GE(max_speed, 0.15) << TrajectoryKindName(kind) << " " << frames;
      }
    }
  }
  // The exposure interval of motion blur reaches beyond [0, duration]: the
  // path is periodic, so poses there are those of the other end.
  const CameraPath path(TrajectoryKind::kSweep, 10.0);
  EXPECT_LT((path.T_world_cam(-0.01).translation - path.T_world_cam(9.99).translation).norm(),
            1e-12);
}

TEST(CameraPath, CameraKeepsClearOfEverySurface) {
  SceneOptions options;
  options.texel_size = 0.05;  // Geometry only: coarse textures build fast.
  const Scene scene = Scene::StandardRoom(options);
  for (TrajectoryKind kind : kAllKinds) {
    for (int frames : kFrameCounts) {
      for (const auto& pose : MakeTrajectory(kind, frames, 30.0)) {
        const Eigen::Vector3d& c = pose.T_world_cam.translation;
        EXPECT_GE(scene.DistanceToNearestSurface(c), 0.5) << TrajectoryKindName(kind) << frames;
        // Inside the room: the floor is below and the ceiling above.
        ASSERT_TRUE(c.x() > -3 && c.x() < 3 && c.y() > -2.5 && c.y() < 2.5 && c.z() > 0 &&
                    c.z() < 3);
        // Nothing within 0.5 m straight ahead.
        const auto hit = scene.RayCast(c, Forward(pose.T_world_cam));
        ASSERT_TRUE(hit.has_value());
        EXPECT_GE(hit->distance, 0.5);
      }
    }
  }
}

// Angles (degrees) between consecutive poses, sorted.
std::vector<double> SortedTurnsDeg(const Trajectory& t) {
  std::vector<double> turns;
  for (size_t i = 1; i < t.size(); ++i) {
    turns.push_back(RotationAngle(t[i].T_world_cam.rotation, t[i - 1].T_world_cam.rotation) / kDeg);
  }
  std::sort(turns.begin(), turns.end());
  return turns;
}

TEST(CameraPath, ShakeTurnsTwoToFourDegreesPerFrameAt30Hz) {
  // The figures: 600 frames at 30 Hz turn 2 to 4 degrees from frame
  // to frame (60 to 120 deg/s), never much more; the tremor's jerk spreads
  // them a little (85% within 2 to 4 degrees).
  const std::vector<double> turns = SortedTurnsDeg(MakeTrajectory(TrajectoryKind::kShake, 600, 30));
  ASSERT_EQ(turns.size(), 599u);
  const double median = turns[turns.size() / 2];
  EXPECT_GE(median, 2.5);
  EXPECT_LE(median, 3.2);
  EXPECT_GE(turns.front(), 1.2);
  EXPECT_LE(turns.back(), 4.7);
  const auto in_range =
      std::count_if(turns.begin(), turns.end(), [](double turn) { return turn >= 2 && turn <= 4; });
  EXPECT_GE(in_range, 0.85 * turns.size()) << "median " << median;

  // The same speeds for every duration (the amplitudes follow the duration).
  for (int frames : kFrameCounts) {
    if (frames < 10) continue;
    const std::vector<double> t =
        SortedTurnsDeg(MakeTrajectory(TrajectoryKind::kShake, frames, 30));
    EXPECT_GE(t[t.size() / 2], 2.0) << frames;
    EXPECT_LE(t[t.size() / 2], 4.0) << frames;
    EXPECT_LE(t.back(), 4.7) << frames;
  }
}

// A hand's tremor: a constant-velocity prediction (the last frame-to-frame
// rotation applied again) misses the next rotation by over half a degree in
// the median, as on real hand-held sequences, where smooth synthetic paths
// are predicted almost exactly.
TEST(CameraPath, ShakeIsJerkyForAConstantVelocityPrediction) {
  const Trajectory t = MakeTrajectory(TrajectoryKind::kShake, 600, 30);
  std::vector<double> misses;
  for (size_t i = 2; i < t.size(); ++i) {
    const Eigen::Quaterniond& q0 = t[i - 2].T_world_cam.rotation;
    const Eigen::Quaterniond& q1 = t[i - 1].T_world_cam.rotation;
    const Eigen::Quaterniond predicted = q1 * (q0.conjugate() * q1);
    misses.push_back(RotationAngle(predicted, t[i].T_world_cam.rotation) / kDeg);
  }
  std::sort(misses.begin(), misses.end());
  EXPECT_GE(misses[misses.size() / 2], 0.6);
  EXPECT_LE(misses.back(), 2.5);
}

TEST(CameraPath, ShakeStaysNearItsCentreAndLooksAtTheEastWall) {
  for (int frames : kFrameCounts) {
    const Trajectory t = MakeTrajectory(TrajectoryKind::kShake, frames, 30.0);
    // Periodic: the last frame (t = duration) is back at the first's pose.
    EXPECT_LT((t.front().T_world_cam.translation - t.back().T_world_cam.translation).norm(), 1e-9)
        << frames;
    EXPECT_LT(RotationAngle(t.front().T_world_cam.rotation, t.back().T_world_cam.rotation), 1e-9)
        << frames;
    double max_offset = 0, max_yaw = 0, min_pitch = 0, max_pitch = -1, max_roll = 0;
    for (size_t i = 0; i < t.size(); ++i) {
      const Eigen::Matrix3d R = t[i].T_world_cam.RotationMatrix();
      // Hand tremor only: within a few centimetres of the nominal centre.
      max_offset = std::max(max_offset,
                            (t[i].T_world_cam.translation - Eigen::Vector3d(0.6, 0, 1.35)).norm());
      // Yaw of the optical axis about east (+x), pitch (positive up) and roll
      // (PoseFromAngles: the x axis tilts down by sin(roll) cos(pitch)).
      const Eigen::Vector3d f = R.col(2);
      max_yaw = std::max(max_yaw, std::fabs(std::atan2(f.y(), f.x())));
      min_pitch = std::min(min_pitch, std::asin(f.z()));
      max_pitch = std::max(max_pitch, std::asin(f.z()));
      max_roll = std::max(max_roll, std::fabs(std::atan2(-R(2, 0), -R(2, 1))));
      if (i > 0) {
        EXPECT_LE((t[i].T_world_cam.translation - t[i - 1].T_world_cam.translation).norm() * 30.0,
                  0.2)
            << frames;
      }
    }
    EXPECT_LE(max_offset, 0.04) << frames;
    EXPECT_LE(max_yaw, 40 * kDeg) << frames;
    EXPECT_GE(min_pitch, -28 * kDeg) << frames;
    EXPECT_LE(max_pitch, 12 * kDeg) << frames;
    EXPECT_LE(max_roll, 10 * kDeg) << frames;
    if (frames >= 300) {
      // A real shake: the centre trembles and the gaze sweeps most of the range.
      EXPECT_GE(max_offset, 0.01) << frames;
      EXPECT_GE(max_yaw, 30 * kDeg) << frames;
      EXPECT_GE(max_pitch - min_pitch, 25 * kDeg) << frames;
      EXPECT_GE(max_roll, 5 * kDeg) << frames;
    }
  }
}

TEST(CameraPath, ShakeLooksAtSurfacesWithinTheSensorsRange) {
  SceneOptions options;
  options.texel_size = 0.05;
  const Scene scene = Scene::StandardRoom(options);
  for (const auto& pose : MakeTrajectory(TrajectoryKind::kShake, 600, 30.0)) {
    const auto hit = scene.RayCast(pose.T_world_cam.translation, Forward(pose.T_world_cam));
    ASSERT_TRUE(hit.has_value());
    EXPECT_LE(hit->distance, 3.5);  // The optical axis meets a surface within Kinect range.
    // Looking at the room's walls, furniture and floor, never the ceiling.
    EXPECT_NE(scene.surface(hit->surface_id).name, "room.+z");
  }
}

}  // namespace
}  // namespace rrslam::synth
