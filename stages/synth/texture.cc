#include "stages/synth/texture.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstring>
#include <opencv2/imgproc.hpp>

#if defined(__SSE4_1__)
#include <smmintrin.h>
#endif

#include "stages/synth/random.h"

namespace rrslam::synth {
namespace {

// Trilinear filtering over box-filtered mip levels is soft: a tent of twice
// the footprint. This bias matches the box average of a supersampled pixel
// best while keeping FAST corners repeatable from frame to frame (measured:
// -1 is a little sharper, 0 clearly blurrier; see renderer_test.cc).
constexpr float kLodBias = -0.6f;

struct ColorF {
  float b = 0, g = 0, r = 0;
};

ColorF Mix(const ColorF& x, const ColorF& y, float t) {
  return {x.b + (y.b - x.b) * t, x.g + (y.g - x.g) * t, x.r + (y.r - x.r) * t};
}

// HSV (hue in degrees, saturation and value in [0, 1]) to BGR in [0, 1].
ColorF FromHsv(double hue, double sat, double val) {
  hue = std::fmod(std::fmod(hue, 360.0) + 360.0, 360.0);
  const double c = val * sat;
  const double h = hue / 60.0;
  const double x = c * (1.0 - std::fabs(std::fmod(h, 2.0) - 1.0));
  double r = 0, g = 0, b = 0;
  switch (static_cast<int>(h)) {
    case 0:
      r = c, g = x;
      break;
    case 1:
      r = x, g = c;
      break;
    case 2:
      g = c, b = x;
      break;
    case 3:
      g = x, b = c;
      break;
    case 4:
      r = x, b = c;
      break;
    default:
      r = c, b = x;
      break;
  }
  const double m = val - c;
  return {static_cast<float>(b + m), static_cast<float>(g + m), static_cast<float>(r + m)};
}

// Palette and pattern parameters of a material.
struct Recipe {
  double hue_lo, hue_hi, sat_lo, sat_hi, val_lo, val_hi;  // Base colours (HSV).
  float base_contrast;          // Weight of the low-frequency blend between the two base colours.
  float dirt_contrast;          // Amplitude of the multiplicative fractal noise.
  double shape_coverage;        // Fraction of area covered per octave of shape size.
  double shape_min, shape_max;  // Shape sizes, metres.
  double text_density;          // Text blocks per square metre.
  double text_min, text_max;    // Glyph heights, metres.
  bool planks = false;          // Floor planks with seams.
  bool grain = false;           // Wood grain along a.
  bool labels = false;          // Light label patches carrying text.
  bool vivid = false;           // Photographic colour field instead of two base colours.
};

Recipe RecipeOf(Material material) {
  switch (material) {
    case Material::kWall:
      return {0, 360, 0.05, 0.3, 0.62, 0.88, 0.5f, 0.14f, 0.13, 0.015, 0.45, 1.6, 0.01, 0.06};
    case Material::kCeiling:
      return {0, 360, 0.0, 0.12, 0.72, 0.9, 0.4f, 0.12f, 0.1, 0.015, 0.45, 0.8, 0.01, 0.06};
    case Material::kFloor: {
      Recipe r{18, 40, 0.35, 0.6, 0.42, 0.68, 0.3f, 0.16f, 0.11, 0.015, 0.4, 0.6, 0.01, 0.05};
      r.planks = true;
      r.grain = true;
      return r;
    }
    case Material::kWood: {
      Recipe r{18, 36, 0.4, 0.7, 0.32, 0.62, 0.3f, 0.14f, 0.11, 0.012, 0.3, 1.0, 0.008, 0.04};
      r.grain = true;
      return r;
    }
    case Material::kCardboard: {
      Recipe r{26, 38, 0.35, 0.55, 0.5, 0.72, 0.3f, 0.12f, 0.09, 0.012, 0.25, 5.0, 0.008, 0.05};
      r.labels = true;
      return r;
    }
    case Material::kPainted:
      return {0, 360, 0.25, 0.75, 0.3, 0.8, 0.4f, 0.14f, 0.15, 0.012, 0.35, 1.5, 0.008, 0.05};
    case Material::kPoster: {
      Recipe r{0, 360, 0.3, 0.9, 0.3, 0.9, 0.5f, 0.16f, 0.3, 0.01, 0.35, 4.0, 0.008, 0.06};
      r.vivid = true;
      return r;
    }
  }
  return RecipeOf(Material::kWall);
}

// Colour of a shape or mark: any hue, clearly darker or lighter than mid-grey.
ColorF RandomMarkColor(Rng& rng) {
  const double hue = rng.Uniform(0, 360);
  const double u = rng.Uniform();
  const double sat = 0.05 + 0.85 * u * u;  // Mostly muted, sometimes vivid.
  const double val = rng.Bernoulli(0.55) ? rng.Uniform(0.05, 0.38) : rng.Uniform(0.62, 1.0);
  return FromHsv(hue, sat, val);
}

// Blends `color` into `image` (CV_32FC3) through `mask` (CV_8UC1, 255 = full)
// placed with its top-left corner at (x0, y0) of the image; `alpha` scales it.
void BlendMask(cv::Mat& image, const cv::Mat& mask, int x0, int y0, const ColorF& color,
               float alpha) {
  const int c0 = std::max(0, -x0), r0 = std::max(0, -y0);
  const int c1 = std::min(mask.cols, image.cols - x0), r1 = std::min(mask.rows, image.rows - y0);
  const float scale = alpha / 255.0f;
  for (int r = r0; r < r1; ++r) {
    const uint8_t* m = mask.ptr<uint8_t>(r);
    float* p = image.ptr<float>(y0 + r) + 3 * x0;
    for (int c = c0; c < c1; ++c) {
      if (m[c] == 0) continue;
      const float t = m[c] * scale;
      p[3 * c + 0] += (color.b - p[3 * c + 0]) * t;
      p[3 * c + 1] += (color.g - p[3 * c + 1]) * t;
      p[3 * c + 2] += (color.r - p[3 * c + 2]) * t;
    }
  }
}

// Fixed-point points for OpenCV's sub-pixel drawing (shift = 4 bits).
constexpr int kShift = 4;
cv::Point Fixed(double x, double y) {
  return {static_cast<int>(std::lround(x * (1 << kShift))),
          static_cast<int>(std::lround(y * (1 << kShift)))};
}

// Draws one random shape of size `size_px` (texels) centred at (cx, cy).
void DrawShape(cv::Mat& image, double cx, double cy, double size_px, Rng& rng) {
  const int half = static_cast<int>(std::ceil(size_px * 0.75)) + 3;
  const int x0 = static_cast<int>(std::floor(cx)) - half;
  const int y0 = static_cast<int>(std::floor(cy)) - half;
  cv::Mat mask(2 * half + 1, 2 * half + 1, CV_8UC1, cv::Scalar(0));
  const double lx = cx - x0, ly = cy - y0;  // Centre in mask coordinates.
  const double angle = rng.Uniform(0, 2 * M_PI);
  const double ca = std::cos(angle), sa = std::sin(angle);
  auto rotated = [&](double dx, double dy) {
    return Fixed(lx + ca * dx - sa * dy, ly + sa * dx + ca * dy);
  };
  const ColorF color = RandomMarkColor(rng);
  const float alpha = static_cast<float>(rng.Uniform(0.65, 1.0));
  const double r = 0.5 * size_px;
  const int kind = rng.UniformInt(0, 7);
  switch (kind) {
    case 0:
    case 1: {  // Rotated rectangle.
      const double aspect = rng.Uniform(0.25, 1.0);
      const double hw = r, hh = r * aspect;
      std::vector<cv::Point> pts = {rotated(-hw, -hh), rotated(hw, -hh), rotated(hw, hh),
                                    rotated(-hw, hh)};
      cv::fillPoly(mask, std::vector<std::vector<cv::Point>>{pts}, cv::Scalar(255), cv::LINE_AA,
                   kShift);
      break;
    }
    case 2: {  // Ellipse.
      const double aspect = rng.Uniform(0.35, 1.0);
      cv::ellipse(mask, Fixed(lx, ly),
                  cv::Size(static_cast<int>(r * (1 << kShift)),
                           static_cast<int>(r * aspect * (1 << kShift))),
                  angle * 180.0 / M_PI, 0, 360, cv::Scalar(255), cv::FILLED, cv::LINE_AA, kShift);
      break;
    }
    case 3:
    case 4: {  // Triangle or star-convex polygon.
      const int n = kind == 3 ? 3 : rng.UniformInt(4, 8);
      std::vector<double> angles(n);
      for (auto& a : angles) a = rng.Uniform(0, 2 * M_PI);
      std::sort(angles.begin(), angles.end());
      std::vector<cv::Point> pts;
      for (double a : angles) {
        const double rr = r * rng.Uniform(0.45, 1.0);
        pts.push_back(rotated(rr * std::cos(a), rr * std::sin(a)));
      }
      cv::fillPoly(mask, std::vector<std::vector<cv::Point>>{pts}, cv::Scalar(255), cv::LINE_AA,
                   kShift);
      break;
    }
    case 5: {  // Ring.
      const double aspect = rng.Uniform(0.5, 1.0);
      const int thickness = std::max(1, static_cast<int>(r * rng.Uniform(0.12, 0.35)));
      const double rr = std::max(1.0, r - 0.5 * thickness);
      cv::ellipse(mask, Fixed(lx, ly),
                  cv::Size(static_cast<int>(rr * (1 << kShift)),
                           static_cast<int>(rr * aspect * (1 << kShift))),
                  angle * 180.0 / M_PI, 0, 360, cv::Scalar(255), thickness, cv::LINE_AA, kShift);
      break;
    }
    case 6: {  // Stroke: a polyline of 2-4 segments.
      const int n = rng.UniformInt(3, 5);
      std::vector<cv::Point> pts;
      for (int i = 0; i < n; ++i) {
        pts.push_back(rotated(r * rng.Uniform(-1, 1), r * rng.Uniform(-1, 1)));
      }
      const int thickness = std::max(1, static_cast<int>(size_px * rng.Uniform(0.04, 0.12)));
      cv::polylines(mask, std::vector<std::vector<cv::Point>>{pts}, false, cv::Scalar(255),
                    thickness, cv::LINE_AA, kShift);
      break;
    }
    default: {  // Small checker of 2x2 to 4x4 cells: X-junction corners.
      const int n = rng.UniformInt(2, 4);
      const double cell = 2.0 * r / n;
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
          if ((i + j) % 2 != 0) continue;
          const double ax = -r + i * cell, ay = -r + j * cell;
          std::vector<cv::Point> pts = {rotated(ax, ay), rotated(ax + cell, ay),
                                        rotated(ax + cell, ay + cell), rotated(ax, ay + cell)};
          cv::fillPoly(mask, std::vector<std::vector<cv::Point>>{pts}, cv::Scalar(255), cv::LINE_AA,
                       kShift);
        }
      }
      break;
    }
  }
  BlendMask(image, mask, x0, y0, color, alpha);
}

