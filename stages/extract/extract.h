// The `extract` stage: ORB features of the frames of an RGB-D sequence,
// written to a features file (features_file.h) that every later stage reads.
//
// For each selected frame: the colour image is converted to grayscale, ORB
// keypoints and descriptors are extracted (orb_extractor.h), undistorted with
// the settings' camera, and given the depth (metres) of the paired depth image
// at their pixel. Frames are processed in parallel, one extractor per thread;
// the output does not depend on the number of threads.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/dataset.h"
#include "common/progress.h"
#include "common/settings.h"
#include "stages/extract/features_file.h"

namespace rrslam {

struct ExtractOptions {
  // TUM RGB-D sequence folder (rgb.txt + depth.txt, or associations.txt). Required.
  std::filesystem::path sequence;
  // ORB-SLAM2 RGB-D settings YAML: camera, distortion, DepthMapFactor and
  // ORBextractor.* (common/settings.h). Required.
  std::filesystem::path settings;
  // Features file to write (HDF5, rrslam.features). Required. Written atomically.
  std::filesystem::path out;
  // Associations file (`rgb_ts rgb_path depth_ts depth_path`), absolute or
  // relative to the sequence folder. Empty: pair rgb.txt with depth.txt by
  // timestamp (or read the sequence's associations.txt when those are absent).
  std::filesystem::path associations;
  // Take every stride-th paired frame; >= 1.
  int stride = 1;
  // Index (among the paired frames) of the first frame taken; >= 0.
  int first = 0;
  // At most this many frames; 0 = no limit; >= 0.
  int max_frames = 0;
  // Worker threads; 0 = one per hardware thread; in [0, 256]. Does not change
  // the output, so it is not recorded in the file.
  int threads = 0;

  // Names the first violated constraint ("--stride = 0; must be >= 1").
  bool Check(std::string* why) const;
  // The options recorded in the output file (everything but `threads`).
  nlohmann::json ToJson() const;
};

// Indices of the frames taken from a sequence of `num_frames` paired frames:
// first, first + stride, ... (at most max_frames of them).
std::vector<size_t> SelectFrames(size_t num_frames, const ExtractOptions& options);

// Extracts the features of `frames` (indices into `sequence`) on `threads`
// threads (0 = one per hardware thread), in the order given. Checks every
// image: readable (NoInputError), colour and depth of the same size, depth
// 16-bit single-channel, size equal to settings.width/height when those are
// given (DataError); the message names the image file. When several frames
// fail, the error of the first of them in `frames` is thrown. `progress`, if
// not null, advances by one per frame. The returned file has no settings text.
FeaturesFile ExtractFrames(const RgbdSequence& sequence, const Settings& settings,
                           const std::vector<size_t>& frames, int threads,
                           ProgressBar* progress = nullptr);

// JSON description of the extractor configuration recorded in the output
// (the ORB settings and the fixed constants of orb_extractor.h).
nlohmann::json OrbOptionsJson(const OrbSettings& orb);

// The whole stage: checks the options (UsageError), reads the settings and the
// sequence (NoInputError / DataError), checks that the output can be created
// (CantCreateError), extracts and writes the features file atomically.
void RunExtract(const ExtractOptions& options);

}  // namespace rrslam
