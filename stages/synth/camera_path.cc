#include "stages/synth/camera_path.h"

#include <algorithm>
#include <cmath>

#include "stages/synth/building.h"

namespace rrslam::synth {
namespace {

constexpr double kTwoPi = 2.0 * M_PI;
constexpr double kDeg = M_PI / 180.0;

// Speed budgets. The main motion of every path peaks at kMainSpeed (m/s) or
// kMainTurnRate (rad/s); the hand-held swings add at most their own budgets,
// so the total stays below 0.4 m/s and 30 deg/s.
constexpr double kMainSpeed = 0.3;
constexpr double kMainTurnRate = 20.0 * kDeg;

// Below this lap duration the loop cannot turn the camera once around within
// kMainTurnRate, so it keeps looking one way.
constexpr double kFullTurnLap = 18.0;

// A periodic swing amplitude * sin(2 pi m s + phase) over a sequence of
// duration T (s = t / T): m = round(frequency * T) >= 1 whole cycles (so the
// path stays periodic), amplitude capped so that the peak rate
// amplitude * 2 pi m / T stays within `rate_budget`.
double Swing(double s, double duration, double amplitude, double frequency, double rate_budget,
             double phase) {
  const double m = std::max(1.0, std::round(frequency * duration));
  const double a = std::min(amplitude, rate_budget * duration / (kTwoPi * m));
  return a * std::sin(kTwoPi * m * s + phase);
}

}  // namespace

std::string TrajectoryKindName(TrajectoryKind kind) {
  switch (kind) {
    case TrajectoryKind::kLoop:
      return "loop";
    case TrajectoryKind::kSweep:
      return "sweep";
    case TrajectoryKind::kRotation:
      return "rotation";
    case TrajectoryKind::kShake:
      return "shake";
    case TrajectoryKind::kTurn:
      return "turn";
    case TrajectoryKind::kTour:
      return "tour";
  }
  return "unknown";
}

bool ParseTrajectoryKind(const std::string& name, TrajectoryKind* kind) {
  for (TrajectoryKind k : {TrajectoryKind::kLoop, TrajectoryKind::kSweep, TrajectoryKind::kRotation,
                           TrajectoryKind::kShake, TrajectoryKind::kTurn, TrajectoryKind::kTour}) {
    if (name == TrajectoryKindName(k)) {
      *kind = k;
      return true;
    }
  }
  return false;
}

CameraPath::CameraPath(TrajectoryKind kind, double duration)
    : kind_(kind), duration_(std::max(0.0, duration)) {}

Rigid3d CameraPath::PoseFromAngles(const Eigen::Vector3d& centre_world, double yaw, double pitch,
                                   double roll) {
  const Eigen::Vector3d forward(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw),
                                std::sin(pitch));
  const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  // Roll turns the image clockwise as seen by the camera for positive angles.
  const Eigen::Vector3d right_rolled = std::cos(roll) * right + std::sin(roll) * down;
  const Eigen::Vector3d down_rolled = -std::sin(roll) * right + std::cos(roll) * down;
  Eigen::Matrix3d R_world_cam;
  R_world_cam.col(0) = right_rolled;
  R_world_cam.col(1) = down_rolled;
  R_world_cam.col(2) = forward;
  return Rigid3d(Eigen::Quaterniond(R_world_cam).normalized(), centre_world);
}