std::string RandomWord(Rng& rng) {
  static const char kLower[] = "abcdefghijklmnopqrstuvwxyz";
  static const char kUpper[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZ";
  static const char kDigits[] = "0123456789";
  const int style = rng.UniformInt(0, 5);
  const int length = rng.UniformInt(2, 9);
  std::string word;
  for (int i = 0; i < length; ++i) {
    if (style == 0) {
      word += kDigits[rng.UniformInt(0, 9)];
    } else if (style == 1 || (i == 0 && style == 2)) {
      word += kUpper[rng.UniformInt(0, 25)];
    } else {
      word += kLower[rng.UniformInt(0, 25)];
    }
  }
  return word;
}

// Draws a block of 1-6 lines of random words with its top-left corner near
// (x, y), glyphs `height_px` texels high, optionally turned by 90 degrees.
void DrawText(cv::Mat& image, double x, double y, double height_px, const ColorF& color, Rng& rng) {
  static constexpr int kFonts[] = {cv::FONT_HERSHEY_SIMPLEX,       cv::FONT_HERSHEY_PLAIN,
                                   cv::FONT_HERSHEY_DUPLEX,        cv::FONT_HERSHEY_COMPLEX,
                                   cv::FONT_HERSHEY_TRIPLEX,       cv::FONT_HERSHEY_COMPLEX_SMALL,
                                   cv::FONT_HERSHEY_SCRIPT_SIMPLEX};
  const int font = kFonts[rng.UniformInt(0, 6)] | (rng.Bernoulli(0.2) ? cv::FONT_ITALIC : 0);
  int baseline = 0;
  const cv::Size unit = cv::getTextSize("Hg", font, 1.0, 1, &baseline);
  const double scale = height_px / std::max(1, unit.height);
  const int thickness = std::max(1, static_cast<int>(std::lround(height_px / 10.0)));
  const int lines = rng.UniformInt(1, 6);
  std::vector<std::string> texts;
  int width = 1;
  const int line_step = static_cast<int>(std::ceil(height_px * 1.6));
  for (int i = 0; i < lines; ++i) {
    std::string line = RandomWord(rng);
    const int words = rng.UniformInt(0, 4);
    for (int w = 0; w < words; ++w) {
      line += ' ';
      line += RandomWord(rng);
    }
    width = std::max(width, cv::getTextSize(line, font, scale, thickness, &baseline).width);
    texts.push_back(line);
  }
  const int pad = 2 + thickness;
  cv::Mat mask(lines * line_step + 2 * pad, width + 2 * pad, CV_8UC1, cv::Scalar(0));
  for (int i = 0; i < lines; ++i) {
    cv::putText(mask, texts[i], cv::Point(pad, pad + static_cast<int>(height_px) + i * line_step),
                font, scale, cv::Scalar(255), thickness, cv::LINE_AA);
  }
  const int turn = rng.UniformInt(0, 5);  // Mostly upright; sometimes turned.
  if (turn == 4) cv::rotate(mask, mask, cv::ROTATE_90_COUNTERCLOCKWISE);
  if (turn == 5) cv::rotate(mask, mask, cv::ROTATE_90_CLOCKWISE);
  const float alpha = static_cast<float>(rng.Uniform(0.75, 1.0));
  BlendMask(image, mask, static_cast<int>(x), static_cast<int>(y), color, alpha);
}

// Chaikin refinement by two along both axes, cropped to out_w x out_h.
cv::Mat Upsample2(const cv::Mat& in, int out_w, int out_h) {
  assert(out_w <= 2 * in.cols && out_h <= 2 * in.rows);
  cv::Mat rows(in.rows, out_w, CV_32FC1);
  for (int r = 0; r < in.rows; ++r) {
    const float* s = in.ptr<float>(r);
    float* d = rows.ptr<float>(r);
    const int last = in.cols - 1;
    for (int c = 0; c < out_w; ++c) {
      const int i = c >> 1;
      const int j = (c & 1) ? std::min(i + 1, last) : std::max(i - 1, 0);
      d[c] = 0.75f * s[i] + 0.25f * s[j];
    }
  }
  cv::Mat out(out_h, out_w, CV_32FC1);
  const int last = in.rows - 1;
  for (int r = 0; r < out_h; ++r) {
    const int i = r >> 1;
    const int j = (r & 1) ? std::min(i + 1, last) : std::max(i - 1, 0);
    const float* a = rows.ptr<float>(i);
    const float* b = rows.ptr<float>(j);
    float* d = out.ptr<float>(r);
    for (int c = 0; c < out_w; ++c) d[c] = 0.75f * a[c] + 0.25f * b[c];
  }
  return out;
}

void AddUniform(cv::Mat& grid, float amplitude, Rng& rng) {
  if (amplitude == 0.0f) return;
  for (int r = 0; r < grid.rows; ++r) {
    float* p = grid.ptr<float>(r);
    for (int c = 0; c < grid.cols; ++c) {
      p[c] += amplitude * static_cast<float>(2.0 * rng.Uniform() - 1.0);
    }
  }
}

// Number of pyramid levels whose lattice spacing (2^l texels) is at most
// `wavelength` metres.
int LevelsUpTo(double wavelength, double texel_size) {
  return std::max(1, static_cast<int>(std::floor(std::log2(wavelength / texel_size))) + 1);
}

// Wooden planks along a: per-plank tint and dark seams. Multiplies `image`.
void ApplyPlanks(cv::Mat& image, double texel_size, Rng& rng) {
  const double plank_width = rng.Uniform(0.12, 0.2);
  const int rows_of_planks = static_cast<int>(std::ceil(image.rows * texel_size / plank_width));
  const double length_lo = 0.6, length_hi = 1.8;
  for (int k = 0; k < rows_of_planks; ++k) {
    const int y_begin = static_cast<int>(std::lround(k * plank_width / texel_size));
    const int y_end =
        std::min(image.rows, static_cast<int>(std::lround((k + 1) * plank_width / texel_size)));
    double x = -rng.Uniform(0, length_hi);  // Staggered joints.
    while (x * texel_size < image.cols * texel_size) {
      const double length = rng.Uniform(length_lo, length_hi) / texel_size;
      const float tint = static_cast<float>(rng.Uniform(0.78, 1.18));
      const float warm = static_cast<float>(rng.Uniform(-0.05, 0.05));
      const int x_begin = std::max(0, static_cast<int>(std::lround(x)));
      const int x_end = std::min(image.cols, static_cast<int>(std::lround(x + length)));
      for (int r = y_begin; r < y_end; ++r) {
        float* p = image.ptr<float>(r);
        const bool seam_row = (r == y_begin);
        for (int c = x_begin; c < x_end; ++c) {
          const bool seam = seam_row || c == x_begin;
          const float f = seam ? 0.45f : tint;
          p[3 * c + 0] *= f * (1.0f - warm);
          p[3 * c + 1] *= f;
          p[3 * c + 2] *= f * (1.0f + warm);
        }
      }
      x += length;
    }
  }
}

}  // namespace

