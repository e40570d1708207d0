// Camera paths through the standard room (scene.h), and the tour of the
// building (building.h), with exact ground truth.
//
// A path is a smooth, periodic function of time: the pose at time t (seconds)
// for a sequence lasting `duration` seconds, with the first and the last
// instant at the same pose (loop) or at rest at the start (sweep and rotation
// swing back; shake is periodic). Poses are T_world_cam with the camera frame
// of camera.h (x right, y down, z forward) and the world frame of scene.h
// (z up).
//
// Speeds are those of a hand-held Kinect: translation at most ~0.4 m/s and
// angular speed at most 30 deg/s for every duration (paths scale with the
// duration, and long sequences repeat laps or cycles instead of speeding up
// or slowing to a crawl). The exception is shake, which exercises fast
// rotation: mostly 60 to 120 deg/s (2 to 4 degrees between frames at 30 fps),
// never above 135 deg/s, likewise for every duration. The camera stays in the
// free middle of the room, at least 0.5 m from every surface. The tour walks
// a little faster (up to about 0.5 m/s) and keeps 0.5 m from every surface of
// the building. Immutable; thread-safe.
#pragma once

#include <string>

#include "common/geometry.h"
#include "common/trajectory.h"

namespace rrslam::synth {

enum class TrajectoryKind {
  // A closed loop around the middle of the room (an ellipse with semi-axes
  // of up to 1.0 and 0.8 m, walked at 0.3 m/s). Sequences of at least 18 s per lap turn the camera
  // once around (it looks outward along the radius and sees every wall, so
  // returning to the start is a true loop closure); shorter ones keep looking
  // east with the gaze swinging up to +-50 deg. Ends exactly where it began.
  kLoop,
  // A back-and-forth sweep: 1.8 m east and back (shorter for short sequences;
  // several cycles for long ones), from rest to rest, looking north.
  kSweep,
  // A pure rotation in place: the camera centre never moves; it pans back and
  // forth (up to +-75 deg of yaw) with small pitch and roll swings.
  kRotation,
  // Fast hand-held shaking around a near-fixed centre: the camera stays
  // within 4 cm of (0.6, 0, 1.35) m (hand tremor) and looks east (+x) at the
  // table, the screen, the cabinet and the column, 8 deg down, while it
  // wobbles in yaw (within +-40 deg), pitch (+-18 deg) and roll (+-9 deg):
  // sums of sinusoids of unrelated frequencies per axis, dominated by an
  // elliptic wobble of yaw and pitch at about 0.9 Hz, with a hand's tremor
  // (25 deg/s at about 5 Hz) that a constant-velocity prediction cannot
  // follow (it misses by 0.86 deg in the median). At 30 fps: median 2.9
  // degrees between frames, 2 to 4 degrees for 88% of frames, at most 4.7,
  // for every duration. Periodic: the last
  // instant is at the first's pose. Rendered with motion blur by default
  // (SynthOptions::MotionBlur()).
  kShake,
  // A session that starts off the sweep's map and turns onto it: the camera
  // stands at (0, -0.4, 1.35) m (the middle of the sweep's track) looking
  // south (away from everything the sweep sees) for the first 15% of the
  // sequence, turns east and on to north (the sweep's view) over the next
  // 60% with a cosine profile of at most 20 deg/s, and looks north, swinging
  // a little, for the rest. Sequences shorter than 23.6 s start less than
  // 180 degrees from north (the turn's peak stays at 20 deg/s). The atlas's
  // test (track/module/atlas.h): a new map, then a merge into the sweep's.
  kTurn,
  // The tour of the building (SceneKind::kBuilding; building.h: the route):
  // a walk through all six rooms and back over the corridor's first stretch,
  // at a walking pace (at most about 0.5 m/s and 25 deg/s) with the camera
  // 1.4 m high (+-4 cm), pitched 12 deg down (+-3 deg) with +-1.6 deg of roll,
  // looking sideways or diagonally at walls and furniture. Unlike the paths
  // above it does not scale with the sequence: one tour lasts
  // BuildingTour::Get().duration() seconds (222.5 s, 6675 frames at 30 fps);
  // a shorter sequence walks the first part of it, a longer one walks it
  // again (the tour is periodic: its end is its start, with the same
  // velocity). Only valid in the building.
  kTour,
};

// "loop", "sweep", "rotation", "shake", "turn", "tour".
std::string TrajectoryKindName(TrajectoryKind kind);
// Parses a name of TrajectoryKindName; false when unknown.
bool ParseTrajectoryKind(const std::string& name, TrajectoryKind* kind);

class CameraPath {
 public:
  // `duration` in seconds (>= 0; 0 gives a single, static pose). The tour
  // ignores it (its period is one tour).
  CameraPath(TrajectoryKind kind, double duration);

  TrajectoryKind kind() const { return kind_; }
  double duration() const { return duration_; }

  // Camera pose at time t (seconds from the start). Defined for every t: the
  // path is periodic with period `duration` (the tour: one tour), so exposure
  // intervals around the first and last frames are well defined.
  Rigid3d T_world_cam(double t) const;

  // Camera pose from a centre and yaw (about world z, 0 = looking along +x),
  // pitch (positive up) and roll (about the optical axis), radians.
  static Rigid3d PoseFromAngles(const Eigen::Vector3d& centre_world, double yaw, double pitch,
                                double roll);

 private:
  // The tour's pose at t seconds (periodic with one tour's duration).
  static Rigid3d TourPose(double t);

  TrajectoryKind kind_;
  double duration_;
};

// Samples a path at `frames` instants t_i = i / fps (i = 0 .. frames - 1) over
// a duration of (frames - 1) / fps; timestamps are start_time + t_i.
// Consecutive quaternions have a non-negative dot product (no sign flips).
Trajectory MakeTrajectory(TrajectoryKind kind, int frames, double fps, double start_time = 0.0);

}  // namespace rrslam::synth
