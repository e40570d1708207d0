// Image files: PNG (8-bit grey/colour, 16-bit grey) and JPEG, read and written
// with libpng and libjpeg-turbo directly.
//
// Why not OpenImageIO or cv::imread/cv::imwrite (measured by `make
// bench-image-io`, bench/results/image-io-2026-12-02.txt): both give the same
// pixels, but linking Debian's libOpenImageIO (262 libraries) adds about
// 0.5-0.65 s to the start-up of every process, and libopencv_imgcodecs (GDAL
// and 140 libraries) about 0.13-0.23 s, most of it the dynamic loader's
// symbol lookups, which no loader setting avoids; OpenImageIO also decodes
// JPEG about 20% slower (it delivers RGB only). rrslam's stages and a robot's
// start-up should not pay that. The render stage, which starts once per
// picture batch, writes its pictures through OpenImageIO
// (stages/render/image_file.h). Colour images are BGR in memory (OpenCV's
// order). Thread-safe.
#pragma once

#include <cstdint>
#include <filesystem>
#include <opencv2/core/mat.hpp>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace rrslam {

// Largest image side read (pixels), whatever the settings say: a file's
// header may declare up to 2^31 pixels a side in a few bytes (a 100 kB PNG of
// 65535 x 65535 decodes to 34 GB), and no RGB-D camera comes near this
// (16384 x 16384 is 268 Mpx, 0.8 GB as 8-bit BGR).
inline constexpr int kMaxImageSide = 16384;

// The largest image a reader accepts, checked from the file's header before
// any pixel is decoded or allocated. A side of 0 (not given) or above
// kMaxImageSide means kMaxImageSide. Callers pass the settings'
// Camera.width x Camera.height: an image larger than the calibration's would
// be tracked with the wrong camera.
struct ImageSizeLimit {
  int width = 0;
  int height = 0;
  // Where the limit comes from, for messages ("Camera.width x Camera.height
  // of settings.yaml"); empty: the limit is kMaxImageSide's.
  std::string source;

  int MaxWidth() const { return width > 0 && width < kMaxImageSide ? width : kMaxImageSide; }
  int MaxHeight() const { return height > 0 && height < kMaxImageSide ? height : kMaxImageSide; }
};

enum class ImageReadMode {
  kUnchanged,  // As stored: CV_8UC1, CV_8UC3 (BGR), CV_8UC4 (BGRA) or CV_16UC1.
  kColor,      // CV_8UC3 BGR (grey is replicated, alpha dropped; 16-bit rejected).
  kGray,       // CV_8UC1 (colour converted as cv::COLOR_BGR2GRAY; 16-bit rejected).
};

// Reads a PNG or JPEG file (told by its signature). Throws NoInputError when the
// file cannot be opened, DataError when it is not a readable PNG/JPEG, its
// pixel format does not fit `mode`, or its header declares an image larger
// than `limit` (the message names the file and both sizes; nothing has been
// decoded). Messages name the file.
cv::Mat ReadImage(const std::filesystem::path& path, ImageReadMode mode = ImageReadMode::kUnchanged,
                  const ImageSizeLimit& limit = {});

// Decodes PNG or JPEG bytes; `name` stands for the file in errors.
cv::Mat DecodeImage(std::span<const uint8_t> bytes, ImageReadMode mode, const std::string& name,
                    const ImageSizeLimit& limit = {});

// Encodes CV_8UC1, CV_8UC3 (BGR), CV_8UC4 (BGRA) or CV_16UC1 as PNG with zlib
// `compression` in [0, 9] and optional tEXt chunks (key, value). The same
// pixels and options always give the same bytes.
std::vector<uint8_t> EncodePng(const cv::Mat& image, int compression = 1,
                               const std::vector<std::pair<std::string, std::string>>& text = {});

// Writes a PNG atomically (common/atomic_file.h). Throws CantCreateError.
void WritePng(const std::filesystem::path& path, const cv::Mat& image, int compression = 1,
              const std::vector<std::pair<std::string, std::string>>& text = {});

}  // namespace rrslam
