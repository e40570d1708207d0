// Fuzz-only: builds HDF5 file images from fuzz inputs, for the fuzz targets of
// rrslam's HDF5 readers (stages/extract/fuzz, stages/cluster/fuzz).
//
// Why not mutate the bytes of an HDF5 file: libhdf5 (1.10.8, Debian 12) does
// not survive that. Within seconds of fuzzing raw file images, it hangs in
// its global heap reader (H5HG_read, the strings of an attribute) and leaks
// the object headers it fails to decode (H5O_protect); neither is rrslam's
// to fix, and a run that stops at the first of them never reaches rrslam's
// own checks. So the fuzz targets read each input as a description of a
// file instead: the objects a reader expects (root attributes, groups,
// datasets, each with its well-formed type, shape and values), of which the
// input keeps each as it is, leaves it out, or writes it as another kind of
// object, with another element type, rank, shape or storage layout, without
// data (a declared shape with only a fill value), or with some values
// replaced (NaN, infinities, extremes, arbitrary bits). libhdf5 writes that
// file into memory (core driver, no backing store) and the reader opens the
// image's bytes, exactly as it would open them from disk: every check behind
// the HDF5 layer (root attributes, schema, shapes, consistency) is fuzzed, on
// files that libhdf5 itself wrote correctly. An input used up early keeps
// the rest as it is, so short inputs give well-formed files.
//
// The raw bytes can still be fuzzed (the targets' RRSLAM_FUZZ_H5_RAW=1 mode)
// to look for libhdf5 bugs; those are reported upstream, not fixed here.
//
// Header-only, used only by fuzz targets and their seed tests; builds with
// gcc and clang (no libFuzzer header). Not thread-safe (libhdf5 is not).
#pragma once

#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <span>
#include <string>
#include <vector>

namespace rrslam::fuzz {

// Reads decisions and values from a fuzz input, front to back; a used-up
// input reads as zeros (the "keep it as it is" decisions).
class FuzzInput {
 public:
  FuzzInput(const uint8_t* data, size_t size) : data_(data), size_(size) {}