std::string MaterialName(Material material) {
  switch (material) {
    case Material::kWall:
      return "wall";
    case Material::kFloor:
      return "floor";
    case Material::kCeiling:
      return "ceiling";
    case Material::kWood:
      return "wood";
    case Material::kCardboard:
      return "cardboard";
    case Material::kPainted:
      return "painted";
    case Material::kPoster:
      return "poster";
  }
  return "unknown";
}

cv::Mat FractalNoise(int width, int height, const std::vector<float>& amplitudes, Rng& rng) {
  assert(width > 0 && height > 0 && !amplitudes.empty());
  const int n = static_cast<int>(amplitudes.size());
  auto size_at = [](int full, int level) { return ((full + (1 << level) - 1) >> level) + 2; };
  cv::Mat grid(size_at(height, n - 1), size_at(width, n - 1), CV_32FC1, cv::Scalar(0));
  AddUniform(grid, amplitudes[n - 1], rng);
  for (int level = n - 2; level >= 0; --level) {
    grid = Upsample2(grid, size_at(width, level), size_at(height, level));
    AddUniform(grid, amplitudes[level], rng);
  }
  cv::Mat noise = grid(cv::Rect(1, 1, width, height)).clone();
  // Normalize with plain double sums: identical on every machine.
  double sum = 0, sum2 = 0;
  for (int r = 0; r < height; ++r) {
    const float* p = noise.ptr<float>(r);
    for (int c = 0; c < width; ++c) sum += p[c], sum2 += double(p[c]) * p[c];
  }
  const double count = double(width) * height;
  const double mean = sum / count;
  const double stddev = std::sqrt(std::max(1e-20, sum2 / count - mean * mean));
  noise.convertTo(noise, CV_32FC1, 1.0 / stddev, -mean / stddev);
  return noise;
}

