// OpenImageIO as a candidate for rrslam's image decoding (common/image_io.h):
// a file read with OIIO::ImageInput into the cv::Mat that ReadImage(path,
// ImageReadMode::kUnchanged) returns for it, for bench_image_io and its
// start-up probe (bench/image_io/bench.mk).
#pragma once

#include <filesystem>
#include <opencv2/core/mat.hpp>
#include <string>

namespace rrslam::bench {

// How the pixels are read from the ImageInput.
enum class OiioRead {
  // read_native_scanlines() of the whole image straight into the cv::Mat.
  kNativeScanlines,
  // read_image() with the type asked for, the call OIIO's documentation
  // shows first. OIIO 2.4 maps and unmaps a 64 MiB scratch block in it on
  // every call (strace), so each image is written through fresh pages.
  kReadImage,
};

// Reads a PNG or JPEG (any format OIIO knows) as stored: CV_8UC1, CV_8UC3
// (BGR), CV_8UC4 (BGRA, alpha not premultiplied) or CV_16UC1 (16-bit values as
// stored). Throws std::runtime_error with OIIO's message when the file cannot
// be opened or decoded, or has a pixel format ReadImage does not give.
cv::Mat ReadImageOiio(const std::filesystem::path& path,
                      OiioRead read = OiioRead::kNativeScanlines);

// OpenImageIO's version, "2.4.7".
std::string OiioVersion();

}  // namespace rrslam::bench