Rigid3d CameraPath::T_world_cam(double t) const {
  if (kind_ == TrajectoryKind::kTour) return TourPose(t);
  const double T = duration_;
  const double s = T > 0 ? t / T : 0.0;  // Phase; the path has period 1 in s.
  // Hand-held swings shared by all paths: pitch, roll and a little height.
  const double pitch_swing = Swing(s, T, 6 * kDeg, 0.1, 4 * kDeg, 0.7);
  const double roll = Swing(s, T, 3 * kDeg, 0.2, 2 * kDeg, 2.1);
  const double yaw_swing = Swing(s, T, 5 * kDeg, 0.15, 3 * kDeg, 4.0);
  const double bob = Swing(s, T, 0.06, 0.12, 0.04, 1.3);

  switch (kind_) {
    case TrajectoryKind::kLoop: {
      const double laps = T >= kFullTurnLap ? std::floor(T / kFullTurnLap) : 1.0;
      const double lap = T / laps;
      const double rx = std::min(1.0, kMainSpeed * lap / kTwoPi), ry = 0.8 * rx;
      const double theta = kTwoPi * laps * s;
      const Eigen::Vector3d centre(rx * std::cos(theta), ry * std::sin(theta), 1.3 + bob);
      double yaw;
      if (lap >= kFullTurnLap) {
        yaw = theta;  // Looking outward: once around the room per lap.
      } else {
        const double amplitude = std::min(50 * kDeg, kMainTurnRate * lap / kTwoPi);
        yaw = amplitude * std::sin(theta);
      }
      return PoseFromAngles(centre, yaw + yaw_swing, -10 * kDeg + pitch_swing, roll);
    }
    case TrajectoryKind::kSweep: {
      const double cycles = std::max(1.0, std::floor(T / 16.0));
      const double cycle = T / cycles;
      // Peak speed of the cosine profile is pi * length / cycle.
      const double length = std::min(1.8, 0.4 * cycle / M_PI);
      const double d = 0.5 * length * (1.0 - std::cos(kTwoPi * cycles * s));
      const double lateral = Swing(s, T, 0.08, 0.1, 0.03, 0.4);
      const Eigen::Vector3d centre(-0.9 + d, -0.4 + lateral, 1.35 + bob);
      const double yaw = 90 * kDeg + Swing(s, T, 12 * kDeg, 0.1, 5 * kDeg, 0.0) + yaw_swing;
      return PoseFromAngles(centre, yaw, -12 * kDeg + pitch_swing, roll);
    }
    case TrajectoryKind::kRotation: {
      const double cycles = std::max(1.0, std::floor(T / 16.0));
      const double cycle = T / cycles;
      const double amplitude = std::min(75 * kDeg, kMainTurnRate * cycle / kTwoPi);
      const double yaw = 45 * kDeg + amplitude * std::sin(kTwoPi * cycles * s) + yaw_swing;
      return PoseFromAngles(Eigen::Vector3d(0.2, 0.1, 1.35), yaw, -8 * kDeg + pitch_swing, roll);
    }
    case TrajectoryKind::kTurn: {
      // The turn takes 60% of the sequence; its cosine profile peaks at
      // pi / 2 * angle / turn, at most kMainTurnRate.
      const double turn = 0.6 * T;
      const double angle = std::min(180 * kDeg, kMainTurnRate * turn * 2.0 / M_PI);
      const double u = std::clamp((s - 0.15) / 0.6, 0.0, 1.0);
      const double yaw = 90 * kDeg - angle * 0.5 * (1.0 + std::cos(M_PI * u)) + yaw_swing;
      return PoseFromAngles(Eigen::Vector3d(0.0, -0.4, 1.35 + bob), yaw, -10 * kDeg + pitch_swing,
                            roll);
    }
    case TrajectoryKind::kTour:
      break;  // TourPose above.
    case TrajectoryKind::kShake: {
      // Every term is a Swing: a whole number of cycles per sequence (so the
      // path is periodic) at about its frequency (Hz; unrelated to the other
      // terms' so that they do not lock together). Its amplitude is its peak
      // rate (rad/s or m/s) over 2 pi times the actual frequency; the caps
      // exceed rate / (2 pi frequency), so the rates bind at nearly every
      // duration and the speeds do not depend on it.
      // The main term is an elliptic wobble of yaw and pitch (same
      // frequency, a quarter cycle apart) at 85 and 76 deg/s; a hand's
      // tremor adds 25 deg/s of yaw and pitch at about 5 Hz (10 deg/s of roll
      // at 4 Hz), whose jerk a constant-velocity prediction cannot follow:
      // it misses the next frame's rotation by 0.86 deg in the median (8 px
      // at 525 px focal length) and 1.4 deg at the 90th percentile. The angle
      // between frames at 30 fps stays within about 1.3 to 4.4 deg (median
      // 2.9 deg, 88% of frames within 2 to 4 deg, for 600 frames).
      // Amplitudes add up to at most 40 deg of yaw, 18 deg of pitch and 9 deg
      // of roll.
      const double yaw = Swing(s, T, 22 * kDeg, 0.11, 14 * kDeg, 0.3) +          // Slow drift.
                         Swing(s, T, 16 * kDeg, 0.9, 85 * kDeg, 0.0) +           // Main wobble.
                         Swing(s, T, 2 * kDeg, 4.7, 25 * kDeg, 1.1);             // Tremor.
      const double pitch = Swing(s, T, 16 * kDeg, 0.9, 76 * kDeg, 0.5 * M_PI) +  // Main wobble.
                           Swing(s, T, 2 * kDeg, 5.3, 25 * kDeg, 1.1 - 0.5 * M_PI);
      const double roll_shake =
          Swing(s, T, 8 * kDeg, 0.67, 24 * kDeg, 2.5) + Swing(s, T, 1 * kDeg, 3.9, 10 * kDeg, 0.6);
      // Hand tremor of the centre: at most 2.1 cm per axis (3.4 cm in all),
      // at most 0.15 m/s.
      const Eigen::Vector3d tremor(
          Swing(s, T, 0.015, 0.53, 0.05, 0.9) + Swing(s, T, 0.006, 1.21, 0.04, 2.7),
          Swing(s, T, 0.015, 0.61, 0.05, 4.2) + Swing(s, T, 0.006, 1.47, 0.04, 0.2),
          Swing(s, T, 0.012, 0.47, 0.035, 1.9) + Swing(s, T, 0.005, 1.13, 0.03, 5.1));
      // The centre is 1.15 m from the table and 2.4 m from the east wall, so
      // that most of the view is within the sensor's reliable depth range
      // (ThDepth, 3 m).
      return PoseFromAngles(Eigen::Vector3d(0.6, 0.0, 1.35) + tremor, yaw, -8 * kDeg + pitch,
                            roll_shake);
    }
  }
  return Rigid3d();
}

