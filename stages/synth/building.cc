#include "stages/synth/building.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace rrslam::synth {
namespace {

using V2 = Eigen::Vector2d;
using V3 = Eigen::Vector3d;
constexpr double kRadPerDeg = M_PI / 180.0;
constexpr double kCorridorY0 = 5.3, kCorridorY1 = 7.3;     // Corridor floor, y in [5.3, 7.3].
constexpr double kSouthY1 = kCorridorY0 - kWallThickness;  // South rooms: y in [0, 5.18].
constexpr double kNorthY0 = kCorridorY1 + kWallThickness;  // North rooms: y in [7.42, 12.6].

// The doorways' middles, metres along their walls: to the corridor (x, on
// the corridor's south and north walls), and between rooms (y, on the
// partitions between S1 and S2, S2 and S3, N2 and N3, whose west faces are at
// x = kWallS1S2, ...).
constexpr double kDoorS1 = 3.5, kDoorS2 = 9.9, kDoorS3 = 11.8;
constexpr double kDoorN1 = 5.1, kDoorN2 = 7.6, kDoorN3 = 14.8;
constexpr double kWallS1S2 = 5.2, kWallS2S3 = 10.8, kWallN1N2 = 6.0, kWallN2N3 = 11.4;
constexpr double kDoorS1S2 = 0.9, kDoorS2S3 = 0.9, kDoorN2N3 = kNorthY0 + 0.9;

// A doorway in a wall: its extent along the wall, metres.
struct Doorway {
  double from, to;
};

// Adds an inner wall of thickness kWallThickness running along world x
// (axis 0) or y (axis 1) from `from` to `to`, its other horizontal extent
// starting at `side` (e.g. y in [side, side + 0.12] for a wall along x):
// floor-to-ceiling segments between the doorways and a lintel above each.
// The wall's two ends touch other walls, so their faces are hidden; the
// faces beside a doorway (the jambs) are seen.
void AddWall(std::vector<Box>* boxes, const std::string& name, int axis, double from, double to,
             double side, const std::vector<Doorway>& doors) {
  const uint8_t end_lo = axis == 0 ? kFaceNegX : kFaceNegY;
  const uint8_t end_hi = axis == 0 ? kFacePosX : kFacePosY;
  auto add = [&](const std::string& part, double lo, double hi, double z0, double z1,
                 uint8_t hidden) {
    const double mid = 0.5 * (lo + hi), across = side + 0.5 * kWallThickness;
    const V3 centre =
        axis == 0 ? V3(mid, across, 0.5 * (z0 + z1)) : V3(across, mid, 0.5 * (z0 + z1));
    const V3 size =
        axis == 0 ? V3(hi - lo, kWallThickness, z1 - z0) : V3(kWallThickness, hi - lo, z1 - z0);
    boxes->push_back(Box::Object(name + "." + part, centre, size, Material::kWall, 0.0,
                                 hidden | kFacePosZ | (z0 == 0 ? kFaceNegZ : 0)));
  };
  double start = from;
  for (size_t i = 0; i <= doors.size(); ++i) {
    const double end = i < doors.size() ? doors[i].from : to;
    const uint8_t hidden = (start == from ? end_lo : 0) | (end == to ? end_hi : 0);
    add("seg" + std::to_string(i), start, end, 0.0, kBuildingHeight, hidden);
    if (i < doors.size()) {
      add("lintel" + std::to_string(i), doors[i].from, doors[i].to, kDoorHeight, kBuildingHeight,
          end_lo | end_hi);
      start = doors[i].to;
    }
  }
}

// The inside-box: floor, ceiling and outer walls.
Box Shell() {
  Box shell;
  shell.name = "building";
  shell.centre_world = V3(0.5 * kBuildingLength, 0.5 * kBuildingWidth, 0.5 * kBuildingHeight);
  shell.size = V3(kBuildingLength, kBuildingWidth, kBuildingHeight);
  shell.inside = true;
  shell.materials = {Material::kWall, Material::kWall,    Material::kWall,
                     Material::kWall, Material::kCeiling, Material::kFloor};
  return shell;
}

// Corridor walls (along x) and the partitions between rooms (along y).
void AddInnerWalls(std::vector<Box>* boxes) {
  const double half = 0.5 * kDoorWidth;
  auto door = [half](double centre) { return Doorway{centre - half, centre + half}; };
  AddWall(boxes, "wall.corridor_south", 0, 0.0, kBuildingLength, kSouthY1,
          {door(kDoorS1), door(kDoorS2), door(kDoorS3)});
  AddWall(boxes, "wall.corridor_north", 0, 0.0, kBuildingLength, kCorridorY1,
          {door(kDoorN1), door(kDoorN2), door(kDoorN3)});
  // Doorways between rooms are in their southern corners, so that a room's
  // walk around its middle sees through them only obliquely (the far side
  // is the next room's south wall, near).
  AddWall(boxes, "wall.s1_s2", 1, 0.0, kSouthY1, kWallS1S2, {door(kDoorS1S2)});
  AddWall(boxes, "wall.s2_s3", 1, 0.0, kSouthY1, kWallS2S3, {door(kDoorS2S3)});
  AddWall(boxes, "wall.n1_n2", 1, kNorthY0, kBuildingWidth, kWallN1N2, {});
  AddWall(boxes, "wall.n2_n3", 1, kNorthY0, kBuildingWidth, kWallN2N3, {door(kDoorN2N3)});
}

// Furniture helpers. Positions are box centres (x, y) on the floor plan and
// sizes (x, y, z), metres; `hidden` adds faces that touch a wall.

// A box standing on the floor.
Box OnFloor(const std::string& name, double x, double y, const V3& size, Material material,
            double yaw_deg = 0.0, uint8_t hidden = 0) {
  return Box::Object(name, V3(x, y, 0.5 * size.z()), size, material, yaw_deg * kRadPerDeg,
                     kFaceNegZ | hidden);
}

// A box resting on a surface `z` metres high (a table top, another box).
Box OnTop(const std::string& name, double x, double y, double z, const V3& size, Material material,
          double yaw_deg = 0.0) {
  return Box::Object(name, V3(x, y, z + 0.5 * size.z()), size, material, yaw_deg * kRadPerDeg,
                     kFaceNegZ);
}

// A thin panel (poster, whiteboard, notice board) flush with a wall; `hidden`
// is its face against the wall.
Box OnWall(const std::string& name, double x, double y, double z, const V3& size, uint8_t hidden) {
  return Box::Object(name, V3(x, y, z), size, Material::kPoster, 0.0, hidden);
}

// A table: a 5 cm top whose upper face is `height` metres high, on four legs
// 6 cm square set 5 cm in from its corners.
void AddTable(std::vector<Box>* boxes, const std::string& name, double x, double y, double size_x,
              double size_y, double height, Material material) {
  boxes->push_back(
      Box::Object(name + ".top", V3(x, y, height - 0.025), V3(size_x, size_y, 0.05), material));
  const double leg_x = 0.5 * size_x - 0.08, leg_y = 0.5 * size_y - 0.08;
  for (int i = 0; i < 4; ++i) {
    const double lx = x + ((i & 1) ? leg_x : -leg_x), ly = y + ((i & 2) ? leg_y : -leg_y);
    boxes->push_back(Box::Object(name + ".leg" + std::to_string(i),
                                 V3(lx, ly, 0.5 * (height - 0.05)), V3(0.06, 0.06, height - 0.05),
                                 material, 0.0, kFaceNegZ | kFacePosZ));
  }
}

// A lamp shade under the ceiling above the light at (x, y).
Box Lamp(const std::string& name, double x, double y) {
  return Box::Object(name, V3(x, y, kBuildingHeight - 0.125), V3(0.45, 0.45, 0.25),
                     Material::kPainted, 0.0, kFacePosZ);
}

// S1, the office (x in [0, 5.2], y in [0, 5.18]): a desk with a screen along
// the west wall, a cabinet, a shelf, a bookcase, crates, a coat stand, a bin.
void AddOffice(std::vector<Box>* b) {
  AddTable(b, "s1.desk", 0.45, 2.3, 0.8, 1.6, 0.77, Material::kWood);
  b->push_back(OnTop("s1.screen", 0.22, 2.4, 0.77, V3(0.06, 0.62, 0.4), Material::kPoster));
  b->push_back(OnTop("s1.parcel", 0.55, 1.8, 0.77, V3(0.32, 0.24, 0.12), Material::kCardboard, 20));
  b->push_back(OnFloor("s1.cabinet", 0.55, 0.35, V3(1.1, 0.7, 1.9), Material::kPainted, 0,
                       kFaceNegX | kFaceNegY));
  b->push_back(
      OnFloor("s1.shelf", 2.9, 0.225, V3(1.6, 0.45, 1.6), Material::kPainted, 0, kFaceNegY));
  b->push_back(OnFloor("s1.bookcase", 1.9, 4.98, V3(1.4, 0.4, 2.0), Material::kWood, 0, kFacePosY));
  b->push_back(OnFloor("s1.crate0", 4.05, 0.35, V3(0.6, 0.6, 0.5), Material::kCardboard));
  b->push_back(OnTop("s1.crate1", 4.05, 0.37, 0.5, V3(0.45, 0.42, 0.35), Material::kCardboard, 12));
  b->push_back(OnFloor("s1.coat_stand", 4.8, 4.8, V3(0.5, 0.5, 1.6), Material::kWood, 10));
  b->push_back(OnFloor("s1.bin", 0.45, 4.5, V3(0.4, 0.5, 0.6), Material::kPainted, 25));
  b->push_back(OnWall("s1.poster_east", 5.19, 3.3, 1.6, V3(0.02, 0.9, 0.7), kFacePosX));
  b->push_back(OnWall("s1.poster_west", 0.01, 2.3, 1.7, V3(0.02, 1.2, 0.8), kFaceNegX));
  b->push_back(Lamp("s1.lamp", 2.6, 2.59));
}

// S2, the lounge (x in [5.32, 10.8], y in [0, 5.18]): a sofa along the south
// wall, a column, a cabinet, a bookshelf, crates and a plant.
void AddLounge(std::vector<Box>* b) {
  b->push_back(OnFloor("s2.sofa_seat", 7.6, 0.44, V3(2.0, 0.6, 0.44), Material::kPainted));
  b->push_back(
      OnFloor("s2.sofa_back", 7.6, 0.07, V3(2.0, 0.14, 1.0), Material::kPainted, 0, kFaceNegY));
  b->push_back(Box::Object("s2.column", V3(8.6, 4.88, 0.5 * kBuildingHeight),
                           V3(0.6, 0.6, kBuildingHeight), Material::kPainted, 0.0,
                           kFacePosY | kFaceNegZ | kFacePosZ));
  b->push_back(
      OnFloor("s2.cabinet", 10.525, 2.7, V3(0.55, 1.4, 1.9), Material::kPainted, 0, kFacePosX));
  b->push_back(
      OnFloor("s2.bookshelf", 6.9, 4.96, V3(1.8, 0.44, 2.0), Material::kWood, 0, kFacePosY));
  b->push_back(OnFloor("s2.crate0", 5.7, 3.3, V3(0.6, 0.6, 0.5), Material::kCardboard));
  b->push_back(OnTop("s2.crate1", 5.7, 3.3, 0.5, V3(0.5, 0.5, 0.4), Material::kCardboard, -8));
  b->push_back(OnFloor("s2.plant", 5.7, 4.4, V3(0.4, 0.4, 0.9), Material::kPainted, 15));
  b->push_back(OnWall("s2.poster_south", 7.6, 0.01, 1.65, V3(1.4, 0.02, 0.8), kFaceNegY));
  b->push_back(OnWall("s2.poster_west", 5.33, 2.2, 1.6, V3(0.02, 0.9, 1.0), kFaceNegX));
  b->push_back(OnWall("s2.poster_east", 10.79, 2.7, 2.3, V3(0.02, 1.0, 0.6), kFacePosX));
  b->push_back(Lamp("s2.lamp", 8.06, 2.59));
}

// S3, the storage room (x in [10.92, 16.2], y in [0, 5.18]): shelves along
// the east wall, crates along the south wall, a workbench, a barrel.
void AddStorage(std::vector<Box>* b) {
  b->push_back(
      OnFloor("s3.shelf0", 15.95, 1.3, V3(0.5, 1.8, 2.0), Material::kPainted, 0, kFacePosX));
  b->push_back(
      OnFloor("s3.shelf1", 15.975, 3.4, V3(0.45, 1.6, 1.6), Material::kWood, 0, kFacePosX));
  b->push_back(OnFloor("s3.crate0", 12.5, 0.3, V3(0.5, 0.5, 0.4), Material::kCardboard, 10));
  b->push_back(OnFloor("s3.crate1", 13.5, 0.35, V3(0.7, 0.6, 0.6), Material::kCardboard));
  b->push_back(OnTop("s3.crate2", 13.5, 0.35, 0.6, V3(0.5, 0.45, 0.4), Material::kCardboard, -12));
  b->push_back(OnFloor("s3.crate3", 14.5, 0.3, V3(0.55, 0.55, 0.5), Material::kCardboard, 5));
  AddTable(b, "s3.bench", 14.2, 4.83, 2.0, 0.7, 0.9, Material::kWood);
  b->push_back(OnTop("s3.toolbox", 14.0, 4.9, 0.9, V3(0.45, 0.25, 0.2), Material::kPainted, 8));
  b->push_back(OnFloor("s3.barrel", 11.3, 2.3, V3(0.5, 0.5, 0.8), Material::kPainted, 15));
  b->push_back(OnWall("s3.poster_west", 10.93, 3.4, 1.6, V3(0.02, 1.0, 0.7), kFaceNegX));
  b->push_back(OnWall("s3.poster_south", 12.8, 0.01, 1.8, V3(1.2, 0.02, 0.8), kFaceNegY));
  b->push_back(Lamp("s3.lamp", 13.56, 2.59));
}

// N1, the meeting room (x in [0, 6.0], y in [7.42, 12.6]): a long table
// along the north wall with two chairs, a whiteboard, a cabinet, a
// sideboard, a screen and a plant.
void AddMeetingRoom(std::vector<Box>* b) {
  AddTable(b, "n1.table", 2.6, 12.2, 2.6, 0.7, 0.74, Material::kWood);
  b->push_back(OnFloor("n1.chair0", 0.9, 12.1, V3(0.45, 0.45, 0.46), Material::kPainted, 10));
  b->push_back(OnFloor("n1.chair1", 4.3, 12.1, V3(0.45, 0.45, 0.46), Material::kPainted, -6));
  b->push_back(OnWall("n1.whiteboard", 0.01, 10.0, 1.5, V3(0.02, 1.8, 1.0), kFaceNegX));
  b->push_back(OnFloor("n1.cabinet", 0.45, 7.77, V3(0.9, 0.7, 1.5), Material::kPainted, 0,
                       kFaceNegX | kFaceNegY));
  // A tall cabinet 1.5 m inside the doorway: what a look in from the
  // corridor meets.
  b->push_back(
      OnFloor("n1.cabinet_east", 5.35, 9.3, V3(1.3, 0.4, 1.8), Material::kPainted, 0, kFacePosX));
  b->push_back(
      OnFloor("n1.sideboard", 5.75, 11.9, V3(0.5, 1.2, 0.9), Material::kWood, 0, kFacePosX));
  b->push_back(OnWall("n1.screen", 5.97, 10.2, 1.5, V3(0.06, 1.2, 0.7), kFacePosX));
  b->push_back(OnFloor("n1.plant", 0.25, 12.35, V3(0.5, 0.5, 1.0), Material::kPainted, 0,
                       kFaceNegX | kFacePosY));
  b->push_back(OnWall("n1.poster_south", 2.3, 7.43, 1.6, V3(1.4, 0.02, 0.8), kFaceNegY));
  b->push_back(Lamp("n1.lamp", 3.0, 10.01));
}

// N2, the kitchen (x in [6.12, 11.4], y in [7.42, 12.6]): a counter with
// wall cabinets above along the north wall, a fridge, a small table with
// a chair, a bin.
void AddKitchen(std::vector<Box>* b) {
  b->push_back(OnFloor("n2.counter", 8.3, 12.3, V3(3.4, 0.6, 0.9), Material::kWood, 0, kFacePosY));
  b->push_back(Box::Object("n2.wall_cabinets", V3(8.3, 12.425, 1.85), V3(3.4, 0.35, 0.7),
                           Material::kPainted, 0.0, kFacePosY));
  b->push_back(OnTop("n2.kettle", 7.4, 12.3, 0.9, V3(0.2, 0.2, 0.25), Material::kPainted, 30));
  b->push_back(OnFloor("n2.fridge", 11.05, 12.25, V3(0.7, 0.7, 1.9), Material::kPainted, 0,
                       kFacePosX | kFacePosY));
  AddTable(b, "n2.table", 10.8, 10.85, 0.7, 0.7, 0.75, Material::kWood);
  b->push_back(OnFloor("n2.chair", 10.8, 11.6, V3(0.45, 0.45, 0.46), Material::kPainted, 12));
  b->push_back(OnFloor("n2.bin", 6.45, 11.7, V3(0.4, 0.4, 0.7), Material::kPainted, 20));
  // A shelf beside the doorway: what a look in from the corridor meets.
  b->push_back(OnFloor("n2.shelf", 6.32, 9.2, V3(0.4, 1.6, 1.8), Material::kWood, 0, kFaceNegX));
  b->push_back(OnWall("n2.poster_west", 6.13, 10.6, 1.6, V3(0.02, 1.0, 0.8), kFaceNegX));
  b->push_back(OnWall("n2.poster_south", 9.0, 7.43, 1.7, V3(1.2, 0.02, 0.7), kFaceNegY));
  b->push_back(Lamp("n2.lamp", 8.76, 10.01));
}

// N3, the workshop (x in [11.52, 16.2], y in [7.42, 12.6]): a workbench
// along the north wall, a tool cabinet, a shelf, a column, crates, a drum.
void AddWorkshop(std::vector<Box>* b) {
  AddTable(b, "n3.bench", 13.6, 12.25, 2.4, 0.7, 0.9, Material::kWood);
  b->push_back(OnTop("n3.vise", 13.0, 12.3, 0.9, V3(0.3, 0.2, 0.18), Material::kPainted, -10));
  b->push_back(OnFloor("n3.tool_cabinet", 15.85, 12.1, V3(0.7, 1.0, 2.0), Material::kPainted, 0,
                       kFacePosX | kFacePosY));
  b->push_back(OnFloor("n3.shelf", 15.975, 9.6, V3(0.45, 1.6, 1.8), Material::kWood, 0, kFacePosX));
  b->push_back(Box::Object("n3.column", V3(11.82, 12.3, 0.5 * kBuildingHeight),
                           V3(0.6, 0.6, kBuildingHeight), Material::kPainted, 0.0,
                           kFaceNegX | kFacePosY | kFaceNegZ | kFacePosZ));
  b->push_back(OnFloor("n3.crate0", 12.9, 7.75, V3(0.6, 0.6, 0.5), Material::kCardboard));
  b->push_back(OnFloor("n3.drum", 13.7, 7.77, V3(0.5, 0.5, 0.9), Material::kPainted, 20));
  b->push_back(OnWall("n3.poster_west", 11.53, 11.5, 1.6, V3(0.02, 0.8, 0.8), kFaceNegX));
  b->push_back(OnWall("n3.poster_south", 13.2, 7.43, 1.7, V3(1.2, 0.02, 0.7), kFaceNegY));
  b->push_back(Lamp("n3.lamp", 13.86, 10.01));
}

// The corridor (x in [0, 16.2], y in [5.3, 7.3]): cabinets at both ends, a
// bench, a cabinet, a water cooler, a plant and notice boards.
void AddCorridor(std::vector<Box>* b) {
  b->push_back(OnFloor("corridor.cabinet_west", 0.25, 6.3, V3(0.5, 1.2, 1.2), Material::kPainted, 0,
                       kFaceNegX));
  b->push_back(
      OnFloor("corridor.shelf_east", 15.95, 6.3, V3(0.5, 1.4, 1.8), Material::kWood, 0, kFacePosX));
  // Across from N1's doorway: what a look out of N1 meets.
  b->push_back(OnFloor("corridor.cabinet_south", 6.0, 5.5, V3(1.2, 0.4, 1.9), Material::kWood, 0,
                       kFaceNegY));
  b->push_back(
      OnFloor("corridor.bench", 7.6, 5.52, V3(1.6, 0.44, 0.46), Material::kWood, 0, kFaceNegY));
  // Across from S2's and S3's doorways: what a look out of them meets.
  b->push_back(
      OnFloor("corridor.lockers", 10.9, 7.1, V3(3.0, 0.4, 1.9), Material::kPainted, 0, kFacePosY));
  b->push_back(OnFloor("corridor.cooler", 3.8, 7.125, V3(0.35, 0.35, 1.2), Material::kPainted, 0,
                       kFacePosY));
  b->push_back(
      OnFloor("corridor.plant", 15.0, 5.55, V3(0.5, 0.5, 1.0), Material::kPainted, 0, kFaceNegY));
  b->push_back(OnWall("corridor.board0", 2.3, 7.29, 1.55, V3(1.6, 0.02, 0.9), kFacePosY));
  b->push_back(OnWall("corridor.board1", 13.5, 7.29, 1.5, V3(1.2, 0.02, 0.8), kFacePosY));
  b->push_back(OnWall("corridor.board2", 1.9, 5.31, 1.6, V3(1.4, 0.02, 0.9), kFaceNegY));
  b->push_back(OnWall("corridor.board3", 7.6, 5.31, 1.5, V3(1.4, 0.02, 0.7), kFaceNegY));
  b->push_back(OnWall("corridor.board4", 13.8, 5.31, 1.55, V3(1.6, 0.02, 0.8), kFaceNegY));
  for (int i = 0; i < 4; ++i) {
    b->push_back(Lamp("corridor.lamp" + std::to_string(i), 2.0 + 4.0 * i, 6.3));
  }
}

// The route's pace: waypoints are timed so that the camera walks at most
// kWalkSpeed (m/s) and turns at most kTurnRate (rad/s) on average between
// two of them, and takes at least kMinStep (s) from one to the next.
constexpr double kWalkSpeed = 0.45;
constexpr double kTurnRate = 22.0 * kRadPerDeg;
constexpr double kMinStep = 0.5;
// Bounds at every instant (BuildingTour stretches the timing to keep them).
constexpr double kMaxSpeed = 0.5;                   // m/s.
constexpr double kMaxTurnRate = 25.0 * kRadPerDeg;  // rad/s.
// Radius of the walks around the rooms' middles, metres: kRoomFreeRadius
// minus 0.6 m of clearance.
constexpr double kCircleRadius = 1.1;

// Builds the route waypoint by waypoint (positions in metres, yaws in
// degrees as in the plan), timing each from the previous.
class RouteBuilder {
 public:
  RouteBuilder(double x, double y, double yaw_deg) {
    waypoints_.push_back({V2(x, y), yaw_deg * kRadPerDeg, 0.0});
  }

