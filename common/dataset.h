// Reader of RGB-D sequences in the TUM RGB-D benchmark layout.
//
// A sequence folder holds `rgb/` (8-bit colour, PNG or JPEG), `depth/` (16-bit
// PNG, DepthMapFactor units per metre, 0 = no measurement), the lists
// `rgb.txt` and `depth.txt` (`timestamp path` per line, '#' comments) and
// optionally `groundtruth.txt` (TUM trajectory, camera-to-world).
//
// RGB and depth images are paired either from an associations file
// (`rgb_ts rgb_path depth_ts depth_path` per line) or, by default, from
// rgb.txt and depth.txt the way TUM's associate.py does (AssociateTimestamps).
// Thread-safe after Open(): images may be loaded from several threads.
#pragma once

#include <filesystem>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/image_io.h"
#include "common/trajectory.h"

namespace rrslam {

struct SequenceOptions {
  // Associations file, absolute or relative to the sequence folder. Empty: pair
  // rgb.txt with depth.txt; if those are absent, use associations.txt.
  std::filesystem::path associations;
  // Largest |t_rgb - t_depth| in seconds for a pair (strictly smaller), as associate.py.
  double max_time_difference = 0.02;
  // Largest image loaded (common/image_io.h), checked from each file's header
  // before it is decoded: the settings' (or the map's) Camera.width x
  // Camera.height; not given: kMaxImageSide a side.
  ImageSizeLimit max_image_size;
};

struct RgbdFrameRef {
  double rgb_timestamp = 0;        // Seconds; the frame's timestamp.
  std::filesystem::path rgb_path;  // Absolute or relative to the working folder.
  double depth_timestamp = 0;
  std::filesystem::path depth_path;
};

// Greedy timestamp association of TUM's associate.py: every pair with
// |a - (b + offset)| < max_difference is a candidate; candidates are taken in
// order of increasing difference (ties by a, then b), each stamp used once;
// the result is sorted by a. Returns index pairs (i into a, j into b).
std::vector<std::pair<size_t, size_t>> AssociateTimestamps(const std::vector<double>& a,
                                                           const std::vector<double>& b,
                                                           double max_difference,
                                                           double offset = 0.0);

// Reads a `timestamp path` list (rgb.txt, depth.txt). Throws NoInputError /
// DataError naming the file and line.
std::vector<std::pair<double, std::string>> ReadTimestampList(const std::filesystem::path& path);

// Parses the text of a `timestamp path` list; `source` names it in errors
// (DataError with the line). Fields after the second are ignored.
std::vector<std::pair<double, std::string>> ParseTimestampList(std::string_view text,
                                                               const std::string& source);

// Parses the text of an associations file (`rgb_timestamp rgb_path
// depth_timestamp depth_path` per line, '#' comments; fields after the fourth
// are ignored); image paths are taken relative to `dir`. `source` names the
// file in errors (DataError with the line). Whether the images exist is
// RgbdSequence::Open's check, not this one's.
std::vector<RgbdFrameRef> ParseAssociations(std::string_view text, const std::filesystem::path& dir,
                                            const std::string& source);

class RgbdSequence {
 public:
  // Opens a sequence folder and pairs its frames. Throws NoInputError when the
  // folder or its lists are missing, DataError when a list is malformed, no
  // frame can be paired, or a listed image file does not exist.
  static RgbdSequence Open(const std::filesystem::path& dir, const SequenceOptions& options = {});

  const std::filesystem::path& dir() const { return dir_; }
  size_t size() const { return frames_.size(); }
  const std::vector<RgbdFrameRef>& frames() const { return frames_; }
  const RgbdFrameRef& frame(size_t i) const { return frames_.at(i); }

  // groundtruth.txt when present (read at Open), else nullopt.
  const std::optional<Trajectory>& groundtruth() const { return groundtruth_; }

  // Colour image as 8-bit BGR (CV_8UC3). Throws NoInputError when the file
  // cannot be opened, DataError when it is not a readable 8-bit PNG or JPEG or
  // is larger than SequenceOptions::max_image_size (every Load* below too).
  cv::Mat LoadColor(size_t i) const;
  // Grayscale 8-bit image (CV_8UC1): a JPEG's luma channel, or a PNG converted
  // as cv::COLOR_BGR2GRAY (common/image_io.h).
  cv::Mat LoadGray(size_t i) const;
  // Raw depth image (CV_16UC1). Throws DataError when it is not 16-bit single-channel.
  cv::Mat LoadDepthRaw(size_t i) const;
  // Depth in metres (CV_32FC1): raw / depth_map_factor; 0 where there is no depth.
  cv::Mat LoadDepthMetres(size_t i, double depth_map_factor) const;

 private:
  std::filesystem::path dir_;
  std::vector<RgbdFrameRef> frames_;
  std::optional<Trajectory> groundtruth_;
  ImageSizeLimit max_image_size_;
};

// Loads an 8-bit image as grayscale (CV_8UC1) / BGR (CV_8UC3), or a 16-bit depth
// image (CV_16UC1), with the same errors as RgbdSequence; an image larger than
// `limit` is refused from its header (DataError naming both sizes).
cv::Mat LoadGrayImage(const std::filesystem::path& path, const ImageSizeLimit& limit = {});
cv::Mat LoadColorImage(const std::filesystem::path& path, const ImageSizeLimit& limit = {});
cv::Mat LoadDepthImage(const std::filesystem::path& path, const ImageSizeLimit& limit = {});

// Checks that rgb and depth images have the same size; throws DataError naming
// `depth_path` otherwise.
void CheckSameSize(const cv::Mat& rgb, const cv::Mat& depth,
                   const std::filesystem::path& depth_path);

}  // namespace rrslam
