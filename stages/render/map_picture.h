// Pictures of a saved map: map points, keyframes as camera frusta, the
// keyframe trajectory, the spanning tree, covisibility and loop edges, from
// above, the side, the front, or in perspective from a viewpoint.
//
// Frames: the map's world frame (the first keyframe of the map that built it
// at identity: x right, y down, z forward of that camera). "Up" is a world
// axis (default -y: the first camera was held level); the ground directions
// are right = x and forward = z for up = -y, and in general
//   right = (-up) x forward,  forward = the first of z, x, y not along up.
// Orthographic views (metres, equal scale, grid and ticks):
//   top    looks down:           image right = right,   image up = forward
//   front  looks along forward:  image right = right,   image up = up
//   side   looks along -right:   image right = forward, image up = up
// Perspective: ORB-SLAM2's viewer camera (common/settings.h Viewpoint), or
// an automatic viewpoint from ORB-SLAM2's default direction at the distance
// that frames the map.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/settings.h"
#include "stages/render/map_scene.h"

namespace rrslam {

enum class MapViewKind { kTop, kSide, kFront, kPerspective };
enum class PointColouring {
  kHeight,        // Along `up`, turbo colormap over the 2nd..98th percentile.
  kObservations,  // Keyframes observing the point, viridis, log scale.
  kAge,           // Loaded (grey) / added in this run (orange) after restore mapping;
                  // otherwise creation order (the keyframe a point was made with).
};

// "top", "side", "front", "perspective"; "height", "observations", "age".
std::string ToString(MapViewKind kind);
std::string ToString(PointColouring colouring);

struct MapPictureOptions {
  int width_px = 1200;  // In [320, 8000].
  int height_px = 900;  // In [240, 8000].
  PointColouring colouring = PointColouring::kHeight;
  std::string up = "-y";               // World axis that points up: x, y, z with optional '-'.
  std::optional<Viewpoint> viewpoint;  // Perspective camera; nullopt = automatic.
  bool frusta = true;                  // Keyframes as camera frusta.
  bool trajectory = true;              // Keyframe centres joined in time order.
  bool spanning_tree = true;
  bool covisibility = false;          // Covisibility edges of weight >= covisibility_min_weight.
  int covisibility_min_weight = 100;  // ORB-SLAM2's essential-graph threshold.
  double frustum_size = 0;            // Frustum depth, metres; 0 = 2% of the map's extent.
  double point_radius_px = 0;         // 0 = scaled with the image (about 1.5 px at 1200 wide).

  bool Check(std::string* why) const;
  nlohmann::ordered_json ToJson() const;
};

// The unit world vectors of the ground frame for `up` ("-y" etc.): right,
// forward, up. Throws UsageError on a malformed axis.
struct GroundFrame {
  Eigen::Vector3d right, forward, up;
  std::string right_name, forward_name, up_name;  // "x", "-y", ...
};
GroundFrame MakeGroundFrame(const std::string& up);

// Where a view puts world points. Orthographic views map through `axes`
// (chart coordinates, metres); perspective views through a pinhole camera.
class MapViewProjection {
 public:
  // Pixel of a world point, or nullopt when it is behind a perspective
  // camera. `depth` (optional) receives the distance along the viewing
  // direction (for drawing far points first).
  std::optional<cv::Point2d> Project(const Eigen::Vector3d& world, double* depth = nullptr) const;

  MapViewKind kind = MapViewKind::kTop;
  // Orthographic: image right / image up world directions, and the chart axes.
  Eigen::Vector3d u_direction, v_direction;
  double centre_u = 0, centre_v = 0, pixels_per_metre = 1;
  cv::Point2d centre_px;
  // Perspective: T_cam_world of the view camera (x right, y down, z forward)
  // and its intrinsics, pixels.
  Rigid3d T_cam_world;
  double fx = 1, fy = 1, cx = 0, cy = 0;
};

struct MapPicture {
  cv::Mat image;                 // CV_8UC3 BGR.
  MapViewProjection projection;  // How world points landed on it.
  std::string title;
  std::vector<std::string> labels;  // Axis labels and legend entries drawn (for tests).
};

// Renders one view of `scene`. Throws UsageError for invalid options and
// DataError when the map has no keyframes.
MapPicture RenderMapPicture(const MapScene& scene, MapViewKind kind,
                            const MapPictureOptions& options);

}  // namespace rrslam