cv::Mat GenerateTexture(Material material, double size_a, double size_b, double texel_size,
                        uint64_t seed) {
  const Recipe recipe = RecipeOf(material);
  Rng rng(seed);
  const int width = std::max(2, static_cast<int>(std::ceil(size_a / texel_size)));
  const int height = std::max(2, static_cast<int>(std::ceil(size_b / texel_size)));
  const double area = size_a * size_b;

  // 1. Base colour field.
  cv::Mat image(height, width, CV_32FC3);
  {
    const int coarse_levels = LevelsUpTo(1.5, texel_size);
    const int fine_cut = LevelsUpTo(0.06, texel_size);  // Colour varies slowly.
    std::vector<float> amplitudes(coarse_levels, 0.0f);
    for (int l = fine_cut; l < coarse_levels; ++l) amplitudes[l] = 1.0f;
    if (recipe.vivid) {
      // Three independent channels through a sigmoid: saturated, photographic colour.
      std::array<cv::Mat, 3> channels;
      for (auto& ch : channels) ch = FractalNoise(width, height, amplitudes, rng);
      for (int r = 0; r < height; ++r) {
        float* p = image.ptr<float>(r);
        for (int k = 0; k < 3; ++k) {
          const float* q = channels[k].ptr<float>(r);
          for (int c = 0; c < width; ++c) p[3 * c + k] = 1.0f / (1.0f + std::exp(-2.2f * q[c]));
        }
      }
    } else {
      const ColorF c1 = FromHsv(rng.Uniform(recipe.hue_lo, recipe.hue_hi),
                                rng.Uniform(recipe.sat_lo, recipe.sat_hi),
                                rng.Uniform(recipe.val_lo, recipe.val_hi));
      const ColorF c2 = FromHsv(rng.Uniform(recipe.hue_lo, recipe.hue_hi),
                                rng.Uniform(recipe.sat_lo, recipe.sat_hi),
                                rng.Uniform(recipe.val_lo, recipe.val_hi));
      const cv::Mat blend = FractalNoise(width, height, amplitudes, rng);
      for (int r = 0; r < height; ++r) {
        float* p = image.ptr<float>(r);
        const float* q = blend.ptr<float>(r);
        for (int c = 0; c < width; ++c) {
          const float t = std::clamp(0.5f + recipe.base_contrast * 0.5f * q[c], 0.0f, 1.0f);
          const ColorF m = Mix(c1, c2, t);
          p[3 * c + 0] = m.b, p[3 * c + 1] = m.g, p[3 * c + 2] = m.r;
        }
      }
    }
  }

  // 2. Material structure.
  if (recipe.grain) {
    // Grain: noise stretched 12 times along a.
    const int gw = std::max(2, width / 12);
    std::vector<float> amplitudes(LevelsUpTo(0.2, texel_size), 1.0f);
    cv::Mat grain_small = FractalNoise(gw, height, amplitudes, rng);
    cv::Mat grain;
    cv::resize(grain_small, grain, cv::Size(width, height), 0, 0, cv::INTER_LINEAR);
    for (int r = 0; r < height; ++r) {
      float* p = image.ptr<float>(r);
      const float* q = grain.ptr<float>(r);
      for (int c = 0; c < width; ++c) {
        const float f = 1.0f + 0.13f * q[c];
        p[3 * c + 0] *= f, p[3 * c + 1] *= f, p[3 * c + 2] *= f;
      }
    }
  }
  if (recipe.planks) ApplyPlanks(image, texel_size, rng);

  // 3. Dead-leaves shapes, largest octave first so that small ones stay visible.
  std::vector<double> octaves;
  for (double s = recipe.shape_max; s >= recipe.shape_min * 0.999; s *= 0.5) octaves.push_back(s);
  for (double s_hi : octaves) {
    const double s_lo = 0.5 * s_hi;
    const double mean_size2 = s_lo * s_hi;  // E[s^2] for log-uniform s in an octave ~ s_lo s_hi.
    // Coverage tilts gently towards large shapes (x0.45 at 1.5 cm against
    // 40 cm), so fine scales are carried by text and grain rather than confetti.
    const double coverage = recipe.shape_coverage * 1.3 * std::pow(s_hi / recipe.shape_max, 0.23);
    const double expected = coverage * area / mean_size2;
    const int count =
        static_cast<int>(expected) + (rng.Uniform() < expected - std::floor(expected));
    for (int i = 0; i < count; ++i) {
      const double cx = rng.Uniform(0, width), cy = rng.Uniform(0, height);
      const double size_px = rng.LogUniform(s_lo, s_hi) / texel_size;
      DrawShape(image, cx, cy, size_px, rng);
    }
  }

  // 4. Labels and text.
  const double expected_text = recipe.text_density * area;
  const int text_blocks =
      static_cast<int>(expected_text) + (rng.Uniform() < expected_text - std::floor(expected_text));
  for (int i = 0; i < text_blocks; ++i) {
    const double x = rng.Uniform(-0.1, 1.0) * width, y = rng.Uniform(-0.1, 1.0) * height;
    const double h = rng.LogUniform(recipe.text_min, recipe.text_max) / texel_size;
    ColorF ink = RandomMarkColor(rng);
    if (recipe.labels && rng.Bernoulli(0.6)) {
      // A light label under dark text.
      const double lw = h * rng.Uniform(6, 14), lh = h * rng.Uniform(2.5, 6);
      cv::Mat mask(static_cast<int>(lh) + 1, static_cast<int>(lw) + 1, CV_8UC1, cv::Scalar(255));
      BlendMask(image, mask, static_cast<int>(x - h), static_cast<int>(y - h),
                FromHsv(rng.Uniform(0, 360), rng.Uniform(0, 0.15), rng.Uniform(0.85, 1.0)), 1.0f);
      ink = FromHsv(rng.Uniform(0, 360), rng.Uniform(0, 0.8), rng.Uniform(0.02, 0.3));
    }
    DrawText(image, x, y, h, ink, rng);
  }

  // 5. Multiplicative fractal dirt over all octaves.
  {
    std::vector<float> amplitudes(LevelsUpTo(0.8, texel_size), 1.0f);
    const cv::Mat dirt = FractalNoise(width, height, amplitudes, rng);
    for (int r = 0; r < height; ++r) {
      float* p = image.ptr<float>(r);
      const float* q = dirt.ptr<float>(r);
      for (int c = 0; c < width; ++c) {
        const float f = std::max(0.2f, 1.0f + recipe.dirt_contrast * q[c]);
        p[3 * c + 0] *= f, p[3 * c + 1] *= f, p[3 * c + 2] *= f;
      }
    }
  }

  cv::Mat out(height, width, CV_8UC3);
  for (int r = 0; r < height; ++r) {
    const float* p = image.ptr<float>(r);
    uint8_t* o = out.ptr<uint8_t>(r);
    for (int c = 0; c < 3 * width; ++c) {
      o[c] = static_cast<uint8_t>(std::clamp(std::lround(p[c] * 255.0f), 0L, 255L));
    }
  }
  return out;
}

