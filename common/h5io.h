// HDF5 helpers: root format attributes, typed arrays, strings.
//
// Every rrslam HDF5 file carries root attributes
//   format        string   FormatSpec::name, e.g. "rrslam.features"
//   format_major  uint16   incompatible-change version
//   format_minor  uint16   compatible-change version
//   producer      string   "rrslam-<stage> <version>"
//   options       string   the producing stage's options as JSON
// Datasets are written without modification times, so the same content gives
// the same bytes. The HDF5 library used here is not thread-safe: use one
// thread per process for HDF5 calls.
#pragma once

#include <H5Cpp.h>

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "common/errors.h"
#include "common/formats.h"

namespace rrslam {

struct H5FormatInfo {
  std::string format;
  uint16_t major = 0;
  uint16_t minor = 0;
  std::string producer;
  nlohmann::json options;
};

// Creates (truncates) an HDF5 file at `path`. Throws CantCreateError.
H5::H5File CreateH5File(const std::filesystem::path& path);

// Creates group `name` in `parent` (a file or a group) without modification
// times, like every dataset written here. Throws H5::Exception.
H5::Group CreateH5Group(H5::Group& parent, const std::string& name);

// Writes the root attributes above.
void WriteFormatAttributes(H5::H5File& file, const FormatSpec& spec, const std::string& producer,
                           const nlohmann::json& options);

// Opens `path` read-only and checks its root attributes against `spec`.
// Throws NoInputError when missing, DataError when it is not HDF5, not of
// this format, or of an unsupported major version.
H5::H5File OpenH5File(const std::filesystem::path& path, const FormatSpec& spec,
                      H5FormatInfo* info = nullptr);

// Opens the HDF5 file image `bytes` (a whole file's bytes held in memory,
// e.g. a fuzz input) read-only, through HDF5's core driver without a backing
// store: nothing is read from or written to disk. HDF5 copies the bytes, so
// they need not outlive the call. Checks the root attributes as OpenH5File
// does, with the same DataErrors, naming `name` (which stands for the file in
// messages; the H5File's own getFileName() is an internal name, not `name`).
H5::H5File OpenH5FileImage(std::span<const uint8_t> bytes, const FormatSpec& spec,
                           const std::string& name, H5FormatInfo* info = nullptr);

// Reads the root attributes without checking them (for `info` commands).
H5FormatInfo ReadFormatAttributes(const H5::H5File& file);

template <typename T>
const H5::PredType& H5TypeOf() {
  if constexpr (std::is_same_v<T, uint8_t>)
    return H5::PredType::NATIVE_UINT8;
  else if constexpr (std::is_same_v<T, int8_t>)
    return H5::PredType::NATIVE_INT8;
  else if constexpr (std::is_same_v<T, uint16_t>)
    return H5::PredType::NATIVE_UINT16;
  else if constexpr (std::is_same_v<T, int16_t>)
    return H5::PredType::NATIVE_INT16;
  else if constexpr (std::is_same_v<T, uint32_t>)
    return H5::PredType::NATIVE_UINT32;
  else if constexpr (std::is_same_v<T, int32_t>)
    return H5::PredType::NATIVE_INT32;
  else if constexpr (std::is_same_v<T, uint64_t>)
    return H5::PredType::NATIVE_UINT64;
  else if constexpr (std::is_same_v<T, int64_t>)
    return H5::PredType::NATIVE_INT64;
  else if constexpr (std::is_same_v<T, float>)
    return H5::PredType::NATIVE_FLOAT;
  else if constexpr (std::is_same_v<T, double>)
    return H5::PredType::NATIVE_DOUBLE;
  else
    static_assert(sizeof(T) == 0, "unsupported HDF5 element type");
}

// Writes `data` as dataset `name` of `group` with shape `dims` (product of
// dims must equal data.size()). `chunk_rows` > 0 stores it chunked along the
// first dimension and deflate-compressed at level 4.
void WriteH5Array(H5::Group& group, const std::string& name, const void* data,
                  const H5::PredType& type, const std::vector<hsize_t>& dims, hsize_t chunk_rows);

template <typename T>
void WriteH5Array(H5::Group& group, const std::string& name, std::span<const T> data,
                  const std::vector<hsize_t>& dims, hsize_t chunk_rows = 0) {
  WriteH5Array(group, name, data.data(), H5TypeOf<T>(), dims, chunk_rows);
}

// Shape of dataset `name`. Throws DataError naming `path` when it is absent,
// unreadable, or declares more data than its file can hold: more bytes than
// 2048 times the bytes stored for it (deflate expands at most 1032:1), capped
// by the file's size. A damaged file can declare any shape with a fill value
// and no data; the check keeps the arrays read from it as small as the file.
std::vector<hsize_t> H5ArrayShape(const H5::Group& group, const std::string& name,
                                  const std::string& path);

// Reads dataset `name` whole, converted to T. Checks the rank when
// `expected_rank` > 0 and returns the shape in `dims`. Throws DataError.
void ReadH5Array(const H5::Group& group, const std::string& name, void* out,
                 const H5::PredType& type, const std::string& path);

template <typename T>
std::vector<T> ReadH5Array(const H5::Group& group, const std::string& name, const std::string& path,
                           std::vector<hsize_t>* dims = nullptr, int expected_rank = 0) {
  const std::vector<hsize_t> shape = H5ArrayShape(group, name, path);
  if (expected_rank > 0 && static_cast<int>(shape.size()) != expected_rank) {
    throw DataError(path + ": dataset " + name + " has rank " + std::to_string(shape.size()) +
                    ", expected " + std::to_string(expected_rank));
  }
  size_t count = 1;
  for (hsize_t d : shape) count *= d;
  std::vector<T> out(count);
  if (count > 0) ReadH5Array(group, name, out.data(), H5TypeOf<T>(), path);
  if (dims != nullptr) *dims = shape;
  return out;
}

// Variable-length string attributes on any object (file, group, dataset).
// The reader accepts fixed-length strings too; it throws DataError naming
// `path` when the attribute is missing, not a string, or not a single value.
void WriteH5StringAttribute(H5::H5Object& object, const std::string& name,
                            const std::string& value);
std::string ReadH5StringAttribute(const H5::H5Object& object, const std::string& name,
                                  const std::string& path);

// Scalar numeric attributes, stored as `stored_type` (converted from double).
// The reader throws DataError naming `path` when the attribute is missing,
// not numeric, or not a single value.
void WriteH5ScalarAttribute(H5::H5Object& object, const std::string& name, double value,
                            const H5::PredType& stored_type = H5::PredType::IEEE_F64LE);
double ReadH5ScalarAttribute(const H5::H5Object& object, const std::string& name,
                             const std::string& path);

}  // namespace rrslam

namespace rrslam {
// 1-D datasets of variable-length UTF-8 strings.
void WriteH5StringArray(H5::Group& group, const std::string& name,
                        const std::vector<std::string>& values);
std::vector<std::string> ReadH5StringArray(const H5::Group& group, const std::string& name,
                                           const std::string& path);
}  // namespace rrslam
