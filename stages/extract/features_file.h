// The features file written by `rrslam-extract` and read by every later stage
// (format rrslam.features 1.1, HDF5).
//
// Format 1.1 added /frames/rgb_checksum and /frames/depth_checksum; a 1.0
// file reads with both 0 (not recorded).
//
// Schema (F frames, N keypoints over all frames, frame f owning keypoints
// [keypoint_offset[f], keypoint_offset[f+1])):
//   root attributes   format, format_major, format_minor, producer, options
//                     (h5io.h), and `settings`: the settings YAML text used
//   /frames/rgb_timestamp     (F)    float64  seconds
//   /frames/depth_timestamp   (F)    float64  seconds
//   /frames/rgb_path          (F)    string   as given by the sequence reader
//   /frames/depth_path        (F)    string
//   /frames/rgb_checksum      (F)    uint64   XXH3-64 of the image files' bytes
//   /frames/depth_checksum    (F)    uint64   (FileChecksum64; since 1.1)
//   /frames/keypoint_offset   (F+1)  uint64
//   /keypoints/pixel          (N,2)  float32  level-0 pixel in the real (distorted) image
//   /keypoints/undistorted    (N,2)  float32  ideal pixel after undistortion
//   /keypoints/angle          (N)    float32  orientation, degrees in [0, 360)
//   /keypoints/octave         (N)    uint8    pyramid level
//   /keypoints/response       (N)    float32  FAST/Harris response
//   /keypoints/depth          (N)    float32  metres at the pixel, 0 = none
//   /keypoints/descriptor     (N,32) uint8    ORB descriptor bytes (orb_descriptor.h)
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "common/h5io.h"
#include "common/keypoint.h"
#include "common/orb_descriptor.h"

namespace rrslam {

// Identity of one RGB-D frame in a features file.
struct FrameRecord {
  double rgb_timestamp = 0;
  double depth_timestamp = 0;
  std::string rgb_path;
  std::string depth_path;
  // XXH3-64 of the rgb and depth files' bytes it was extracted from
  // (FileChecksum64); 0: not recorded (a format 1.0 file).
  uint64_t rgb_checksum = 0;
  uint64_t depth_checksum = 0;
  uint64_t keypoint_begin = 0;  // Index of its first keypoint in FeaturesFile::keypoints.
  uint64_t keypoint_end = 0;    // One past its last keypoint.
};

// A whole features file in memory, keypoints of all frames in one array.
struct FeaturesFile {
  H5FormatInfo format;        // Root attributes (producer, options).
  std::string settings_yaml;  // Settings text the features were extracted with.
  std::vector<FrameRecord> frames;
  std::vector<Keypoint> keypoints;
  std::vector<OrbDescriptor> descriptors;  // Parallel to keypoints.

  size_t num_frames() const { return frames.size(); }
  std::span<const Keypoint> FrameKeypoints(size_t frame) const {
    const FrameRecord& f = frames.at(frame);
    return {keypoints.data() + f.keypoint_begin, keypoints.data() + f.keypoint_end};
  }
  std::span<const OrbDescriptor> FrameDescriptors(size_t frame) const {
    const FrameRecord& f = frames.at(frame);
    return {descriptors.data() + f.keypoint_begin, descriptors.data() + f.keypoint_end};
  }
  // Appends a frame (keypoint_begin/end are set here).
  void AddFrame(FrameRecord record, std::span<const Keypoint> frame_keypoints,
                std::span<const OrbDescriptor> frame_descriptors);
};

// Writes `features` atomically to `path` with root attributes from `producer`
// and `options`. Throws CantCreateError.
void WriteFeaturesFile(const std::filesystem::path& path, const FeaturesFile& features,
                       const std::string& producer, const nlohmann::json& options);

// Reads a whole features file. Throws NoInputError when missing, DataError
// when it is not a rrslam.features file of a supported version or is
// inconsistent (offsets out of range, array lengths that disagree); HDF5
// errors in a damaged file are DataErrors too.
FeaturesFile ReadFeaturesFile(const std::filesystem::path& path);

// The same from the bytes of a features file held in memory (an HDF5 file
// image, see OpenH5FileImage; used by the fuzz target). `name` stands for the
// file in messages. Throws DataError as ReadFeaturesFile.
FeaturesFile ReadFeaturesFileImage(std::span<const uint8_t> bytes, const std::string& name);

// Reads only the descriptors of every `stride`-th frame (for vocabulary
// training), without the keypoints. Errors as ReadFeaturesFile.
std::vector<OrbDescriptor> ReadFeatureDescriptors(const std::filesystem::path& path,
                                                  size_t stride = 1);

// The same from the bytes of a features file held in memory (see
// ReadFeaturesFileImage).
std::vector<OrbDescriptor> ReadFeatureDescriptorsImage(std::span<const uint8_t> bytes,
                                                       const std::string& name, size_t stride = 1);

}  // namespace rrslam