MipTexture::MipTexture(const cv::Mat& image, double texel_size) : texel_size_(texel_size) {
  assert(image.type() == CV_8UC3 && !image.empty() && texel_size > 0);
  Level base;
  base.width = image.cols;
  base.height = image.rows;
  base.texels.resize(4 * size_t(image.cols) * image.rows);
  for (int r = 0; r < image.rows; ++r) {
    const uint8_t* s = image.ptr<uint8_t>(r);
    uint8_t* d = base.texels.data() + 4 * size_t(r) * image.cols;
    for (int c = 0; c < image.cols; ++c) {
      d[4 * c + 0] = s[3 * c + 0], d[4 * c + 1] = s[3 * c + 1], d[4 * c + 2] = s[3 * c + 2];
      d[4 * c + 3] = 0;
    }
  }
  levels_.push_back(std::move(base));
  while (levels_.back().width > 1 || levels_.back().height > 1) {
    const Level& prev = levels_.back();
    Level next;
    next.width = std::max(1, (prev.width + 1) / 2);
    next.height = std::max(1, (prev.height + 1) / 2);
    next.texels.resize(4 * size_t(next.width) * next.height);
    for (int r = 0; r < next.height; ++r) {
      const int r0 = std::min(2 * r, prev.height - 1), r1 = std::min(2 * r + 1, prev.height - 1);
      for (int c = 0; c < next.width; ++c) {
        const int c0 = std::min(2 * c, prev.width - 1), c1 = std::min(2 * c + 1, prev.width - 1);
        const uint8_t* p00 = &prev.texels[4 * (size_t(r0) * prev.width + c0)];
        const uint8_t* p01 = &prev.texels[4 * (size_t(r0) * prev.width + c1)];
        const uint8_t* p10 = &prev.texels[4 * (size_t(r1) * prev.width + c0)];
        const uint8_t* p11 = &prev.texels[4 * (size_t(r1) * prev.width + c1)];
        uint8_t* d = &next.texels[4 * (size_t(r) * next.width + c)];
        for (int k = 0; k < 4; ++k)
          d[k] = static_cast<uint8_t>((p00[k] + p01[k] + p10[k] + p11[k] + 2) / 4);
      }
    }
    levels_.push_back(std::move(next));
  }
}

