// Writing a big file once, in large pieces (a map file: stages/mapstore/
// map_file.cc). Pieces that are whole aligned blocks (offset, size and
// address multiples of kAlignment) go to the disk directly (O_DIRECT): no
// copy into the page cache and no writeback left for the commit's fsync. On
// the bench's 2-core VM a 1 GB map took 2.2 s to save through the page cache
// and its fsync, where the disk writes 1 GB in 0.7 s directly (dd
// oflag=direct); docs/mapstore.md, "At scale". The other pieces (the last,
// partial one; the header written over the first block at the end) go
// through the page cache, each one's writeback started as it is written
// (sync_file_range), as everything does where the file system refuses direct
// I/O (tmpfs, some network file systems). The bytes on disk are the same
// either way; durability is the caller's fsync (AtomicOutput::Commit), which
// also flushes the disk's cache of the direct writes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <span>
#include <string>

namespace rrslam {

class FileSink {
 public:
  // Direct writes need offsets, sizes and buffers aligned to the device's
  // logical block (512 or 4096 bytes): 4096 suits both.
  static constexpr size_t kAlignment = 4096;

  struct FreeBuffer {
    void operator()(uint8_t* p) const { std::free(p); }
  };
  using Buffer = std::unique_ptr<uint8_t, FreeBuffer>;
  // `bytes` (a multiple of kAlignment) of memory aligned for direct writes,
  // uninitialized. Throws std::bad_alloc.
  static Buffer AlignedBuffer(size_t bytes);

  // Creates (or truncates) `file`; `name` prefixes errors (the final path
  // of an atomic output). Throws CantCreateError.
  FileSink(const std::filesystem::path& file, std::string name);
  ~FileSink();
  FileSink(const FileSink&) = delete;
  FileSink& operator=(const FileSink&) = delete;

  // Writes `bytes` at `offset` (directly when all three are aligned and the
  // file system takes it). Throws CantCreateError.
  void WriteAt(uint64_t offset, std::span<const uint8_t> bytes);
  // Closes the file; throws CantCreateError when the close reports an error.
  void Close();
  // Whether aligned pieces still go directly (false from the first refusal).
  bool direct() const { return direct_fd_ >= 0; }

 private:
  // Writes what it can of `bytes` directly; returns the bytes written (the
  // rest goes through the page cache). A first refusal turns direct I/O off.
  size_t WriteDirect(uint64_t offset, std::span<const uint8_t> bytes);
  void WriteBuffered(uint64_t offset, std::span<const uint8_t> bytes);

  int fd_ = -1;         // Through the page cache.
  int direct_fd_ = -1;  // O_DIRECT; -1: not supported here.
  std::string name_;
};

}  // namespace rrslam
