#include "stages/mapstore/floor.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <random>

#include "common/errors.h"
#include "common/trajectory.h"
#include "stages/mapstore/map_join.h"

namespace rrslam {
namespace {

constexpr double kDegrees = 180.0 / M_PI;
// The floor's slab: points within kSlabMetres of its height along the
// largest plane's normal, its plane within kSlabTiltDeg of that normal (a
// far floor's plane is fitted where it is, not tilted with a near table's);
// a slab holds at least kSlabShare of the fullest one's points to count.
constexpr double kSlabMetres = 0.15, kSlabTiltDeg = 10, kSlabShare = 0.15;

struct Plane {
  Eigen::Vector3d normal;
  double offset;
  double Distance(const Eigen::Vector3d& x) const { return normal.dot(x) + offset; }
};

std::vector<Eigen::Vector3d> CameraCentres(const MapData& map) {
  std::vector<Eigen::Vector3d> centres;
  for (const KeyFrameRecord& kf : map.keyframes) {
    centres.push_back(RigidOf(kf.T_cam_world).Inverse().translation);
  }
  return centres;
}

double MedianHeight(const Plane& plane, const std::vector<Eigen::Vector3d>& centres) {
  std::vector<double> h;
  for (const Eigen::Vector3d& c : centres) h.push_back(plane.Distance(c));
  std::nth_element(h.begin(), h.begin() + h.size() / 2, h.end());
  return h[h.size() / 2];
}

// Least-squares plane through the points within `threshold` of `plane`,
// its normal on the side of `up`.
Plane Refit(const Plane& plane, const std::vector<Eigen::Vector3d>& points, double threshold,
            const Eigen::Vector3d& up, size_t* inliers) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  std::vector<const Eigen::Vector3d*> in;
  for (const Eigen::Vector3d& x : points) {
    if (std::abs(plane.Distance(x)) < threshold) in.push_back(&x);
  }
  for (const Eigen::Vector3d* x : in) mean += *x;
  mean /= static_cast<double>(in.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d* x : in) covariance += (*x - mean) * (*x - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  Eigen::Vector3d n = solver.eigenvectors().col(0);  // Smallest eigenvalue.
  if (n.dot(up) < 0) n = -n;
  *inliers = in.size();
  return {n, -n.dot(mean)};
}

// RANSAC: the plane with the most points within inlier_metres whose normal
// is within `max_tilt_deg` of `up` and that lies min_camera_height below the
// cameras' median height; `count` (may be null) gets its points.
std::optional<Plane> LargestPlane(const std::vector<Eigen::Vector3d>& points,
                                  const std::vector<Eigen::Vector3d>& centres,
                                  const Eigen::Vector3d& up, double max_tilt_deg,
                                  const FloorOptions& o, size_t* count) {
  if (points.size() < 3) return std::nullopt;
  const double min_cos = std::cos(max_tilt_deg / kDegrees);
  std::mt19937_64 rng(o.seed);
  std::uniform_int_distribution<size_t> pick(0, points.size() - 1);
  std::optional<Plane> best;
  size_t best_count = 0;
  for (int it = 0; it < o.iterations; ++it) {
    const Eigen::Vector3d &a = points[pick(rng)], &b = points[pick(rng)], &c = points[pick(rng)];
    Eigen::Vector3d n = (b - a).cross(c - a);
    if (n.norm() < 1e-9) continue;
    n.normalize();
    if (n.dot(up) < 0) n = -n;
    if (n.dot(up) < min_cos) continue;
    const Plane plane{n, -n.dot(a)};
    if (MedianHeight(plane, centres) < o.min_camera_height) continue;
    size_t n_in = 0;
    for (const Eigen::Vector3d& x : points) n_in += std::abs(plane.Distance(x)) < o.inlier_metres;
    if (n_in > best_count) {
      best_count = n_in;
      best = plane;
    }
  }
  if (count != nullptr) *count = best_count;
  return best;
}

// The height along `plane`'s normal (relative to it) of the lowest 5 cm slab
// of points that holds at least kSlabShare of the fullest slab's points (and
// min_inliers), min_camera_height below the cameras; nullopt when none does.
std::optional<double> LowestSlab(const Plane& plane, const std::vector<Eigen::Vector3d>& points,
                                 const std::vector<Eigen::Vector3d>& centres,
                                 const FloorOptions& o) {
  constexpr double kBin = 0.05, kRange = 5.0;  // Metres either side of the plane.
  std::vector<size_t> bins(static_cast<size_t>(2 * kRange / kBin), 0);
  for (const Eigen::Vector3d& x : points) {
    const double b = std::floor((plane.Distance(x) + kRange) / kBin);
    if (b >= 0 && b < static_cast<double>(bins.size())) ++bins[static_cast<size_t>(b)];
  }
  const size_t fullest = *std::max_element(bins.begin(), bins.end());
  const double camera_height = MedianHeight(plane, centres);
  for (size_t b = 0; b < bins.size(); ++b) {
    const double height = (static_cast<double>(b) + 0.5) * kBin - kRange;
    if (camera_height - height < o.min_camera_height) break;
    if (bins[b] >= std::max<size_t>(o.min_inliers, kSlabShare * fullest)) return height;
  }
  return std::nullopt;
}

Rigid3d FloorFrame(const MapData& map, const Plane& plane) {
  const Rigid3d T_world_cam = RigidOf(map.keyframes.front().T_cam_world).Inverse();
  const Eigen::Vector3d& c = T_world_cam.translation;
  const Eigen::Vector3d z = plane.normal;
  const Eigen::Vector3d origin = c - plane.Distance(c) * z;
  Eigen::Vector3d x = T_world_cam.rotation * Eigen::Vector3d::UnitZ();
  x -= x.dot(z) * z;
  if (x.norm() < 1e-6)
    x = T_world_cam.rotation * Eigen::Vector3d::UnitX();  // Looking straight down.
  x = (x - x.dot(z) * z).normalized();
  Eigen::Matrix3d R_world_floor;
  R_world_floor << x, z.cross(x), z;
  return Rigid3d(Eigen::Quaterniond(R_world_floor).normalized(), origin).Inverse();
}

}  // namespace

Eigen::Vector3d CamerasUp(const MapData& map) {
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  for (const KeyFrameRecord& kf : map.keyframes) {
    up += RigidOf(kf.T_cam_world).rotation.inverse() * Eigen::Vector3d(0, -1, 0);
  }
  return up.norm() > 0 ? up.normalized() : Eigen::Vector3d(0, -1, 0);
}

std::optional<Floor> FindFloor(const MapData& map, const std::vector<Eigen::Vector3d>& points,
                               const FloorOptions& o) {
  if (map.keyframes.empty() || points.size() < 3) return std::nullopt;
  const std::vector<Eigen::Vector3d> centres = CameraCentres(map);
  const Eigen::Vector3d up = CamerasUp(map);
  // The largest horizontal plane (a table, a counter or the floor) gives
  // the normal; the floor is the lowest slab of points along it that holds
  // a good share of them; its plane is fitted there.
  const std::optional<Plane> largest =
      LargestPlane(points, centres, up, o.max_tilt_deg, o, nullptr);
  if (!largest) return std::nullopt;
  const std::optional<double> height = LowestSlab(*largest, points, centres, o);
  if (!height) return std::nullopt;
  std::vector<Eigen::Vector3d> slab;
  for (const Eigen::Vector3d& x : points) {
    if (std::abs(largest->Distance(x) - *height) < kSlabMetres) slab.push_back(x);
  }
  size_t count = 0;
  const std::optional<Plane> found =
      LargestPlane(slab, centres, largest->normal, kSlabTiltDeg, o, &count);
  if (!found || count < static_cast<size_t>(o.min_inliers)) return std::nullopt;
  Floor floor;
  const Plane plane = Refit(*found, points, o.inlier_metres, up, &floor.inliers);
  floor.normal = plane.normal;
  floor.offset = plane.offset;
  floor.points = points.size();
  floor.tilt_deg = std::acos(std::clamp(plane.normal.dot(up), -1.0, 1.0)) * kDegrees;
  floor.camera_height = MedianHeight(plane, centres);
  floor.T_floor_map = FloorFrame(map, plane);
  return floor;
}

std::vector<Eigen::Vector3d> FloorSearchPoints(const MapData& map, const RgbdSequence* sequence,
                                               int stride, const std::string& source) {
  std::vector<Eigen::Vector3d> points;
  for (const MapPointRecord& p : map.map_points) {
    points.emplace_back(p.position[0], p.position[1], p.position[2]);
  }
  if (sequence == nullptr) return points;
  std::vector<double> keyframe_stamps, frame_stamps;
  for (const KeyFrameRecord& kf : map.keyframes) keyframe_stamps.push_back(kf.timestamp);
  for (const RgbdFrameRef& f : sequence->frames()) frame_stamps.push_back(f.rgb_timestamp);
  const auto frames = MatchTimestamps(keyframe_stamps, frame_stamps, kKeyFrameTimestampTolerance);
  const MapCamera& c = map.camera;
  for (size_t k = 0; k < map.keyframes.size(); ++k) {
    if (!frames[k]) {
      throw DataError(source + ": keyframe " + std::to_string(map.keyframes[k].id) +
                      " has no frame in " + sequence->dir().string());
    }
    const cv::Mat depth = sequence->LoadDepthMetres(*frames[k], c.depth_map_factor);
    const Rigid3d T_world_cam = RigidOf(map.keyframes[k].T_cam_world).Inverse();
    for (int v = stride / 2; v < depth.rows; v += stride) {
      for (int u = stride / 2; u < depth.cols; u += stride) {
        const float z = depth.at<float>(v, u);
        if (!(z > 0) || !std::isfinite(z)) continue;
        // Undistortion is ignored: a floor a few pixels off at the image
        // border is the same plane.
        const Eigen::Vector3d x_cam((u - c.cx) * z / c.fx, (v - c.cy) * z / c.fy, z);
        points.push_back(T_world_cam * x_cam);
      }
    }
  }
  return points;
}

std::string FloorToJson(const Floor& floor) {
  const Rigid3d& T = floor.T_floor_map;
  nlohmann::json j = {{"T_floor_map",
                       {T.rotation.w(), T.rotation.x(), T.rotation.y(), T.rotation.z(),
                        T.translation.x(), T.translation.y(), T.translation.z()}},
                      {"normal", {floor.normal.x(), floor.normal.y(), floor.normal.z()}},
                      {"offset", floor.offset},
                      {"inliers", floor.inliers},
                      {"points", floor.points},
                      {"tilt_deg", floor.tilt_deg},
                      {"camera_height", floor.camera_height}};
  return j.dump();
}

std::optional<Rigid3d> FloorFromMetadata(const std::string& metadata) {
  const nlohmann::json j = nlohmann::json::parse(metadata, nullptr, false);
  if (!j.is_object() || !j.contains("floor") || !j["floor"].is_object()) return std::nullopt;
  const nlohmann::json& t = j["floor"]["T_floor_map"];
  if (!t.is_array() || t.size() != 7) return std::nullopt;
  for (const auto& v : t) {
    if (!v.is_number()) return std::nullopt;
  }
  const Eigen::Quaterniond q(t[0].get<double>(), t[1].get<double>(), t[2].get<double>(),
                             t[3].get<double>());
  if (!(std::abs(q.norm() - 1) < 1e-6)) return std::nullopt;
  return Rigid3d(q.normalized(),
                 Eigen::Vector3d(t[4].get<double>(), t[5].get<double>(), t[6].get<double>()));
}

}  // namespace rrslam