  uint8_t Byte() { return at_ < size_ ? data_[at_++] : 0; }
  // A value in [0, n), n in [1, 256].
  uint32_t Below(uint32_t n) { return Byte() % n; }
  // A number for a replaced value: mostly the edge cases a reader must
  // reject or survive, otherwise 8 arbitrary bytes as a double.
  double Number() {
    static const double kEdges[] = {0,
                                    -0.0,
                                    1,
                                    -1,
                                    0.5,
                                    2,
                                    31,
                                    32,
                                    255,
                                    256,
                                    65535,
                                    2147483647.0,
                                    4294967295.0,
                                    9007199254740993.0,
                                    9223372036854775807.0,
                                    18446744073709551615.0,
                                    1e300,
                                    -1e300,
                                    std::numeric_limits<double>::denorm_min(),
                                    std::numeric_limits<double>::quiet_NaN(),
                                    std::numeric_limits<double>::infinity(),
                                    -std::numeric_limits<double>::infinity()};
    const uint8_t pick = Byte();
    if (pick < sizeof(kEdges) / sizeof(kEdges[0])) return kEdges[pick];
    if (pick < 128) return static_cast<double>(pick) - 64;  // Small integers, some negative.
    uint64_t bits = 0;
    for (int i = 0; i < 8; ++i) bits = bits << 8 | Byte();
    double value;
    std::memcpy(&value, &bits, 8);
    return value;
  }
  // A string of up to 255 bytes (any bytes, NULs too).
  std::string Text() {
    const size_t length = std::min<size_t>(Byte(), size_ - std::min(at_, size_));
    std::string text(reinterpret_cast<const char*>(data_) + at_, length);
    at_ += length;
    return text;
  }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t at_ = 0;
};

// One object a reader expects, well-formed.
struct H5Object {
  enum class Kind { kGroup, kDataset, kAttribute };
  Kind kind = Kind::kDataset;
  std::string path;  // "frames", "frames/rgb_timestamp"; attributes: a name on the root.
  hid_t type = H5T_NATIVE_DOUBLE;  // Element type in the file (numbers), e.g. H5T_STD_U64LE.
  bool strings = false;            // Variable-length UTF-8 strings (texts) instead.
  std::vector<hsize_t> dims;       // Empty: a scalar.
  std::vector<double> numbers;     // Values, row-major (converted to `type` on writing).
  std::vector<std::string> texts;  // Values of a string object.
};

namespace internal {

inline hsize_t Elements(const std::vector<hsize_t>& dims) {
  hsize_t n = 1;
  for (hsize_t d : dims) n = d != 0 && n > std::numeric_limits<hsize_t>::max() / d ? 0 : n * d;
  return n;
}

// Element types a damaged object may take instead of its own; H5T_NO_CLASS
// (-1) stands for variable-length strings, -2 for 8-byte fixed strings.
inline hid_t OtherType(FuzzInput& in) {
  const hid_t kTypes[] = {H5T_STD_U8LE,
                          H5T_STD_I8LE,
                          H5T_STD_U16LE,
                          H5T_STD_I32LE,
                          H5T_STD_U32LE,
                          H5T_STD_I64LE,
                          H5T_STD_U64LE,
                          H5T_IEEE_F32LE,
                          H5T_IEEE_F64LE,
                          H5T_STD_I16BE,
                          H5T_IEEE_F64BE,
                          -1,
                          -2};
  return kTypes[in.Below(sizeof(kTypes) / sizeof(kTypes[0]))];
}

// Writes `o` (already damaged as decided) under `file`; HDF5 errors (e.g. a
// parent group that is missing or is a dataset) leave the object out.
inline void Write(hid_t file, const H5Object& o, bool fill_only, int layout, FuzzInput& in) {
  if (o.kind == H5Object::Kind::kGroup) {
    const hid_t g = H5Gcreate2(file, o.path.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    if (g >= 0) H5Gclose(g);
    return;
  }
  hid_t type = o.type;
  bool variable_strings = o.strings;
  bool fixed_strings = false;
  if (type == -1) variable_strings = true;
  if (type == -2) fixed_strings = true;
  if (variable_strings || fixed_strings) {
    type = H5Tcopy(H5T_C_S1);
    H5Tset_size(type, variable_strings ? H5T_VARIABLE : 8);
    H5Tset_cset(type, H5T_CSET_UTF8);
  }
  const hid_t space =
      o.dims.empty() ? H5Screate(H5S_SCALAR)
                     : H5Screate_simple(static_cast<int>(o.dims.size()), o.dims.data(), nullptr);
  const hsize_t n = Elements(o.dims);
  // Small written arrays keep every run fast; larger shapes are declared only.
  const bool write = !fill_only && n > 0 && n <= (hsize_t{1} << 16) && space >= 0;
  hid_t object = -1;
  if (o.kind == H5Object::Kind::kAttribute) {
    object = H5Acreate2(file, o.path.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT);
  } else {
    const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    if (layout == 1 && !o.dims.empty() && n > 0) {
      std::vector<hsize_t> chunk = o.dims;
      for (hsize_t& c : chunk) c = std::max<hsize_t>(1, std::min<hsize_t>(c, 1 + in.Below(64)));
      // At most 256 chunks: tens of thousands of them (a 65536-element array
      // in chunks of one) took libhdf5 over 10 s to write and index under
      // AddressSanitizer, a timeout of the builder's, not of a reader's.
      auto chunks = [&] {
        hsize_t count = 1;
        for (size_t i = 0; i < chunk.size(); ++i) count *= (o.dims[i] + chunk[i] - 1) / chunk[i];
        return count;
      };
      for (size_t i = 0; chunks() > 256; i = (i + 1) % chunk.size()) {
        chunk[i] = std::min(o.dims[i], 2 * chunk[i]);
      }
      H5Pset_chunk(dcpl, static_cast<int>(chunk.size()), chunk.data());
      H5Pset_deflate(dcpl, 1 + in.Below(9));
    } else if (layout == 2) {
      H5Pset_layout(dcpl, H5D_COMPACT);
    }
    object = H5Dcreate2(file, o.path.c_str(), type, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    if (object < 0 && layout != 0) {  // E.g. compact data larger than 64 KB.
      object = H5Dcreate2(file, o.path.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    }
    H5Pclose(dcpl);
  }
  // A conversion buffer of the data's size, not libhdf5's default 1 MB
  // (zeroed on every write: most of a run's time otherwise).
  const hid_t dxpl = H5Pcreate(H5P_DATASET_XFER);
  H5Pset_buffer(dxpl, std::max<size_t>(4096, 16 * n), nullptr, nullptr);
  if (object >= 0 && write) {
    const bool attribute = o.kind == H5Object::Kind::kAttribute;
    if (variable_strings || fixed_strings) {
      std::vector<std::string> texts(n);
      for (hsize_t i = 0; i < n; ++i) {
        texts[i] = !o.texts.empty()     ? o.texts[i % o.texts.size()]
                   : !o.numbers.empty() ? std::to_string(o.numbers[i % o.numbers.size()])
                                        : std::string();
      }
      hid_t memory = H5Tcopy(H5T_C_S1);
      H5Tset_cset(memory, H5T_CSET_UTF8);
      std::vector<const char*> pointers(n);
      std::vector<char> fixed(8 * n, 0);
      if (variable_strings) {
        H5Tset_size(memory, H5T_VARIABLE);
        for (hsize_t i = 0; i < n; ++i) pointers[i] = texts[i].c_str();
      } else {
        H5Tset_size(memory, 8);
        for (hsize_t i = 0; i < n; ++i) {
          std::memcpy(fixed.data() + 8 * i, texts[i].data(), std::min<size_t>(8, texts[i].size()));
        }
      }
      const void* buffer = variable_strings ? static_cast<const void*>(pointers.data())
                                            : static_cast<const void*>(fixed.data());
      if (attribute) {
        H5Awrite(object, memory, buffer);
      } else {
        H5Dwrite(object, memory, H5S_ALL, H5S_ALL, dxpl, buffer);
      }
      H5Tclose(memory);
    } else {
      std::vector<double> values(n, 0.0);
      for (hsize_t i = 0; i < n; ++i) {
        values[i] = !o.numbers.empty() ? o.numbers[i % o.numbers.size()]
                    : !o.texts.empty() ? static_cast<double>(o.texts[i % o.texts.size()].size())
                                       : 0.0;
      }
      // Out-of-range values are clamped by libhdf5's conversion (its default).
      if (attribute) {
        H5Awrite(object, H5T_NATIVE_DOUBLE, values.data());
      } else {
        H5Dwrite(object, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, dxpl, values.data());
      }
    }
  }
  H5Pclose(dxpl);
  if (object >= 0) {
    if (o.kind == H5Object::Kind::kAttribute) {
      H5Aclose(object);
    } else {
      H5Dclose(object);
    }
  }
  if (space >= 0) H5Sclose(space);
  if (variable_strings || fixed_strings) H5Tclose(type);
}

}  // namespace internal

// Lets libhdf5 keep every block it frees on its free lists for reuse. Each
// file it opens allocates a 0.5 MB metadata cache; AddressSanitizer maps and
// unmaps a block of that size on every allocation and free (no cache for
// large blocks), which made a fuzz run some 30 times slower than the same
// work without it. Call once, before the first file is opened.
inline void KeepH5FreeLists() { H5set_free_list_limits(-1, -1, -1, -1, -1, -1); }

// Writes `objects` into a new in-memory HDF5 file, each damaged or not as
// `in` decides (see the top of this file), and returns the file's bytes.
// Objects are written in order: a group before what it holds.
inline std::vector<uint8_t> BuildH5Image(FuzzInput& in, const std::vector<H5Object>& objects) {
  static uint64_t counter = 0;
  const std::string name = "/dev/null/rrslam-fuzz-build-" + std::to_string(++counter);
  const hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
  H5Pset_fapl_core(fapl, 1 << 16, /*backing_store=*/false);
  // libhdf5's default format bounds, not CreateH5File's 1.8 ones: with those,
  // the image of a file still open (H5Fget_file_image) carries a superblock
  // whose checksum libhdf5 then rejects. The reader's calls are the same.
  const hid_t file = H5Fcreate(name.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl);
  H5Pclose(fapl);
  if (file < 0) return {};
  for (H5Object o : objects) {
    const uint8_t decision = in.Byte();
    bool fill_only = false;
    if (decision < 128) {
      // As it is.
    } else if (decision < 144) {
      continue;                   // Left out.
    } else if (decision < 152) {  // Another kind of object.
      if (o.kind == H5Object::Kind::kGroup) {
        o.kind = H5Object::Kind::kDataset;
        o.dims = {1};
        o.numbers = {1};
      } else if (o.kind == H5Object::Kind::kDataset) {
        o.kind = H5Object::Kind::kGroup;
      } else {
        o.strings = !o.strings;
      }
    } else if (o.kind == H5Object::Kind::kGroup) {
      // Groups have no type, shape or values.
    } else if (decision < 176) {
      o.type = internal::OtherType(in);
      o.strings = false;
    } else if (decision < 200) {  // Another rank and shape.
      const size_t rank = in.Below(4);
      std::vector<hsize_t> dims(rank);
      for (size_t i = 0; i < rank; ++i) {
        const hsize_t good = i < o.dims.size() ? o.dims[i] : 1;
        const uint8_t pick = in.Byte();
        dims[i] = pick < 64 ? good + 1 : pick < 128 ? (good > 0 ? good - 1 : 0) : pick - 128;
      }
      o.dims = dims;
    } else if (decision < 212) {  // A declared shape, no data (or several attribute values).
      if (o.kind == H5Object::Kind::kAttribute) {
        o.dims = {2 + in.Below(3)};
      } else {
        for (hsize_t& d : o.dims) d = hsize_t{1} << in.Below(48);
        if (o.dims.empty()) o.dims = {hsize_t{1} << in.Below(48)};
        fill_only = true;
      }
    } else {  // Some values replaced.
      const int count = 1 + static_cast<int>(in.Below(4));
      for (int k = 0; k < count; ++k) {
        const uint8_t at = in.Byte();
        if (o.strings && !o.texts.empty()) {
          o.texts[at % o.texts.size()] = in.Text();
        } else if (!o.numbers.empty()) {
          o.numbers[at % o.numbers.size()] = in.Number();
        }
      }
    }
    const int layout = o.kind == H5Object::Kind::kDataset ? static_cast<int>(in.Below(4)) : 0;
    internal::Write(file, o, fill_only, layout == 3 ? 0 : layout, in);
  }
  std::vector<uint8_t> image;
  if (H5Fflush(file, H5F_SCOPE_GLOBAL) >= 0) {
    const ssize_t size = H5Fget_file_image(file, nullptr, 0);
    if (size > 0) {
      image.resize(static_cast<size_t>(size));
      if (H5Fget_file_image(file, image.data(), image.size()) != size) image.clear();
    }
  }
  H5Fclose(file);
  return image;
}

// The file image an input describes: `describe(in)` gives the objects a
// reader expects (a target's schema, e.g. FeaturesObjects), and the rest of
// the input damages them (BuildH5Image above).
template <class Describe>
std::vector<uint8_t> BuildH5Image(std::span<const uint8_t> input, Describe describe) {
  FuzzInput in(input.data(), input.size());
  const std::vector<H5Object> objects = describe(in);
  return BuildH5Image(in, objects);
}

}  // namespace rrslam::fuzz
