// Seeded textured images for the extract tests (test-only, header-only).
//
// A camera-like 8-bit image: a background of smooth random texture at several
// scales, several hundred filled
// and outlined shapes (rectangles, circles, ellipses, triangles, lines) of
// random grey levels with sizes from a few pixels to a fifth of the image,
// text-like marks, then mild blur and sensor noise. It has corners at every
// scale and everywhere, like a well-textured indoor frame. cv::RNG makes the
// result the same on every platform for a given seed.
#pragma once

#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

namespace rrslam::testing {

inline cv::Mat MakeTexturedImage(int width, int height, uint64_t seed) {
  cv::RNG rng(seed);
  // Background: a gentle gradient plus smooth random texture at three scales
  // (8, 24 and 72 px), like the photographic clutter of an indoor scene.
  cv::Mat field(height, width, CV_32FC1);
  const double gx = rng.uniform(-0.1, 0.1), gy = rng.uniform(-0.1, 0.1);
  const double base = rng.uniform(100.0, 150.0);
  for (int y = 0; y < height; ++y) {
    float* row = field.ptr<float>(y);
    for (int x = 0; x < width; ++x) row[x] = static_cast<float>(base + gx * x + gy * y);
  }
  for (const int scale : {8, 24, 72}) {
    cv::Mat coarse(height / scale + 2, width / scale + 2, CV_32FC1);
    rng.fill(coarse, cv::RNG::UNIFORM, -30.0, 30.0);
    cv::Mat fine;
    cv::resize(coarse, fine, cv::Size(), scale, scale, cv::INTER_CUBIC);
    field += fine(cv::Rect(scale / 2, scale / 2, width, height));
  }
  cv::Mat image;
  field.convertTo(image, CV_8UC1);
  const int area = width * height;
  const int n_shapes = std::max(40, area / 400);
  const double min_size = 3.0, max_size = std::max(8.0, 0.2 * std::min(width, height));
  for (int i = 0; i < n_shapes; ++i) {
    // Log-uniform sizes: as many small shapes per octave as large ones.
    const double size = min_size * std::pow(max_size / min_size, rng.uniform(0.0, 1.0));
    const cv::Point center(rng.uniform(0, width), rng.uniform(0, height));
    const cv::Scalar colour(rng.uniform(0, 256));
    const int thickness = rng.uniform(0, 3) == 0 ? rng.uniform(1, 4) : cv::FILLED;
    const int radius = std::max(1, static_cast<int>(size / 2));
    switch (rng.uniform(0, 5)) {
      case 0:
        cv::rectangle(image, center - cv::Point(radius, radius / 2),
                      center + cv::Point(radius, radius), colour, thickness);
        break;
      case 1:
        cv::circle(image, center, radius, colour, thickness, cv::LINE_AA);
        break;
      case 2:
        cv::ellipse(image, center, cv::Size(radius, std::max(1, radius / 3)),
                    rng.uniform(0.0, 180.0), 0, 360, colour, thickness, cv::LINE_AA);
        break;
      case 3: {
        const cv::Point pts[3] = {
            center + cv::Point(rng.uniform(-radius, radius + 1), rng.uniform(-radius, radius + 1)),
            center + cv::Point(rng.uniform(-radius, radius + 1), rng.uniform(-radius, radius + 1)),
            center + cv::Point(rng.uniform(-radius, radius + 1), rng.uniform(-radius, radius + 1))};
        cv::fillConvexPoly(image, pts, 3, colour, cv::LINE_AA);
        break;
      }
      default:
        cv::line(
            image, center,
            center + cv::Point(rng.uniform(-radius, radius + 1), rng.uniform(-radius, radius + 1)),
            colour, rng.uniform(1, 3), cv::LINE_AA);
        break;
    }
  }
  // Text-like marks.
  const std::string glyphs = "ABCDEFGHKMNPRSTUVWXYZ0123456789#%&";
  const int n_marks = std::max(5, area / 20000);
  for (int i = 0; i < n_marks; ++i) {
    std::string text;
    const int length = rng.uniform(2, 7);
    for (int k = 0; k < length; ++k)
      text += glyphs[rng.uniform(0, static_cast<int>(glyphs.size()))];
    cv::putText(image, text, cv::Point(rng.uniform(0, width), rng.uniform(0, height)),
                cv::FONT_HERSHEY_SIMPLEX, rng.uniform(0.3, 1.2), cv::Scalar(rng.uniform(0, 256)),
                rng.uniform(1, 3), cv::LINE_AA);
  }
  // Optics and sensor: slight blur, then Gaussian noise of sigma 2 grey levels.
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0.7);
  cv::Mat noise(height, width, CV_16SC1);
  rng.fill(noise, cv::RNG::NORMAL, 0, 2);
  cv::Mat noisy;
  image.convertTo(noisy, CV_16SC1);
  noisy += noise;
  noisy.convertTo(image, CV_8UC1);
  return image;
}

// A filled `square` of grey `square_grey` on a `background_grey` image of
// `size`, plus uniform noise in [0, noise_max) from cv::RNG(seed). The noise
// breaks the ties of equal corner scores that a perfectly flat square has.
inline cv::Mat MakeNoisySquare(cv::Size size, cv::Rect square, int background_grey, int square_grey,
                               uint64_t seed, int noise_max) {
  cv::Mat image(size, CV_8UC1, cv::Scalar(background_grey));
  cv::rectangle(image, square, cv::Scalar(square_grey), cv::FILLED);
  cv::Mat noise(size, CV_8UC1);
  cv::RNG(seed).fill(noise, cv::RNG::UNIFORM, 0, noise_max);
  image += noise;
  return image;
}

}  // namespace rrslam::testing
