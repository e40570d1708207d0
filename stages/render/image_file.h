// Writing the render stage's pictures through OpenImageIO.
//
// Every picture is an 8-bit PNG with its producer (`rrslam-render <version>`)
// and the options that made it as PNG text chunks (OpenImageIO metadata
// "Software" and "Description"; any further key/value pairs as attributes),
// written atomically (common/atomic_file.h): an error never leaves a partial
// file under the final name.
#pragma once

#include <filesystem>
#include <opencv2/core/mat.hpp>
#include <string>
#include <utility>
#include <vector>

namespace rrslam {

struct ImageMetadata {
  std::string software;     // Producer, e.g. Producer("render").
  std::string description;  // What the image shows and the options (JSON is fine).
  std::vector<std::pair<std::string, std::string>> attributes;  // Further text chunks.
};

// Writes a CV_8UC1 (grey), CV_8UC3 (BGR) or CV_8UC4 (BGRA) image as PNG.
// Throws CantCreateError naming the file when it cannot be written.
void WritePicture(const std::filesystem::path& path, const cv::Mat& image,
                  const ImageMetadata& metadata);

// Reads a PNG's text metadata back (for tests and `rrslam-render` users):
// (name, value) of every attribute OpenImageIO reports. Throws NoInputError /
// DataError naming the file.
std::vector<std::pair<std::string, std::string>> ReadPictureMetadata(
    const std::filesystem::path& path);

}  // namespace rrslam
