// Surface textures of the synthetic room: procedural generation and filtered
// (mip-mapped, anisotropic) sampling.
//
// Texture space: a surface point has coordinates (a, b) in metres from the
// surface's corner (see scene.h). Level-0 texel (col, row) covers
// [col, col + 1) x [row, row + 1) times texel_size, so image columns follow a
// and rows follow b. Seen from the surface's visible side, a points right and
// b down, so text in a texture reads normally.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

namespace rrslam::synth {

class Rng;

// A colour texture with its mip-map chain (levels by 2x2 box averaging down to
// 1x1). Immutable after construction; thread-safe.
class MipTexture {
 public:
  MipTexture() = default;
  // `image` is CV_8UC3 (BGR), non-empty; `texel_size` is metres per texel.
  MipTexture(const cv::Mat& image, double texel_size);

  int width() const { return levels_.empty() ? 0 : levels_[0].width; }
  int height() const { return levels_.empty() ? 0 : levels_[0].height; }
  double texel_size() const { return texel_size_; }
  int num_levels() const { return static_cast<int>(levels_.size()); }
  // Level `level` as a CV_8UC3 image (a copy; for inspection and tests).
  cv::Mat LevelImage(int level) const;
  // Bytes held by all levels.
  size_t MemoryBytes() const;

  // Filtered colour (B, G, R on the 0-255 scale) seen through one image
  // pixel at surface point (a, b) (metres). The pixel's footprint is given by
  // the derivatives of (a, b) with respect to the image coordinates u and v
  // (metres per pixel). Anisotropic filtering: up to kMaxAnisotropy trilinear
  // samples along the footprint's major axis, at the level of detail of its
  // minor axis, so oblique surfaces stay sharp without aliasing.
  Eigen::Vector3f Sample(float a, float b, float da_du, float db_du, float da_dv,
                         float db_dv) const;

  // Trilinear sample at level-0 texel coordinates (x, y) (texel centres at
  // +0.5) and level of detail `lod` (0 = finest, clamped to the chain).
  Eigen::Vector3f SampleTrilinear(float x, float y, float lod) const;

  static constexpr int kMaxAnisotropy = 8;

 private:
  struct Level {
    int width = 0;
    int height = 0;
    std::vector<uint8_t> texels;  // 4 bytes per texel: B, G, R, 0.
  };
  // Add weight * (filtered colour) to bgr[0..2].
  void AddBilinear(int level, float x, float y, float weight, float* bgr) const;
  void AddTrilinear(float x, float y, float lod, float weight, float* bgr) const;

  std::vector<Level> levels_;
  double texel_size_ = 1.0;
};

// Kinds of surface, each with its own palette and patterns.
enum class Material {
  kWall,       // Plaster with dirt, marks, shapes and notes.
  kFloor,      // Wooden planks with grain, seams, shapes and marks.
  kCeiling,    // Light, lower-contrast version of the wall.
  kWood,       // Furniture wood grain (tables, legs).
  kCardboard,  // Boxes with printed labels and text.
  kPainted,    // Painted or fabric furniture with patterns.
  kPoster,     // Photographic-like pictures: dense multi-scale colour shapes.
};

std::string MaterialName(Material material);

// Generates the texture image (CV_8UC3, BGR) of a surface of size_a x size_b
// metres at `texel_size` metres per texel. Deterministic in `seed`.
//
// Recipe, so that FAST/ORB finds many stable corners at every scale:
//  - base colour: two material colours blended by low-frequency noise;
//  - material structure (planks and wood grain, plaster, cardboard tone);
//  - "dead leaves" shapes (rectangles, ellipses, polygons, rings, strokes,
//    small checkers) with log-uniform sizes from ~1 cm to ~45 cm and nearly
//    equal coverage per octave of size, the statistics of natural images;
//  - text-like marks: random words in Hershey fonts, 0.8-6 cm high;
//  - multiplicative fractal "dirt" noise over all octaves (1/f spectrum).
cv::Mat GenerateTexture(Material material, double size_a, double size_b, double texel_size,
                        uint64_t seed);

// Zero-mean, unit-variance fractal noise (CV_32FC1, width x height) built by
// pyramid refinement: starting from a random lattice of spacing
// 2^(n-1) texels, each finer level is smoothly upsampled by two (Chaikin's
// quadratic B-spline rule) and gets fresh uniform detail of amplitude
// amplitudes[level]; level 0 is the texel scale. Equal amplitudes give the
// 1/f amplitude spectrum of natural images.
cv::Mat FractalNoise(int width, int height, const std::vector<float>& amplitudes, Rng& rng);

}  // namespace rrslam::synth
