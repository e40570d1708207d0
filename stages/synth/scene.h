// The synthetic indoor scene of rrslam-synth: textured planar rectangles
// (the faces of a room and of the boxes in it) with ray casting and shading.
//
// World frame: metres, z up (gravity along -z). The standard room spans
// x in [-3, 3], y in [-2.5, 2.5], z in [0, 3]; its middle (radius 1.55 m
// around the z axis) is kept free for the camera paths of camera_path.h. The
// building (building.h) is another list of boxes with its own lights.
//
// Every surface is one-sided: it is visible only from the side its normal
// points to. Boxes are closed and seen from outside, the room from inside, so
// one-sided surfaces render exactly like two-sided ones for any camera inside
// the room and outside the boxes. Immutable after construction; thread-safe.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "stages/synth/texture.h"

namespace rrslam::synth {

// Tolerance of the inside-rectangle test (metres in the surface's plane),
// shared by Scene::RayCast and the renderer: rays through a shared edge hit
// one of the two faces, never the gap between them.
inline constexpr double kEdgeTolerance = 1e-9;

// A textured planar rectangle. A point with texture coordinates (a, b),
// 0 <= a <= size_a, 0 <= b <= size_b (metres), is
//   point_world = origin_world + a * axis_a_world + b * axis_b_world.
// The visible side is the one `normal_world` = axis_b x axis_a points to:
// seen from there, a points right and b down (like image columns and rows).
struct Surface {
  int id = 0;        // Index in Scene::surfaces().
  std::string name;  // "room.floor", "table_top.+z", ...
  Material material = Material::kWall;
  Eigen::Vector3d origin_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_a_world = Eigen::Vector3d::UnitX();   // Unit.
  Eigen::Vector3d axis_b_world = Eigen::Vector3d::UnitY();   // Unit, orthogonal to axis_a.
  Eigen::Vector3d normal_world = -Eigen::Vector3d::UnitZ();  // Unit, axis_b x axis_a.
  double size_a = 1.0;                                       // Extent along axis_a, metres.
  double size_b = 1.0;                                       // Extent along axis_b, metres.

  // Signed distance of a point to the surface's plane, positive on the visible side.
  double PlaneDistance(const Eigen::Vector3d& point_world) const {
    return normal_world.dot(point_world - origin_world);
  }
  // Euclidean distance from a point to the rectangle (not just its plane).
  double Distance(const Eigen::Vector3d& point_world) const;
  Eigen::Vector3d Corner(int i) const;  // i in [0, 4): (0,0), (a,0), (a,b), (0,b).
};

// An oriented box: a room (seen from inside) or an object (seen from outside).
struct Box {
  std::string name;
  Eigen::Vector3d centre_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d size = Eigen::Vector3d::Ones();  // Extents along its own x, y, z; metres.
  double yaw = 0.0;                                // Rotation about the world z axis, radians.
  bool inside = false;  // true: faces look inward (a room); false: outward (an object).
  // Material of faces +x, -x, +y, -y, +z, -z (box frame).
  std::array<Material, 6> materials{};
  // Faces never visible (resting on the floor, against a wall), bit i = face i
  // in the order above: they get no surface and no texture.
  uint8_t hidden_faces = 0;

  // A box with one material on every face.
  static Box Object(std::string name, const Eigen::Vector3d& centre, const Eigen::Vector3d& size,
                    Material material, double yaw = 0.0, uint8_t hidden_faces = 0);
};

// Face bits for Box::hidden_faces.
enum BoxFace : uint8_t {
  kFacePosX = 1,
  kFaceNegX = 2,
  kFacePosY = 4,
  kFaceNegY = 8,
  kFacePosZ = 16,
  kFaceNegZ = 32,
};

// The first surface hit by a ray.
struct RayHit {
  double distance = 0;  // Along the ray, in units of the direction's length.
  Eigen::Vector3d point_world = Eigen::Vector3d::Zero();
  int surface_id = -1;
  double a = 0, b = 0;  // Texture coordinates of the hit on the surface, metres.
};

// A point light of the scene's Lambertian shading.
struct PointLight {
  Eigen::Vector3d position_world;
  double intensity;  // Irradiance factor at 1 m, facing the light.
};

struct SceneOptions {
  uint64_t seed = 0;          // Seed of every texture (the geometry is fixed).
  double texel_size = 0.003;  // Texture resolution, metres per texel (0.5 mm to 5 cm).
  int num_threads = 1;        // Threads generating textures (>= 1); does not change the result.
};

class Scene {
 public:
  // Builds the surfaces of `boxes` and generates their textures (surface i's
  // from options.seed and i only), lit by the standard room's two ceiling
  // lights (StandardRoomLights()). Throws std::invalid_argument when
  // options.texel_size is outside [0.0005, 0.05].
  Scene(const std::vector<Box>& boxes, const SceneOptions& options);
  // The same with the given lights.
  Scene(const std::vector<Box>& boxes, const std::vector<PointLight>& lights,
        const SceneOptions& options);

  // The standard furnished room of rrslam-synth (StandardRoomBoxes()).
  static Scene StandardRoom(const SceneOptions& options);
  // The building of rrslam-synth --scene building (building.h:
  // BuildingBoxes(), BuildingLights()).
  static Scene Building(const SceneOptions& options);

