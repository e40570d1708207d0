// Rendering of a Scene through a pinhole camera: exact depth, anti-aliased
// colour.
//
// Method: per frame, each surface facing the camera is clipped to the near
// plane and scanned over its screen bounding box; for every pixel centre the
// depth of the surface's plane follows in closed form (a pinhole ray
// (u, v) -> ((u - cx) / fx, (v - cy) / fy, 1) meets a plane at a depth that is
// the inverse of an affine function of u and v), and a z-buffer keeps the
// nearest surface. Depth is thus exact at pixel centres (to double rounding),
// like a structured-light sensor that measures one depth per pixel.
//
// Colour: the texture is filtered over each pixel's exact footprint
// (anisotropic trilinear mip-mapping, texture.h), so surfaces are band-limited
// and do not shimmer as the camera moves; pixels on a boundary between
// surfaces are supersampled (3 x 3 samples), so object outlines are
// anti-aliased too. Shading is Lambertian (Scene::Shading).
//
// Thread-safe: one Renderer may render on several threads at once. A frame is
// rendered on the calling thread; its pixels do not depend on any other frame.
#pragma once

#include <opencv2/core/mat.hpp>
#include <vector>

#include "common/camera.h"
#include "common/geometry.h"
#include "stages/synth/scene.h"

namespace rrslam::synth {

struct RenderedFrame {
  cv::Mat color;          // CV_32FC3: B, G, R on the 0-255 scale, before exposure and rounding.
  cv::Mat depth;          // CV_32FC1: metres along the optical axis (z), 0 where no surface.
  cv::Mat surface_id;     // CV_32SC1: surface seen at each pixel centre, -1 where none.
  cv::Mat cos_incidence;  // CV_32FC1: cosine between viewing ray and surface normal, 0 where none.
};

class Renderer {
 public:
  // Samples per axis on surface boundaries (the colour of other pixels is one
  // filtered texture lookup).
  static constexpr int kEdgeSamples = 3;
  // Surfaces are clipped at this depth (metres).
  static constexpr double kNearPlane = 1e-3;

  // `camera` must have no distortion and a positive size. The scene must
  // outlive the renderer.
  Renderer(const Scene& scene, const PinholeCamera& camera);

  const PinholeCamera& camera() const { return camera_; }
  const Scene& scene() const { return scene_; }

  // Renders the view from camera pose T_world_cam.
  RenderedFrame Render(const Rigid3d& T_world_cam) const;

  // The colour (CV_32FC3) averaged over the views from several poses: motion
  // blur over an exposure. `poses` must not be empty.
  cv::Mat RenderAveragedColor(const std::vector<Rigid3d>& poses) const;

 private:
  const Scene& scene_;
  PinholeCamera camera_;
};

// 8-bit colour (CV_8UC3) from a rendered colour times an exposure gain,
// rounded to nearest and clamped to [0, 255].
cv::Mat ToColor8(const cv::Mat& color, double gain = 1.0);

// Renders one frame and returns its 8-bit colour (BGR) and exact depth
// (CV_32FC1, metres): a convenience for tests and small in-process sequences.
struct SimpleFrame {
  cv::Mat color;  // CV_8UC3, BGR.
  cv::Mat depth;  // CV_32FC1, metres, 0 where no surface.
};
SimpleFrame RenderFrame(const Scene& scene, const PinholeCamera& camera,
                        const Rigid3d& T_world_cam);

}  // namespace rrslam::synth