cv::Mat MipTexture::LevelImage(int level) const {
  const Level& l = levels_.at(level);
  cv::Mat out(l.height, l.width, CV_8UC3);
  for (int r = 0; r < l.height; ++r) {
    uint8_t* d = out.ptr<uint8_t>(r);
    const uint8_t* s = &l.texels[4 * size_t(r) * l.width];
    for (int c = 0; c < l.width; ++c) {
      d[3 * c + 0] = s[4 * c + 0], d[3 * c + 1] = s[4 * c + 1], d[3 * c + 2] = s[4 * c + 2];
    }
  }
  return out;
}

size_t MipTexture::MemoryBytes() const {
  size_t bytes = 0;
  for (const auto& l : levels_) bytes += l.texels.size();
  return bytes;
}

namespace {

// log2 for positive normal floats to about 1e-4: exponent plus a cubic in
// the mantissa. Plenty for a level of detail, and much cheaper than log2f.
inline float FastLog2(float x) {
  int exponent;
  const float m = std::frexp(x, &exponent);  // x = m 2^e, m in [0.5, 1).
  const float y = 2.0f * m - 1.0f;           // In [0, 1): log2(1 + y).
  return static_cast<float>(exponent - 1) +
         y * (1.4425449f + y * (-0.7181452f + y * (0.4575485f - 0.1832929f * y)));
}

}  // namespace