  const std::vector<Surface>& surfaces() const { return surfaces_; }
  const Surface& surface(int id) const { return surfaces_.at(id); }
  const MipTexture& texture(int surface_id) const { return textures_.at(surface_id); }
  const std::vector<Box>& boxes() const { return boxes_; }
  const std::vector<PointLight>& lights() const { return lights_; }
  const SceneOptions& options() const { return options_; }

  // First hit of the ray origin + t * direction with t > min_distance (direction
  // need not be unit). Only visible sides are hit. nullopt if nothing is hit.
  std::optional<RayHit> RayCast(const Eigen::Vector3d& origin_world,
                                const Eigen::Vector3d& direction_world,
                                double min_distance = 0.0) const;

  // Distance from a point to the nearest surface (e.g. camera clearance).
  double DistanceToNearestSurface(const Eigen::Vector3d& point_world) const;

  // Lambertian irradiance factor (ambient + point lights) at a surface point
  // with the given unit normal; about 0.5 to 1.1.
  float Shading(const Eigen::Vector3d& point_world, const Eigen::Vector3d& normal_world) const;

  // Albedo (B, G, R on the 0-255 scale) of surface `surface_id` at texture
  // coordinates (a, b), filtered over a pixel footprint given by the
  // derivatives of (a, b) with respect to image u and v (metres per pixel).
  Eigen::Vector3f Albedo(int surface_id, float a, float b, float da_du, float db_du, float da_dv,
                         float db_dv) const {
    return textures_[surface_id].Sample(a, b, da_du, db_du, da_dv, db_dv);
  }

  // Bytes held by the textures.
  size_t TextureBytes() const;

 private:
  std::vector<Box> boxes_;
  std::vector<Surface> surfaces_;
  std::vector<MipTexture> textures_;
  std::vector<PointLight> lights_;
  SceneOptions options_;
};

// The boxes of the standard room: the room itself (walls, floor, ceiling),
// tables, cabinet, shelf, sofa, crates, a column, a lamp and wall posters.
std::vector<Box> StandardRoomBoxes();

// The standard room's two lights, 0.35 m under its ceiling.
std::vector<PointLight> StandardRoomLights();

// The scenes of rrslam-synth (--scene).
enum class SceneKind {
  kStandard,  // The standard room (StandardRoomBoxes()), with its SceneChange edits.
  kBuilding,  // The building: six rooms along a corridor (building.h).
};
// "standard", "building".
std::string SceneKindName(SceneKind kind);
// Parses a name of SceneKindName; false when unknown.
bool ParseSceneKind(const std::string& name, SceneKind* kind);

// Free space of the standard room kept clear for cameras: no object comes
// closer than this to the room's vertical axis (x = y = 0) below 2.5 m.
inline constexpr double kStandardRoomFreeRadius = 1.55;

// Axis-aligned world bounds of a box (of its full extent, hidden faces
// included), metres.
Eigen::AlignedBox3d BoxBounds(const Box& box);

// Edits of the standard room: "the same room, changed", for tests of map
// updates (map the standard room, then run on the changed one). A change moves
// and adds boxes without disturbing anything else: a moved box keeps its
// place in the box list (so its surfaces keep their ids and, having the same
// sizes, their textures: it is the same physical object), added boxes come
// after all standard boxes (so no other surface's id, and hence texture seed,
// changes). Every unchanged surface therefore renders bit-identically.
enum class SceneChange {
  // The standard room as it is.
  kNone,
  // The screen moves from the east table (centre (2.42, 0.35, 0.97)) to the
  // floor by the east wall, south of the table (centre (2.5, -1.2, 0.2)),
  // 1.73 m away, still facing west; a new cardboard crate "crate3"
  // (0.5 x 0.45 x 0.5 m, yaw 10 deg) stands on the floor between the table
  // and the cabinet (centre (2.3, 1.35, 0.25)). All three places are seen by
  // the default loop (300 frames, looking east: each in more than half of its
  // frames) and by the full-turn loops of 18 s and more per lap (about a
  // sixth of their frames); sweep and rotation do not see them all.
  kMovedBox,
};

// "none", "moved-box".
std::string SceneChangeName(SceneChange change);
// Parses a name of SceneChangeName; false when unknown.
bool ParseSceneChange(const std::string& name, SceneChange* change);
// The valid names in a sentence: "none or moved-box".
std::string SceneChangeNames();

// What a SceneChange does to StandardRoomBoxes(), for tests and for stages
// that need to know where the room changed.
struct SceneChangeInfo {
  // A box of the standard room put elsewhere (same name, size, yaw, materials).
  struct Move {
    int index = -1;  // In StandardRoomBoxes() and in ChangedRoomBoxes(): the same.
    Box from;        // As in StandardRoomBoxes().
    Box to;          // As in ChangedRoomBoxes().
  };
  // A box that is not in the standard room.
  struct Addition {
    int index = -1;  // In ChangedRoomBoxes(); after every standard box.
    Box box;
  };
  SceneChange change = SceneChange::kNone;
  std::vector<Move> moved;
  std::vector<Addition> added;

  // Axis-aligned world bounds (BoxBounds) of every place whose look changed:
  // each moved box's old and new place, then each added box. Empty for kNone.
  // Outside these regions (and what they hide from a given viewpoint) the
  // changed room looks exactly like the standard one.
  std::vector<Eigen::AlignedBox3d> ChangedRegions() const;
};
SceneChangeInfo DescribeSceneChange(SceneChange change);

// The boxes of the standard room with `change` applied
// (StandardRoomBoxes() for kNone).
std::vector<Box> ChangedRoomBoxes(SceneChange change);

}  // namespace rrslam::synth
