#include "common/binary_header.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <new>
#include <span>
#include <utility>

#include "common/errors.h"
#include "common/path_check.h"

namespace rrslam {
namespace {

uint64_t HeaderChecksum(std::span<const uint8_t> header) {
  std::vector<uint8_t> copy(header.begin(), header.end());
  StoreLittleEndian<uint64_t>(copy.data() + 32, 0);
  return Checksum64(copy);
}

}  // namespace

uint64_t Checksum64(std::span<const uint8_t> bytes) {
  return XXH3_64bits(bytes.data(), bytes.size());
}

uint64_t FileChecksum64(const std::filesystem::path& path) {
  RequireFile(path, "file");
  std::ifstream stream(path, std::ios::binary);
  if (!stream) throw NoInputError(path.string() + ": cannot open: " + std::strerror(errno));
  // In pieces: memory stays bounded whatever the file's size.
  StreamingChecksum64 checksum;
  std::vector<uint8_t> piece(size_t{1} << 20);
  while (stream) {
    stream.read(reinterpret_cast<char*>(piece.data()), static_cast<std::streamsize>(piece.size()));
    checksum.Update({piece.data(), static_cast<size_t>(stream.gcount())});
  }
  if (!stream.eof()) throw NoInputError(path.string() + ": read failed: " + std::strerror(errno));
  return checksum.Digest();
}

bool HasMagic(std::span<const uint8_t> file, const FormatSpec& spec) {
  return file.size() >= 8 && std::memcmp(file.data(), spec.magic, 8) == 0;
}

struct StreamingChecksum64::State {
  XXH3_state_t* xxh = nullptr;
};

StreamingChecksum64::StreamingChecksum64() : state_(new State) {
  state_->xxh = XXH3_createState();
  if (state_->xxh == nullptr) {
    delete state_;
    throw std::bad_alloc();
  }
  XXH3_64bits_reset(state_->xxh);
}

StreamingChecksum64::~StreamingChecksum64() {
  if (state_ != nullptr) XXH3_freeState(state_->xxh);
  delete state_;
}

StreamingChecksum64::StreamingChecksum64(StreamingChecksum64&& other) noexcept
    : state_(std::exchange(other.state_, nullptr)) {}

StreamingChecksum64& StreamingChecksum64::operator=(StreamingChecksum64&& other) noexcept {
  std::swap(state_, other.state_);
  return *this;
}

void StreamingChecksum64::Update(std::span<const uint8_t> bytes) {
  if (!bytes.empty()) XXH3_64bits_update(state_->xxh, bytes.data(), bytes.size());
}

uint64_t StreamingChecksum64::Digest() const { return XXH3_64bits_digest(state_->xxh); }

std::vector<uint8_t> BuildBinaryHeader(const FormatSpec& spec, std::span<const uint8_t> fields,
                                       std::span<const uint8_t> payload) {
  return BuildBinaryHeader(spec, fields, payload.size(), Checksum64(payload));
}

std::vector<uint8_t> BuildBinaryHeader(const FormatSpec& spec, std::span<const uint8_t> fields,
                                       uint64_t payload_size, uint64_t payload_checksum) {
  const size_t padded = (fields.size() + 7) / 8 * 8;
  std::vector<uint8_t> header(kBaseHeaderSize + padded, 0);
  std::memcpy(header.data(), spec.magic, 8);
  StoreLittleEndian<uint16_t>(header.data() + 8, spec.major);
  StoreLittleEndian<uint16_t>(header.data() + 10, spec.minor);
  StoreLittleEndian<uint32_t>(header.data() + 12, static_cast<uint32_t>(header.size()));
  StoreLittleEndian<uint64_t>(header.data() + 16, payload_size);
  StoreLittleEndian<uint64_t>(header.data() + 24, payload_checksum);
  if (!fields.empty()) std::memcpy(header.data() + kBaseHeaderSize, fields.data(), fields.size());
  StoreLittleEndian<uint64_t>(header.data() + 32, HeaderChecksum(header));
  return header;
}

BinaryHeaderView ParseBinaryHeader(std::span<const uint8_t> file, const FormatSpec& spec,
                                   const std::string& path) {
  if (file.size() < kBaseHeaderSize) {
    throw DataError(path + ": truncated: " + std::to_string(file.size()) +
                    " bytes, shorter than a " + spec.name + " header");
  }
  if (!HasMagic(file, spec))
    throw DataError(path + ": not a " + std::string(spec.name) + " file (bad magic)");
  BinaryHeaderView view;
  view.major = LoadLittleEndian<uint16_t>(file.data() + 8);
  view.minor = LoadLittleEndian<uint16_t>(file.data() + 10);
  if (view.major != spec.major) {
    throw DataError(path + ": " + spec.name + " format version " + std::to_string(view.major) +
                    "." + std::to_string(view.minor) + " is not supported (this build reads " +
                    std::to_string(spec.major) + ".x)");
  }
  const uint32_t header_size = LoadLittleEndian<uint32_t>(file.data() + 12);
  const uint64_t payload_size = LoadLittleEndian<uint64_t>(file.data() + 16);
  if (header_size < kBaseHeaderSize) {
    throw DataError(path + ": corrupt header (header size " + std::to_string(header_size) + ")");
  }
  if (header_size > file.size()) {
    throw DataError(path + ": truncated: " + std::to_string(file.size()) +
                    " bytes, shorter than its " + std::to_string(header_size) + "-byte header");
  }
  if (LoadLittleEndian<uint64_t>(file.data() + 32) != HeaderChecksum(file.first(header_size))) {
    throw DataError(path + ": corrupt header (header checksum mismatch)");
  }
  if (payload_size != file.size() - header_size) {
    throw DataError(path + ": truncated or padded: payload is " +
                    std::to_string(file.size() - header_size) + " bytes, header says " +
                    std::to_string(payload_size));
  }
  view.payload_checksum = LoadLittleEndian<uint64_t>(file.data() + 24);
  view.fields = file.subspan(kBaseHeaderSize, header_size - kBaseHeaderSize);
  view.payload = file.subspan(header_size);
  return view;
}

void VerifyPayloadChecksum(const BinaryHeaderView& header, const std::string& path) {
  if (Checksum64(header.payload) != header.payload_checksum) {
    throw DataError(path + ": corrupt payload (checksum mismatch)");
  }
}

MappedFile::MappedFile(const std::filesystem::path& path, bool populate) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) throw NoInputError(path.string() + ": cannot open: " + std::strerror(errno));
  struct stat st;
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw NoInputError(path.string() + ": not a regular file");
  }
  size_ = static_cast<size_t>(st.st_size);
  if (size_ > 0) {
    void* p = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE | (populate ? MAP_POPULATE : 0), fd, 0);
    if (p == MAP_FAILED) {
      ::close(fd);
      throw NoInputError(path.string() + ": cannot map: " + std::strerror(errno));
    }
    data_ = static_cast<const uint8_t*>(p);
  }
  ::close(fd);
}

