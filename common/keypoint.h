// One ORB keypoint of an image (Keypoint) and the 2-D float point it holds
// its pixels in (Pixel2f).
//
// Keypoint is trivially copyable with a fixed 32-byte layout, the keypoint
// record of a map file since format 2.0 (stages/mapstore/map_file.cc), so a
// loaded map's keyframes view their keypoints in the mapped file
// (stages/mapstore/record_array.h) instead of copying them. It lives in
// common because extract (which makes keypoints), mapstore (which stores
// them) and track (which uses them) all share it.
#pragma once

#include <Eigen/Core>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <type_traits>

namespace rrslam {

// An image position in pixels (x along the row, rightwards; y down the
// column), two floats, x first: a plain value for records that must stay
// trivially copyable, which Eigen::Vector2f is not. Converts to and from
// Eigen::Vector2f for arithmetic: `(a.vec() - b.vec()).norm()`,
// `p.cast<double>()`.
class Pixel2f {
 public:
  constexpr Pixel2f() = default;
  constexpr Pixel2f(float x, float y) : x_(x), y_(y) {}
  Pixel2f(const Eigen::Vector2f& v) : x_(v.x()), y_(v.y()) {}  // NOLINT: implicit.

  constexpr float x() const { return x_; }
  constexpr float y() const { return y_; }
  constexpr float& x() { return x_; }
  constexpr float& y() { return y_; }

  Eigen::Vector2f vec() const { return {x_, y_}; }
  template <typename S>
  Eigen::Matrix<S, 2, 1> cast() const {
    return vec().cast<S>();
  }

  bool operator==(const Pixel2f&) const = default;

 private:
  float x_ = 0;
  float y_ = 0;
};

// One ORB keypoint. Pixels are level-0 image coordinates.
struct Keypoint {
  Pixel2f pixel;        // Real (distorted) image.
  Pixel2f undistorted;  // Ideal pinhole pixel.
  float angle_deg = 0;  // Orientation by intensity centroid, [0, 360).
  uint8_t octave = 0;   // Pyramid level it was detected on (3 bytes of padding follow).
  float response = 0;   // Corner score used to rank keypoints.
  float depth = 0;      // Metres from the paired depth image at `pixel`; 0 = none.

  bool operator==(const Keypoint&) const = default;
};

// The layout the map file's keypoint records rely on: floats pixel x, y at
// 0, 4, undistorted x, y at 8, 12, angle at 16, the octave at 20, response
// at 24, depth at 28.
static_assert(std::is_trivially_copyable_v<Pixel2f> && sizeof(Pixel2f) == 8);
static_assert(std::bit_cast<std::array<float, 2>>(Pixel2f(1, 2)) == std::array<float, 2>{1, 2},
              "Pixel2f: x at byte 0, y at byte 4");
static_assert(std::is_trivially_copyable_v<Keypoint> && std::is_standard_layout_v<Keypoint>);
static_assert(sizeof(Keypoint) == 32 && alignof(Keypoint) == 4);
static_assert(offsetof(Keypoint, pixel) == 0 && offsetof(Keypoint, undistorted) == 8 &&
              offsetof(Keypoint, angle_deg) == 16 && offsetof(Keypoint, octave) == 20 &&
              offsetof(Keypoint, response) == 24 && offsetof(Keypoint, depth) == 28);

}  // namespace rrslam
