// Fuzz-only: the objects of a well-formed rrslam.features file
// (features_file.h) for common/fuzz/h5_image_builder.h, with the frame and
// keypoint counts taken from the fuzz input. Used by features_fuzzer.cc and
// checked by features_seeds_test.cc (a well-formed description must read
// back): a change of the features schema must be made here too.
#pragma once

#include <string>
#include <vector>

#include "common/fuzz/h5_image_builder.h"

namespace rrslam::fuzz {

// F = input in [0, 4] frames, frame f with input in [0, 5] keypoints; the
// keypoint values follow a fixed pattern (the builder may replace some).
inline std::vector<H5Object> FeaturesObjects(FuzzInput& in) {
  using Kind = H5Object::Kind;
  const int frames = static_cast<int>(in.Below(5));
  std::vector<double> offsets = {0};
  for (int f = 0; f < frames; ++f) offsets.push_back(offsets.back() + in.Below(6));
  const hsize_t F = static_cast<hsize_t>(frames);
  const hsize_t N = static_cast<hsize_t>(offsets.back());
  auto pattern = [](hsize_t count, double scale, double offset) {
    std::vector<double> values(count);
    for (hsize_t i = 0; i < count; ++i) values[i] = offset + scale * static_cast<double>(i % 97);
    return values;
  };
  auto attribute = [](const char* name, hid_t type, double value) {
    return H5Object{Kind::kAttribute, name, type, false, {}, {value}, {}};
  };
  auto text_attribute = [](const char* name, const char* value) {
    return H5Object{Kind::kAttribute, name, H5T_NATIVE_DOUBLE, true, {}, {}, {value}};
  };
  auto dataset = [](const char* path, hid_t type, std::vector<hsize_t> dims,
                    std::vector<double> values) {
    return H5Object{Kind::kDataset, path, type, false, std::move(dims), std::move(values), {}};
  };
  std::vector<std::string> rgb_paths, depth_paths;
  for (int f = 0; f < frames; ++f) {
    rgb_paths.push_back("rgb/" + std::to_string(1000 + f) + ".png");
    depth_paths.push_back("depth/" + std::to_string(1000 + f) + ".png");
  }
  std::vector<double> angle = pattern(N, 3.5, 0), octave(N);
  for (hsize_t i = 0; i < N; ++i) octave[i] = static_cast<double>(i % 8);
  return {
      text_attribute("format", "rrslam.features"),
      attribute("format_major", H5T_STD_U16LE, 1),
      attribute("format_minor", H5T_STD_U16LE, 1),
      text_attribute("producer", "rrslam-extract fuzz"),
      text_attribute("options", "{\"orb\":{\"n_features\":1000}}"),
      text_attribute("settings", "%YAML:1.0\nCamera.fx: 500\nCamera.fy: 500\n"),
      H5Object{Kind::kGroup, "frames", H5T_NATIVE_DOUBLE, false, {}, {}, {}},
      dataset("frames/rgb_timestamp", H5T_IEEE_F64LE, {F}, pattern(F, 1.0 / 30, 1000)),
      dataset("frames/depth_timestamp", H5T_IEEE_F64LE, {F}, pattern(F, 1.0 / 30, 1000.004)),
      H5Object{Kind::kDataset, "frames/rgb_path", H5T_NATIVE_DOUBLE, true, {F}, {}, rgb_paths},
      H5Object{Kind::kDataset, "frames/depth_path", H5T_NATIVE_DOUBLE, true, {F}, {}, depth_paths},
      dataset("frames/rgb_checksum", H5T_STD_U64LE, {F}, pattern(F, 977, 12345)),
      dataset("frames/depth_checksum", H5T_STD_U64LE, {F}, pattern(F, 991, 54321)),
      dataset("frames/keypoint_offset", H5T_STD_U64LE, {F + 1}, offsets),
      H5Object{Kind::kGroup, "keypoints", H5T_NATIVE_DOUBLE, false, {}, {}, {}},
      dataset("keypoints/pixel", H5T_IEEE_F32LE, {N, 2}, pattern(2 * N, 6.5, 1)),
      dataset("keypoints/undistorted", H5T_IEEE_F32LE, {N, 2}, pattern(2 * N, 6.5, 1.25)),
      dataset("keypoints/angle", H5T_IEEE_F32LE, {N}, angle),
      dataset("keypoints/octave", H5T_STD_U8LE, {N}, octave),
      dataset("keypoints/response", H5T_IEEE_F32LE, {N}, pattern(N, 0.5, 10)),
      dataset("keypoints/depth", H5T_IEEE_F32LE, {N}, pattern(N, 0.05, 0)),
      dataset("keypoints/descriptor", H5T_STD_U8LE, {N, 32}, pattern(32 * N, 7, 0)),
  };
}

}  // namespace rrslam::fuzz