#if defined(__SSE4_1__)
namespace {
inline __m128 LoadTexel(const uint8_t* p) {
  int32_t bits;
  std::memcpy(&bits, p, 4);
  return _mm_cvtepi32_ps(_mm_cvtepu8_epi32(_mm_cvtsi32_si128(bits)));
}
}  // namespace
#endif

void MipTexture::AddBilinear(int level, float x, float y, float weight, float* bgr) const {
  const Level& l = levels_[level];
  // Texel centres sit at integer + 0.5.
  x -= 0.5f;
  y -= 0.5f;
  const float fx = std::floor(x), fy = std::floor(y);
  const float tx = x - fx, ty = y - fy;
  const int ix = static_cast<int>(fx), iy = static_cast<int>(fy);
  const int x0 = std::clamp(ix, 0, l.width - 1), x1 = std::clamp(ix + 1, 0, l.width - 1);
  const int y0 = std::clamp(iy, 0, l.height - 1), y1 = std::clamp(iy + 1, 0, l.height - 1);
  const uint8_t* row0 = &l.texels[4 * size_t(y0) * l.width];
  const uint8_t* row1 = &l.texels[4 * size_t(y1) * l.width];
  const float w00 = (1 - tx) * (1 - ty) * weight, w01 = tx * (1 - ty) * weight;
  const float w10 = (1 - tx) * ty * weight, w11 = tx * ty * weight;
#if defined(__SSE4_1__)
  __m128 sum = _mm_mul_ps(LoadTexel(row0 + 4 * x0), _mm_set1_ps(w00));
  sum = _mm_add_ps(sum, _mm_mul_ps(LoadTexel(row0 + 4 * x1), _mm_set1_ps(w01)));
  sum = _mm_add_ps(sum, _mm_mul_ps(LoadTexel(row1 + 4 * x0), _mm_set1_ps(w10)));
  sum = _mm_add_ps(sum, _mm_mul_ps(LoadTexel(row1 + 4 * x1), _mm_set1_ps(w11)));
  alignas(16) float out[4];
  _mm_store_ps(out, sum);
  bgr[0] += out[0], bgr[1] += out[1], bgr[2] += out[2];
#else
  for (int k = 0; k < 3; ++k) {
    bgr[k] += w00 * row0[4 * x0 + k] + w01 * row0[4 * x1 + k] + w10 * row1[4 * x0 + k] +
              w11 * row1[4 * x1 + k];
  }
#endif
}

