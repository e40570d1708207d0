#include "common/h5io.h"

#include <H5FDcore.h>

#include <algorithm>
#include <atomic>
#include <system_error>

#include "common/json_text.h"
#include "common/path_check.h"

namespace rrslam {

H5::H5File CreateH5File(const std::filesystem::path& path) {
  try {
    H5::FileCreatPropList create;
    // No modification times in the root group's header: the same content
    // gives the same bytes (datasets and groups are created likewise).
    H5Pset_obj_track_times(create.getId(), false);
    H5::FileAccPropList access;
    // Fix the library format bounds so output does not depend on defaults.
    access.setLibverBounds(H5F_LIBVER_V18, H5F_LIBVER_V110);
    return H5::H5File(path.string(), H5F_ACC_TRUNC, create, access);
  } catch (const H5::Exception& e) {
    throw CantCreateError(path.string() + ": cannot create HDF5 file");
  }
}

H5::Group CreateH5Group(H5::Group& parent, const std::string& name) {
  H5::PropList props(H5Pcreate(H5P_GROUP_CREATE));
  H5Pset_obj_track_times(props.getId(), false);
  const hid_t id =
      H5Gcreate2(parent.getId(), name.c_str(), H5P_DEFAULT, props.getId(), H5P_DEFAULT);
  if (id < 0) throw H5::GroupIException("CreateH5Group", "H5Gcreate2 failed for " + name);
  H5::Group group(id);  // Takes a reference of its own.
  H5Gclose(id);         // Drops ours, so the Group object owns the only one.
  return group;
}

void WriteFormatAttributes(H5::H5File& file, const FormatSpec& spec, const std::string& producer,
                           const nlohmann::json& options) {
  WriteH5StringAttribute(file, "format", spec.name);
  WriteH5ScalarAttribute(file, "format_major", spec.major, H5::PredType::STD_U16LE);
  WriteH5ScalarAttribute(file, "format_minor", spec.minor, H5::PredType::STD_U16LE);
  WriteH5StringAttribute(file, "producer", producer);
  WriteH5StringAttribute(file, "options", DumpJson(options));
}

namespace {

// ReadFormatAttributes naming `path` in its errors.
H5FormatInfo ReadFormatAttributesOf(const H5::H5File& file, const std::string& path) {
  H5FormatInfo info;
  info.format = ReadH5StringAttribute(file, "format", path);
  info.major = static_cast<uint16_t>(ReadH5ScalarAttribute(file, "format_major", path));
  info.minor = static_cast<uint16_t>(ReadH5ScalarAttribute(file, "format_minor", path));
  if (file.attrExists("producer")) info.producer = ReadH5StringAttribute(file, "producer", path);
  if (file.attrExists("options")) {
    const std::string text = ReadH5StringAttribute(file, "options", path);
    info.options = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  }
  return info;
}

// The root attribute checks of OpenH5File and OpenH5FileImage: `file` is
// of `spec`'s format and a supported major version. Throws DataError naming
// `path`, also for HDF5 errors on the way (a damaged attribute table).
void CheckFormatAttributes(const H5::H5File& file, const FormatSpec& spec, const std::string& path,
                           H5FormatInfo* info) {
  H5FormatInfo read;
  try {
    if (!file.attrExists("format")) {
      throw DataError(path + ": HDF5 file without a 'format' attribute (expected " + spec.name +
                      ")");
    }
    read = ReadFormatAttributesOf(file, path);
  } catch (const H5::Exception&) {
    throw DataError(path + ": cannot read the root attributes (corrupt HDF5 file?)");
  }
  if (read.format != spec.name) {
    throw DataError(path + ": is a " + read.format + " file, expected " + spec.name);
  }
  if (read.major != spec.major) {
    throw DataError(path + ": " + spec.name + " version " + std::to_string(read.major) + "." +
                    std::to_string(read.minor) + " is not supported (this build reads " +
                    std::to_string(spec.major) + ".x)");
  }
  if (info != nullptr) *info = std::move(read);
}

}  // namespace

H5FormatInfo ReadFormatAttributes(const H5::H5File& file) {
  return ReadFormatAttributesOf(file, file.getFileName());
}

H5::H5File OpenH5File(const std::filesystem::path& path, const FormatSpec& spec,
                      H5FormatInfo* info) {
  RequireFile(path, "file");
  if (H5::H5File::isHdf5(path.string()) <= 0) {
    throw DataError(path.string() + ": not an HDF5 file (expected " + spec.name + ")");
  }
  H5::H5File file;
  try {
    file.openFile(path.string(), H5F_ACC_RDONLY);
  } catch (const H5::Exception&) {
    throw DataError(path.string() + ": cannot open as HDF5 (corrupt or truncated?)");
  }
  CheckFormatAttributes(file, spec, path.string(), info);
  return file;
}

H5::H5File OpenH5FileImage(std::span<const uint8_t> bytes, const FormatSpec& spec,
                           const std::string& name, H5FormatInfo* info) {
  if (bytes.empty())
    throw DataError(name + ": empty, not an HDF5 file (expected " + spec.name + ")");
  // The core driver refuses to open an image under the name of an existing
  // file; no file can exist below /dev/null, and the counter keeps the names
  // of images open at the same time apart.
  static std::atomic<uint64_t> counter{0};
  const std::string image_name = "/dev/null/rrslam-h5-image-" + std::to_string(++counter);
  H5::H5File file;
  try {
    H5::FileAccPropList access;
    if (H5Pset_fapl_core(access.getId(), 1 << 16, /*backing_store=*/false) < 0 ||
        H5Pset_file_image(access.getId(), const_cast<uint8_t*>(bytes.data()), bytes.size()) < 0) {
      throw H5::PropListIException("OpenH5FileImage", "cannot set up the core driver");
    }
    file.openFile(image_name, H5F_ACC_RDONLY, access);
  } catch (const H5::Exception&) {
    throw DataError(name + ": cannot open as HDF5 (not HDF5, corrupt or truncated?)");
  }
  CheckFormatAttributes(file, spec, name, info);
  return file;
}

void WriteH5Array(H5::Group& group, const std::string& name, const void* data,
                  const H5::PredType& type, const std::vector<hsize_t>& dims, hsize_t chunk_rows) {
  H5::DataSpace space(static_cast<int>(dims.size()), dims.data());
  H5::DSetCreatPropList props;
  H5Pset_obj_track_times(props.getId(), false);
  bool empty = dims.empty();
  for (hsize_t d : dims) empty = empty || d == 0;
  if (chunk_rows > 0 && !empty) {
    std::vector<hsize_t> chunk = dims;
    chunk[0] = std::min(chunk_rows, dims[0]);
    props.setChunk(static_cast<int>(chunk.size()), chunk.data());
    props.setDeflate(4);
  }
  H5::DataSet set = group.createDataSet(name, type, space, props);
  if (!empty) set.write(data, type);
}

namespace {

// Deflate expands at most 1032:1; twice that leaves room for any chunk layout.
constexpr hsize_t kMaxExpansion = 2048;

// Throws DataError when dataset `set` of shape `dims` declares more data
// than its stored bytes (at most the file's size) can hold.
void CheckDeclaredSize(const H5::DataSet& set, const std::vector<hsize_t>& dims,
                       const std::string& name, const std::string& path) {
  hsize_t bytes = set.getDataType().getSize();
  bool overflow = false;
  for (hsize_t d : dims) overflow |= __builtin_mul_overflow(bytes, d, &bytes);
  if (!overflow && bytes == 0) return;
  hsize_t stored = set.getStorageSize();
  hsize_t file_size = 0;
  const hid_t file_id = H5Iget_file_id(set.getId());
  if (file_id >= 0) {
    H5Fget_filesize(file_id, &file_size);
    H5Fclose(file_id);
  }
  stored = std::min(stored, file_size);
  if (overflow || stored == 0 || bytes / kMaxExpansion > stored) {
    std::string shape;
    for (hsize_t d : dims) shape += (shape.empty() ? "" : " x ") + std::to_string(d);
    if (shape.empty()) shape = "1";
    throw DataError(path + ": dataset " + name + " declares " + shape +
                    " elements, more than the " + std::to_string(stored) +
                    " bytes stored for it can hold (corrupt file)");
  }
}

}  // namespace

std::vector<hsize_t> H5ArrayShape(const H5::Group& group, const std::string& name,
                                  const std::string& path) {
  try {
    if (!group.nameExists(name)) throw DataError(path + ": missing dataset " + name);
    H5::DataSet set = group.openDataSet(name);
    H5::DataSpace space = set.getSpace();
    std::vector<hsize_t> dims(space.getSimpleExtentNdims());
    space.getSimpleExtentDims(dims.data());
    CheckDeclaredSize(set, dims, name, path);
    return dims;
  } catch (const H5::Exception&) {
    throw DataError(path + ": cannot read dataset " + name);
  }
}

namespace {

// Transfer properties with a type conversion buffer for `elements` values:
// libhdf5's default is 1 MB, zeroed for every read that converts (every
// string read), whatever the data's size.
H5::DSetMemXferPropList ConversionBuffer(hsize_t elements) {
  H5::DSetMemXferPropList xfer;
  xfer.setBuffer(std::clamp<size_t>(16 * elements, 4096, size_t{1} << 20), nullptr, nullptr);
  return xfer;
}

}  // namespace

void ReadH5Array(const H5::Group& group, const std::string& name, void* out,
                 const H5::PredType& type, const std::string& path) {
  try {
    H5::DataSet set = group.openDataSet(name);
    set.read(out, type, H5::DataSpace::ALL, H5::DataSpace::ALL,
             ConversionBuffer(set.getSpace().getSimpleExtentNpoints()));
  } catch (const H5::Exception&) {
    throw DataError(path + ": cannot read dataset " + name + " (corrupt or wrong type)");
  }
}

void WriteH5StringAttribute(H5::H5Object& object, const std::string& name,
                            const std::string& value) {
  H5::StrType type(H5::PredType::C_S1, H5T_VARIABLE);
  type.setCset(H5T_CSET_UTF8);
  H5::Attribute attribute = object.createAttribute(name, type, H5::DataSpace(H5S_SCALAR));
  attribute.write(type, value);
}

namespace {

// Opens attribute `name` of `object` and checks that it holds one value (a
// read into a single string or double would overrun with more).
H5::Attribute OpenSingleAttribute(const H5::H5Object& object, const std::string& name,
                                  const std::string& path) {
  if (!object.attrExists(name)) throw DataError(path + ": missing attribute " + name);
  H5::Attribute attribute = object.openAttribute(name);
  if (attribute.getSpace().getSimpleExtentNpoints() != 1) {
    throw DataError(path + ": attribute " + name + " is not a single value");
  }
  return attribute;
}

}  // namespace

std::string ReadH5StringAttribute(const H5::H5Object& object, const std::string& name,
                                  const std::string& path) {
  try {
    H5::Attribute attribute = OpenSingleAttribute(object, name, path);
    std::string value;
    attribute.read(attribute.getStrType(), value);
    return value;
  } catch (const H5::Exception&) {
    throw DataError(path + ": attribute " + name + " is not a string");
  }
}

void WriteH5ScalarAttribute(H5::H5Object& object, const std::string& name, double value,
                            const H5::PredType& stored_type) {
  H5::Attribute attribute = object.createAttribute(name, stored_type, H5::DataSpace(H5S_SCALAR));
  attribute.write(H5::PredType::NATIVE_DOUBLE, &value);
}

double ReadH5ScalarAttribute(const H5::H5Object& object, const std::string& name,
                             const std::string& path) {
  try {
    H5::Attribute attribute = OpenSingleAttribute(object, name, path);
    double value = 0;
    attribute.read(H5::PredType::NATIVE_DOUBLE, &value);
    return value;
  } catch (const H5::Exception&) {
    throw DataError(path + ": attribute " + name + " is not numeric");
  }
}

}  // namespace rrslam

