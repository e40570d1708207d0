// The header shared by every rrslam binary format, and read-only file mapping.
//
// Layout (little-endian, fixed width; offsets in bytes):
//    0  char[8]  magic                 FormatSpec::magic
//    8  uint16   major version
//   10  uint16   minor version
//   12  uint32   header_size           bytes from file start to payload (>= 40)
//   16  uint64   payload_size          bytes of payload after the header
//   24  uint64   payload_checksum      XXH3-64 of the payload bytes
//   32  uint64   header_checksum       XXH3-64 of bytes [0, header_size) with
//                                      this field read as zero
//   40  ...      format-specific header fields, up to header_size
//   header_size  payload
// A newer minor version may append header fields; readers take the fields they
// know and skip to header_size.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "common/formats.h"

namespace rrslam {

static_assert(std::endian::native == std::endian::little,
              "rrslam's binary formats are read by direct mapping on little-endian hosts");

inline constexpr uint32_t kBaseHeaderSize = 40;

// Unaligned little-endian loads and stores of fixed-width values (the host is
// little-endian, see above).
template <typename T>
T LoadLittleEndian(const uint8_t* p) {
  T value;
  std::memcpy(&value, p, sizeof(T));
  return value;
}

template <typename T>
void StoreLittleEndian(uint8_t* p, T value) {
  std::memcpy(p, &value, sizeof(T));
}

// XXH3-64 of `bytes` (the checksum of every rrslam binary format).
uint64_t Checksum64(std::span<const uint8_t> bytes);

// XXH3-64 of a whole file's bytes, read in pieces (for example an image that
// a features file was extracted from): Checksum64 of its content. Throws
// NoInputError when `path` is not a readable regular file.
uint64_t FileChecksum64(const std::filesystem::path& path);

// XXH3-64 of bytes given in pieces: Update with each piece in order; Digest
// equals Checksum64 of their concatenation. Move-only.
class StreamingChecksum64 {
 public:
  StreamingChecksum64();
  ~StreamingChecksum64();
  StreamingChecksum64(StreamingChecksum64&& other) noexcept;
  StreamingChecksum64& operator=(StreamingChecksum64&& other) noexcept;
  StreamingChecksum64(const StreamingChecksum64&) = delete;
  StreamingChecksum64& operator=(const StreamingChecksum64&) = delete;

  void Update(std::span<const uint8_t> bytes);
  uint64_t Digest() const;

 private:
  struct State;
  State* state_ = nullptr;
};

// Builds the header bytes for `spec` with the format-specific `fields`
// (padded with zeros to a multiple of 8) and the given payload.
std::vector<uint8_t> BuildBinaryHeader(const FormatSpec& spec, std::span<const uint8_t> fields,
                                       std::span<const uint8_t> payload);

// The same for a payload written elsewhere (streamed to a file): its size in
// bytes and its Checksum64.
std::vector<uint8_t> BuildBinaryHeader(const FormatSpec& spec, std::span<const uint8_t> fields,
                                       uint64_t payload_size, uint64_t payload_checksum);

struct BinaryHeaderView {
  uint16_t major = 0;
  uint16_t minor = 0;
  uint64_t payload_checksum = 0;
  std::span<const uint8_t> fields;   // Format-specific header fields.
  std::span<const uint8_t> payload;  // Exactly payload_size bytes.
};

// Parses and validates the header of `file` (the whole file's bytes): magic,
// major version (must equal spec.major), header size, header checksum, and that
// the file holds exactly header_size + payload_size bytes. Does not check the
// payload checksum (see VerifyPayloadChecksum). Throws DataError naming `path`.
BinaryHeaderView ParseBinaryHeader(std::span<const uint8_t> file, const FormatSpec& spec,
                                   const std::string& path);

// Throws DataError naming `path` when the payload checksum does not match.
void VerifyPayloadChecksum(const BinaryHeaderView& header, const std::string& path);

// True when `file` starts with `spec`'s magic.
bool HasMagic(std::span<const uint8_t> file, const FormatSpec& spec);

// A read-only memory map of a whole file. Move-only; unmapped on destruction.
// Throws NoInputError when the file cannot be opened.
class MappedFile {
 public:
  // `populate` pre-faults every page (MAP_POPULATE): faster when the whole file
  // is read soon after, e.g. a vocabulary.
  explicit MappedFile(const std::filesystem::path& path, bool populate = false);
  ~MappedFile();
  MappedFile(MappedFile&& other) noexcept;
  MappedFile& operator=(MappedFile&& other) noexcept;
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;

  std::span<const uint8_t> bytes() const { return {data_, size_}; }

  // Memory hints for a part of bytes() (the whole pages inside it; a part
  // outside the mapping is ignored). Release drops its pages from this
  // process (they stay in the page cache; reading them again maps them
  // back), so a reader that is done with a part stops counting it in its
  // resident memory. Prefault maps a part's pages at once (MADV_POPULATE_READ,
  // Linux >= 5.14; a no-op elsewhere) instead of one fault per page.
  void Release(std::span<const uint8_t> part) const;
  void Prefault(std::span<const uint8_t> part) const;

 private:
  const uint8_t* data_ = nullptr;
  size_t size_ = 0;
};

}  // namespace rrslam