  // Walks to (x, y) while turning to look at yaw_deg, the shorter way round
  // (turns of more than 180 degrees take several waypoints).
  void To(double x, double y, double yaw_deg) {
    const BuildingTour::Waypoint& last = waypoints_.back();
    const double turn = std::remainder(yaw_deg * kRadPerDeg - last.yaw, 2 * M_PI);
    const V2 position(x, y);
    const double step = std::max(
        {(position - last.position).norm() / kWalkSpeed, std::fabs(turn) / kTurnRate, kMinStep});
    waypoints_.push_back({position, last.yaw + turn, last.time + step});
  }

  // Walks around a room's middle on a circle of kCircleRadius, looking
  // outward (yaw = the angle on the circle), from angle from_deg to to_deg
  // (counterclockwise when to_deg > from_deg), in steps of at most 45 deg.
  // Starts with a walk to the circle.
  void Around(const V2& centre, double from_deg, double to_deg) {
    const int steps = std::max(1, static_cast<int>(std::ceil(std::fabs(to_deg - from_deg) / 45.0)));
    for (int i = 0; i <= steps; ++i) {
      const double angle = from_deg + (to_deg - from_deg) * i / steps;
      const V2 p =
          centre + kCircleRadius * V2(std::cos(angle * kRadPerDeg), std::sin(angle * kRadPerDeg));
      To(p.x(), p.y(), angle);
    }
  }

