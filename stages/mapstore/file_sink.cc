#include "stages/mapstore/file_sink.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <new>
#include <utility>

#include "common/errors.h"

namespace rrslam {
namespace {

bool Aligned(uint64_t value) { return value % FileSink::kAlignment == 0; }

}  // namespace

FileSink::Buffer FileSink::AlignedBuffer(size_t bytes) {
  Buffer buffer(static_cast<uint8_t*>(std::aligned_alloc(kAlignment, bytes)));
  if (buffer == nullptr) throw std::bad_alloc();
  return buffer;
}

FileSink::FileSink(const std::filesystem::path& file, std::string name) : name_(std::move(name)) {
  fd_ = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) throw CantCreateError(name_ + ": cannot create " + file.string());
  // A second descriptor of the same file for the direct writes; where the
  // file system has no direct I/O the open fails (EINVAL) and all goes
  // through fd_.
  direct_fd_ = ::open(file.c_str(), O_WRONLY | O_DIRECT | O_CLOEXEC);
}

FileSink::~FileSink() {
  if (direct_fd_ >= 0) ::close(direct_fd_);
  if (fd_ >= 0) ::close(fd_);
}

void FileSink::WriteAt(uint64_t offset, std::span<const uint8_t> bytes) {
  size_t done = 0;
  if (direct_fd_ >= 0 && Aligned(offset) && Aligned(bytes.size()) &&
      Aligned(reinterpret_cast<uintptr_t>(bytes.data()))) {
    done = WriteDirect(offset, bytes);
  }
  if (done < bytes.size()) WriteBuffered(offset + done, bytes.subspan(done));
}

size_t FileSink::WriteDirect(uint64_t offset, std::span<const uint8_t> bytes) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::pwrite(direct_fd_, bytes.data() + done, bytes.size() - done,
                               static_cast<off_t>(offset + done));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && errno == EINVAL) {
      // Alignment or direct I/O refused after all: the page cache from now on.
      ::close(std::exchange(direct_fd_, -1));
      return done;
    }
    if (n <= 0) throw CantCreateError(name_ + ": write failed: " + std::strerror(errno));
    done += static_cast<size_t>(n);
    // A short write leaves the rest unaligned, perhaps: the page cache's.
    if (!Aligned(done)) return done;
  }
  return done;
}

void FileSink::WriteBuffered(uint64_t offset, std::span<const uint8_t> bytes) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n =
        ::pwrite(fd_, bytes.data() + done, bytes.size() - done, static_cast<off_t>(offset + done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw CantCreateError(name_ + ": write failed: " + std::strerror(errno));
    done += static_cast<size_t>(n);
  }
  // Best effort: where unsupported, the commit's fsync writes it all.
  ::sync_file_range(fd_, static_cast<off_t>(offset), static_cast<off_t>(bytes.size()),
                    SYNC_FILE_RANGE_WRITE);
}

void FileSink::Close() {
  if (direct_fd_ >= 0) ::close(std::exchange(direct_fd_, -1));
  const int fd = std::exchange(fd_, -1);
  if (::close(fd) != 0) throw CantCreateError(name_ + ": write failed: " + std::strerror(errno));
}

}  // namespace rrslam
