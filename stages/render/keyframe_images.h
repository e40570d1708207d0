// The depth and colour images of a saved map's keyframes, read from the
// RGB-D sequence the map was built from (each keyframe's frame found by its
// timestamp) and undistorted to the ideal pinhole camera of the map: what
// the models that fuse depth (dense/, octomap/) integrate.
//
// Units: depth in metres along the optical axis (0 = no measurement),
// pixels of the map's image size.
#pragma once

#include <cstddef>
#include <filesystem>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "common/dataset.h"
#include "stages/render/map_scene.h"

namespace rrslam {

// The pinhole camera of the loaded images (ideal pixels: images with lens
// distortion are undistorted when loaded).
struct KeyFrameCamera {
  double fx = 0, fy = 0, cx = 0, cy = 0;  // Pixels.
  int width = 0, height = 0;              // Pixels.
};

// The images of one view.
struct KeyFrameView {
  cv::Mat depth;  // CV_32FC1, metres along the optical axis; 0 = none.
  cv::Mat color;  // CV_8UC3 BGR, the depth's size; may be empty when not asked for.
};

// Throws DataError naming the map when its keyframes' images cannot be
// loaded for fusion: no keyframes, a depth_map_factor <= 0, an image size
// beyond kMaxImageSide, or intrinsics or distortion that are not finite.
void CheckFusableMap(const MapScene& scene);

// The keyframes' images of `scene` (CheckFusableMap first). Undistortion,
// when the camera has lens distortion: both images through one map (TUM's
// depth is registered to the colour image); depth with the nearest
// neighbour, so no depth is blended across edges.
class KeyFrameImages {
 public:
  // Opens the sequence (associations absolute or relative to it, as given to
  // rrslam-track; images larger than the map's camera are refused from their
  // headers) and finds every keyframe's frame. Throws NoInputError for a
  // missing sequence, DataError for a malformed one or a keyframe without
  // its frame (KeyFrameFrames, map_scene.h).
  KeyFrameImages(const MapScene& scene, const std::filesystem::path& sequence_dir,
                 const std::filesystem::path& associations);

  const KeyFrameCamera& camera() const { return camera_; }
  bool undistorts() const { return !undistort_x_.empty(); }
  size_t size() const { return frame_of_.size(); }

  // The images of keyframe `index` (the scene's keyframe order); the colour
  // image only when `with_color`. Throws NoInputError/DataError naming the
  // image file when one is missing, unreadable or of another size.
  KeyFrameView Load(size_t index, bool with_color) const;

 private:
  RgbdSequence sequence_;
  std::vector<size_t> frame_of_;  // Sequence frame of each keyframe.
  double depth_map_factor_ = 0;
  KeyFrameCamera camera_;
  cv::Mat undistort_x_, undistort_y_;  // Empty: no lens distortion.
};

}  // namespace rrslam