  // Walks straight through a doorway (its middle `door`, crossing it along
  // the unit vector `direction`), from 0.45 m before it to 0.45 m after it,
  // looking at yaw_deg: the camera stays 0.6 m from the jambs.
  void Through(const V2& door, const V2& direction, double yaw_deg) {
    for (int k = -1; k <= 1; ++k) {
      const V2 p = door + 0.45 * k * direction;
      To(p.x(), p.y(), yaw_deg);
    }
  }

  std::vector<BuildingTour::Waypoint> Finish() const { return waypoints_; }

 private:
  std::vector<BuildingTour::Waypoint> waypoints_;
};

// The route (building.h). Doorways are passed in their middle, the gaze
// diagonally at the wall or furniture nearest beyond them (each doorway is
// near a corner); in the corridor the camera looks at the wall on one side
// and turns to the other only inside a room or at the corridor's west end,
// where looking along the corridor meets its end wall within 1.5 m.
std::vector<BuildingTour::Waypoint> TourWaypoints() {
  const std::vector<BuildingRoom> rooms = BuildingRooms();
  auto centre = [&rooms](const std::string& name) {
    for (const BuildingRoom& r : rooms) {
      if (r.name == name) return r.centre();
    }
    throw std::logic_error("TourWaypoints: no room " + name);
  };
  const double y = 0.5 * (kCorridorY0 + kCorridorY1);  // The corridor's middle, 6.3 m.
  // The middles of the walls with doorways, across them.
  const double half = 0.5 * kWallThickness;
  const double s_wall = kSouthY1 + half, n_wall = kCorridorY1 + half;
  const double s1_s2 = kWallS1S2 + half, s2_s3 = kWallS2S3 + half, n2_n3 = kWallN2N3 + half;
  const V2 north(0, 1), south(0, -1), east(1, 0), west(-1, 0);
  RouteBuilder route(2.0, y, 50);  // The start: walking east, looking north-east.
  // East into N1, once around it, back out and west, looking at the north
  // wall; round at the corridor's west end and east again over the first
  // stretch (a revisit).
  route.To(3.5, y, 50);
  route.Through(V2(kDoorN1, n_wall), north, 60);
  route.Around(centre("N1"), -90, 270);
  route.Through(V2(kDoorN1, n_wall), south, 60);
  route.To(4.2, y, 100);
  route.To(3.0, y, 130);
  route.To(1.3, y, 90);
  route.To(2.0, y, 50);
  route.To(3.5, y, 50);
  route.To(5.4, y, 60);
  // N2 (from the corridor), through the doorway into N3, out into the
  // corridor and across into S3.
  route.Through(V2(kDoorN2, n_wall), north, 130);
  route.Around(centre("N2"), 200, -30);
  route.Through(V2(n2_n3, kDoorN2N3), east, -45);
  route.Around(centre("N3"), -160, -430);
  route.Through(V2(kDoorN3, n_wall), south, -110);
  route.To(13.0, 6.2, -135);
  route.Through(V2(kDoorS3, s_wall), south, -135);
  // Once around S3, through the doorways into S2 and S1 (once around), out
  // into the corridor, west to its end and round to the start.
  route.Around(centre("S3"), 150, 570);
  route.Through(V2(s2_s3, kDoorS2S3), west, 220);
  route.Around(centre("S2"), 340, 571);
  route.Through(V2(s1_s2, kDoorS1S2), west, 225);
  route.Around(centre("S1"), 330, 790);
  route.Through(V2(kDoorS1, s_wall), north, 80);
  route.To(3.0, y, 130);
  route.To(1.3, y, 90);
  route.To(2.0, y, 50);
  return route.Finish();
}

}  // namespace

