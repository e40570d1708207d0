#include "stages/render/keyframe_images.h"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "common/errors.h"
#include "common/image_io.h"
#include "common/text.h"

namespace rrslam {
namespace {

bool HasDistortion(const MapCamera& camera) {
  return camera.k1 != 0 || camera.k2 != 0 || camera.p1 != 0 || camera.p2 != 0 || camera.k3 != 0;
}

RgbdSequence OpenSequence(const MapScene& scene, const std::filesystem::path& sequence_dir,
                          const std::filesystem::path& associations) {
  SequenceOptions options;
  options.associations = associations;
  options.max_image_size = {scene.camera.width, scene.camera.height,
                            "the camera of " + scene.source};
  return RgbdSequence::Open(sequence_dir, options);
}

}  // namespace

void CheckFusableMap(const MapScene& scene) {
  const std::string& name = scene.source;
  if (scene.keyframes.empty()) throw DataError(name + ": the map has no keyframes");
  const MapCamera& camera = scene.camera;
  if (!(camera.depth_map_factor > 0)) {
    throw DataError(name + ": camera depth_map_factor " + Format("%g", camera.depth_map_factor) +
                    "; must be > 0");
  }
  // The camera sizes the undistortion maps (8 bytes a pixel, made before any
  // image is read) and the images: checked against the images' cap (OpenCV's
  // remap also asserts below 32767 pixels a side) and for finite values.
  if (camera.width <= 0 || camera.height <= 0 || camera.width > kMaxImageSide ||
      camera.height > kMaxImageSide) {
    throw DataError(name + ": camera image size " + std::to_string(camera.width) + "x" +
                    std::to_string(camera.height) + "; must be in [1, " +
                    std::to_string(kMaxImageSide) + "] a side");
  }
  for (const double value : {camera.fx, camera.fy, camera.cx, camera.cy, camera.k1, camera.k2,
                             camera.p1, camera.p2, camera.k3}) {
    if (!std::isfinite(value))
      throw DataError(name + ": camera intrinsics or distortion not finite");
  }
}

KeyFrameImages::KeyFrameImages(const MapScene& scene, const std::filesystem::path& sequence_dir,
                               const std::filesystem::path& associations)
    : sequence_(OpenSequence(scene, sequence_dir, associations)),
      frame_of_(KeyFrameFrames(scene, sequence_)),
      depth_map_factor_(scene.camera.depth_map_factor) {
  const MapCamera& c = scene.camera;
  camera_ = {c.fx, c.fy, c.cx, c.cy, c.width, c.height};
  if (HasDistortion(c) && c.width > 0 && c.height > 0) {
    const cv::Matx33d K(c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
    const cv::Matx<double, 1, 5> D(c.k1, c.k2, c.p1, c.p2, c.k3);
    cv::initUndistortRectifyMap(K, D, cv::noArray(), K, cv::Size(c.width, c.height), CV_32FC1,
                                undistort_x_, undistort_y_);
  }
}

KeyFrameView KeyFrameImages::Load(size_t index, bool with_color) const {
  const size_t frame = frame_of_.at(index);
  KeyFrameView view;
  view.depth = sequence_.LoadDepthMetres(frame, depth_map_factor_);
  if (view.depth.cols != camera_.width || view.depth.rows != camera_.height) {
    throw DataError(sequence_.frame(frame).depth_path.string() + ": " +
                    std::to_string(view.depth.cols) + "x" + std::to_string(view.depth.rows) +
                    " depth; the map's camera is " + std::to_string(camera_.width) + "x" +
                    std::to_string(camera_.height));
  }
  if (with_color) {
    view.color = sequence_.LoadColor(frame);
    CheckSameSize(view.color, view.depth, sequence_.frame(frame).depth_path);
  }
  if (undistorts()) {
    cv::Mat depth, color;
    cv::remap(view.depth, depth, undistort_x_, undistort_y_, cv::INTER_NEAREST, cv::BORDER_CONSTANT,
              0);
    view.depth = depth;
    if (with_color) {
      cv::remap(view.color, color, undistort_x_, undistort_y_, cv::INTER_LINEAR,
                cv::BORDER_CONSTANT, 0);
      view.color = color;
    }
  }
  return view;
}

}  // namespace rrslam
