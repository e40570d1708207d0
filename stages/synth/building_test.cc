#include "stages/synth/building.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "stages/synth/camera_path.h"
#include "stages/synth/scene.h"

namespace rrslam::synth {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kFps = 30.0;

// The building's geometry with coarse textures (built once: a few ms).
const Scene& Building() {
  static const Scene* scene = [] {
    SceneOptions options;
    options.texel_size = 0.05;
    return new Scene(Scene::Building(options));
  }();
  return *scene;
}

// One whole tour at 30 fps (the frame after the last is back at the first).
int TourFrames() { return static_cast<int>(std::ceil(BuildingTour::Get().duration() * kFps)); }
const Trajectory& Tour() {
  static const Trajectory* tour =
      new Trajectory(MakeTrajectory(TrajectoryKind::kTour, TourFrames(), kFps));
  return *tour;
}

Eigen::Vector3d Forward(const Rigid3d& T_world_cam) {
  return T_world_cam.rotation * Eigen::Vector3d::UnitZ();
}

// Whether a point is inside a box (its solid, for objects), with a margin.
bool Contains(const Box& box, const Eigen::Vector3d& point_world, double margin = 0.0) {
  const Eigen::Vector3d d = point_world - box.centre_world;
  const double c = std::cos(box.yaw), s = std::sin(box.yaw);
  const Eigen::Vector3d local(c * d.x() + s * d.y(), -s * d.x() + c * d.y(), d.z());
  return (local.cwiseAbs() - 0.5 * box.size).maxCoeff() < -margin;
}

TEST(Building, RoomsCorridorAndCeilingHaveTheirSizes) {
  const std::vector<BuildingRoom> rooms = BuildingRooms();
  ASSERT_EQ(rooms.size(), 7u);
  for (const BuildingRoom& room : rooms) {
    const Eigen::Vector2d size = room.floor.sizes();
    if (room.name == "corridor") {
      EXPECT_GE(size.y(), 1.8);
      EXPECT_LE(size.y(), 2.5);
      EXPECT_NEAR(size.x(), kBuildingLength, 1e-12);
    } else {
      EXPECT_GE(size.minCoeff(), 4.0) << room.name;
      EXPECT_LE(size.maxCoeff(), 6.0) << room.name;
    }
  }
  EXPECT_GE(kBuildingHeight, 2.7);
  EXPECT_LE(kBuildingHeight, 3.0);
  // No two rooms share floor: walls between them.
  for (size_t i = 0; i < rooms.size(); ++i) {
    for (size_t j = i + 1; j < rooms.size(); ++j) {
      EXPECT_GE(rooms[i].floor.exteriorDistance(rooms[j].floor), kWallThickness - 1e-9)
          << rooms[i].name << " " << rooms[j].name;
    }
  }
  EXPECT_EQ(BuildingLights().size(), 10u);  // One per room, four in the corridor.
}

TEST(Building, BoxesAreValidAndInsideTheBuilding) {
  const std::vector<Box> boxes = BuildingBoxes();
  ASSERT_GT(boxes.size(), 100u);
  EXPECT_EQ(boxes[0].name, "building");
  EXPECT_TRUE(boxes[0].inside);
  const Eigen::AlignedBox3d inside(
      Eigen::Vector3d::Zero(), Eigen::Vector3d(kBuildingLength, kBuildingWidth, kBuildingHeight));
  EXPECT_TRUE(BoxBounds(boxes[0]).isApprox(inside));
  std::set<std::string> names;
  for (size_t i = 1; i < boxes.size(); ++i) {
    const Box& box = boxes[i];
    EXPECT_TRUE(names.insert(box.name).second) << "duplicate " << box.name;
    EXPECT_FALSE(box.inside) << box.name;
    EXPECT_GT(box.size.minCoeff(), 0.0) << box.name;
    EXPECT_NE(box.hidden_faces, 0x3f) << box.name << " has no visible face";
    const Eigen::AlignedBox3d bounds = BoxBounds(box);
    EXPECT_TRUE(inside.contains(bounds.min() + Eigen::Vector3d::Constant(1e-9)) &&
                inside.contains(bounds.max() - Eigen::Vector3d::Constant(1e-9)))
        << box.name;
  }
}

// Boxes never overlap (walls meet end to end, furniture stands beside or on
// other boxes): the axis-aligned bounds of any two share no volume.
TEST(Building, BoxesMeetOnlyAtJoints) {
  const std::vector<Box> boxes = BuildingBoxes();
  for (size_t i = 1; i < boxes.size(); ++i) {
    const Eigen::AlignedBox3d a = BoxBounds(boxes[i]);
    for (size_t j = i + 1; j < boxes.size(); ++j) {
      const Eigen::AlignedBox3d common = a.intersection(BoxBounds(boxes[j]));
      if (common.isEmpty()) continue;
      EXPECT_LE(common.sizes().minCoeff(), 1e-9) << boxes[i].name << " and " << boxes[j].name;
    }
  }
}

// A face left without a surface (hidden) must touch something solid: the
// floor, the ceiling, an outer wall or another box. Otherwise a camera could
// look into a box through the missing face.
TEST(Building, HiddenFacesTouchAWallOrAnotherBox) {
  const std::vector<Box> boxes = BuildingBoxes();
  for (size_t i = 1; i < boxes.size(); ++i) {
    const Box& box = boxes[i];
    const double c = std::cos(box.yaw), s = std::sin(box.yaw);
    const Eigen::Vector3d axes[3] = {{c, s, 0}, {-s, c, 0}, {0, 0, 1}};
    for (int face = 0; face < 6; ++face) {
      if (!(box.hidden_faces & (1u << face))) continue;
      const Eigen::Vector3d outward = (face % 2 == 0 ? 1.0 : -1.0) * axes[face / 2];
      // The face's middle, 1 mm beyond it.
      const Eigen::Vector3d beyond = box.centre_world + (0.5 * box.size[face / 2] + 1e-3) * outward;
      bool solid = !Contains(boxes[0], beyond);  // Beyond the shell.
      for (size_t j = 1; j < boxes.size() && !solid; ++j) {
        solid = j != i && Contains(boxes[j], beyond);
      }
      EXPECT_TRUE(solid) << box.name << " face " << face;
    }
  }
}

TEST(Building, FurnitureLeavesTheRoomsMiddlesFree) {
  const std::vector<Box> boxes = BuildingBoxes();
  for (const BuildingRoom& room : BuildingRooms()) {
    if (room.name == "corridor") continue;
    for (size_t i = 1; i < boxes.size(); ++i) {
      const Eigen::AlignedBox3d b = BoxBounds(boxes[i]);
      if (b.min().z() > 2.2) continue;  // Lamp shades, lintels: above the camera.
      const Eigen::AlignedBox2d footprint(b.min().head<2>(), b.max().head<2>());
      EXPECT_GE(footprint.exteriorDistance(room.centre()), kRoomFreeRadius - 1e-9)
          << room.name << ": " << boxes[i].name;
    }
  }
}

// At the default 3 mm texels the building's textures take about 0.6 GB
// (mip-maps included), well below the 1.5 GB that would call for coarser
// texels on its large surfaces. Computed from the surfaces' sizes as
// MipTexture lays them out (checked against a real scene at coarse texels).
TEST(Building, TextureMemoryAtTheDefaultTexelSizeIsBounded) {
  auto bytes = [](const Scene& scene, double texel) {
    double total = 0;
    for (const Surface& s : scene.surfaces()) {
      int w = std::max(2, static_cast<int>(std::ceil(s.size_a / texel)));
      int h = std::max(2, static_cast<int>(std::ceil(s.size_b / texel)));
      for (;;) {
        total += 4.0 * w * h;
        if (w == 1 && h == 1) break;
        w = std::max(1, (w + 1) / 2), h = std::max(1, (h + 1) / 2);
      }
    }
    return total;
  };
  EXPECT_DOUBLE_EQ(bytes(Building(), 0.05), static_cast<double>(Building().TextureBytes()));
  const double at_default = bytes(Building(), SceneOptions().texel_size);
  EXPECT_GT(at_default, 0.4e9);
  EXPECT_LT(at_default, 0.8e9);
}

TEST(BuildingTour, IsClosedSmoothAndWalksSeveralMinutes) {
  const BuildingTour& tour = BuildingTour::Get();
  EXPECT_GE(tour.duration(), 150.0);
  EXPECT_LE(tour.duration(), 300.0);
  const Trajectory& t = Tour();
  // Ends at the start, moving on as it began: the next tour follows.
  const CameraPath path(TrajectoryKind::kTour, 0.0);
  const double T = tour.duration();
  for (double dt : {0.0, 1.0 / kFps, 0.5}) {
    EXPECT_LT((path.T_world_cam(T + dt).translation - path.T_world_cam(dt).translation).norm(),
              1e-9);
    EXPECT_LT(RotationAngle(path.T_world_cam(T + dt).rotation, path.T_world_cam(dt).rotation),
              1e-9);
  }
  for (size_t i = 1; i < t.size(); ++i) {
    ASSERT_GE(t[i].T_world_cam.rotation.dot(t[i - 1].T_world_cam.rotation), 0.0) << i;
  }
}

TEST(BuildingTour, WalksAtAWalkingPaceWithTheCameraAtChestHeight) {
  const Trajectory& t = Tour();
  std::vector<double> speeds;
  double max_turn_rate = 0;
  for (size_t i = 1; i < t.size(); ++i) {
    const double dt = t[i].timestamp - t[i - 1].timestamp;
    speeds.push_back((t[i].T_world_cam.translation - t[i - 1].T_world_cam.translation).norm() / dt);
    max_turn_rate =
        std::max(max_turn_rate,
                 RotationAngle(t[i].T_world_cam.rotation, t[i - 1].T_world_cam.rotation) / dt);
  }
  std::sort(speeds.begin(), speeds.end());
  EXPECT_LE(speeds.back(), 0.55);
  EXPECT_GE(speeds[speeds.size() / 2], 0.3);  // It walks, mostly at 0.4 to 0.5 m/s.
  EXPECT_LE(max_turn_rate, 30 * kDeg);
  for (const auto& pose : t) {
    const Eigen::Vector3d& c = pose.T_world_cam.translation;
    EXPECT_GE(c.z(), 1.3);
    EXPECT_LE(c.z(), 1.5);
    // Looking a little down, never up at the ceiling or down at the floor.
    const double pitch = std::asin(Forward(pose.T_world_cam).z());
    EXPECT_GE(pitch, -16 * kDeg);
    EXPECT_LE(pitch, -8 * kDeg);
  }
}

TEST(BuildingTour, KeepsClearOfSurfacesAndNeverCrossesAWall) {
  const Scene& scene = Building();
  const Trajectory& t = Tour();
  double min_clearance = 1e9;
  for (size_t i = 0; i < t.size(); ++i) {
    const Eigen::Vector3d& c = t[i].T_world_cam.translation;
    min_clearance = std::min(min_clearance, scene.DistanceToNearestSurface(c));
    if (i == 0) continue;
    // Nothing between consecutive camera centres (surfaces face both ways:
    // walls are boxes).
    const Eigen::Vector3d& previous = t[i - 1].T_world_cam.translation;
    const auto hit = scene.RayCast(previous, c - previous);
    EXPECT_FALSE(hit && hit->distance <= 1.0)
        << "crosses " << scene.surface(hit->surface_id).name << " at frame " << i;
  }
  EXPECT_GE(min_clearance, 0.5);
}

TEST(BuildingTour, EntersEveryRoom) {
  for (const BuildingRoom& room : BuildingRooms()) {
    const Eigen::AlignedBox2d well_inside(room.floor.min() + Eigen::Vector2d(0.5, 0.5),
                                          room.floor.max() - Eigen::Vector2d(0.5, 0.5));
    int frames = 0;
    for (const auto& pose : Tour()) {
      if (well_inside.contains(pose.T_world_cam.translation.head<2>())) ++frames;
    }
    EXPECT_GE(frames, 10 * kFps) << room.name;  // At least 10 s in each.
  }
}

// Fraction of a 16 x 12 grid of rays over a 640 x 480 Kinect image that
// meets a surface at a depth (z) in [0.3, 4] m.
double NearFraction(const Scene& scene, const Rigid3d& T_world_cam) {
  int near = 0;
  for (int gy = 0; gy < 12; ++gy) {
    for (int gx = 0; gx < 16; ++gx) {
      const Eigen::Vector3d ray_cam(((gx + 0.5) * 40 - 319.5) / 525,
                                    ((gy + 0.5) * 40 - 239.5) / 525, 1.0);
      const auto hit = scene.RayCast(T_world_cam.translation, T_world_cam.rotation * ray_cam);
      if (hit && hit->distance >= 0.3 && hit->distance <= 4.0) ++near;
    }
  }
  return near / 192.0;
}

// Every view has textured surfaces within the sensor's range over most of
// the image: at least 80% of it but for 7 frames (a quarter of a second) at
// N2's doorway, where the camera turning to go in looks into the kitchen
// (79%).
TEST(BuildingTour, SeesSurfacesWithinFourMetresOverMostOfEveryView) {
  const Scene& scene = Building();
  int below_80 = 0;
  double worst = 1;
  for (const auto& pose : Tour()) {
    const double fraction = NearFraction(scene, pose.T_world_cam);
    worst = std::min(worst, fraction);
    if (fraction < 0.8) ++below_80;
  }
  EXPECT_GE(worst, 0.78);
  EXPECT_LE(below_80, 10);
}

// Loops can close: the tour comes back to where it was 20 s or more before,
// looking the same way, and does so within its first minute (1800 frames):
// first at 36.6 s, when the walk around N1's middle ends where it came in.
TEST(BuildingTour, RevisitsPlacesLookingTheSameWay) {
  const Trajectory& t = Tour();
  const int gap = static_cast<int>(20 * kFps);
  auto first_revisit = [&]() -> int {
    for (size_t j = gap; j < t.size(); ++j) {
      for (size_t i = 0; i + gap <= j; ++i) {
        const Rigid3d& a = t[i].T_world_cam;
        const Rigid3d& b = t[j].T_world_cam;
        if ((a.translation - b.translation).norm() <= 0.3 &&
            Forward(a).dot(Forward(b)) >= std::cos(20 * kDeg)) {
          return static_cast<int>(j);
        }
      }
    }
    return -1;
  };
  const int j = first_revisit();
  EXPECT_GE(j, 0);
  EXPECT_LT(j, 1800);
}

TEST(BuildingTour, ShortSequencesWalkItsStartLongOnesWalkItAgain) {
  const Trajectory& one = Tour();
  const Trajectory short_one = MakeTrajectory(TrajectoryKind::kTour, 300, kFps);
  for (size_t i = 0; i < short_one.size(); ++i) {
    EXPECT_LT((short_one[i].T_world_cam.translation - one[i].T_world_cam.translation).norm(),
              1e-12);
  }
  const int n = TourFrames();
  const Trajectory twice = MakeTrajectory(TrajectoryKind::kTour, 2 * n, kFps);
  const double T = BuildingTour::Get().duration();
  const CameraPath path(TrajectoryKind::kTour, 0.0);
  for (int i : {0, 100, n - 1}) {
    // Frame n + i is at i / fps + n / fps, i.e. one tour plus (n / fps - T) later.
    const Rigid3d expected = path.T_world_cam(i / kFps + n / kFps - T);
    EXPECT_LT((twice[n + i].T_world_cam.translation - expected.translation).norm(), 1e-9) << i;
  }
}

}  // namespace
}  // namespace rrslam::synth