std::vector<BuildingRoom> BuildingRooms() {
  auto room = [](const std::string& name, double x0, double y0, double x1, double y1) {
    return BuildingRoom{name, Eigen::AlignedBox2d(V2(x0, y0), V2(x1, y1))};
  };
  return {room("S1", 0.0, 0.0, 5.2, kSouthY1),
          room("S2", 5.32, 0.0, 10.8, kSouthY1),
          room("S3", 10.92, 0.0, 16.2, kSouthY1),
          room("N1", 0.0, kNorthY0, 6.0, 12.6),
          room("N2", 6.12, kNorthY0, 11.4, 12.6),
          room("N3", 11.52, kNorthY0, 16.2, 12.6),
          room("corridor", 0.0, kCorridorY0, 16.2, kCorridorY1)};
}

std::vector<Box> BuildingBoxes() {
  std::vector<Box> boxes = {Shell()};
  AddInnerWalls(&boxes);
  AddOffice(&boxes);
  AddLounge(&boxes);
  AddStorage(&boxes);
  AddMeetingRoom(&boxes);
  AddKitchen(&boxes);
  AddWorkshop(&boxes);
  AddCorridor(&boxes);
  return boxes;
}

std::vector<PointLight> BuildingLights() {
  std::vector<PointLight> lights;
  for (const BuildingRoom& room : BuildingRooms()) {
    if (room.name == "corridor") continue;
    lights.push_back({V3(room.centre().x(), room.centre().y(), kBuildingHeight - 0.3), 0.55});
  }
  for (int i = 0; i < 4; ++i) {
    lights.push_back({V3(2.0 + 4.0 * i, 6.3, kBuildingHeight - 0.3), 0.45});
  }
  return lights;
}

}  // namespace rrslam::synth

