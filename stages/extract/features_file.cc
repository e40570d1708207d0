#include "stages/extract/features_file.h"

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/formats.h"

namespace rrslam {

void FeaturesFile::AddFrame(FrameRecord record, std::span<const Keypoint> frame_keypoints,
                            std::span<const OrbDescriptor> frame_descriptors) {
  if (frame_keypoints.size() != frame_descriptors.size()) {
    throw std::invalid_argument("AddFrame: keypoints and descriptors differ in count");
  }
  record.keypoint_begin = keypoints.size();
  keypoints.insert(keypoints.end(), frame_keypoints.begin(), frame_keypoints.end());
  descriptors.insert(descriptors.end(), frame_descriptors.begin(), frame_descriptors.end());
  record.keypoint_end = keypoints.size();
  frames.push_back(std::move(record));
}

void WriteFeaturesFile(const std::filesystem::path& path, const FeaturesFile& features,
                       const std::string& producer, const nlohmann::json& options) {
  AtomicOutput out(path);
  {
    H5::H5File file = CreateH5File(out.temp_path());
    try {
      WriteFormatAttributes(file, kFeaturesFormat, producer, options);
      WriteH5StringAttribute(file, "settings", features.settings_yaml);
      const size_t F = features.frames.size();
      const size_t N = features.keypoints.size();
      H5::Group frames = CreateH5Group(file, "frames");
      std::vector<double> rgb_ts(F), depth_ts(F);
      std::vector<std::string> rgb_paths(F), depth_paths(F);
      std::vector<uint64_t> offsets(F + 1, 0), rgb_checksums(F), depth_checksums(F);
      for (size_t f = 0; f < F; ++f) {
        const FrameRecord& r = features.frames[f];
        rgb_ts[f] = r.rgb_timestamp;
        depth_ts[f] = r.depth_timestamp;
        rgb_paths[f] = r.rgb_path;
        depth_paths[f] = r.depth_path;
        rgb_checksums[f] = r.rgb_checksum;
        depth_checksums[f] = r.depth_checksum;
        offsets[f] = r.keypoint_begin;
        offsets[f + 1] = r.keypoint_end;
      }
      WriteH5Array<double>(frames, "rgb_timestamp", rgb_ts, {F});
      WriteH5Array<double>(frames, "depth_timestamp", depth_ts, {F});
      WriteH5StringArray(frames, "rgb_path", rgb_paths);
      WriteH5StringArray(frames, "depth_path", depth_paths);
      WriteH5Array<uint64_t>(frames, "rgb_checksum", rgb_checksums, {F});
      WriteH5Array<uint64_t>(frames, "depth_checksum", depth_checksums, {F});
      WriteH5Array<uint64_t>(frames, "keypoint_offset", offsets, {F + 1});

      H5::Group kps = CreateH5Group(file, "keypoints");
      std::vector<float> pixel(2 * N), undistorted(2 * N), angle(N), response(N), depth(N);
      std::vector<uint8_t> octave(N);
      for (size_t i = 0; i < N; ++i) {
        const Keypoint& k = features.keypoints[i];
        pixel[2 * i] = k.pixel.x();
        pixel[2 * i + 1] = k.pixel.y();
        undistorted[2 * i] = k.undistorted.x();
        undistorted[2 * i + 1] = k.undistorted.y();
        angle[i] = k.angle_deg;
        octave[i] = k.octave;
        response[i] = k.response;
        depth[i] = k.depth;
      }
      WriteH5Array<float>(kps, "pixel", pixel, {N, 2});
      WriteH5Array<float>(kps, "undistorted", undistorted, {N, 2});
      WriteH5Array<float>(kps, "angle", angle, {N});
      WriteH5Array<uint8_t>(kps, "octave", octave, {N});
      WriteH5Array<float>(kps, "response", response, {N});
      WriteH5Array<float>(kps, "depth", depth, {N});
      WriteH5Array(kps, "descriptor", features.descriptors.data(), H5::PredType::NATIVE_UINT8,
                   {N, 32}, 0);
      file.close();
    } catch (const H5::Exception& e) {
      throw CantCreateError(path.string() + ": HDF5 write failed: " + e.getDetailMsg());
    }
  }
  out.Commit();
}

namespace {

// The frame offsets of an opened features file and its keypoint count.
struct FeaturesLayout {
  std::vector<uint64_t> offsets;
  size_t num_keypoints = 0;
};

// Group `group` of `file`; DataError when it is absent or not a group.
H5::Group OpenGroup(const H5::H5File& file, const std::string& group, const std::string& name) {
  if (!file.nameExists(group) || file.childObjType(group) != H5O_TYPE_GROUP) {
    throw DataError(name + ": missing group " + group);
  }
  return file.openGroup(group);
}

FeaturesLayout ReadLayout(const H5::H5File& file, const std::string& name) {
  FeaturesLayout o;
  H5::Group frames = OpenGroup(file, "frames", name);
  o.offsets = ReadH5Array<uint64_t>(frames, "keypoint_offset", name, nullptr, 1);
  if (o.offsets.empty() || o.offsets.front() != 0) {
    throw DataError(name + ": frames/keypoint_offset must start at 0");
  }
  for (size_t f = 1; f < o.offsets.size(); ++f) {
    if (o.offsets[f] < o.offsets[f - 1]) {
      throw DataError(name + ": frames/keypoint_offset decreases at frame " + std::to_string(f));
    }
  }
  o.num_keypoints = o.offsets.back();
  H5::Group kps = OpenGroup(file, "keypoints", name);
  const std::vector<hsize_t> desc_shape = H5ArrayShape(kps, "descriptor", name);
  if (desc_shape.size() != 2 || desc_shape[1] != 32) {
    throw DataError(name + ": keypoints/descriptor must be N x 32 bytes (256-bit ORB)");
  }
  if (desc_shape[0] != o.num_keypoints) {
    throw DataError(name + ": " + std::to_string(desc_shape[0]) + " descriptors but offsets give " +
                    std::to_string(o.num_keypoints) + " keypoints");
  }
  return o;
}

template <typename T>
std::vector<T> ReadColumn(const H5::Group& group, const std::string& dataset, size_t expected,
                          size_t width, const std::string& name) {
  std::vector<hsize_t> dims;
  std::vector<T> values = ReadH5Array<T>(group, dataset, name, &dims);
  if (values.size() != expected * width) {
    throw DataError(name + ": " + dataset + " has " + std::to_string(values.size() / width) +
                    " rows, expected " + std::to_string(expected));
  }
  return values;
}

// The body of ReadFeaturesFile and ReadFeaturesFileImage: everything after
// the root attributes were checked.
FeaturesFile ReadFeatures(const H5::H5File& file, const H5FormatInfo& info,
                          const std::string& name) {
  const FeaturesLayout o = ReadLayout(file, name);
  FeaturesFile out;
  out.format = info;
  if (file.attrExists("settings")) {
    out.settings_yaml = ReadH5StringAttribute(file, "settings", name);
  }
  const size_t F = o.offsets.size() - 1;
  const size_t N = o.num_keypoints;
  H5::Group frames = OpenGroup(file, "frames", name);
  const auto rgb_ts = ReadColumn<double>(frames, "rgb_timestamp", F, 1, name);
  const auto depth_ts = ReadColumn<double>(frames, "depth_timestamp", F, 1, name);
  const auto rgb_paths = ReadH5StringArray(frames, "rgb_path", name);
  const auto depth_paths = ReadH5StringArray(frames, "depth_path", name);
  if (rgb_paths.size() != F || depth_paths.size() != F) {
    throw DataError(name + ": frame path lists do not match the frame count");
  }
  // The images' checksums: since format 1.1 (required there), 0 before.
  std::vector<uint64_t> rgb_checksums(F, 0), depth_checksums(F, 0);
  if (info.minor >= 1) {
    rgb_checksums = ReadColumn<uint64_t>(frames, "rgb_checksum", F, 1, name);
    depth_checksums = ReadColumn<uint64_t>(frames, "depth_checksum", F, 1, name);
  }
  out.frames.resize(F);
  for (size_t f = 0; f < F; ++f) {
    out.frames[f] = {rgb_ts[f],        depth_ts[f],        rgb_paths[f], depth_paths[f],
                     rgb_checksums[f], depth_checksums[f], o.offsets[f], o.offsets[f + 1]};
  }
  H5::Group kps = OpenGroup(file, "keypoints", name);
  const auto pixel = ReadColumn<float>(kps, "pixel", N, 2, name);
  const auto undistorted = ReadColumn<float>(kps, "undistorted", N, 2, name);
  const auto angle = ReadColumn<float>(kps, "angle", N, 1, name);
  const auto octave = ReadColumn<uint8_t>(kps, "octave", N, 1, name);
  const auto response = ReadColumn<float>(kps, "response", N, 1, name);
  const auto depth = ReadColumn<float>(kps, "depth", N, 1, name);
  out.keypoints.resize(N);
  for (size_t i = 0; i < N; ++i) {
    Keypoint& k = out.keypoints[i];
    k.pixel = {pixel[2 * i], pixel[2 * i + 1]};
    k.undistorted = {undistorted[2 * i], undistorted[2 * i + 1]};
    k.angle_deg = angle[i];
    k.octave = octave[i];
    k.response = response[i];
    k.depth = depth[i];
  }
  out.descriptors.resize(N);
  if (N > 0)
    ReadH5Array(kps, "descriptor", out.descriptors.data(), H5::PredType::NATIVE_UINT8, name);
  return out;
}

// The body of ReadFeatureDescriptors and ReadFeatureDescriptorsImage.
std::vector<OrbDescriptor> ReadDescriptors(const H5::H5File& file, const std::string& name,
                                           size_t stride) {
  if (stride == 0) stride = 1;
  const FeaturesLayout o = ReadLayout(file, name);
  H5::Group kps = OpenGroup(file, "keypoints", name);
  std::vector<OrbDescriptor> all(o.num_keypoints);
  if (!all.empty()) ReadH5Array(kps, "descriptor", all.data(), H5::PredType::NATIVE_UINT8, name);
  if (stride == 1) return all;
  std::vector<OrbDescriptor> selected;
  for (size_t f = 0; f + 1 < o.offsets.size(); f += stride) {
    selected.insert(selected.end(), all.begin() + o.offsets[f], all.begin() + o.offsets[f + 1]);
  }
  return selected;
}

// Runs `read` on an opened file, turning the HDF5 errors of a damaged file
// (an unreadable group or attribute) into a DataError naming it.
template <typename Read>
auto ReadOrDataError(const std::string& name, Read read) {
  try {
    return read();
  } catch (const H5::Exception& e) {
    throw DataError(name + ": HDF5 read failed (corrupt file?): " + e.getDetailMsg());
  }
}

}  // namespace

FeaturesFile ReadFeaturesFile(const std::filesystem::path& path) {
  const std::string name = path.string();
  H5FormatInfo info;
  const H5::H5File file = OpenH5File(path, kFeaturesFormat, &info);
  return ReadOrDataError(name, [&] { return ReadFeatures(file, info, name); });
}

FeaturesFile ReadFeaturesFileImage(std::span<const uint8_t> bytes, const std::string& name) {
  H5FormatInfo info;
  const H5::H5File file = OpenH5FileImage(bytes, kFeaturesFormat, name, &info);
  return ReadOrDataError(name, [&] { return ReadFeatures(file, info, name); });
}

std::vector<OrbDescriptor> ReadFeatureDescriptors(const std::filesystem::path& path,
                                                  size_t stride) {
  const std::string name = path.string();
  const H5::H5File file = OpenH5File(path, kFeaturesFormat);
  return ReadOrDataError(name, [&] { return ReadDescriptors(file, name, stride); });
}

std::vector<OrbDescriptor> ReadFeatureDescriptorsImage(std::span<const uint8_t> bytes,
                                                       const std::string& name, size_t stride) {
  const H5::H5File file = OpenH5FileImage(bytes, kFeaturesFormat, name);
  return ReadOrDataError(name, [&] { return ReadDescriptors(file, name, stride); });
}

}  // namespace rrslam
