#include "stages/synth/scene.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <thread>

#include "common/worker_pool.h"
#include "stages/synth/building.h"
#include "stages/synth/random.h"

namespace rrslam::synth {
namespace {

const char* kFaceNames[6] = {"+x", "-x", "+y", "-y", "+z", "-z"};

}  // namespace

double Surface::Distance(const Eigen::Vector3d& point_world) const {
  const Eigen::Vector3d d = point_world - origin_world;
  const double a = std::clamp(d.dot(axis_a_world), 0.0, size_a);
  const double b = std::clamp(d.dot(axis_b_world), 0.0, size_b);
  return (point_world - (origin_world + a * axis_a_world + b * axis_b_world)).norm();
}

Eigen::Vector3d Surface::Corner(int i) const {
  const double a = (i == 1 || i == 2) ? size_a : 0.0;
  const double b = (i >= 2) ? size_b : 0.0;
  return origin_world + a * axis_a_world + b * axis_b_world;
}

Box Box::Object(std::string name, const Eigen::Vector3d& centre, const Eigen::Vector3d& size,
                Material material, double yaw, uint8_t hidden_faces) {
  Box box;
  box.name = std::move(name);
  box.centre_world = centre;
  box.size = size;
  box.yaw = yaw;
  box.materials.fill(material);
  box.hidden_faces = hidden_faces;
  return box;
}

Scene::Scene(const std::vector<Box>& boxes, const SceneOptions& options)
    : Scene(boxes, StandardRoomLights(), options) {}

Scene::Scene(const std::vector<Box>& boxes, const std::vector<PointLight>& lights,
             const SceneOptions& options)
    : boxes_(boxes), lights_(lights), options_(options) {
  if (!(options.texel_size >= 0.0005 && options.texel_size <= 0.05)) {
    throw std::invalid_argument("Scene: texel_size must be in [0.0005, 0.05] m");
  }
  for (const Box& box : boxes_) {
    const Eigen::Vector3d ex(std::cos(box.yaw), std::sin(box.yaw), 0.0);
    const Eigen::Vector3d ey(-std::sin(box.yaw), std::cos(box.yaw), 0.0);
    const Eigen::Vector3d ez = Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d axes[3] = {ex, ey, ez};
    for (int face = 0; face < 6; ++face) {
      if (box.hidden_faces & (1u << face)) continue;
      const int axis = face / 2;
      const double sign = (face % 2 == 0) ? 1.0 : -1.0;
      const Eigen::Vector3d outward = sign * axes[axis];
      const Eigen::Vector3d centre = box.centre_world + 0.5 * box.size[axis] * outward;
      Surface s;
      s.id = static_cast<int>(surfaces_.size());
      s.name = box.name + "." + kFaceNames[face];
      s.material = box.materials[face];
      s.normal_world = box.inside ? -outward : outward;
      if (axis == 2) {
        // Horizontal face: a along the box's x; b completes (a, b, -normal).
        s.axis_a_world = ex;
        s.axis_b_world = (-s.normal_world).cross(s.axis_a_world);
        s.size_a = box.size.x();
        s.size_b = box.size.y();
      } else {
        // Vertical face: b points down, so text on walls stands upright.
        s.axis_b_world = -ez;
        s.axis_a_world = s.normal_world.cross(s.axis_b_world);
        s.size_a = box.size[1 - axis];  // The other horizontal extent.
        s.size_b = box.size.z();
      }
      s.origin_world = centre - 0.5 * s.size_a * s.axis_a_world - 0.5 * s.size_b * s.axis_b_world;
      surfaces_.push_back(std::move(s));
    }
  }

  // Textures, one per surface, generated on several threads: surface i's
  // texture depends only on (seed, i), so the result does not depend on the
  // thread count or scheduling.
  textures_.resize(surfaces_.size());
  std::atomic<size_t> next{0};
  auto worker = [&] {
    for (size_t i = next++; i < surfaces_.size(); i = next++) {
      const Surface& s = surfaces_[i];
      const cv::Mat image = GenerateTexture(s.material, s.size_a, s.size_b, options_.texel_size,
                                            HashKeys(options_.seed, 0x5eed7e47, i));
      textures_[i] = MipTexture(image, options_.texel_size);
    }
  };
  const int threads = std::max(1, options_.num_threads);
  // A thread that cannot be started is a ResourceError (WorkerPool).
  WorkerPool pool(threads);
  pool.ParallelFor(static_cast<size_t>(threads), [&](size_t) { worker(); });
}

Scene Scene::StandardRoom(const SceneOptions& options) {
  return Scene(StandardRoomBoxes(), options);
}

Scene Scene::Building(const SceneOptions& options) {
  return Scene(BuildingBoxes(), BuildingLights(), options);
}

std::optional<RayHit> Scene::RayCast(const Eigen::Vector3d& origin_world,
                                     const Eigen::Vector3d& direction_world,
                                     double min_distance) const {
  std::optional<RayHit> best;
  for (const Surface& s : surfaces_) {
    const double denom = s.normal_world.dot(direction_world);
    if (denom >= 0.0) continue;  // Parallel, or the back side.
    const double t = s.normal_world.dot(s.origin_world - origin_world) / denom;
    if (!(t > min_distance)) continue;
    if (best && t >= best->distance) continue;
    const Eigen::Vector3d point = origin_world + t * direction_world;
    const Eigen::Vector3d d = point - s.origin_world;
    const double a = d.dot(s.axis_a_world), b = d.dot(s.axis_b_world);
    if (a < -kEdgeTolerance || a > s.size_a + kEdgeTolerance || b < -kEdgeTolerance ||
        b > s.size_b + kEdgeTolerance) {
      continue;
    }
    best = RayHit{t, point, s.id, a, b};
  }
  return best;
}

double Scene::DistanceToNearestSurface(const Eigen::Vector3d& point_world) const {
  double best = std::numeric_limits<double>::infinity();
  for (const Surface& s : surfaces_) best = std::min(best, s.Distance(point_world));
  return best;
}

float Scene::Shading(const Eigen::Vector3d& point_world,
                     const Eigen::Vector3d& normal_world) const {
  // Ambient term plus Lambertian point lights with a soft inverse-square
  // falloff (1 + 0.2 d^2 keeps nearby surfaces from saturating). No shadows:
  // shading stays a smooth function of position, stable from any viewpoint.
  double irradiance = 0.5;
  for (const PointLight& light : lights_) {
    const Eigen::Vector3d to_light = light.position_world - point_world;
    const double d2 = to_light.squaredNorm();
    const double cosine = normal_world.dot(to_light) / std::sqrt(d2);
    if (cosine > 0) irradiance += light.intensity * cosine / (1.0 + 0.2 * d2);
  }
  return static_cast<float>(irradiance);
}

size_t Scene::TextureBytes() const {
  size_t bytes = 0;
  for (const auto& t : textures_) bytes += t.MemoryBytes();
  return bytes;
}

std::vector<Box> StandardRoomBoxes() {
  using V = Eigen::Vector3d;
  constexpr double kDeg = M_PI / 180.0;
  std::vector<Box> boxes;

  Box room;
  room.name = "room";
  room.centre_world = V(0, 0, 1.5);
  room.size = V(6.0, 5.0, 3.0);
  room.inside = true;
  room.materials = {Material::kWall, Material::kWall,    Material::kWall,
                    Material::kWall, Material::kCeiling, Material::kFloor};
  boxes.push_back(room);

  const uint8_t on_floor = kFaceNegZ;
  // East table with things on it.
  const double top_z = 0.745;
  boxes.push_back(
      Box::Object("table.top", V(2.15, 0.2, top_z), V(0.8, 1.5, 0.05), Material::kWood));
  for (int i = 0; i < 4; ++i) {
    const double x = 2.15 + ((i & 1) ? 0.33 : -0.33), y = 0.2 + ((i & 2) ? 0.68 : -0.68);
    boxes.push_back(Box::Object("table.leg" + std::to_string(i), V(x, y, 0.36), V(0.06, 0.06, 0.72),
                                Material::kWood, 0.0, on_floor | kFacePosZ));
  }
  boxes.push_back(Box::Object("screen", V(2.42, 0.35, 0.97), V(0.06, 0.62, 0.4), Material::kPoster,
                              0.0, on_floor));
  boxes.push_back(Box::Object("parcel", V(2.05, -0.25, 0.83), V(0.32, 0.24, 0.12),
                              Material::kCardboard, 25 * kDeg, on_floor));
  boxes.push_back(Box::Object("tin", V(1.95, 0.72, 0.87), V(0.2, 0.2, 0.2), Material::kPainted,
                              -15 * kDeg, on_floor));

  // North-east cabinet against the north wall; west shelf against the west wall.
  boxes.push_back(Box::Object("cabinet", V(2.35, 2.15, 0.95), V(1.1, 0.7, 1.9), Material::kPainted,
                              0.0, on_floor | kFacePosY));
  boxes.push_back(Box::Object("shelf", V(-2.75, 0.3, 0.8), V(0.5, 1.6, 1.6), Material::kPainted,
                              0.0, on_floor | kFaceNegX));

  // South-west crates, one stacked on another.
  boxes.push_back(Box::Object("crate0", V(-2.3, -1.95, 0.25), V(0.6, 0.6, 0.5),
                              Material::kCardboard, 0.0, on_floor));
  boxes.push_back(Box::Object("crate1", V(-2.3, -1.95, 0.675), V(0.45, 0.42, 0.35),
                              Material::kCardboard, 12 * kDeg, on_floor));
  boxes.push_back(Box::Object("crate2", V(-1.55, -2.05, 0.2), V(0.5, 0.5, 0.4),
                              Material::kCardboard, -8 * kDeg, on_floor));
  boxes.push_back(Box::Object("bin", V(-1.85, 1.25, 0.3), V(0.4, 0.6, 0.6), Material::kPainted,
                              30 * kDeg, on_floor));

  // Sofa along the north wall.
  boxes.push_back(Box::Object("sofa.seat", V(-0.9, 2.1, 0.22), V(1.9, 0.8, 0.44),
                              Material::kPainted, 0.0, on_floor));
  boxes.push_back(Box::Object("sofa.back", V(-0.9, 2.42, 0.65), V(1.9, 0.16, 0.86),
                              Material::kPainted, 0.0, on_floor | kFacePosY));

  // Low table by the south wall; a column in the south-east corner.
  boxes.push_back(Box::Object("low_table", V(0.5, -1.95, 0.2), V(1.1, 0.6, 0.4), Material::kWood,
                              0.0, on_floor));
  boxes.push_back(Box::Object("column", V(2.7, -2.2, 1.5), V(0.6, 0.6, 3.0), Material::kPainted,
                              0.0, on_floor | kFacePosZ | kFacePosX | kFaceNegY));

  // Posters flush with the walls.
  boxes.push_back(Box::Object("poster.south", V(-0.6, -2.49, 1.6), V(1.2, 0.02, 0.85),
                              Material::kPoster, 0.0, kFaceNegY));
  boxes.push_back(Box::Object("poster.north", V(0.9, 2.49, 1.75), V(1.0, 0.02, 0.7),
                              Material::kPoster, 0.0, kFacePosY));
  boxes.push_back(Box::Object("poster.east", V(2.99, -0.9, 1.6), V(0.02, 0.9, 0.7),
                              Material::kPoster, 0.0, kFacePosX));
  boxes.push_back(Box::Object("poster.west", V(-2.99, -1.4, 1.75), V(0.02, 0.8, 1.0),
                              Material::kPoster, 0.0, kFaceNegX));

  // Lamp shades under the ceiling, above the lights.
  boxes.push_back(Box::Object("lamp0", V(-1.3, 0.6, 2.85), V(0.45, 0.45, 0.3), Material::kPainted,
                              0.0, kFacePosZ));
  boxes.push_back(Box::Object("lamp1", V(1.4, -0.5, 2.85), V(0.45, 0.45, 0.3), Material::kPainted,
                              0.0, kFacePosZ));
  return boxes;
}

std::vector<PointLight> StandardRoomLights() {
  return {{Eigen::Vector3d(-1.3, 0.6, 2.65), 0.6}, {Eigen::Vector3d(1.4, -0.5, 2.65), 0.6}};
}

std::string SceneKindName(SceneKind kind) {
  switch (kind) {
    case SceneKind::kStandard:
      return "standard";
    case SceneKind::kBuilding:
      return "building";
  }
  return "unknown";
}

bool ParseSceneKind(const std::string& name, SceneKind* kind) {
  for (SceneKind k : {SceneKind::kStandard, SceneKind::kBuilding}) {
    if (name == SceneKindName(k)) {
      *kind = k;
      return true;
    }
  }
  return false;
}

Eigen::AlignedBox3d BoxBounds(const Box& box) {
  // Half-extents along world x and y of a box turned by `yaw` about z.
  const double c = std::fabs(std::cos(box.yaw)), s = std::fabs(std::sin(box.yaw));
  const Eigen::Vector3d half(0.5 * (c * box.size.x() + s * box.size.y()),
                             0.5 * (s * box.size.x() + c * box.size.y()), 0.5 * box.size.z());
  return Eigen::AlignedBox3d(box.centre_world - half, box.centre_world + half);
}

std::string SceneChangeName(SceneChange change) {
  switch (change) {
    case SceneChange::kNone:
      return "none";
    case SceneChange::kMovedBox:
      return "moved-box";
  }
  return "unknown";
}

bool ParseSceneChange(const std::string& name, SceneChange* change) {
  for (SceneChange c : {SceneChange::kNone, SceneChange::kMovedBox}) {
    if (name == SceneChangeName(c)) {
      *change = c;
      return true;
    }
  }
  return false;
}

std::string SceneChangeNames() { return "none or moved-box"; }

std::vector<Eigen::AlignedBox3d> SceneChangeInfo::ChangedRegions() const {
  std::vector<Eigen::AlignedBox3d> regions;
  for (const Move& m : moved) {
    regions.push_back(BoxBounds(m.from));
    regions.push_back(BoxBounds(m.to));
  }
  for (const Addition& a : added) regions.push_back(BoxBounds(a.box));
  return regions;
}

SceneChangeInfo DescribeSceneChange(SceneChange change) {
  using V = Eigen::Vector3d;
  constexpr double kDeg = M_PI / 180.0;
  SceneChangeInfo info;
  info.change = change;
  if (change == SceneChange::kNone) return info;
  const std::vector<Box> standard = StandardRoomBoxes();
  auto index_of = [&](const std::string& name) {
    for (size_t i = 0; i < standard.size(); ++i) {
      if (standard[i].name == name) return static_cast<int>(i);
    }
    throw std::logic_error("DescribeSceneChange: no box " + name + " in the standard room");
  };
  // The places were chosen with the default loop in mind: it looks east
  // (yaw within about +-35 deg, +-31 deg of field of view), so the old and the
  // new place of the screen and the crate are all in its view. The screen
  // stands on the floor with its -z face still hidden; both boxes keep at least
  // 0.15 m from every other box (their axis-aligned bounds do) and stay well
  // outside the cameras' free middle (kStandardRoomFreeRadius).
  SceneChangeInfo::Move move;
  move.index = index_of("screen");
  move.from = standard[move.index];
  move.to = move.from;
  move.to.centre_world = V(2.5, -1.2, 0.5 * move.from.size.z());
  info.moved.push_back(move);
  SceneChangeInfo::Addition add;
  add.index = static_cast<int>(standard.size());
  add.box = Box::Object("crate3", V(2.3, 1.35, 0.25), V(0.5, 0.45, 0.5), Material::kCardboard,
                        10 * kDeg, kFaceNegZ);
  info.added.push_back(add);
  return info;
}

std::vector<Box> ChangedRoomBoxes(SceneChange change) {
  std::vector<Box> boxes = StandardRoomBoxes();
  const SceneChangeInfo info = DescribeSceneChange(change);
  for (const SceneChangeInfo::Move& m : info.moved) boxes[m.index] = m.to;
  for (const SceneChangeInfo::Addition& a : info.added) {
    // Appended in index order: no standard surface changes id (texture seed).
    boxes.insert(boxes.begin() + a.index, a.box);
  }
  return boxes;
}

}  // namespace rrslam::synth