namespace {

// The whole pages of `part` within [data, data + size), or an empty range.
std::pair<uintptr_t, size_t> WholePages(const uint8_t* data, size_t size,
                                        std::span<const uint8_t> part) {
  const auto begin = reinterpret_cast<uintptr_t>(part.data());
  const auto end = begin + part.size();
  const auto lo = reinterpret_cast<uintptr_t>(data);
  if (data == nullptr || begin < lo || end > lo + size) return {0, 0};
  const auto page = static_cast<uintptr_t>(::sysconf(_SC_PAGESIZE));
  const uintptr_t first = (begin + page - 1) & ~(page - 1);
  const uintptr_t last = end & ~(page - 1);
  return last > first ? std::pair{first, static_cast<size_t>(last - first)}
                      : std::pair{uintptr_t{0}, size_t{0}};
}

#ifndef MADV_POPULATE_READ
#define MADV_POPULATE_READ 22
#endif

}  // namespace

void MappedFile::Release(std::span<const uint8_t> part) const {
  const auto [first, bytes] = WholePages(data_, size_, part);
  // A hint: a failure leaves the pages mapped, which is only more memory.
  if (bytes > 0) ::madvise(reinterpret_cast<void*>(first), bytes, MADV_DONTNEED);
}

void MappedFile::Prefault(std::span<const uint8_t> part) const {
  const auto [first, bytes] = WholePages(data_, size_, part);
  if (bytes > 0) ::madvise(reinterpret_cast<void*>(first), bytes, MADV_POPULATE_READ);
}

MappedFile::~MappedFile() {
  if (data_ != nullptr) ::munmap(const_cast<uint8_t*>(data_), size_);
}

MappedFile::MappedFile(MappedFile&& other) noexcept : data_(other.data_), size_(other.size_) {
  other.data_ = nullptr;
  other.size_ = 0;
}

MappedFile& MappedFile::operator=(MappedFile&& other) noexcept {
  if (this != &other) {
    if (data_ != nullptr) ::munmap(const_cast<uint8_t*>(data_), size_);
    data_ = other.data_;
    size_ = other.size_;
    other.data_ = nullptr;
    other.size_ = 0;
  }
  return *this;
}

}  // namespace rrslam
