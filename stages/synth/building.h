// The building of rrslam-synth --scene building: one floor of six furnished
// rooms along a corridor, and the route of the tour (--trajectory tour,
// camera_path.h) that walks through all of them and comes back over places it
// has seen, so that loops close.
//
// World frame: metres, z up, the floor at z = 0. Plan (x east, y north;
// [ ] a doorway to the corridor, = a doorway between two rooms):
//
//   y = 12.6 +--------------+----------------+-------------+
//            |  N1 meeting  |   N2 kitchen   = N3 workshop |  y in [7.42, 12.6]
//            |  6.0 x 5.18  |   5.28 x 5.18  | 4.68 x 5.18 |
//   y = 7.42 +---------[ ]--+[ ]-------------+-----[ ]-----+
//            |   corridor, 16.2 x 2.3 m, y in [5.0, 7.3]    |
//   y = 4.88 +--------[ ]---+-------------[ ]+[ ]----------+
//            |  S1 office   =   S2 lounge    = S3 storage  |  y in [0, 4.88]
//            |  5.2 x 4.88  |   5.48 x 4.88  | 5.28 x 4.88 |
//   y = 0    +--------------+----------------+-------------+
//          x = 0       5.2 | 5.32      10.8 | 10.92      16.2
//   (north rooms: N1 x in [0, 6.0], N2 [6.12, 11.4], N3 [11.52, 16.2])
//
// The ceiling is 2.8 m high. Inner walls are 0.12 m thick boxes (seen from
// both sides) with doorways 1.2 m wide and 2.1 m high (a lintel above); the
// floor, the ceiling and the outer walls are one inside-box. Each room's
// doorway to the corridor is near one of its corners; S1-S2, S2-S3 and N2-N3
// are joined by doorways too. Every room has its own furniture (tables,
// cabinets, shelves, crates, posters) along its walls, leaving its middle
// (kRoomFreeRadius around BuildingRoom::centre()) free for the camera; the
// corridor has cabinets, a bench and notice boards. One point light (under a
// lamp shade) in the middle of each room, four along the corridor.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "stages/synth/scene.h"

namespace rrslam::synth {

// Extent of the building inside its outer walls, metres.
inline constexpr double kBuildingLength = 16.2;  // x in [0, 16.2].
inline constexpr double kBuildingWidth = 12.6;   // y in [0, 12.6].
inline constexpr double kBuildingHeight = 2.8;   // z in [0, 2.8]: floor to ceiling.
// Inner walls and doorways, metres.
inline constexpr double kWallThickness = 0.12;
inline constexpr double kDoorWidth = 1.2;
inline constexpr double kDoorHeight = 2.1;
// No furniture comes closer than this (metres, horizontally) to a room's centre.
inline constexpr double kRoomFreeRadius = 1.7;

// A room or the corridor: its floor inside its walls (world x, y; metres).
struct BuildingRoom {
  std::string name;  // "S1", "S2", "S3", "N1", "N2", "N3", "corridor".
  Eigen::AlignedBox2d floor;
  Eigen::Vector2d centre() const { return floor.center(); }
};

// The six rooms (S1, S2, S3, N1, N2, N3), then the corridor.
std::vector<BuildingRoom> BuildingRooms();

// The boxes of the building: first the inside-box "building" (floor,
// ceiling, outer walls), then the inner walls (segments and lintels, named
// "wall.*"), then the furniture, lamp shades and posters of each room and of
// the corridor (named "<room>.*").
std::vector<Box> BuildingBoxes();

// The point lights: one 0.3 m under the ceiling in the middle of each room,
// four along the corridor.
std::vector<PointLight> BuildingLights();

// The route of the tour: where the camera is and which way it looks, as a
// function of time; camera_path.h adds the hand-held pitch, roll and height
// swings. A closed walk of 222.5 s (6675 frames at 30 fps) and 90 m at a
// walking pace: waypoints are timed for 0.45 m/s and 22 deg/s, and segments
// the spline would take faster are slowed so that no instant exceeds 0.5 m/s
// or 25 deg/s of yaw (median 0.42 m/s). Smooth: a cubic Hermite spline
// through the timed waypoints (continuous velocity and turn rate). The gaze
// is sideways or diagonal, at walls and furniture; doorways are passed
// straight through their middle (0.6 m from the jambs), looking diagonally at
// the wall or furniture nearest beyond them. In the corridor the camera
// looks diagonally at one wall, never down the corridor, and turns from one
// wall to the other only at the corridor's west end or inside a room.
//
// Route (seconds from the start):
//     0  from the corridor's west end (2.0, 6.3) east, looking north-east,
//        into N1 (9 s) and once around its middle, looking outward (20-37 s);
//    47  back out, west to the corridor's end and round: at 59 s the camera
//        passes the start again, looking the same way (a revisit);
//    59  east again over the first stretch, into N2 (73 s), most of the way
//        round (230 deg, 79-89 s);
//    94  through the doorway into N3, round (270 deg, 101-114 s), out into
//        the corridor (118 s) and across into S3 (127 s), once around and
//        on (420 deg, 133-153 s);
//   158  through the doorway into S2, round (230 deg, 165-175 s), through the
//        doorway into S1 (180 s), once around and on (460 deg, 187-208 s);
//   212  out into the corridor, west to its end and round to the start.
// The last instant is at the first's place, moving the same way, so the
// route repeats seamlessly.
class BuildingTour {
 public:
  // A place the route passes through: position (world x, y; metres) and gaze
  // yaw (radians about world z, 0 = looking east, pi / 2 north; unwrapped:
  // consecutive waypoints differ by the turn actually made) at `time`.
  struct Waypoint {
    Eigen::Vector2d position = Eigen::Vector2d::Zero();
    double yaw = 0;
    double time = 0;  // Seconds from the start of the tour.
  };
  // Where the camera is and which way it looks (as Waypoint, without time).
  struct Place {
    Eigen::Vector2d position = Eigen::Vector2d::Zero();
    double yaw = 0;
  };

  // The tour of the building (built once; thread-safe).
  static const BuildingTour& Get();

  // Duration of one tour, seconds; the last waypoint is the first again.
  double duration() const { return waypoints_.back().time; }
  const std::vector<Waypoint>& waypoints() const { return waypoints_; }

  // The place at time t seconds; periodic with period duration().
  Place At(double t) const;

 private:
  BuildingTour();
  // Sets tangents_ from the waypoints and their times.
  void ComputeTangents();
  // (x, y, yaw) on segment i (waypoints i to i + 1) at s in [0, 1] of it, or
  // its time derivative.
  Eigen::Vector3d Hermite(size_t i, double s, bool derivative) const;
  // The largest ratio of speed to kMaxSpeed or of turn rate to kMaxTurnRate
  // (building.cc) on segment i.
  double SegmentExcess(size_t i) const;

  std::vector<Waypoint> waypoints_;
  // Time derivatives of (x, y, yaw) at each waypoint: m/s, m/s, rad/s.
  std::vector<Eigen::Vector3d> tangents_;
};

}  // namespace rrslam::synth