Rigid3d CameraPath::TourPose(double t) {
  // The route gives the place and the gaze's yaw; the hand-held swings are
  // whole cycles per tour (so the tour stays periodic), as for the other
  // paths, with the tour's period as the duration.
  const BuildingTour& tour = BuildingTour::Get();
  const double T = tour.duration();
  const double s = t / T;
  const BuildingTour::Place place = tour.At(t);
  const double pitch_swing = Swing(s, T, 3 * kDeg, 0.1, 3 * kDeg, 0.7);
  const double roll = Swing(s, T, 2 * kDeg, 0.2, 2 * kDeg, 2.1);
  const double bob = Swing(s, T, 0.04, 0.12, 0.04, 1.3);
  const Eigen::Vector3d centre(place.position.x(), place.position.y(), 1.4 + bob);
  return PoseFromAngles(centre, place.yaw, -12 * kDeg + pitch_swing, roll);
}

Trajectory MakeTrajectory(TrajectoryKind kind, int frames, double fps, double start_time) {
  Trajectory trajectory;
  if (frames <= 0) return trajectory;
  const CameraPath path(kind, (frames - 1) / fps);
  trajectory.reserve(frames);
  for (int i = 0; i < frames; ++i) {
    const double t = i / fps;
    Rigid3d pose = path.T_world_cam(t);
    // q and -q are the same rotation: keep the sign continuous along the
    // path, as a tracker's output would be.
    if (i > 0 && pose.rotation.dot(trajectory.back().T_world_cam.rotation) < 0) {
      pose.rotation.coeffs() = -pose.rotation.coeffs();
    }
    trajectory.push_back({start_time + t, pose});
  }
  return trajectory;
}

}  // namespace rrslam::synth