namespace rrslam {

void WriteH5StringArray(H5::Group& group, const std::string& name,
                        const std::vector<std::string>& values) {
  H5::StrType type(H5::PredType::C_S1, H5T_VARIABLE);
  type.setCset(H5T_CSET_UTF8);
  const hsize_t dims[1] = {values.size()};
  H5::DataSpace space(1, dims);
  H5::DSetCreatPropList props;
  H5Pset_obj_track_times(props.getId(), false);
  H5::DataSet set = group.createDataSet(name, type, space, props);
  std::vector<const char*> pointers;
  pointers.reserve(values.size());
  for (const std::string& value : values) pointers.push_back(value.c_str());
  if (!values.empty()) set.write(pointers.data(), type);
}

std::vector<std::string> ReadH5StringArray(const H5::Group& group, const std::string& name,
                                           const std::string& path) {
  const std::vector<hsize_t> dims = H5ArrayShape(group, name, path);
  if (dims.size() != 1) throw DataError(path + ": dataset " + name + " is not a string list");
  std::vector<std::string> values;
  if (dims[0] == 0) return values;
  try {
    H5::DataSet set = group.openDataSet(name);
    H5::DataType file_type = set.getDataType();
    if (file_type.getClass() != H5T_STRING) {
      throw DataError(path + ": dataset " + name + " is not a string list");
    }
    H5::StrType type(H5::PredType::C_S1, H5T_VARIABLE);
    std::vector<char*> pointers(dims[0], nullptr);
    set.read(pointers.data(), type, H5::DataSpace::ALL, H5::DataSpace::ALL,
             ConversionBuffer(dims[0]));
    values.reserve(dims[0]);
    for (char* p : pointers) values.emplace_back(p != nullptr ? p : "");
    H5::DataSpace space = set.getSpace();
    H5Dvlen_reclaim(type.getId(), space.getId(), H5P_DEFAULT, pointers.data());
  } catch (const H5::Exception&) {
    throw DataError(path + ": cannot read dataset " + name);
  }
  return values;
}

}  // namespace rrslam