void MipTexture::AddTrilinear(float x, float y, float lod, float weight, float* bgr) const {
  const int last = num_levels() - 1;
  lod = std::clamp(lod, 0.0f, static_cast<float>(last));
  const int l0 = static_cast<int>(lod);
  const float f = lod - l0;
  const float s0 = 1.0f / static_cast<float>(1 << l0);
  if (f < 1e-3f || l0 == last) {
    AddBilinear(l0, x * s0, y * s0, weight, bgr);
  } else {
    AddBilinear(l0, x * s0, y * s0, (1.0f - f) * weight, bgr);
    AddBilinear(l0 + 1, x * s0 * 0.5f, y * s0 * 0.5f, f * weight, bgr);
  }
}

Eigen::Vector3f MipTexture::SampleTrilinear(float x, float y, float lod) const {
  float bgr[3] = {0, 0, 0};
  AddTrilinear(x, y, lod, 1.0f, bgr);
  return {bgr[0], bgr[1], bgr[2]};
}

Eigen::Vector3f MipTexture::Sample(float a, float b, float da_du, float db_du, float da_dv,
                                   float db_dv) const {
  const float inv = static_cast<float>(1.0 / texel_size_);
  const float x = a * inv, y = b * inv;
  const float ux = da_du * inv, uy = db_du * inv, vx = da_dv * inv, vy = db_dv * inv;
  const float lu2 = ux * ux + uy * uy, lv2 = vx * vx + vy * vy;
  const bool u_major = lu2 >= lv2;
  const float mx = u_major ? ux : vx, my = u_major ? uy : vy;
  const float major = std::sqrt(u_major ? lu2 : lv2);
  // Width across the major axis: the parallelogram's area over its length.
  const float minor = major > 0 ? std::fabs(ux * vy - uy * vx) / major : 0.0f;
  int taps = 1;
  if (major > 1.0f) {
    taps = minor * kMaxAnisotropy <= major
               ? kMaxAnisotropy
               : std::max(1, static_cast<int>(std::ceil(major / minor - 0.01f)));
  }
  const float extent = std::max(major / taps, minor);
  const float lod = extent > 1e-30f ? FastLog2(extent) + kLodBias : 0.0f;
  float bgr[3] = {0, 0, 0};
  if (taps == 1) {
    AddTrilinear(x, y, lod, 1.0f, bgr);
  } else {
    const float weight = 1.0f / taps;
    for (int k = 0; k < taps; ++k) {
      const float t = (k + 0.5f) / taps - 0.5f;
      AddTrilinear(x + t * mx, y + t * my, lod, weight, bgr);
    }
  }
  return {bgr[0], bgr[1], bgr[2]};
}

}  // namespace rrslam::synth