namespace rrslam::synth {

const BuildingTour& BuildingTour::Get() {
  static const BuildingTour tour;
  return tour;
}

BuildingTour::BuildingTour() : waypoints_(TourWaypoints()) {
  const size_t n = waypoints_.size() - 1;  // Waypoint n is waypoint 0 again.
  const double turns = (waypoints_[n].yaw - waypoints_[0].yaw) / (2 * M_PI);
  if ((waypoints_[n].position - waypoints_[0].position).norm() > 1e-12 ||
      std::fabs(turns - std::round(turns)) > 1e-9) {
    throw std::logic_error("BuildingTour: the route does not end where it began");
  }
  // The waypoints' timing bounds the average speed between them; the spline
  // can go faster within a segment (curving, or between a slow and a fast
  // segment). Stretch such segments until no instant exceeds the bounds
  // (a few rounds: a segment's tangents depend on its neighbours' timing).
  for (int round = 0; round < 100; ++round) {
    ComputeTangents();
    bool stretched = false;
    for (size_t i = 0; i < n; ++i) {
      const double excess = SegmentExcess(i);
      if (excess <= 1.0) continue;
      const double stretch = (waypoints_[i + 1].time - waypoints_[i].time) * (excess - 1.0 + 0.01);
      for (size_t j = i + 1; j <= n; ++j) waypoints_[j].time += stretch;
      stretched = true;
    }
    if (!stretched) return;
  }
  throw std::logic_error("BuildingTour: cannot time the route within its speed bounds");
}

void BuildingTour::ComputeTangents() {
  const long n = static_cast<long>(waypoints_.size()) - 1;
  const double lap_turn = waypoints_[n].yaw - waypoints_[0].yaw;
  // Waypoint i as (x, y, yaw) and its time, continued periodically beyond
  // both ends (the yaw gains the route's whole turns every period).
  auto value = [&](long i) {
    const long k = static_cast<long>(std::floor(static_cast<double>(i) / n));
    const Waypoint& w = waypoints_[i - k * n];
    return std::pair<Eigen::Vector3d, double>(
        Eigen::Vector3d(w.position.x(), w.position.y(), w.yaw + k * lap_turn),
        w.time + k * duration());
  };
  // The derivative at waypoint i of the parabola through waypoints i - 1, i
  // and i + 1 (exact for quadratic motion; with unequal steps the nearer
  // neighbour weighs more), so velocity and turn rate are continuous.
  tangents_.clear();
  for (long i = 0; i <= n; ++i) {
    const auto [v0, t0] = value(i - 1);
    const auto [v1, t1] = value(i);
    const auto [v2, t2] = value(i + 1);
    const double h0 = t1 - t0, h1 = t2 - t1;
    const Eigen::Vector3d d0 = (v1 - v0) / h0, d1 = (v2 - v1) / h1;
    tangents_.push_back((h1 * d0 + h0 * d1) / (h0 + h1));
  }
}

Eigen::Vector3d BuildingTour::Hermite(size_t i, double s, bool derivative) const {
  const Waypoint& a = waypoints_[i];
  const Waypoint& b = waypoints_[i + 1];
  const double h = b.time - a.time;
  const Eigen::Vector3d pa(a.position.x(), a.position.y(), a.yaw);
  const Eigen::Vector3d pb(b.position.x(), b.position.y(), b.yaw);
  if (derivative) {  // d/dt of the curve below.
    const double d00 = 6 * s * s - 6 * s, d10 = 3 * s * s - 4 * s + 1;
    const double d01 = -d00, d11 = 3 * s * s - 2 * s;
    return (d00 * pa + d01 * pb) / h + d10 * tangents_[i] + d11 * tangents_[i + 1];
  }
  const double h00 = (1 + 2 * s) * (1 - s) * (1 - s), h10 = s * (1 - s) * (1 - s);
  const double h01 = s * s * (3 - 2 * s), h11 = s * s * (s - 1);
  return h00 * pa + h10 * h * tangents_[i] + h01 * pb + h11 * h * tangents_[i + 1];
}

double BuildingTour::SegmentExcess(size_t i) const {
  double excess = 0;
  for (int k = 0; k <= 32; ++k) {
    const Eigen::Vector3d v = Hermite(i, k / 32.0, true);
    excess = std::max({excess, v.head<2>().norm() / kMaxSpeed, std::fabs(v.z()) / kMaxTurnRate});
  }
  return excess;
}

BuildingTour::Place BuildingTour::At(double t) const {
  const double period = duration();
  const double laps = std::floor(t / period);
  const double u = t - laps * period;  // In [0, period).
  const size_t n = waypoints_.size() - 1;
  // The segment [i, i + 1] holding u.
  const auto after =
      std::upper_bound(waypoints_.begin(), waypoints_.end(), u,
                       [](double value, const Waypoint& w) { return value < w.time; });
  const size_t i = std::clamp<size_t>(after - waypoints_.begin(), 1, n) - 1;
  const double s = (u - waypoints_[i].time) / (waypoints_[i + 1].time - waypoints_[i].time);
  const Eigen::Vector3d p = Hermite(i, s, false);
  const double lap_turn = waypoints_[n].yaw - waypoints_[0].yaw;
  return {p.head<2>(), p.z() + laps * lap_turn};
}

}  // namespace rrslam::synth
